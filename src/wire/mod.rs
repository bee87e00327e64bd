//! The wire codec, at the bottom of every layer: MAVLink framing (parser, CRC, encoder with our own
//! sequence numbers), and the MAVFTP and `param.pck` codecs. Pure: bytes in, values out. Used by
//! the ground station and the simulated vehicle alike.

pub mod cmd;
pub mod frame;
pub mod mavftp;
pub mod mavlink_xml;
pub mod param_pck;
pub mod parser;
pub mod payload;
pub mod severity;
pub mod signing;
pub mod tx;

pub use frame::{Frame, Header, RawBytes, Version};
pub use parser::{FrameParser, ParserStats};
pub use severity::Severity;
