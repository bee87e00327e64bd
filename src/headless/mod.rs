//! Running mavterm without a terminal: virtual-clock runs, recorded-input replay, reports.

pub mod realtime;
pub mod replay;
pub mod runner;
pub mod script;
