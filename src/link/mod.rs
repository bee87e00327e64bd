//! Links: connection strings, framing, and the transports that move bytes.

pub mod frame;
pub(crate) mod local;
pub mod manager;
pub mod parser;
pub mod spec;
pub mod tlog;
pub mod transport;
pub mod tx;

pub use frame::{Frame, Header, Version};
pub use parser::{FrameParser, ParserStats};
pub use spec::LinkSpec;

/// Index of a link in the order the links were given.
pub type LinkId = usize;
