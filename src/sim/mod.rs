//! The simulated vehicle(s) behind `sim://`.
