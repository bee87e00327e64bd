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

impl super::App {
    /// Ask the edge for `path`, for `purpose`: an action whose line is done when the file is read
    /// (with what was read) or could not be (with why, and where).
    pub(super) fn read_file(
        &mut self,
        path: std::path::PathBuf,
        purpose: FileUse,
        fx: &mut Vec<super::Effect>,
    ) -> String {
        let text = format!("reading {}", path.display());
        self.start_action(
            None,
            Vec::new(),
            super::outcome::ActionKind::Read(path.clone()),
            text.clone(),
        );
        fx.push(super::Effect::ReadFile { path, purpose });
        text
    }
}
