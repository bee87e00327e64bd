//! Files the core reads: why each is read, carried by [`Effect::ReadFile`](super::Effect) out and
//! by [`Event::FileRead`](super::Event) back, so the answer goes to whoever asked (parameters,
//! missions) without either knowing the other.

/// Why a file is being read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FileUse {
    /// Parameters: compare, then offer to apply the differences (`param load`).
    Load,
    /// Parameters: compare only (`param diff`).
    Diff,
    /// A mission, fence or rally point file (`wp load`, …): WPL or `.plan`.
    Mission(crate::mission::MissionType),
}
