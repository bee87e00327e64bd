//! How ArduPilot sends PARAM_VALUE (`libraries/GCS_MAVLink/GCS_Param.cpp`), and the link it
//! paces them by.
//!
//! - `queued_param_send` runs from the deferred message MSG_NEXT_PARAM, whose interval
//!   (`set_ap_message_interval`) is the SRn_PARAMS rate but never slower than 1 s and, at rate
//!   0, 100 ms: "parameters always get streamed". Each run first sends up to 5 queued answers
//!   to PARAM_REQUEST_READ, then continues a PARAM_REQUEST_LIST download:
//!   `bytes_allowed = bw_in_bytes_per_second * (now_ms - last_ms) / 3333` (30 % of the link),
//!   at least one PARAM_VALUE (25 bytes + 12 of MAVLink 2 framing) and at most the channel's
//!   `txspace()`, which `GCS_MAVLINK::txspace` caps at 8192; without hardware flow control
//!   never more than 5 a run ("we really need to keep the param download very slow"); the
//!   answers already sent count against it.
//! - PARAM_REQUEST_READ is not answered where it is handled: `handle_param_request_read` queues
//!   it (20 deep, dropped when full), the IO thread's `param_io_timer` (1 kHz) looks up one at a
//!   time into a reply queue of 5, and `send_parameter_async_replies` sends them at the next run.
//!   The reply's `param_index` is the one asked for: -1 (65535) when asked by name.
//!
//! On a UART (`baud=`) the port's bandwidth is `baud / 10` bytes/s and there is no flow control
//! (a radio on a telemetry port). Without `baud` the link is the SITL/network kind: flow control
//! and far more bandwidth than a run can use, so the 8192-byte `txspace` cap decides: 221
//! PARAM_VALUE every 100 ms, as the real SITL capture shows.

use super::params::ParamTable;
use super::telemetry::param_value_indexed;
use crate::clock::Micros;
use crate::dialect::MavMessage;
use std::collections::VecDeque;

/// MSG_NEXT_PARAM's interval with SRn_PARAMS at 0 (the default).
pub const PARAM_SEND_INTERVAL: Micros = 100_000;
/// `param_io_timer` runs on the IO thread, about every millisecond.
pub const IO_TIMER_PERIOD: Micros = 1_000;
/// `MAVLINK_MSG_ID_PARAM_VALUE_LEN + packet_overhead()` (MAVLink 2, unsigned).
pub const PARAM_VALUE_SIZE: u64 = 25 + 12;
/// `GCS_MAVLINK::txspace()` never reports more than this.
pub const TXSPACE_CAP: u64 = 8192;
/// PARAM_VALUEs per run on a link without flow control.
pub const NO_FLOW_CONTROL_MAX: u64 = 5;
/// `param_requests` and `param_replies` sizes; answers sent per run.
pub const REQUEST_QUEUE: usize = 20;
pub const REPLY_QUEUE: usize = 5;
pub const REPLIES_PER_RUN: usize = 5;
/// Bandwidth of the network link (no `baud=`): a 10 Mbit/s-class link, whose 30 % share per
/// 100 ms run is well above the txspace cap.
pub const NETWORK_BW: u32 = 1_000_000;

/// What the vehicle's MAVLink port looks like to GCS_MAVLINK.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LinkModel {
    /// `bw_in_bytes_per_second()`.
    pub bytes_per_second: u32,
    /// `have_flow_control()` / `get_flow_control() == FLOW_CONTROL_ENABLE`.
    pub flow_control: bool,
}

impl LinkModel {
    /// A UART at `baud` (10 bits a byte, no flow control), or the network link.
    pub fn new(baud: Option<u32>) -> LinkModel {
        match baud {
            Some(b) => LinkModel {
                bytes_per_second: b / 10,
                flow_control: false,
            },
            None => LinkModel {
                bytes_per_second: NETWORK_BW,
                flow_control: true,
            },
        }
    }

    /// PARAM_VALUEs one `queued_param_send` run may send after `dt_ms` (before answers are
    /// taken off).
    pub fn params_per_run(&self, dt_ms: u64) -> u64 {
        let bytes =
            (self.bytes_per_second as u64 * dt_ms / 3333).clamp(PARAM_VALUE_SIZE, TXSPACE_CAP);
        let count = bytes / PARAM_VALUE_SIZE;
        if self.flow_control {
            count
        } else {
            count.min(NO_FLOW_CONTROL_MAX)
        }
    }
}

/// A PARAM_REQUEST_LIST download in progress.
#[derive(Debug, Clone, Copy)]
struct ListDownload {
    next: usize,
    /// `_queued_parameter_count`, taken when the list was asked for.
    count: u16,
}

/// One channel's parameter sending state.
#[derive(Debug, Clone, Default)]
pub struct ParamSender {
    list: Option<ListDownload>,
    /// `_queued_parameter_send_time_ms`.
    last_send_ms: u64,
    /// `param_requests`: (param_index as asked, name).
    requests: VecDeque<(i16, String)>,
    /// `param_replies`: built by the IO thread, values as they were then.
    replies: VecDeque<MavMessage>,
}

impl ParamSender {
    /// `handle_param_request_list`: start (or restart) the download.
    pub fn request_list(&mut self, now: Micros, params: &ParamTable) {
        self.list = Some(ListDownload {
            next: 0,
            count: params.len().min(u16::MAX as usize) as u16,
        });
        // "avoid initial flooding"
        self.last_send_ms = now / 1000;
    }

    /// `handle_param_request_read`: queue it, or drop it when 20 wait.
    pub fn request_read(&mut self, index: i16, name: String) {
        if self.requests.len() < REQUEST_QUEUE {
            self.requests.push_back((index, name));
        }
    }

    /// `param_io_timer`, `runs` times: look up one request per run while the reply queue has
    /// room. Unknown names and indices are dropped silently.
    pub fn io_timer(&mut self, runs: u64, params: &ParamTable) {
        for _ in 0..runs {
            if self.replies.len() >= REPLY_QUEUE {
                return;
            }
            let Some((index, name)) = self.requests.pop_front() else {
                return;
            };
            let found = if index != -1 {
                // find_by_index takes the index as unsigned: other negatives find nothing.
                Some(index as u16 as usize).filter(|&i| i < params.len())
            } else {
                params.index_of(&name)
            };
            if let Some(i) = found {
                let count = params.len().min(u16::MAX as usize) as u16;
                self.replies
                    .push_back(param_value_indexed(params, i, index as u16, count));
            }
        }
    }

    /// True while something waits for the next run.
    pub fn busy(&self) -> bool {
        self.list.is_some() || !self.replies.is_empty()
    }

    /// True while requests wait for the IO thread.
    pub fn io_pending(&self) -> bool {
        !self.requests.is_empty()
    }

    /// One `queued_param_send` run at `now`.
    pub fn run(&mut self, now: Micros, params: &ParamTable, link: &LinkModel) -> Vec<MavMessage> {
        let now_ms = now / 1000;
        let mut out = Vec::new();
        while out.len() < REPLIES_PER_RUN {
            let Some(r) = self.replies.pop_front() else {
                break;
            };
            out.push(r);
            self.last_send_ms = now_ms;
        }
        let answers = out.len() as u64;
        let Some(list) = &mut self.list else {
            return out;
        };
        let count = link.params_per_run(now_ms.saturating_sub(self.last_send_ms));
        if answers >= count {
            return out;
        }
        for _ in 0..count - answers {
            if list.next >= params.len() {
                break;
            }
            out.push(param_value_indexed(
                params,
                list.next,
                list.next.min(u16::MAX as usize) as u16,
                list.count,
            ));
            list.next += 1;
        }
        if list.next >= params.len() {
            self.list = None;
        }
        self.last_send_ms = now_ms;
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn per_run_budget_follows_queued_param_send() {
        // 57600 baud: 5760 B/s * 100 ms / 3333 = 172 bytes = 4 PARAM_VALUEs of 37 bytes.
        let radio = LinkModel::new(Some(57_600));
        assert_eq!(radio.params_per_run(100), 4);
        // Never less than one, never more than 5 without flow control.
        assert_eq!(radio.params_per_run(0), 1);
        assert_eq!(LinkModel::new(Some(9_600)).params_per_run(100), 1);
        assert_eq!(LinkModel::new(Some(921_600)).params_per_run(100), 5);
        // The network link: the 8192-byte txspace cap, 221 a run.
        assert_eq!(LinkModel::new(None).params_per_run(100), 221);
        assert_eq!(LinkModel::new(None).params_per_run(1), 8);
    }

    #[test]
    fn list_and_reads_share_a_run() {
        let params = ParamTable::copter(50);
        let link = LinkModel::new(Some(57_600));
        let mut s = ParamSender::default();
        s.request_list(0, &params);
        s.request_read(-1, "PILOT_THR_FILT".into());
        s.request_read(3, String::new());
        s.request_read(-1, "NO_SUCH".into());
        s.request_read(-2, String::new());
        s.io_timer(10, &params);
        let out = s.run(100_000, &params, &link);
        let idx: Vec<u16> = out
            .iter()
            .map(|m| match m {
                MavMessage::PARAM_VALUE(p) => p.param_index,
                _ => panic!(),
            })
            .collect();
        // Two answers (the unknown ones dropped). Sending them restarts the clock of the list
        // budget, so this run has room for one PARAM_VALUE, already used: no list entry.
        assert_eq!(idx, vec![65535, 3]);
        let out = s.run(200_000, &params, &link);
        assert_eq!(out.len(), 4);
        match &out[0] {
            MavMessage::PARAM_VALUE(p) => assert_eq!((p.param_index, p.param_count), (0, 50)),
            _ => panic!(),
        }
    }
}
