//! In-process links (`sim://`, `tlog:`) in real time: the same [`VirtualSource`] the headless
//! runner steps on a virtual clock, woken here at its own deadlines on the wall clock.
//!
//! A live source (the sim) hands its frames on as a socket would: what a full queue cannot
//! take is dropped and counted. A replay ([`VirtualSource::lossless`]) waits for the core
//! instead, so nothing of the log is lost however fast it plays; a replay that has ended stays
//! open, idle, until a control (a seek back) moves it.

use std::time::Duration;

use tokio::sync::mpsc;

use super::replay::ReplayCmd;
use super::source::VirtualSource;
use super::transport::{LinkEvent, LocalIngest};
use crate::clock::Micros;

pub(crate) async fn run_local(
    mut src: Box<dyn VirtualSource>,
    ingest: &mut LocalIngest<'_>,
    out: &mut mpsc::Receiver<Vec<u8>>,
    ctl: &mut mpsc::Receiver<ReplayCmd>,
) -> Result<(), String> {
    ingest.up();
    let mut skipped_reported = 0;
    let start = tokio::time::Instant::now();
    let now = move || start.elapsed().as_micros() as Micros;
    loop {
        let deadline = src.next_deadline();
        let sleep = async {
            if deadline == Micros::MAX {
                std::future::pending::<()>().await
            } else {
                tokio::time::sleep_until(start + Duration::from_micros(deadline)).await
            }
        };
        let mut events = Vec::with_capacity(3);
        tokio::select! {
            _ = sleep => {}
            m = out.recv() => match m {
                Some(bytes) => src.receive(now(), &bytes),
                None => return Ok(()),
            },
            Some(cmd) = ctl.recv() => {
                src.control(now(), cmd);
                // Told before the frames that follow, so a seek's jump is known when they come.
                events.extend(src.take_status(now()).map(LinkEvent::Replay));
            }
        }
        let bytes = src.poll(now());
        // What the source passed over (a tlog's garbage) counts as garbage on the link.
        let skipped = src.skipped();
        let new_skipped = skipped.saturating_sub(skipped_reported);
        skipped_reported = skipped;
        if !src.lossless() {
            if !bytes.is_empty() || new_skipped > 0 {
                ingest.feed_skipped(&bytes, new_skipped);
            }
            continue;
        }
        if !bytes.is_empty() || new_skipped > 0 {
            events.push(ingest.frames_event(&bytes, new_skipped));
        }
        events.extend(src.take_status(now()).map(LinkEvent::Replay));
        for ev in events {
            if !ingest
                .send_waiting(ev, out, |b| src.receive(now(), &b))
                .await
            {
                return Ok(());
            }
        }
    }
}
