//! Links: connection strings, framing, and the transports that move bytes.

pub mod frame;
pub mod parser;
pub mod spec;

pub use frame::{Frame, Header, Version};
pub use parser::{FrameParser, ParserStats};
pub use spec::LinkSpec;
