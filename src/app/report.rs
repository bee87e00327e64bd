//! The headless JSON report (`--report json`): one object with links and vehicles.
//!
//! Field names and meanings are a contract with scripts: `links[].spec/state/frames/bytes/
//! crc_errors/unknown_ids/sources[].{sysid,compid,received,lost,duplicates,reordered,loss_pct}`,
//! `vehicles[].{sysid,compid,type,autopilot,mode,armed,system_status,lost}`. Extra fields may be
//! added, never renamed. Bounded tables and queues say what they let go: `links[].dropped` (frames
//! a queue dropped), `links[].echoes` (our own frames heard back), `links[].evicted_sources`, and
//! `vehicles_evicted` at the top (with `vehicles_refused`: newcomers turned away because every
//! component kept was the target or busy, and `heartbeat_floods` / `flood_found`: floods of new
//! ids and the components found during them). A tlog link's skipped bytes are in `links[].garbage_bytes`, and
//! where its replay is in `links[].replay.{position_s,duration_s,speed,paused,ended}` (speed 0 =
//! as fast as possible; `null` on other links).
//!
//! `streams[]`, per session (`sysid`, `compid`, `autopilot`), per link heard: `link`, `state`
//! (`due`, `asking`, `flowing`, `failed`, `high-latency`), `requests` (frames sent),
//! `expected_bytes_per_second`, `budget_bytes_per_second` (a serial link with a known baud),
//! and `messages[].{id,name,requested_hz,measured_hz,method,state}` (method:
//! `REQUEST_DATA_STREAM <GROUP>` or `SET_MESSAGE_INTERVAL`).
//!
//! MAVLink signing: `signing.{key,key_id,timestamp}` at the top (whether we sign, the key's
//! short id, never the key; our last timestamp), `links[].{secure,signing_streams,
//! signing_streams_evicted}`, and `links[].sources[].signing.{signed,unchecked,unsigned,
//! bad_signature,replayed,too_old,rejected}`.
//! `outputs[].{spec,state,reason,sent,received,dropped}`: the forwarding outputs (`--out`);
//! `recording.{path,bytes,dropped,error}` (null when not recording): the telemetry log.
//! `version` (mavterm's), `start` (RFC 3339: the wall-clock time the run started; a replay's is
//! its log's start, a `sim://` run on the virtual clock has a fixed one) and `duration_s` (how
//! long the run lasted, in seconds of its clock).

use serde_json::{json, Value};

use super::links::{loss_pct, LinkState};
use super::App;
use crate::proto::vehicles::VehicleKey;

/// A link's or output's state for the report: `up`, `connecting` or `down` with the reason.
fn state_reason(s: &LinkState) -> (&'static str, Option<String>) {
    match s {
        LinkState::Up => ("up", None),
        LinkState::Connecting => ("connecting", None),
        LinkState::Down(r) => ("down", Some(r.clone())),
    }
}

fn round2(v: f64) -> f64 {
    (v * 100.0).round() / 100.0
}

impl App {
    /// `all links stayed down: SPEC (REASON), ...` when no link has ever been up (nothing could
    /// be heard, whatever the report says): a headless report then ends in failure.
    pub fn all_links_stayed_down(&self) -> Option<String> {
        if self.links.is_empty() || self.links.iter().any(|l| l.was_up) {
            return None;
        }
        let each: Vec<String> = self
            .links
            .iter()
            .map(|l| match &l.state {
                LinkState::Down(why) => format!("{} ({why})", l.spec),
                LinkState::Connecting | LinkState::Up => format!("{} (never connected)", l.spec),
            })
            .collect();
        Some(format!("all links stayed down: {}", each.join(", ")))
    }

    /// The report as a JSON value.
    pub fn report(&self) -> Value {
        let now = self.now;
        let links: Vec<Value> = self
            .links
            .iter()
            .map(|l| {
                let sources: Vec<Value> = l
                    .sources
                    .iter()
                    .map(|(&VehicleKey(sysid, compid), s)| {
                        json!({
                            "sysid": sysid,
                            "compid": compid,
                            "received": s.seq.received,
                            "lost": s.seq.lost,
                            "duplicates": s.seq.duplicates,
                            "reordered": s.seq.reordered,
                            "restarts": s.seq.restarts,
                            "frames": s.frames,
                            "loss_pct": round2(s.seq.loss_pct()),
                            "loss_pct_10s": round2(s.seq.window_loss_pct(now)),
                            "signing": {
                                "signed": s.signing.signed,
                                "unchecked": s.signing.unchecked,
                                "unsigned": s.signing.unsigned,
                                "bad_signature": s.signing.bad_signature,
                                "replayed": s.signing.replayed,
                                "too_old": s.signing.too_old,
                                "future": s.signing.future,
                                "rejected": s.signing.rejected,
                            },
                        })
                    })
                    .collect();
                let (state, reason) = state_reason(&l.state);
                json!({
                    "spec": l.spec,
                    "state": state,
                    "reason": reason,
                    "frames": l.parser.frames,
                    "bytes": l.parser.bytes,
                    "crc_errors": l.parser.crc_errors,
                    "unknown_ids": l.parser.unknown_ids,
                    "truncated": l.parser.truncated,
                    "decode_errors": l.parser.decode_errors,
                    "garbage_bytes": l.parser.garbage_bytes,
                    "signed_frames": l.parser.signed_frames,
                    "v1_frames": l.parser.v1_frames,
                    "v2_frames": l.parser.v2_frames,
                    "loss_pct": round2(loss_pct(l.totals())),
                    "dropped": l.dropped,
                    "echoes": l.echoes,
                    "sent_frames": l.sent_frames,
                    "sent_bytes": l.sent_bytes,
                    "evicted_sources": l.evicted_sources,
                    "secure": l.secure,
                    "signing_streams": l.signing_streams.len(),
                    "signing_streams_evicted": l.signing_streams.evicted,
                    "sources": sources,
                    "replay": l.replay.as_ref().map(|v| json!({
                        "position_s": v.position(now) as f64 / 1e6,
                        "duration_s": v.status.duration.map(|d| d as f64 / 1e6),
                        "speed": v.status.speed.get(),
                        "paused": v.status.paused,
                        "ended": v.status.ended,
                    })),
                })
            })
            .collect();
        let vehicles: Vec<Value> = self
            .vehicles
            .iter()
            .map(|v| {
                json!({
                    "sysid": v.sysid,
                    "compid": v.compid,
                    "type": v.type_name(),
                    "autopilot": v.autopilot_name(),
                    "mode": v.mode_name(),
                    "custom_mode": v.custom_mode,
                    "armed": v.armed(),
                    "system_status": v.status_name(),
                    "lost": v.lost,
                    "heartbeats": v.heartbeats,
                    "heartbeat_hz": round2(v.heartbeat_hz()),
                    "links": v.links.iter().collect::<Vec<_>>(),
                    "reboots": v.reboots,
                    "conflict": v.conflict,
                    "uses_gcs_sysid": v.uses_gcs_sysid,
                })
            })
            .collect();
        // Parameters of each session: per component, how far the download got, and every edit
        // with its outcome.
        let params: Vec<Value> = self
            .sessions
            .iter()
            .map(|(key, s)| {
                let sets: Vec<Value> = s
                    .params
                    .sets
                    .iter()
                    .map(|(comp, set)| {
                        let (got, count) = set.progress();
                        let edits: Vec<Value> = set
                            .params
                            .iter()
                            .filter_map(|(name, p)| {
                                let e = p.edit.as_ref()?;
                                let (state, why) = match &e.state {
                                    crate::proto::params::EditState::Pending => ("pending", None),
                                    crate::proto::params::EditState::Confirmed => {
                                        ("confirmed", None)
                                    }
                                    crate::proto::params::EditState::Failed(w) => {
                                        ("failed", Some(w.clone()))
                                    }
                                };
                                Some(json!({
                                    "name": name,
                                    "value": e.value,
                                    "state": state,
                                    "reason": why,
                                    "vehicle_value": p.value,
                                }))
                            })
                            .collect();
                        json!({
                            "compid": comp,
                            "received": got,
                            "count": count,
                            "complete": set.complete(),
                            "refused_names": set.refused,
                            "edits": edits,
                        })
                    })
                    .collect();
                let last = s.params.last.as_ref().map(|d| {
                    json!({
                        "method": d.method.name(),
                        "seconds": d.finished.map(|f| (f - d.started) as f64 / 1e6),
                        "requests": d.requests,
                        "retries": d.retries,
                        "fallback": d.fallback,
                    })
                });
                json!({
                    "sysid": key.0,
                    "compid": key.1,
                    "components": sets,
                    "download": last,
                    "encoding": s.params.encoding.name(),
                    "encoding_by": s.params.encoding_by.name(),
                    "encoding_suspect": s.params.encoding_suspect,
                })
            })
            .collect();
        // Telemetry asked of each autopilot, per link: asked and measured rates.
        let streams: Vec<Value> = self
            .sessions
            .iter()
            .map(|(key, s)| {
                let links: Vec<Value> = s
                    .streams
                    .link_states()
                    .map(|(link, state)| {
                        let messages: Vec<Value> = s
                            .streams
                            .report(now, link)
                            .into_iter()
                            .map(|m| {
                                json!({
                                    "id": m.msgid,
                                    "name": crate::proto::streams::msg_name(m.msgid),
                                    "requested_hz": round2(m.requested_hz as f64),
                                    "measured_hz": round2(m.measured_hz),
                                    "method": m.method.name(),
                                    "state": m.state.name(),
                                })
                            })
                            .collect();
                        let (bytes, budget) = s.streams.load(link).unwrap_or((0.0, None));
                        json!({
                            "link": link,
                            "state": state.name(),
                            "requests": s.streams.requests_sent(link),
                            "expected_bytes_per_second": round2(bytes),
                            "budget_bytes_per_second": budget,
                            "messages": messages,
                        })
                    })
                    .collect();
                json!({
                    "sysid": key.0,
                    "compid": key.1,
                    "links": links,
                })
            })
            .collect();
        let outputs: Vec<Value> = self
            .outputs
            .list
            .iter()
            .map(|o| {
                let (state, reason) = state_reason(&o.state);
                json!({
                    "spec": o.spec,
                    "state": state,
                    "reason": reason,
                    "sent": o.sent,
                    "received": o.received,
                    "dropped": o.dropped,
                })
            })
            .collect();
        let recording = self.recording.as_ref().map(|r| {
            json!({
                "path": r.path,
                "bytes": r.bytes,
                "dropped": r.dropped,
                "error": r.error,
            })
        });
        json!({
            "version": env!("CARGO_PKG_VERSION"),
            "start": self.cfg.epoch.to_rfc3339_opts(chrono::SecondsFormat::Micros, true),
            "duration_s": now as f64 / 1e6,
            "links": links,
            "vehicles": vehicles,
            "params": params,
            "streams": streams,
            "vehicles_evicted": self.vehicles.evicted,
            "vehicles_refused": self.vehicles.refused,
            "auto_held": self.auto_held,
            "heartbeat_floods": self.vehicles.floods,
            "flood_found": self.vehicles.flood_found,
            "signing": {
                "key": self.signing.key.is_some(),
                "key_id": self.signing.key.as_ref().map(|k| k.id()),
                "timestamp": self.signing.clock.last(),
                "state_repaired_from": self.signing.repaired_from,
            },
            "outputs": outputs,
            "recording": recording,
        })
    }
}
