//! Links that live in this process: the simulated vehicle (`sim://`) and tlog replay, run in
//! real time for the terminal and report front ends. (Headless replay runs the same sources on a
//! virtual clock instead; see `headless::runner`.)

use std::time::Duration;

use tokio::sync::mpsc;

use super::spec::LinkSpec;
use super::tlog::read_tlog;
use super::transport::LocalIngest;
use super::tx::LinkTx;
use crate::dialect::MavMessage;

pub(crate) async fn run_local(
    spec: &LinkSpec,
    ingest: &mut LocalIngest<'_>,
    tx: &mut LinkTx,
    out: &mut mpsc::UnboundedReceiver<MavMessage>,
) -> Result<(), String> {
    match spec {
        LinkSpec::Tlog { path } => {
            let bytes = std::fs::read(path).map_err(|e| format!("{path}: {e}"))?;
            let records = read_tlog(&bytes).map_err(|e| format!("{path}: {e}"))?;
            ingest.up();
            let start = tokio::time::Instant::now();
            let t0 = records.first().map(|r| r.time_us).unwrap_or(0);
            for r in records {
                let due = start + Duration::from_micros(r.time_us.saturating_sub(t0));
                loop {
                    tokio::select! {
                        _ = tokio::time::sleep_until(due) => break,
                        m = out.recv() => if m.is_none() { return Ok(()) },
                    }
                }
                ingest.feed(&r.frame, tx);
            }
            // Replay done: the link stays up, quietly dropping what we send.
            while out.recv().await.is_some() {}
            Ok(())
        }
        LinkSpec::Sim { .. } => Err("simulated vehicle not built in".into()),
        _ => Err("not a local link".into()),
    }
}
