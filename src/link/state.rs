//! A link's state as its task reports it.

/// Up, down (with the reason), or not yet connected.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LinkState {
    Connecting,
    Up,
    Down(String),
}

impl LinkState {
    /// `up`, `connecting` or `down: <reason>`.
    pub fn label(&self) -> String {
        match self {
            LinkState::Connecting => "connecting".into(),
            LinkState::Up => "up".into(),
            LinkState::Down(r) => format!("down: {r}"),
        }
    }
}
