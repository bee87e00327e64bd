//! Running mavterm without a terminal: recorded-input replay and reports, on the driver's
//! virtual or real-time runners.

pub mod logs;
pub mod params;
pub mod replay;
pub mod script;
