//! Links: connection strings and the transports that move bytes, at the edge. Framing is in
//! `wire`; links report frames, parser counters and their state, and never see the core.

pub(crate) mod local;
pub mod manager;
pub mod replay;
pub mod source;
pub mod spec;
pub mod state;
pub mod tlog;
pub mod transport;

pub use crate::wire::{Frame, FrameParser, Header, ParserStats, Version};
pub use spec::LinkSpec;
pub use state::LinkState;

/// Index of a link in the order the links were given.
pub type LinkId = usize;
