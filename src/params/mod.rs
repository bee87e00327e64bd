//! Parameter data, independent of any link or vehicle: values and types on the wire
//! ([`value`]), parameter files ([`file`]) and parameter metadata ([`meta`]).

pub mod file;
pub mod meta;
pub mod value;
