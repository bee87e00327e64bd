//! The link manager: starts one task per link (more at run time), hands on their reports, and
//! carries frames to the right links.

use tokio::sync::mpsc;

use super::replay::ReplayCmd;
use super::source::SourceFactory;
use super::transport::{spawn_link, EventTx, LinkEvent, LinkHandle, EVENT_QUEUE};
use super::{LinkId, LinkSpec};

/// All running links.
pub struct LinkManager {
    handles: Vec<Option<LinkHandle>>,
    local: SourceFactory,
    tx: EventTx,
    frames: mpsc::Receiver<(LinkId, LinkEvent)>,
    states: mpsc::UnboundedReceiver<(LinkId, LinkEvent)>,
}

/// Reports a forwarding output may have waiting (its clients' frames for the vehicles).
pub const OUTPUT_QUEUE: usize = 32;

impl LinkManager {
    /// Start a task for every spec; link ids are the specs' positions. `local` builds the
    /// in-process sources (`sim://`, `tlog:`).
    pub fn start(specs: &[LinkSpec], local: SourceFactory) -> Self {
        Self::start_queued(specs, local, EVENT_QUEUE)
    }

    /// As [`LinkManager::start`], with at most `queue` reports waiting (each the frames of one
    /// read): forwarding outputs get [`OUTPUT_QUEUE`], so a client flooding one costs a bounded
    /// amount of memory (the rest is dropped and counted).
    pub fn start_queued(specs: &[LinkSpec], local: SourceFactory, queue: usize) -> Self {
        let (ftx, frames) = mpsc::channel(queue);
        let (stx, states) = mpsc::unbounded_channel();
        let mut m = Self {
            handles: Vec::new(),
            local,
            tx: EventTx {
                frames: ftx,
                states: stx,
            },
            frames,
            states,
        };
        for (i, s) in specs.iter().enumerate() {
            m.open(i, s.clone());
        }
        m
    }

    /// Start link `id` (ids past the end leave gaps that are never used).
    pub fn open(&mut self, id: LinkId, spec: LinkSpec) {
        if self.handles.len() <= id {
            self.handles.resize_with(id + 1, || None);
        }
        self.handles[id] = Some(spawn_link(id, spec, self.local.clone(), self.tx.clone()));
    }

    /// The next report from any link (state changes first).
    pub async fn next_event(&mut self) -> Option<(LinkId, LinkEvent)> {
        let ev = tokio::select! {
            biased;
            Some(ev) = self.states.recv() => Some(ev),
            ev = self.frames.recv() => ev,
        };
        if let Some((id, LinkEvent::Frames { .. })) = &ev {
            if let Some(Some(h)) = self.handles.get(*id) {
                h.took_frames();
            }
        }
        ev
    }

    /// Pass a replay control to a link; false when it was dropped (no such link, queue full).
    pub fn control(&self, link: LinkId, cmd: ReplayCmd) -> bool {
        match self.handles.get(link) {
            Some(Some(h)) => h.control(cmd),
            _ => false,
        }
    }

    /// How many link ids there are (the highest opened, plus one).
    pub fn len(&self) -> usize {
        self.handles.len()
    }

    pub fn is_empty(&self) -> bool {
        self.handles.is_empty()
    }

    /// Queue a frame on a link; false when it was dropped (queue full, link ended).
    pub fn send(&self, link: LinkId, frame: Vec<u8>) -> bool {
        match self.handles.get(link) {
            Some(Some(h)) => h.send(frame),
            _ => false,
        }
    }
}
