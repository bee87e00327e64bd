//! Running mavterm without a terminal: virtual-clock runs, recorded-input replay, reports.

pub mod runner;
