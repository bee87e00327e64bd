//! In-process links (`sim://`, `tlog:`) in real time: the same [`VirtualSource`] the headless
//! runner steps on a virtual clock, woken here at its own deadlines on the wall clock.

use std::time::Duration;

use tokio::sync::mpsc;

use super::source::VirtualSource;
use super::transport::LocalIngest;
use crate::clock::Micros;

pub(crate) async fn run_local(
    mut src: Box<dyn VirtualSource>,
    ingest: &mut LocalIngest<'_>,
    out: &mut mpsc::Receiver<Vec<u8>>,
) -> Result<(), String> {
    ingest.up();
    let mut skipped_reported = 0;
    let start = tokio::time::Instant::now();
    let now = || start.elapsed().as_micros() as Micros;
    loop {
        let deadline = src.next_deadline();
        let sleep = async {
            if deadline == Micros::MAX {
                std::future::pending::<()>().await
            } else {
                tokio::time::sleep_until(start + Duration::from_micros(deadline)).await
            }
        };
        tokio::select! {
            _ = sleep => {}
            m = out.recv() => match m {
                Some(bytes) => src.receive(now(), &bytes),
                None => return Ok(()),
            },
        }
        let bytes = src.poll(now());
        // What the source passed over (a tlog's garbage) counts as garbage on the link.
        let skipped = src.skipped();
        let new_skipped = skipped.saturating_sub(skipped_reported);
        skipped_reported = skipped;
        if !bytes.is_empty() || new_skipped > 0 {
            ingest.feed_skipped(&bytes, new_skipped);
        }
    }
}
