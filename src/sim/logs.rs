//! The vehicle's onboard logs, served as ArduPilot serves them
//! (`libraries/AP_Logger/AP_Logger_MAVLinkLogTransfer.cpp`):
//!
//! - LOG_REQUEST_LIST (`start`, `end`): LOG_ENTRY for each id from `start` (at least 1) to
//!   `end` (at most the number of logs), one per send call, each with `num_logs` and
//!   `last_log_num` = the last id of this listing; no logs: one LOG_ENTRY id 0, `num_logs` 0.
//! - LOG_REQUEST_DATA (`id`, `ofs`, `count`): LOG_DATA of 90 bytes from `ofs` until `count`
//!   bytes (or the log's end: a short chunk, `count` 0 past it) went out; an unknown id ends
//!   any transfer. While a listing or a data request is being answered, another request is
//!   dropped (a list request with "Log download in progress").
//! - Pace: `handle_log_send` runs with every GCS update (400 Hz on Copter: four times a 10 ms
//!   tick); each call sends while the UART has room for the message (`HAVE_PAYLOAD_SPACE`), at
//!   most 1 LOG_DATA a call on a UART without flow control, 40 in SITL (the network link).
//! - LOG_ERASE erases every log; LOG_REQUEST_END ends the transfer.
//! - Armed: nothing is answered ("Disarm for log download", once).
//! - Logging pauses from the first data request until LOG_REQUEST_END.
//!
//! The logs' bytes are a deterministic pattern of (id, offset) ([`byte`]): tests compare what
//! was written with [`content`].

use crate::dialect::{MavMessage, LOG_DATA_DATA, LOG_ENTRY_DATA};

/// `handle_log_send` calls in one 10 ms tick of the simulation (a 400 Hz loop).
pub const CALLS_PER_TICK: u32 = 4;
/// LOG_DATAs a call on a UART without flow control, and on the network link (SITL).
pub const SENDS_UART: u32 = 1;
pub const SENDS_SITL: u32 = 40;
/// Bytes of a LOG_DATA and a LOG_ENTRY on the wire (MAVLink 2, unsigned, whole payload).
pub const LOG_DATA_SIZE: u64 = 97 + 12;
pub const LOG_ENTRY_SIZE: u64 = 14 + 12;
/// The UART's transmit buffer (what `txspace` reports when it is empty).
pub const UART_TXBUF: u64 = 1024;
/// The first log's time (UTC seconds); log `i` is `i` hours later; log 1 has none (no GPS
/// fix when it started).
pub const BASE_TIME: u32 = 1_764_000_000;

/// Byte `ofs` of log `id`.
pub fn byte(id: u16, ofs: u32) -> u8 {
    let x = ofs.wrapping_mul(2_654_435_761) ^ (id as u32).wrapping_mul(40_503) ^ (ofs >> 7);
    (x ^ (x >> 13) ^ (x >> 24)) as u8
}

/// The whole of log `id`, `size` bytes.
pub fn content(id: u16, size: u32) -> Vec<u8> {
    (0..size).map(|o| byte(id, o)).collect()
}

/// The sizes and times of `n` logs whose newest is `newest` bytes: log `i` (1-based) is
/// `newest * i / n` bytes, plus 7·i so that sizes are not multiples of 90.
pub fn catalogue(n: u16, newest: u32) -> Vec<(u32, u32)> {
    (1..=n as u32)
        .map(|i| {
            let size = (newest as u64 * i as u64 / n.max(1) as u64) as u32 + 7 * i;
            let time = if i == 1 { 0 } else { BASE_TIME + i * 3600 };
            (size, time)
        })
        .collect()
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Activity {
    Idle,
    Listing { next: u16, last: u16 },
    Sending { id: u16, ofs: u32, remaining: u32 },
}

/// One vehicle's logs and the transfer running.
#[derive(Debug, Clone)]
pub struct SimLogs {
    /// (size, time_utc) of log id `i + 1`.
    pub logs: Vec<(u32, u32)>,
    activity: Activity,
    /// Logging stopped: a data request came, LOG_REQUEST_END has not.
    pub logging_paused: bool,
    warned_armed: bool,
    /// Every request heard, for tests: LOG_REQUEST_DATA as (id, ofs, count).
    pub data_requests: Vec<(u16, u32, u32)>,
    pub list_requests: Vec<(u16, u16)>,
    pub ends: u32,
    pub erases: u32,
    /// Requests dropped because one was being answered.
    pub dropped_requests: u32,
    /// LOG_DATA sent.
    pub chunks_sent: u64,
}

impl SimLogs {
    pub fn new(n: u16, newest: u32) -> SimLogs {
        SimLogs {
            logs: catalogue(n, newest),
            activity: Activity::Idle,
            logging_paused: false,
            warned_armed: false,
            data_requests: Vec::new(),
            list_requests: Vec::new(),
            ends: 0,
            erases: 0,
            dropped_requests: 0,
            chunks_sent: 0,
        }
    }

    pub fn active(&self) -> bool {
        self.activity != Activity::Idle
    }

    /// `handle_log_message`: one of the log protocol's requests. `Err(text)`: a STATUSTEXT to
    /// send.
    pub fn handle(&mut self, armed: bool, msg: &MavMessage) -> Result<(), &'static str> {
        if armed {
            if !self.warned_armed {
                self.warned_armed = true;
                return Err("Disarm for log download");
            }
            return Ok(());
        }
        self.warned_armed = false;
        match msg {
            MavMessage::LOG_REQUEST_LIST(m) => {
                self.list_requests.push((m.start, m.end));
                if self.active() {
                    self.dropped_requests += 1;
                    return Err("Log download in progress");
                }
                let n = self.logs.len() as u16;
                self.activity = if n == 0 {
                    Activity::Listing { next: 0, last: 0 }
                } else {
                    Activity::Listing {
                        next: m.start.max(1),
                        last: m.end.min(n),
                    }
                };
                if let Activity::Listing { next, last } = self.activity {
                    if next > last && n > 0 {
                        // start past end: ArduPilot would send entry `start` (it checks ==
                        // only); nothing useful: treat as idle.
                        self.activity = Activity::Idle;
                    }
                }
            }
            MavMessage::LOG_REQUEST_DATA(m) => {
                self.data_requests.push((m.id, m.ofs, m.count));
                if self.active() {
                    // Same channel: dropped without a word.
                    self.dropped_requests += 1;
                    return Ok(());
                }
                let n = self.logs.len() as u16;
                if m.id < 1 || m.id > n {
                    self.activity = Activity::Idle;
                    return Ok(());
                }
                self.logging_paused = true;
                let size = self.logs[m.id as usize - 1].0;
                let remaining = size.saturating_sub(m.ofs).min(m.count);
                self.activity = Activity::Sending {
                    id: m.id,
                    ofs: m.ofs,
                    remaining,
                };
            }
            MavMessage::LOG_ERASE(_) => {
                self.erases += 1;
                self.logs.clear();
            }
            MavMessage::LOG_REQUEST_END(_) => {
                self.ends += 1;
                self.activity = Activity::Idle;
                self.logging_paused = false;
            }
            _ => {}
        }
        Ok(())
    }

    /// One tick's `handle_log_send` calls, with `txspace` bytes of room in the UART (and
    /// `flow_control`: the SITL network link). The messages to send.
    pub fn tick(&mut self, mut txspace: u64, flow_control: bool) -> Vec<MavMessage> {
        let mut out = Vec::new();
        let per_call = if flow_control { SENDS_SITL } else { SENDS_UART };
        'calls: for _ in 0..CALLS_PER_TICK {
            match self.activity {
                Activity::Idle => break,
                Activity::Listing { next, last } => {
                    if txspace < LOG_ENTRY_SIZE {
                        break;
                    }
                    txspace -= LOG_ENTRY_SIZE;
                    let (size, time_utc) = match next {
                        0 => (0, 0),
                        i => self.logs[i as usize - 1],
                    };
                    out.push(MavMessage::LOG_ENTRY(LOG_ENTRY_DATA {
                        time_utc,
                        size,
                        id: next,
                        num_logs: self.logs.len() as u16,
                        last_log_num: last,
                    }));
                    self.activity = if next >= last {
                        Activity::Idle
                    } else {
                        Activity::Listing {
                            next: next + 1,
                            last,
                        }
                    };
                }
                Activity::Sending { .. } => {
                    for _ in 0..per_call {
                        let Activity::Sending { id, ofs, remaining } = self.activity else {
                            break 'calls;
                        };
                        if txspace < LOG_DATA_SIZE {
                            break 'calls;
                        }
                        txspace -= LOG_DATA_SIZE;
                        let n = remaining.min(90);
                        let mut data = [0u8; 90];
                        for (k, d) in data.iter_mut().enumerate().take(n as usize) {
                            *d = byte(id, ofs + k as u32);
                        }
                        out.push(MavMessage::LOG_DATA(LOG_DATA_DATA {
                            ofs,
                            id,
                            count: n as u8,
                            data,
                        }));
                        self.chunks_sent += 1;
                        self.activity = if n < 90 || remaining - n == 0 {
                            Activity::Idle
                        } else {
                            Activity::Sending {
                                id,
                                ofs: ofs + n,
                                remaining: remaining - n,
                            }
                        };
                    }
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dialect::{LOG_REQUEST_DATA_DATA, LOG_REQUEST_END_DATA, LOG_REQUEST_LIST_DATA};

    fn list(start: u16, end: u16) -> MavMessage {
        MavMessage::LOG_REQUEST_LIST(LOG_REQUEST_LIST_DATA {
            start,
            end,
            target_system: 1,
            target_component: 1,
        })
    }

    fn data(id: u16, ofs: u32, count: u32) -> MavMessage {
        MavMessage::LOG_REQUEST_DATA(LOG_REQUEST_DATA_DATA {
            ofs,
            count,
            id,
            target_system: 1,
            target_component: 1,
        })
    }

    #[test]
    fn a_listing_gives_every_id_with_the_count_and_the_last_id() {
        let mut l = SimLogs::new(3, 1000);
        l.handle(false, &list(0, 0xFFFF)).unwrap();
        let out = l.tick(u64::MAX, false);
        let ids: Vec<(u16, u16, u16)> = out
            .iter()
            .map(|m| match m {
                MavMessage::LOG_ENTRY(e) => (e.id, e.num_logs, e.last_log_num),
                _ => panic!(),
            })
            .collect();
        assert_eq!(ids, vec![(1, 3, 3), (2, 3, 3), (3, 3, 3)]);
        // A range: `last_log_num` is its end.
        l.handle(false, &list(2, 2)).unwrap();
        let out = l.tick(u64::MAX, false);
        assert!(matches!(&out[..], [MavMessage::LOG_ENTRY(e)] if e.id == 2 && e.last_log_num == 2));
        // None at all: id 0, count 0.
        let mut empty = SimLogs::new(0, 0);
        empty.handle(false, &list(0, 0xFFFF)).unwrap();
        let out = empty.tick(u64::MAX, false);
        assert!(matches!(&out[..], [MavMessage::LOG_ENTRY(e)] if e.id == 0 && e.num_logs == 0));
    }

    #[test]
    fn data_comes_in_90_byte_chunks_paced_and_a_request_during_one_is_dropped() {
        let mut l = SimLogs::new(1, 1000);
        let size = l.logs[0].0;
        assert_eq!(size, 1007);
        l.handle(false, &data(1, 0, 1000)).unwrap();
        assert!(l.logging_paused);
        // A UART: one a call, four calls a tick.
        let out = l.tick(u64::MAX, false);
        let got: Vec<(u32, u8)> = out
            .iter()
            .map(|m| match m {
                MavMessage::LOG_DATA(d) => (d.ofs, d.count),
                _ => panic!(),
            })
            .collect();
        assert_eq!(got, vec![(0, 90), (90, 90), (180, 90), (270, 90)]);
        let MavMessage::LOG_DATA(d) = &out[1] else {
            panic!()
        };
        assert_eq!(d.data[..], content(1, 180)[90..180]);
        // Asked again while sending: dropped.
        l.handle(false, &data(1, 0, 90)).unwrap();
        assert_eq!(l.dropped_requests, 1);
        l.tick(u64::MAX, false);
        // 720..1000 of the 1000 asked: three of 90, then 10.
        let out = l.tick(u64::MAX, false);
        let got: Vec<(u32, u8)> = out
            .iter()
            .map(|m| match m {
                MavMessage::LOG_DATA(d) => (d.ofs, d.count),
                _ => panic!(),
            })
            .collect();
        assert_eq!(got, vec![(720, 90), (810, 90), (900, 90), (990, 10)]);
        assert!(!l.active());
        // Past the end of the log: a short chunk.
        l.handle(false, &data(1, 990, 1000)).unwrap();
        let out = l.tick(u64::MAX, false);
        assert!(matches!(&out[..], [MavMessage::LOG_DATA(d)] if d.ofs == 990 && d.count == 17));
        // Room for one only.
        l.handle(false, &data(1, 0, 1007)).unwrap();
        assert_eq!(l.tick(LOG_DATA_SIZE, true).len(), 1);
        assert_eq!(
            l.tick(u64::MAX, true).len(),
            12 - 1,
            "11 of 90 and one of 17"
        );
        l.handle(
            false,
            &MavMessage::LOG_REQUEST_END(LOG_REQUEST_END_DATA {
                target_system: 1,
                target_component: 1,
            }),
        )
        .unwrap();
        assert!(!l.logging_paused);
        // Armed: refused once with the reason.
        assert_eq!(
            l.handle(true, &data(1, 0, 90)),
            Err("Disarm for log download")
        );
        assert_eq!(l.handle(true, &data(1, 0, 90)), Ok(()));
        assert!(!l.active());
    }
}
