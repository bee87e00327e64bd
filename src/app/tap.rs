//! What the edge's tap on the links reports to the core: the telemetry log being recorded, and
//! the outputs frames are forwarded to (`--out`). Recording and forwarding happen at the edge
//! (the driver), off the core; the core only shows how they go: the log's name and size in the
//! status bar, outputs in the Links pane, and a notice when something stops.

use std::path::PathBuf;

use super::App;
use crate::link::LinkState;
use crate::wire::Severity;

/// The telemetry log: where, how big, and whether it stopped.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RecordingStatus {
    pub path: PathBuf,
    /// Size of the file, counting what is queued to be written.
    pub bytes: u64,
    /// Frames not recorded because the writer fell behind.
    pub dropped: u64,
    /// Why recording stopped (or never started); `None` while it goes on.
    pub error: Option<String>,
}

impl RecordingStatus {
    /// The file's name, as shown in the status bar.
    pub fn name(&self) -> String {
        self.path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| self.path.display().to_string())
    }
}

/// One forwarding output, with its counters since start.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OutputStatus {
    /// The connection string, as given.
    pub spec: String,
    pub state: LinkState,
    /// Frames heard on the vehicles' links and handed to this output.
    pub sent: u64,
    /// Frames this output's ground station sent (carried to the vehicles).
    pub received: u64,
    /// Frames dropped: the output down or not keeping up, or its frames not taken by a link.
    pub dropped: u64,
}

impl App {
    pub(super) fn on_recording(&mut self, st: RecordingStatus) {
        let before = self.recording.as_ref();
        let same_file = before.is_some_and(|b| b.path == st.path);
        let was_failed = same_file && before.is_some_and(|b| b.error.is_some());
        match &st.error {
            Some(e) if !was_failed => {
                let text = if st.path.as_os_str().is_empty() {
                    format!("not recording: {e}")
                } else if same_file {
                    format!("recording stopped: {}: {e}", st.path.display())
                } else {
                    format!("not recording: {}: {e}", st.path.display())
                };
                self.notice(Severity::ERROR, None, text);
            }
            None if !same_file => self.notice(
                Severity::INFO,
                None,
                format!("recording to {}", st.path.display()),
            ),
            _ => {}
        }
        self.recording = Some(st);
        self.dirty = true;
    }

    pub(super) fn on_output(&mut self, out: usize, st: OutputStatus) {
        // Outputs come from the command line: a few at most.
        if out >= MAX_OUTPUTS {
            return;
        }
        let o = &mut self.outputs;
        if o.list.len() <= out {
            o.list.resize_with(out + 1, || OutputStatus {
                spec: String::new(),
                state: LinkState::Connecting,
                sent: 0,
                received: 0,
                dropped: 0,
            });
            o.told_down.resize(out + 1, None);
        }
        let changed = o.list[out].state != st.state;
        let mut notice = None;
        if changed {
            match &st.state {
                LinkState::Up => {
                    o.told_down[out] = None;
                    notice = Some((Severity::INFO, format!("output {} up", st.spec)));
                }
                // An output retried with the same failure is told of once.
                LinkState::Down(reason) if o.told_down[out].as_ref() != Some(reason) => {
                    o.told_down[out] = Some(reason.clone());
                    let text = format!("output {} down: {reason}", st.spec);
                    notice = Some((Severity::WARNING, text));
                }
                _ => {}
            }
        }
        o.list[out] = st;
        if let Some((sev, text)) = notice {
            self.notice(sev, None, text);
        }
        self.dirty = true;
    }
}

/// Outputs shown at most.
pub const MAX_OUTPUTS: usize = 64;

/// The outputs, by the edge's output number.
#[derive(Debug, Clone, Default)]
pub struct Outputs {
    pub list: Vec<OutputStatus>,
    /// The last "down" reason told of per output, so retries do not repeat it.
    told_down: Vec<Option<String>>,
}
