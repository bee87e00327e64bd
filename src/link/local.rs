//! Links that live in this process: the simulated vehicle (`sim://`) and tlog replay, run in
//! real time for the terminal and report front ends. (Headless replay runs the same sources on a
//! virtual clock instead; see `headless::runner`.)

use std::time::Duration;

use tokio::sync::mpsc;

use super::spec::LinkSpec;
use super::tlog::read_tlog;
use super::transport::LocalIngest;
use crate::clock::Micros;
use crate::dialect::MavMessage;
use crate::sim::{Sim, SimConfig};
use crate::wire::tx::LinkTx;

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
        LinkSpec::Sim { query } => {
            let cfg = SimConfig::from_query(query).map_err(|e| format!("sim: {e}"))?;
            let mut sim = Sim::new(cfg);
            ingest.up();
            let start = tokio::time::Instant::now();
            let now = || start.elapsed().as_micros() as Micros;
            loop {
                // Wake at the sim's next deadline (at most every 10 ms), or when we send.
                let due = sim.next_deadline().saturating_sub(now()).min(10_000);
                tokio::select! {
                    _ = tokio::time::sleep(Duration::from_micros(due)) => {}
                    m = out.recv() => match m {
                        Some(msg) => {
                            let bytes = tx.encode(&msg);
                            sim.receive(now(), &bytes);
                        }
                        None => return Ok(()),
                    },
                }
                let bytes = sim.poll(now());
                if !bytes.is_empty() {
                    ingest.feed(&bytes, tx);
                }
            }
        }
        _ => Err("not a local link".into()),
    }
}
