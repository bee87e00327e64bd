//! Sans-I/O protocol state machines.

pub mod loss;
pub mod modes;
pub mod streams;
pub mod vehicles;
