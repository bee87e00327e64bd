//! Links: connection strings, framing, and the transports that move bytes.

pub mod frame;
pub mod parser;
pub mod spec;

pub use frame::{Frame, Header, Version};
pub use parser::{FrameParser, ParserStats};
pub use spec::LinkSpec;

/// Index of a link in the order the links were given.
pub type LinkId = usize;
