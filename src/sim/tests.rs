//! Tests of the whole simulator on a virtual clock.

use super::vehicle::mode;
use super::*;
use crate::dialect::*;
use crate::wire::frame::Frame;
use crate::wire::{mavftp, param_pck};

const GCS: Header = Header {
    sysid: 255,
    compid: 190,
    seq: 0,
};

/// A GCS on a virtual clock: sends messages, collects every frame the sim emits.
struct Gcs {
    sim: Sim,
    now: Micros,
    parser: FrameParser,
    frames: Vec<Frame>,
    seq: u8,
}

impl Gcs {
    fn new(query: &str) -> Gcs {
        Gcs {
            sim: Sim::new(SimConfig::from_query(query).unwrap()),
            now: 0,
            parser: FrameParser::new(),
            frames: Vec::new(),
            seq: 0,
        }
    }

    fn send(&mut self, msg: MavMessage) {
        let h = Header {
            seq: self.seq,
            ..GCS
        };
        self.seq = self.seq.wrapping_add(1);
        let bytes = encode(Version::V2, h, &msg);
        self.sim.receive(self.now, &bytes);
    }

    /// Run until `until`, jumping from deadline to deadline like a virtual clock would.
    fn run_until(&mut self, until: Micros) {
        loop {
            let next = self.sim.next_deadline().min(until);
            assert!(next >= self.now, "deadline {next} before now {}", self.now);
            self.now = next;
            let out = self.sim.poll(self.now);
            let frames = &mut self.frames;
            self.parser.push(&out, |f| frames.push(f));
            if self.now >= until {
                break;
            }
        }
    }

    fn run_for(&mut self, d: Micros) {
        self.run_until(self.now + d);
    }

    fn acks(&self) -> Vec<(MavCmd, MavResult)> {
        self.frames
            .iter()
            .filter_map(|f| match f.message.as_deref() {
                Some(MavMessage::COMMAND_ACK(a)) => Some((a.command, a.result)),
                _ => None,
            })
            .collect()
    }

    fn last_ack(&self) -> (MavCmd, MavResult) {
        *self.acks().last().expect("an ACK")
    }

    fn texts(&self) -> Vec<(MavSeverity, String)> {
        self.frames
            .iter()
            .filter_map(|f| match f.message.as_deref() {
                Some(MavMessage::STATUSTEXT(t)) => {
                    Some((t.severity, t.text.to_str().unwrap_or("").to_string()))
                }
                _ => None,
            })
            .collect()
    }

    fn command(&mut self, command: MavCmd, p: [f32; 7], confirmation: u8) -> MavResult {
        self.send(MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
            param1: p[0],
            param2: p[1],
            param3: p[2],
            param4: p[3],
            param5: p[4],
            param6: p[5],
            param7: p[6],
            command,
            target_system: 1,
            target_component: 1,
            confirmation,
        }));
        self.run_for(20_000);
        let (c, r) = self.last_ack();
        assert_eq!(c, command);
        r
    }

    fn set_mode(&mut self, m: u32) -> MavResult {
        self.command(
            MavCmd::MAV_CMD_DO_SET_MODE,
            [1.0, m as f32, 0.0, 0.0, 0.0, 0.0, 0.0],
            0,
        )
    }

    fn arm(&mut self, force: bool) -> MavResult {
        let p2 = if force { handlers::FORCE_MAGIC } else { 0.0 };
        self.command(
            MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
            [1.0, p2, 0.0, 0.0, 0.0, 0.0, 0.0],
            0,
        )
    }

    fn takeoff(&mut self, alt: f32) -> MavResult {
        self.command(
            MavCmd::MAV_CMD_NAV_TAKEOFF,
            [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, alt],
            0,
        )
    }

    fn v(&self) -> &SimVehicle {
        self.sim.vehicle(1).unwrap()
    }

    /// Send a COMMAND_LONG to vehicle 1 without waiting for anything.
    fn send_long(&mut self, command: MavCmd, p: [f32; 7], confirmation: u8) {
        self.send(MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
            param1: p[0],
            param2: p[1],
            param3: p[2],
            param4: p[3],
            param5: p[4],
            param6: p[5],
            param7: p[6],
            command,
            target_system: 1,
            target_component: 1,
            confirmation,
        }));
    }

    /// A COMMAND_INT to vehicle 1; returns its ACK's result.
    fn command_int(
        &mut self,
        command: MavCmd,
        frame: MavFrame,
        p: [f32; 4],
        x: i32,
        y: i32,
        z: f32,
    ) -> MavResult {
        self.send(MavMessage::COMMAND_INT(COMMAND_INT_DATA {
            param1: p[0],
            param2: p[1],
            param3: p[2],
            param4: p[3],
            x,
            y,
            z,
            command,
            target_system: 1,
            target_component: 1,
            frame,
            current: 0,
            autocontinue: 0,
        }));
        self.run_for(20_000);
        let (c, r) = self.last_ack();
        assert_eq!(c, command);
        r
    }

    /// Every COMMAND_ACK from frame `from` on as (command, result, progress), read from the
    /// payload so that ACKs whose command the dialect lacks (SET_MODE's 11) are included.
    fn raw_acks_since(&self, from: usize) -> Vec<(u16, u8, u8)> {
        self.frames[from..]
            .iter()
            .filter(|f| f.msgid == COMMAND_ACK_ID)
            .map(|f| {
                let mut b = [0u8; 4];
                let p = f.payload();
                let n = p.len().min(4);
                b[..n].copy_from_slice(&p[..n]);
                (u16::from_le_bytes([b[0], b[1]]), b[2], b[3])
            })
            .collect()
    }

    /// COMMAND_ACKs (command, result) and STATUSTEXTs from frame `from` on, in arrival order.
    fn events_since(&self, from: usize) -> Vec<Ev> {
        self.frames[from..]
            .iter()
            .filter_map(|f| match f.message.as_deref() {
                Some(MavMessage::STATUSTEXT(t)) => {
                    Some(Ev::Text(t.text.to_str().unwrap_or("").to_string()))
                }
                _ if f.msgid == COMMAND_ACK_ID => {
                    let p = f.payload();
                    let mut b = [0u8; 3];
                    let n = p.len().min(3);
                    b[..n].copy_from_slice(&p[..n]);
                    Some(Ev::Ack(u16::from_le_bytes([b[0], b[1]]), b[2]))
                }
                _ => None,
            })
            .collect()
    }

    fn last_heartbeat(&self) -> HEARTBEAT_DATA {
        self.frames
            .iter()
            .rev()
            .find_map(|f| match f.message.as_deref() {
                Some(MavMessage::HEARTBEAT(h)) => Some(h.clone()),
                _ => None,
            })
            .expect("a heartbeat")
    }

    /// Messages of one type from frame `from` on.
    fn msgs_since<T>(&self, from: usize, pick: impl Fn(&MavMessage) -> Option<T>) -> Vec<T> {
        self.frames[from..]
            .iter()
            .filter_map(|f| f.message.as_deref().and_then(&pick))
            .collect()
    }

    /// Armed and hovering at `alt` metres in GUIDED, after the EKF uses GPS.
    fn fly_guided(&mut self, alt: f32) {
        self.run_until(vehicle::EKF_GPS_AT + 100_000);
        assert_eq!(self.set_mode(mode::GUIDED), MAV_RESULT_ACCEPTED);
        assert_eq!(self.arm(false), MAV_RESULT_ACCEPTED);
        assert_eq!(self.takeoff(alt), MAV_RESULT_ACCEPTED);
        self.run_for((alt as f64 / vehicle::CLIMB_RATE * 1e6) as Micros + 1_000_000);
        assert!((self.v().relative_alt_m() - alt as f64).abs() < 0.01);
    }
}

/// A COMMAND_ACK (command, result) or a STATUSTEXT, in the order they arrived.
#[derive(Debug, Clone, PartialEq)]
enum Ev {
    Ack(u16, u8),
    Text(String),
}

/// A STATUSTEXT as it arrives: ArduPilot formats texts into the message's 50 characters, so
/// longer ones are cut.
fn text(s: &str) -> Ev {
    Ev::Text(s.chars().take(50).collect())
}

use MavResult::*;

#[test]
fn boots_with_heartbeat_and_banner_streams_off() {
    let mut g = Gcs::new("");
    g.run_until(3_500_000);
    let hb: Vec<&HEARTBEAT_DATA> = g
        .frames
        .iter()
        .filter_map(|f| match f.message.as_deref() {
            Some(MavMessage::HEARTBEAT(h)) => Some(h),
            _ => None,
        })
        .collect();
    assert_eq!(hb.len(), 4, "1 Hz from t=0");
    assert_eq!(hb[0].custom_mode, mode::STABILIZE);
    assert_eq!(hb[0].mavtype, MavType::MAV_TYPE_QUADROTOR);
    assert_eq!(hb[0].autopilot, MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA);
    assert_eq!(hb[0].base_mode.bits(), 81, "ArduCopter STABILIZE disarmed");
    assert_eq!(hb[0].system_status, MavState::MAV_STATE_STANDBY);
    let texts: Vec<String> = g.texts().into_iter().map(|t| t.1).collect();
    assert_eq!(texts[0], "ArduCopter V4.7.0-dev (sim)");
    assert!(texts.contains(&"Frame: QUAD/PLUS".to_string()));
    assert!(texts.contains(&"ArduPilot Ready".to_string()));
    // And the calibrations of the boot, each result notified as it is saved, in order.
    let notices: Vec<(String, f32)> = g
        .frames
        .iter()
        .filter_map(|f| match f.message.as_deref() {
            Some(MavMessage::PARAM_VALUE(p)) => {
                assert!(is_boot_notice(p), "{p:?}");
                Some((p.param_id.to_str().unwrap().to_string(), p.param_value))
            }
            Some(MavMessage::HEARTBEAT(_)) | Some(MavMessage::STATUSTEXT(_)) => None,
            m => panic!("{m:?}"),
        })
        .collect();
    let due: Vec<(String, f32)> = crate::sim::params::boot_changes()
        .iter()
        .filter(|c| c.0 <= 3_500_000)
        .map(|c| (c.1.to_string(), c.2 as f32))
        .collect();
    assert_eq!(notices, due);
    assert_eq!(due.len(), 13);
    // Sequence numbers count up from 0 without gaps; all frames MAVLink 2 from 1:1.
    for (i, f) in g.frames.iter().enumerate() {
        assert_eq!(
            (f.seq, f.sysid, f.compid, f.version),
            (i as u8, 1, 1, Version::V2)
        );
    }
}

#[test]
fn prearm_refusal_until_position_then_arm() {
    let mut g = Gcs::new("");
    g.run_until(1_000_000);
    // As in the real capture: GUIDED is accepted while disarmed, arming in it is refused
    // (COMMAND_ACK FAILED) with an "Arm: " reason (ArduPilot prefixes failures found while
    // arming "Arm: ", the periodic ones "PreArm: ").
    assert_eq!(g.set_mode(mode::GUIDED), MAV_RESULT_ACCEPTED);
    assert_eq!(g.arm(false), MAV_RESULT_FAILED);
    assert!(g.texts().contains(&(
        MavSeverity::MAV_SEVERITY_CRITICAL,
        "Arm: AHRS: waiting for home".to_string()
    )));
    assert!(!g.v().armed());
    g.run_until(vehicle::EKF_GPS_AT + 100_000);
    assert_eq!(g.arm(false), MAV_RESULT_ACCEPTED);
    assert!(g.v().armed());
    g.run_for(1_000_000);
    let hb = g.last_heartbeat();
    assert!(hb
        .base_mode
        .contains(MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED));
    assert_eq!(
        hb.system_status,
        MavState::MAV_STATE_STANDBY,
        "armed on the ground"
    );
    g.set_mode(mode::GUIDED);
    g.takeoff(5.0);
    g.run_for(1_000_000);
    assert_eq!(
        g.last_heartbeat().system_status,
        MavState::MAV_STATE_ACTIVE,
        "flying"
    );
}

#[test]
fn force_arm_skips_checks() {
    let mut g = Gcs::new("");
    g.run_until(500_000);
    assert_eq!(g.arm(true), MAV_RESULT_ACCEPTED);
    assert!(g.v().armed());
}

#[test]
fn takeoff_refused_unless_guided_and_armed() {
    let mut g = Gcs::new("");
    g.run_until(vehicle::EKF_GPS_AT + 100_000);
    assert_eq!(g.takeoff(10.0), MAV_RESULT_FAILED, "disarmed, STABILIZE");
    assert_eq!(g.set_mode(mode::GUIDED), MAV_RESULT_ACCEPTED);
    assert_eq!(g.takeoff(10.0), MAV_RESULT_FAILED, "disarmed, GUIDED");
    assert_eq!(g.set_mode(mode::STABILIZE), MAV_RESULT_ACCEPTED);
    assert_eq!(g.arm(false), MAV_RESULT_ACCEPTED);
    assert_eq!(g.takeoff(10.0), MAV_RESULT_FAILED, "armed, STABILIZE");
    assert_eq!(g.v().relative_alt_m(), 0.0);
}

#[test]
fn takeoff_to_10m_then_land_and_auto_disarm() {
    let mut g = Gcs::new("");
    g.run_until(vehicle::EKF_GPS_AT + 100_000);
    assert_eq!(g.set_mode(mode::GUIDED), MAV_RESULT_ACCEPTED);
    assert_eq!(g.arm(false), MAV_RESULT_ACCEPTED);
    assert_eq!(g.takeoff(10.0), MAV_RESULT_ACCEPTED);
    let t0 = g.now;
    g.run_for(3_000_000);
    let a = g.v().relative_alt_m();
    assert!((4.0..5.0).contains(&a), "1.5 m/s climb: {a} after 3 s");
    assert_eq!(g.takeoff(20.0), MAV_RESULT_FAILED, "already flying");
    g.run_until(t0 + 8_000_000);
    let a = g.v().relative_alt_m();
    assert!((a - 10.0).abs() <= 0.5, "alt {a}");
    // The vehicle does not auto-disarm in the air.
    g.run_for(12_000_000);
    assert!(g.v().armed() && !g.v().landed());
    assert_eq!(
        g.command(MavCmd::MAV_CMD_NAV_LAND, [0.0; 7], 0),
        MAV_RESULT_ACCEPTED
    );
    assert_eq!(g.v().custom_mode(), mode::LAND);
    g.run_for(5_000_000);
    let a = g.v().relative_alt_m();
    assert!((6.5..8.0).contains(&a), "0.5 m/s descent: {a}");
    g.run_for(20_000_000);
    assert!(g.v().landed() && !g.v().armed());
    assert!(g.texts().iter().any(|t| t.1 == "Disarming motors"));
}

#[test]
fn rtl_climbs_returns_and_lands() {
    let mut g = Gcs::new("");
    g.run_until(vehicle::EKF_GPS_AT + 100_000);
    g.set_mode(mode::GUIDED);
    g.arm(false);
    g.takeoff(5.0);
    g.run_for(5_000_000);
    g.sim.vehicles[0].north = 50.0; // as if flown away
    assert_eq!(
        g.command(MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH, [0.0; 7], 0),
        MAV_RESULT_ACCEPTED
    );
    g.run_for(8_000_000);
    assert!(
        (g.v().relative_alt_m() - 15.0).abs() < 0.01,
        "RTL_ALT 1500 cm"
    );
    g.run_for(15_000_000);
    assert_eq!(g.v().position_ne(), (0.0, 0.0));
    g.run_for(40_000_000);
    assert!(g.v().landed() && !g.v().armed());
}

#[test]
fn auto_disarm_after_10s_on_the_ground() {
    let mut g = Gcs::new("");
    g.run_until(vehicle::EKF_GPS_AT + 100_000);
    g.arm(false);
    g.run_for(9_500_000);
    assert!(g.v().armed());
    g.run_for(1_000_000);
    assert!(!g.v().armed());
}

#[test]
fn unknown_and_unsupported_commands() {
    let mut g = Gcs::new("");
    g.run_until(100_000);
    assert_eq!(
        g.command(MavCmd::MAV_CMD_DO_SET_SERVO, [0.0; 7], 0),
        MAV_RESULT_UNSUPPORTED
    );
    assert_eq!(
        g.command(
            MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
            [3.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            0
        ),
        MAV_RESULT_UNSUPPORTED
    );
    assert_eq!(g.set_mode(8), MAV_RESULT_FAILED, "no mode 8 in ArduCopter");
    // No MAV_MODE_FLAG_CUSTOM_MODE_ENABLED: _set_mode_common answers DENIED.
    assert_eq!(
        g.command(
            MavCmd::MAV_CMD_DO_SET_MODE,
            [0.0, 4.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            0
        ),
        MAV_RESULT_DENIED
    );
    // A command id the dialect does not know at all: hand-made COMMAND_LONG with id 60000.
    let mut payload = vec![0u8; 28];
    payload.extend_from_slice(&60000u16.to_le_bytes());
    payload.extend_from_slice(&[1, 1, 0]);
    let frame = encode_raw(GCS, COMMAND_LONG_ID, &payload);
    g.sim.receive(g.now, &frame);
    g.run_for(20_000);
    let f = g.frames.last().unwrap();
    assert_eq!(f.msgid, COMMAND_ACK_ID);
    let p = f.payload();
    assert_eq!(u16::from_le_bytes([p[0], p[1]]), 60000);
    assert_eq!(p[2], MAV_RESULT_UNSUPPORTED as u8);
    assert_eq!(&p[8..10], &[255, 190]);
    // The same as COMMAND_INT (same offsets for command and targets).
    let mut payload = vec![0u8; 28];
    payload.extend_from_slice(&60001u16.to_le_bytes());
    payload.extend_from_slice(&[1, 1, 0, 0, 0]);
    let frame = encode_raw(GCS, COMMAND_INT_ID, &payload);
    g.sim.receive(g.now, &frame);
    g.run_for(20_000);
    let f = g.frames.last().unwrap();
    assert_eq!(f.msgid, COMMAND_ACK_ID);
    let p = f.payload();
    assert_eq!(u16::from_le_bytes([p[0], p[1]]), 60001);
    assert_eq!(p[2], MAV_RESULT_UNSUPPORTED as u8);
    // Garbage bytes do not panic and do not produce replies.
    let n = g.frames.len();
    let mut rng = Rng::new(3);
    let junk: Vec<u8> = (0..5000).map(|_| rng.next_u64() as u8).collect();
    g.sim.receive(g.now, &junk);
    g.run_for(10_000);
    assert!(g.frames[n..]
        .iter()
        .all(|f| !matches!(f.message.as_deref(), Some(MavMessage::COMMAND_ACK(_)))));
}

#[test]
fn retransmission_acked_but_not_executed_twice() {
    let mut g = Gcs::new("");
    g.run_until(vehicle::EKF_GPS_AT + 100_000);
    assert_eq!(g.arm(false), MAV_RESULT_ACCEPTED);
    let arm_texts = |g: &Gcs| g.texts().iter().filter(|t| t.1 == "Arming motors").count();
    // Disarm, then the GCS "lost" our ACK and resends the disarm with confirmation 1: a second
    // ACK comes, nothing else happens. We arm in between via a different sender... no: here
    // arm, retransmit arm after disarming; a retransmission must not re-arm.
    let arm = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    assert_eq!(
        g.command(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, [0.0; 7], 0),
        MAV_RESULT_ACCEPTED
    );
    assert!(!g.v().armed());
    assert_eq!(
        g.command(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, arm, 0),
        MAV_RESULT_ACCEPTED
    );
    assert_eq!(arm_texts(&g), 2);
    // Simulate: vehicle disarmed by someone else (internal), then a retransmitted arm arrives.
    g.sim.vehicles[0].disarm("Disarming motors");
    let acks = g.acks().len();
    assert_eq!(
        g.command(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, arm, 1),
        MAV_RESULT_ACCEPTED
    );
    assert_eq!(g.acks().len(), acks + 1);
    assert!(!g.v().armed(), "retransmission must not execute again");
    assert_eq!(arm_texts(&g), 2);
    // After the window, or with confirmation 0, it is a new command.
    assert_eq!(
        g.command(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, arm, 0),
        MAV_RESULT_ACCEPTED
    );
    assert!(g.v().armed());
}

/// PARAM_VALUEs since frame `from`, but for the notices of the calibrations of the boot.
fn param_values_since(g: &Gcs, from: usize) -> Vec<PARAM_VALUE_DATA> {
    g.msgs_since(from, |m| match m {
        MavMessage::PARAM_VALUE(p) if !is_boot_notice(p) => Some(p.clone()),
        _ => None,
    })
}

/// Every PARAM_VALUE since frame `from`.
fn every_param_value_since(g: &Gcs, from: usize) -> Vec<PARAM_VALUE_DATA> {
    g.msgs_since(from, |m| match m {
        MavMessage::PARAM_VALUE(p) => Some(p.clone()),
        _ => None,
    })
}

fn is_boot_notice(p: &PARAM_VALUE_DATA) -> bool {
    let name = p.param_id.to_str().unwrap_or_default();
    p.param_index == u16::MAX
        && crate::sim::params::boot_changes()
            .iter()
            .any(|c| c.1 == name)
}

fn param_set_msg(name: &str, v: f32) -> MavMessage {
    MavMessage::PARAM_SET(PARAM_SET_DATA {
        param_value: v,
        target_system: 1,
        target_component: 1,
        param_id: name.into(),
        param_type: MavParamType::MAV_PARAM_TYPE_REAL32,
    })
}

fn param_read_msg(name: &str, index: i16) -> MavMessage {
    MavMessage::PARAM_REQUEST_READ(PARAM_REQUEST_READ_DATA {
        param_index: index,
        target_system: 1,
        target_component: 1,
        param_id: name.into(),
    })
}

#[test]
fn params_list_read_set() {
    let mut g = Gcs::new("params=400");
    g.run_until(100_000);
    g.send(MavMessage::PARAM_REQUEST_LIST(PARAM_REQUEST_LIST_DATA {
        target_system: 1,
        target_component: 1,
    }));
    g.run_for(2_000_000);
    let pv = param_values_since(&g, 0);
    assert_eq!(pv.len(), 400);
    for (i, p) in pv.iter().enumerate() {
        assert_eq!((p.param_index as usize, p.param_count), (i, 400));
    }
    assert_eq!(pv[0].param_id.to_str().unwrap(), "FORMAT_VERSION");
    assert_eq!(pv[0].param_type, MavParamType::MAV_PARAM_TYPE_INT16);
    assert_eq!(pv[0].param_value, 120.0);
    // Banner again after the list request.
    assert_eq!(
        g.texts()
            .iter()
            .filter(|t| t.1 == "Frame: QUAD/PLUS")
            .count(),
        2
    );

    // PARAM_REQUEST_READ is answered from the parameter schedule (every 100 ms), with the
    // index as asked: -1 (65535) by name.
    let read = |g: &mut Gcs, name: &str, index: i16| {
        let n = g.frames.len();
        g.send(param_read_msg(name, index));
        g.run_for(110_000);
        param_values_since(g, n).first().cloned()
    };
    let p = read(&mut g, "PILOT_THR_FILT", -1).unwrap();
    assert_eq!(p.param_id.to_str().unwrap(), "PILOT_THR_FILT");
    assert_eq!(
        (p.param_index, p.param_count, p.param_type),
        (65535, 400, MavParamType::MAV_PARAM_TYPE_REAL32)
    );
    let p = read(&mut g, "", 3).unwrap();
    assert_eq!(p.param_index, 3);
    let p = read(&mut g, "IGNORED", 2).unwrap();
    assert_eq!(p.param_index, 2, "an index wins over the name");
    assert!(read(&mut g, "NO_SUCH_PARAM", -1).is_none());
    assert!(read(&mut g, "", 400).is_none());
    assert!(
        read(&mut g, "FORMAT_VERSION", -2).is_none(),
        "only -1 means by name"
    );

    // PARAM_SET: the stored value comes back with index -1 (65535) and the count.
    let set = |g: &mut Gcs, name: &str, v: f32| {
        let n = g.frames.len();
        g.send(param_set_msg(name, v));
        g.run_for(20_000);
        param_values_since(g, n)
    };
    let p = set(&mut g, "FORMAT_VERSION", 7.7);
    assert_eq!(p.len(), 1);
    // AP_Param::set_float truncates (after adding 0.01): 7.7 is 7 in an INT16.
    assert_eq!(
        (p[0].param_value, p[0].param_index, p[0].param_count),
        (7.0, 65535, 400)
    );
    assert_eq!(p[0].param_type, MavParamType::MAV_PARAM_TYPE_INT16);
    assert_eq!(g.v().param("FORMAT_VERSION"), Some(7.0));
    // The same value again is still saved and echoed.
    assert_eq!(set(&mut g, "FORMAT_VERSION", 7.0)[0].param_value, 7.0);
    // Unknown name, NaN, infinity: ignored, nothing sent.
    assert!(set(&mut g, "NO_SUCH_PARAM", 1.0).is_empty());
    assert!(set(&mut g, "FORMAT_VERSION", f32::NAN).is_empty());
    assert!(set(&mut g, "FORMAT_VERSION", f32::INFINITY).is_empty());
    assert_eq!(g.v().param("FORMAT_VERSION"), Some(7.0));
}

/// The parameters ArduPilot flags AP_PARAM_FLAG_INTERNAL_USE_ONLY refuse PARAM_SET
/// (`allow_set_via_mavlink`): the current value comes back (index -1) and a warning says so;
/// BRD_OPTIONS bit 2 (ALLOW_SET_INTERNAL_PARM) lets them be set.
#[test]
fn internal_parameters_refuse_param_set() {
    let mut g = Gcs::new("");
    g.run_until(100_000);
    let old = g.v().param("BARO1_GND_PRESS").unwrap();
    let n = g.frames.len();
    g.send(param_set_msg("BARO1_GND_PRESS", 100_000.0));
    g.run_for(20_000);
    let pv = param_values_since(&g, n);
    assert_eq!(pv.len(), 1);
    assert_eq!(
        (pv[0].param_value as f64, pv[0].param_index),
        (old as f32 as f64, 65535)
    );
    assert_eq!(g.v().param("BARO1_GND_PRESS"), Some(old));
    let events: Vec<u32> = g.frames[n..].iter().map(|f| f.msgid).collect();
    assert_eq!(events, vec![22, 253], "PARAM_VALUE, then the queued text");
    assert_eq!(
        g.texts().last().unwrap(),
        &(
            MavSeverity::MAV_SEVERITY_WARNING,
            "Param write denied (BARO1_GND_PRESS)".to_string()
        )
    );
    g.send(param_set_msg("BRD_OPTIONS", 4.0));
    g.run_for(20_000);
    let n = g.frames.len();
    g.send(param_set_msg("BARO1_GND_PRESS", 100_000.0));
    g.run_for(20_000);
    assert_eq!(param_values_since(&g, n)[0].param_value, 100_000.0);
    assert_eq!(g.v().param("BARO1_GND_PRESS"), Some(100_000.0));
}

/// PARAM_REQUEST_READ goes through ArduPilot's queues: 20 requests wait at most (more are
/// dropped), the IO thread moves them into 5 replies, each parameter run (every 100 ms) sends 5.
#[test]
fn param_reads_are_queued_and_paced() {
    let mut g = Gcs::new("");
    g.run_until(1_005_000);
    let n = g.frames.len();
    for i in 0..30 {
        g.send(param_read_msg("", i));
    }
    let mut per_run = Vec::new();
    for k in 1..=5 {
        g.run_until(1_000_000 + k * 100_000);
        per_run.push(param_values_since(&g, n).len());
    }
    assert_eq!(per_run, vec![5, 10, 15, 20, 20]);
    let idx: Vec<u16> = param_values_since(&g, n)
        .iter()
        .map(|p| p.param_index)
        .collect();
    assert_eq!(idx, (0..20).collect::<Vec<u16>>(), "20 queued, 10 dropped");
}

#[test]
fn state_file_persists_param_set() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("state.parm");
    let q = format!("state={}", path.display());
    let mut g = Gcs::new(&q);
    g.run_until(10_000);
    g.send(MavMessage::PARAM_SET(PARAM_SET_DATA {
        param_value: 2500.0,
        target_system: 1,
        target_component: 1,
        param_id: "RTL_ALT".into(),
        param_type: MavParamType::MAV_PARAM_TYPE_INT32,
    }));
    assert!(!path.exists(), "the state machine writes no file itself");
    save_pending(&mut g.sim);
    assert!(path.exists());
    let g2 = Gcs {
        sim: open(SimConfig::from_query(&q).unwrap()),
        ..Gcs::new("")
    };
    assert_eq!(g2.v().param("RTL_ALT"), Some(2500.0));
}

/// Each group at its own rate, as a GCS asks them one by one (QGroundControl's rates): every
/// message ArduCopter puts in a group comes at that group's rate, and asking one group leaves the
/// others as they are.
#[test]
#[allow(deprecated)]
fn stream_groups_each_at_their_own_rate() {
    let mut g = Gcs::new("");
    g.run_until(100_000);
    let rates: [(u8, u16); 7] = [(1, 2), (2, 2), (3, 2), (6, 3), (10, 10), (11, 10), (12, 3)];
    for (group, hz) in rates {
        g.send(MavMessage::REQUEST_DATA_STREAM(REQUEST_DATA_STREAM_DATA {
            req_message_rate: hz,
            target_system: 1,
            target_component: 1,
            req_stream_id: num_traits::FromPrimitive::from_u8(group).unwrap(),
            start_stop: 1,
        }));
    }
    g.run_for(1_000_000);
    let n = g.frames.len();
    g.run_for(20_000_000);
    let count = |id: u32| g.frames[n..].iter().filter(|f| f.msgid == id).count() as f64;
    for (group, hz) in rates {
        // GIMBAL_DEVICE_ATTITUDE_STATUS is in EXTRA3 but only a vehicle with a mount sends it.
        let mount_only = super::streams::id::GIMBAL_DEVICE_ATTITUDE_STATUS;
        for &id in super::streams::stream_group(group)
            .iter()
            .filter(|&&id| id != mount_only)
        {
            let got = count(id) / 20.0;
            assert!(
                (got - hz as f64).abs() <= 0.05 * hz as f64,
                "group {group} message {id}: {got} Hz, asked {hz}"
            );
        }
    }
    // EXTRA1 holds ATTITUDE and AHRS2, as ArduCopter's STREAM_EXTRA1_msgs.
    assert_eq!(super::streams::stream_group(10), &[30, 178]);
}

#[test]
fn streams_and_message_interval() {
    let mut g = Gcs::new("");
    g.run_until(100_000);
    assert_eq!(
        g.command(
            MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
            [33.0, 200_000.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            0
        ),
        MAV_RESULT_ACCEPTED
    );
    let n = g.frames.len();
    g.run_for(10_000_000);
    let count =
        |g: &Gcs, from: usize, id: u32| g.frames[from..].iter().filter(|f| f.msgid == id).count();
    let c = count(&g, n, 33);
    assert!((49..=51).contains(&c), "5 Hz for 10 s: {c}");
    assert_eq!(
        g.command(
            MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
            [33.0, -1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            0
        ),
        MAV_RESULT_ACCEPTED
    );
    let n = g.frames.len();
    g.run_for(2_000_000);
    assert_eq!(count(&g, n, 33), 0);
    assert_eq!(
        g.command(
            MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
            [0.0, 100.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            0
        ),
        MAV_RESULT_FAILED
    );
    // REQUEST_DATA_STREAM ALL at 4 Hz: every group's messages come.
    #[allow(deprecated)]
    g.send(MavMessage::REQUEST_DATA_STREAM(REQUEST_DATA_STREAM_DATA {
        req_message_rate: 4,
        target_system: 1,
        target_component: 1,
        req_stream_id: MavDataStream::MAV_DATA_STREAM_ALL,
        start_stop: 1,
    }));
    let n = g.frames.len();
    g.run_for(5_000_000);
    for id in [1, 2, 24, 27, 29, 30, 32, 33, 36, 65, 74, 147, 163] {
        let c = count(&g, n, id);
        assert!((19..=21).contains(&c), "msg {id}: {c} in 5 s at 4 Hz");
    }
    let gps = g.frames[n..]
        .iter()
        .rev()
        .find_map(|f| match f.message.as_deref() {
            Some(MavMessage::GPS_RAW_INT(m)) => Some(m.clone()),
            _ => None,
        });
    assert_eq!(gps.unwrap().fix_type, GpsFixType::GPS_FIX_TYPE_3D_FIX);
    // REQUEST_MESSAGE: one AUTOPILOT_VERSION after the ACK; HOME_POSITION too.
    assert_eq!(
        g.command(
            MavCmd::MAV_CMD_REQUEST_MESSAGE,
            [148.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            0
        ),
        MAV_RESULT_ACCEPTED
    );
    let av = g.frames.iter().find_map(|f| match f.message.as_deref() {
        Some(MavMessage::AUTOPILOT_VERSION(a)) => Some(a.clone()),
        _ => None,
    });
    let av = av.unwrap();
    assert!(av
        .capabilities
        .contains(MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_MAVLINK2));
    assert!(av
        .capabilities
        .contains(MavProtocolCapability::MAV_PROTOCOL_CAPABILITY_FTP));
    assert_eq!(av.flight_sw_version >> 8, 0x040700);
    assert_eq!(
        g.command(
            MavCmd::MAV_CMD_REQUEST_MESSAGE,
            [242.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            0
        ),
        MAV_RESULT_ACCEPTED
    );
    assert!(g.frames.iter().any(|f| f.msgid == 242));
    assert_eq!(
        g.command(
            MavCmd::MAV_CMD_REQUEST_MESSAGE,
            [9999.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            0
        ),
        MAV_RESULT_FAILED,
        "handle_command_request_message: FAILED for an id it has no message for"
    );
}

/// Sequence-gap loss counter as a GCS would write it: (seq - last - 1) mod 256 per source.
fn gaps_per_sysid(frames: &[Frame]) -> std::collections::BTreeMap<u8, u64> {
    let mut last: std::collections::BTreeMap<u8, u8> = Default::default();
    let mut gaps: std::collections::BTreeMap<u8, u64> = Default::default();
    for f in frames {
        if let Some(l) = last.insert(f.sysid, f.seq) {
            *gaps.entry(f.sysid).or_default() += f.seq.wrapping_sub(l).wrapping_sub(1) as u64;
        }
    }
    gaps
}

fn stream_all(g: &mut Gcs, sysid: u8) {
    #[allow(deprecated)]
    g.send(MavMessage::REQUEST_DATA_STREAM(REQUEST_DATA_STREAM_DATA {
        req_message_rate: 10,
        target_system: sysid,
        target_component: 1,
        req_stream_id: MavDataStream::MAV_DATA_STREAM_ALL,
        start_stop: 1,
    }));
}

#[test]
fn loss_truth_equals_sequence_gaps() {
    for seed in [1, 7, 42] {
        let mut g = Gcs::new(&format!("loss=0.2&seed={seed}&vehicles=3"));
        // The first frame of each vehicle must arrive for the counter to start at seq 0:
        // count from whatever arrives first, and add the frames lost before it.
        for s in 1..=3 {
            stream_all(&mut g, s);
        }
        g.run_until(60_000_000);
        let gaps = gaps_per_sysid(&g.frames);
        let truth = g.sim.truth();
        for s in 1..=3u8 {
            let first_seq = g.frames.iter().find(|f| f.sysid == s).unwrap().seq as u64;
            let t = truth.get(s);
            assert!(t.generated > 5_000, "{t:?}");
            let measured = gaps[&s] + first_seq;
            // Frames lost after the last one that arrived show no gap yet.
            let last_seq = g.frames.iter().rev().find(|f| f.sysid == s).unwrap().seq;
            let tail = (g.sim.seqs[(s - 1) as usize]
                .wrapping_sub(last_seq)
                .wrapping_sub(1)) as u64;
            assert_eq!(measured + tail, t.dropped, "seed {seed} sysid {s}");
            let rate = t.dropped as f64 / t.generated as f64;
            assert!((0.18..0.22).contains(&rate), "loss rate {rate}");
        }
    }
}

#[test]
fn deterministic_byte_identical_output() {
    let run = |q: &str, step: Micros| {
        let mut sim = Sim::new(SimConfig::from_query(q).unwrap());
        let mut out = Vec::new();
        let mut t = 0;
        let req = encode(
            Version::V2,
            GCS,
            #[allow(deprecated)]
            &MavMessage::REQUEST_DATA_STREAM(REQUEST_DATA_STREAM_DATA {
                req_message_rate: 10,
                target_system: 0,
                target_component: 0,
                req_stream_id: MavDataStream::MAV_DATA_STREAM_ALL,
                start_stop: 1,
            }),
        );
        while t < 20_000_000 {
            if t == 1_000_000 {
                sim.receive(t, &req);
            }
            out.extend(sim.poll(t));
            t += step;
        }
        out.extend(sim.poll(20_000_000));
        out
    };
    let q =
        "vehicles=2&loss=0.1&dup=0.05&reorder=0.05&corrupt=0.01&latency_ms=30&seed=9&baud=57600";
    let a = run(q, 10_000);
    assert!(a.len() > 100_000);
    assert_eq!(a, run(q, 10_000));
    // Polling in different steps at the same input times gives the same bytes.
    assert_eq!(a, run(q, 50_000));
    assert_ne!(a, run(&q.replace("seed=9", "seed=10"), 10_000));
}

#[test]
fn corruption_shows_as_crc_errors() {
    let mut g = Gcs::new("corrupt=0.05&seed=3");
    stream_all(&mut g, 1);
    g.run_until(20_000_000);
    let t = g.sim.truth().get(1);
    assert!(t.corrupted > 100);
    // Each corrupted frame fails its CRC once; the parser then rescans the rejected bytes, and
    // a magic byte among them can start a second failing candidate: a few more, never fewer.
    let crc = g.parser.stats().crc_errors;
    assert!(
        crc >= t.corrupted && crc <= t.corrupted + t.corrupted / 20,
        "{crc} CRC errors for {} corrupted frames",
        t.corrupted
    );
}

/// PARAM_REQUEST_LIST paced as `queued_param_send` does, every 100 ms: on a 57600 baud radio
/// (5760 B/s, no flow control) 5760 * 100 / 3333 = 172 bytes a run, 4 PARAM_VALUEs of 37 bytes,
/// so 1354 parameters take 339 runs; the radio queue never overflows. On the network link the
/// 8192-byte txspace cap gives 221 a run: 7 runs.
#[test]
fn param_list_paced_by_the_link() {
    let list = MavMessage::PARAM_REQUEST_LIST(PARAM_REQUEST_LIST_DATA {
        target_system: 1,
        target_component: 1,
    });
    let mut g = Gcs::new("baud=57600");
    g.run_until(100_000);
    g.send(list.clone());
    // (+50 ms: the radio takes 6.4 ms a PARAM_VALUE.)
    g.run_until(250_000);
    assert_eq!(param_values_since(&g, 0).len(), 4);
    g.run_until(1_150_000);
    assert_eq!(param_values_since(&g, 0).len(), 40, "4 a run");
    g.run_until(100_000 + 338 * 100_000 + 50_000);
    assert_eq!(param_values_since(&g, 0).len(), 1352);
    g.run_until(100_000 + 339 * 100_000 + 50_000);
    let pv = param_values_since(&g, 0);
    assert_eq!(pv.len(), 1354);
    assert!(pv
        .iter()
        .enumerate()
        .all(|(i, p)| p.param_index as usize == i));
    let t = g.sim.truth().get(1);
    assert_eq!((t.queue_overflow, t.dropped), (0, 0), "{t:?}");

    let mut g = Gcs::new("");
    g.run_until(100_000);
    g.send(list);
    let mut per_run = Vec::new();
    for k in 2..=8 {
        g.run_until(k * 100_000);
        per_run.push(param_values_since(&g, 0).len());
    }
    assert_eq!(per_run, vec![221, 442, 663, 884, 1105, 1326, 1354]);
}

#[test]
fn several_vehicles_have_own_ids_and_seqs() {
    let mut g = Gcs::new("vehicles=3&sysid=10");
    g.run_until(2_500_000);
    for s in 10..=12u8 {
        let seqs: Vec<u8> = g
            .frames
            .iter()
            .filter(|f| f.sysid == s)
            .map(|f| f.seq)
            .collect();
        assert!(seqs.len() > 5);
        assert!(seqs.iter().enumerate().all(|(i, &q)| q == i as u8));
    }
    assert!(g.sim.vehicle(13).is_none());
    assert_eq!(g.sim.vehicle(11).unwrap().param("MAV_SYSID"), Some(11.0));
}

/// The real ArduCopter param.pck in the capture decodes with our decoder to the 1,354
/// parameters of copter-params.parm, and our encoder reproduces the file byte for byte.
/// The FTP packets the real ArduCopter sent in the MAVFTP capture, in order.
fn capture_ftp_packets() -> Vec<mavftp::FtpPacket> {
    let tlog = include_bytes!("../../assets/sim/testdata/copter-mavftp-params.vehicle.tlog");
    let mut out = Vec::new();
    let mut parser = FrameParser::new();
    let mut pos = 0;
    while pos + 8 < tlog.len() {
        pos += 8; // timestamp
        let len = tlog[pos + 1] as usize;
        let signed = tlog[pos + 2] & 1 != 0;
        let flen = 12 + len + if signed { 13 } else { 0 };
        for f in parser.parse_all(&tlog[pos..pos + flen]) {
            if let Some(MavMessage::FILE_TRANSFER_PROTOCOL(m)) = f.message.as_deref() {
                out.push(mavftp::FtpPacket::parse(&m.payload));
            }
        }
        pos += flen;
    }
    out
}

/// The `@PARAM/param.pck?withdefaults=1` of the capture (read size 239).
fn capture_param_pck() -> Vec<u8> {
    let mut chunks: std::collections::BTreeMap<u32, Vec<u8>> = Default::default();
    for p in capture_ftp_packets() {
        if p.opcode == mavftp::op::ACK && p.req_opcode == mavftp::op::BURST_READ_FILE {
            chunks.insert(p.offset, p.data);
        }
    }
    chunks.values().flatten().copied().collect()
}

#[test]
fn real_capture_param_pck_decodes_and_reencodes() {
    let file = capture_param_pck();
    assert_eq!(file.len(), 15024);
    let decoded = param_pck::decode(&file).unwrap();
    assert_eq!(decoded.params.len(), 1354);
    assert_eq!(decoded.total_params, 1354);
    let parm = include_str!("../../assets/sim/copter-params.parm");
    let mut names = std::collections::BTreeSet::new();
    for line in parm.lines() {
        let mut it = line.split_whitespace();
        let (name, v) = (
            it.next().unwrap(),
            it.next().unwrap().parse::<f64>().unwrap(),
        );
        let p = decoded
            .params
            .iter()
            .find(|p| p.name == name)
            .unwrap_or_else(|| panic!("{name}"));
        // The .parm has 6 significant digits for a few lat/lon floats.
        assert!(
            (p.value - v).abs() <= 1e-5 * v.abs().max(1.0),
            "{name}: {} vs {v}",
            p.value
        );
        names.insert(name);
    }
    assert_eq!(names.len(), 1354);
    // Our table is that vehicle's: same order, same types.
    let table = ParamTable::copter(0);
    for (i, p) in decoded.params.iter().enumerate() {
        let q = table.get(i).unwrap();
        assert_eq!((&q.name, q.ptype), (&p.name, p.ptype));
    }
    // Re-encoding at the capture's read size (239) gives the same bytes.
    assert_eq!(param_pck::encode(&decoded.params, 1354, 239), file);
}

/// A GCS's FTP request to vehicle 1 (session 3, from 255:190).
fn ftp_req(seq: u16, opcode: u8, size: u8, offset: u32, data: &[u8]) -> MavMessage {
    let p = mavftp::FtpPacket {
        seq,
        session: 3,
        opcode,
        size,
        req_opcode: 0,
        burst_complete: 0,
        offset,
        data: data.to_vec(),
    };
    MavMessage::FILE_TRANSFER_PROTOCOL(FILE_TRANSFER_PROTOCOL_DATA {
        target_network: 0,
        target_system: 1,
        target_component: 1,
        payload: p.to_payload(),
    })
}

fn ftp_since(g: &Gcs, from: usize) -> Vec<mavftp::FtpPacket> {
    g.msgs_since(from, |m| match m {
        MavMessage::FILE_TRANSFER_PROTOCOL(f) => Some(mavftp::FtpPacket::parse(&f.payload)),
        _ => None,
    })
}

/// The simulator's `param.pck?withdefaults=1`, for the capture's parameter values, is the real
/// ArduCopter's file byte for byte (same padding, same defaults flagged), and the exchange has
/// the capture's shape: ACK with the 12-bytes-a-parameter estimate and then the banner, a burst
/// whose short last packet is flagged, a NAK EndOfFile flagged too.
#[test]
fn withdefaults_download_is_the_real_file() {
    let real = capture_param_pck();
    let decoded = param_pck::decode(&real).unwrap();
    let mut g = Gcs::new("");
    for p in &decoded.params {
        assert!(g.sim.vehicles[0].params.set(&p.name, p.value).is_some());
    }
    g.run_until(100_000);
    let path = b"@PARAM/param.pck?withdefaults=1";
    let n = g.frames.len();
    g.send(ftp_req(
        0,
        mavftp::op::OPEN_FILE_RO,
        path.len() as u8,
        0,
        path,
    ));
    g.run_for(20_000);
    let ack = &ftp_since(&g, n)[0];
    assert_eq!(ack.data, 16248u32.to_le_bytes(), "the capture's estimate");
    let texts: Vec<String> = g.texts().into_iter().map(|t| t.1).collect();
    assert_eq!(
        texts[texts.len() - 3..],
        [
            telemetry::FIRMWARE_STRING.to_string(),
            "SIM 0 0 0 (simulated board)".into(),
            "Frame: QUAD/PLUS".into()
        ],
        "the banner after the open"
    );
    g.send(ftp_req(1, mavftp::op::BURST_READ_FILE, 239, 0, &[]));
    g.run_for(1_000_000);
    let burst = ftp_since(&g, n);
    let file: Vec<u8> = burst[1..]
        .iter()
        .filter(|p| p.opcode == mavftp::op::ACK)
        .flat_map(|p| p.data.clone())
        .collect();
    let first_diff = file.iter().zip(&real).position(|(a, b)| a != b);
    assert_eq!(
        (file.len(), first_diff),
        (real.len(), None),
        "{:?}",
        param_pck::decode(&file).map(|f| f
            .params
            .iter()
            .zip(&decoded.params)
            .filter(|(a, b)| a != b)
            .map(|(a, b)| format!("{a:?} vs {b:?}"))
            .collect::<Vec<_>>())
    );
    let shape = |ps: &[mavftp::FtpPacket]| -> Vec<(u16, u8, u8, u8, u32)> {
        ps.iter()
            .filter(|p| p.req_opcode == mavftp::op::BURST_READ_FILE)
            .map(|p| (p.seq, p.opcode, p.size, p.burst_complete, p.offset))
            .collect()
    };
    assert_eq!(shape(&burst), shape(&capture_ftp_packets()));
}

#[test]
fn mavftp_download_through_the_sim() {
    let mut g = Gcs::new("");
    g.run_until(100_000);
    let ftp = |g: &mut Gcs, seq: u16, opcode: u8, size: u8, data: &[u8]| {
        let p = mavftp::FtpPacket {
            seq,
            session: 3,
            opcode,
            size,
            req_opcode: 0,
            burst_complete: 0,
            offset: 0,
            data: data.to_vec(),
        };
        g.send(MavMessage::FILE_TRANSFER_PROTOCOL(
            FILE_TRANSFER_PROTOCOL_DATA {
                target_network: 0,
                target_system: 1,
                target_component: 1,
                payload: p.to_payload(),
            },
        ));
    };
    ftp(&mut g, 0, mavftp::op::OPEN_FILE_RO, 16, b"@PARAM/param.pck");
    g.run_for(20_000);
    ftp(&mut g, 1, mavftp::op::BURST_READ_FILE, 239, &[]);
    g.run_for(2_000_000);
    let mut file = Vec::new();
    let mut eof = false;
    for f in &g.frames {
        if let Some(MavMessage::FILE_TRANSFER_PROTOCOL(m)) = f.message.as_deref() {
            assert_eq!((m.target_system, m.target_component), (255, 190));
            let p = mavftp::FtpPacket::parse(&m.payload);
            if p.req_opcode == mavftp::op::BURST_READ_FILE {
                if p.opcode == mavftp::op::NAK {
                    eof = p.data == [mavftp::err::EOF];
                } else {
                    assert_eq!(p.offset as usize, file.len());
                    file.extend_from_slice(&p.data);
                }
            }
        }
    }
    assert!(eof);
    let d = param_pck::decode(&file).unwrap();
    assert_eq!(
        d.params,
        ParamTable::copter(0)
            .iter()
            .map(|p| param_pck::PckParam {
                name: p.name.clone(),
                ptype: p.ptype,
                value: p.value,
                default: None,
            })
            .collect::<Vec<_>>()
    );
}

/// FTP replies take the same lossy link as everything else. A GCS fills the holes of a burst
/// with ReadFile at their offsets, and resends a request whose reply was lost with the same
/// sequence number: the vehicle answers it again from its last reply.
#[test]
fn mavftp_over_a_lossy_link_fills_gaps() {
    let mut g = Gcs::new("loss=0.3&seed=11");
    // After the calibrations of the boot (blocks read at different times then hold the same
    // values).
    g.run_until(4_500_000);
    let path = b"@PARAM/param.pck";
    let mut seq = 0u16;
    let ask = |g: &mut Gcs, seq: &mut u16, op: u8, size: u8, ofs: u32, data: &[u8]| {
        // Until a reply to this request arrives; the same seq each time.
        for _ in 0..50 {
            let n = g.frames.len();
            g.send(ftp_req(*seq, op, size, ofs, data));
            g.run_for(50_000);
            if let Some(r) = ftp_since(g, n).into_iter().find(|p| p.seq == *seq + 1) {
                *seq += 2;
                return r;
            }
        }
        panic!("no reply to {op}");
    };
    let r = ask(&mut g, &mut seq, mavftp::op::OPEN_FILE_RO, 16, 0, path);
    assert_eq!(r.opcode, mavftp::op::ACK);
    let n = g.frames.len();
    g.send(ftp_req(seq, mavftp::op::BURST_READ_FILE, 239, 0, &[]));
    seq += 2;
    g.run_for(1_000_000);
    let mut blocks: std::collections::BTreeMap<u32, Vec<u8>> = ftp_since(&g, n)
        .into_iter()
        .filter(|p| p.opcode == mavftp::op::ACK)
        .map(|p| (p.offset, p.data))
        .collect();
    let t = g.sim.truth().get(1);
    assert!(t.dropped > 10, "{t:?}");
    let mut ofs = 0;
    let mut missing = 0;
    loop {
        if let Some(b) = blocks.get(&ofs) {
            if b.len() < 239 {
                break;
            }
            ofs += 239;
            continue;
        }
        missing += 1;
        let r = ask(&mut g, &mut seq, mavftp::op::READ_FILE, 239, ofs, &[]);
        if r.opcode == mavftp::op::NAK {
            assert_eq!(r.data, [mavftp::err::EOF]);
            break;
        }
        assert_eq!(r.offset, ofs);
        blocks.insert(ofs, r.data);
    }
    assert!(missing > 5, "{missing} holes");
    let file: Vec<u8> = blocks.values().flatten().copied().collect();
    let d = param_pck::decode(&file).unwrap();
    assert_eq!(d.params, g.v().params().to_pck());
}

/// `ftp=0`: a build without MAVFTP. FILE_TRANSFER_PROTOCOL gets no answer at all and
/// AUTOPILOT_VERSION does not announce MAV_PROTOCOL_CAPABILITY_FTP. BRD_OPTIONS DISABLE_FTP
/// (bit 1) on a build with it: no FTP bit either, and each request is dropped with ArduPilot's
/// "failed to initialize MAVFTP" warning.
#[test]
fn ftp_off_is_silent_and_unannounced() {
    let caps = |g: &mut Gcs| {
        assert_eq!(
            g.command(
                MavCmd::MAV_CMD_REQUEST_MESSAGE,
                [148.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
                0
            ),
            MAV_RESULT_ACCEPTED
        );
        g.frames
            .iter()
            .rev()
            .find_map(|f| match f.message.as_deref() {
                Some(MavMessage::AUTOPILOT_VERSION(a)) => Some(a.capabilities.bits()),
                _ => None,
            })
            .unwrap()
    };
    let mut g = Gcs::new("ftp=0");
    g.run_until(1_000_000);
    let n = g.frames.len();
    g.send(ftp_req(
        0,
        mavftp::op::OPEN_FILE_RO,
        16,
        0,
        b"@PARAM/param.pck",
    ));
    g.send(ftp_req(2, mavftp::op::NONE, 0, 0, &[]));
    g.run_for(2_000_000);
    assert!(ftp_since(&g, n).is_empty());
    assert!(
        g.frames[n..].iter().all(|f| f.msgid != 253),
        "no text either"
    );
    assert_eq!(caps(&mut g) & 32, 0);
    assert_eq!(caps(&mut g), 64495 - 32);

    let mut g = Gcs::new("");
    g.run_until(1_000_000);
    assert_eq!(caps(&mut g), 64495, "the real ArduCopter's capabilities");
    g.send(MavMessage::PARAM_SET(PARAM_SET_DATA {
        param_value: 2.0,
        target_system: 1,
        target_component: 1,
        param_id: "BRD_OPTIONS".into(),
        param_type: MavParamType::MAV_PARAM_TYPE_INT32,
    }));
    g.run_for(20_000);
    assert_eq!(caps(&mut g), 64495 - 32);
    let n = g.frames.len();
    g.send(ftp_req(
        0,
        mavftp::op::OPEN_FILE_RO,
        16,
        0,
        b"@PARAM/param.pck",
    ));
    g.run_for(100_000);
    assert!(ftp_since(&g, n).is_empty());
    assert_eq!(
        g.texts().last().unwrap(),
        &(
            MavSeverity::MAV_SEVERITY_WARNING,
            "failed to initialize MAVFTP".to_string()
        )
    );
}

/// AUTOPILOT_VERSION: COMMAND_ACK ACCEPTED first, then the message, for REQUEST_MESSAGE 148 and
/// for REQUEST_AUTOPILOT_CAPABILITIES with param1 = 1 (any other param1: FAILED, nothing sent).
/// TERRAIN follows TERRAIN_ENABLE.
#[test]
#[allow(deprecated)]
fn autopilot_version_answers() {
    let mut g = Gcs::new("");
    g.run_until(1_000_000);
    let n = g.frames.len();
    let cmd = MavCmd::MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES;
    assert_eq!(
        g.command(cmd, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], 0),
        MAV_RESULT_ACCEPTED
    );
    let ids: Vec<u32> = g.frames[n..]
        .iter()
        .map(|f| f.msgid)
        .filter(|&m| m == COMMAND_ACK_ID || m == 148)
        .collect();
    assert_eq!(ids, vec![COMMAND_ACK_ID, 148]);
    let av = g
        .msgs_since(n, |m| match m {
            MavMessage::AUTOPILOT_VERSION(a) => Some(a.clone()),
            _ => None,
        })
        .remove(0);
    assert_eq!(av.capabilities.bits(), 64495);
    // 4.7.0, FIRMWARE_VERSION_TYPE_DEV, as the capture's (pymavlink: 67567616).
    assert_eq!(av.flight_sw_version, 0x0407_0000);
    let n = g.frames.len();
    assert_eq!(
        g.command(cmd, [0.0; 7], 0),
        MAV_RESULT_FAILED,
        "param1 must be 1"
    );
    assert!(g.frames[n..].iter().all(|f| f.msgid != 148));
    g.send(MavMessage::PARAM_SET(PARAM_SET_DATA {
        param_value: 0.0,
        target_system: 1,
        target_component: 1,
        param_id: "TERRAIN_ENABLE".into(),
        param_type: MavParamType::MAV_PARAM_TYPE_INT8,
    }));
    g.run_for(20_000);
    let n = g.frames.len();
    g.command(cmd, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], 0);
    let caps = g.msgs_since(n, |m| match m {
        MavMessage::AUTOPILOT_VERSION(a) => Some(a.capabilities.bits()),
        _ => None,
    });
    assert_eq!(caps, vec![64495 - 512]);
}

/// A baro calibration (PREFLIGHT_CALIBRATION param3 = 1) runs AP_Baro::update_calibration,
/// which sends each barometer's BAROn_GND_PRESS (index -1) at once, ahead of the ACK, at most
/// every 10 s, counting from boot.
#[test]
fn baro_calibration_notifies_ground_pressures() {
    let mut g = Gcs::new("");
    let baro = [0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0];
    g.run_until(5_000_000);
    let n = g.frames.len();
    g.command(MavCmd::MAV_CMD_PREFLIGHT_CALIBRATION, baro, 0);
    assert!(
        every_param_value_since(&g, n).is_empty(),
        "not in the first 10 s"
    );
    g.run_until(10_500_000);
    let n = g.frames.len();
    g.command(MavCmd::MAV_CMD_PREFLIGHT_CALIBRATION, baro, 0);
    let pv = every_param_value_since(&g, n);
    let names: Vec<&str> = pv.iter().map(|p| p.param_id.to_str().unwrap()).collect();
    assert_eq!(names, vec!["BARO1_GND_PRESS", "BARO2_GND_PRESS"]);
    assert!(pv.iter().all(|p| p.param_index == 65535));
    assert_eq!(g.frames[n].msgid, 22, "before the ACK");
    g.run_for(1_000_000);
    let n = g.frames.len();
    g.command(MavCmd::MAV_CMD_PREFLIGHT_CALIBRATION, baro, 0);
    assert!(
        every_param_value_since(&g, n).is_empty(),
        "within 10 s of the last"
    );
}

#[test]
fn command_int_and_set_mode_message() {
    let mut g = Gcs::new("");
    g.run_until(vehicle::EKF_GPS_AT + 100_000);
    #[allow(deprecated)]
    g.send(MavMessage::SET_MODE(SET_MODE_DATA {
        custom_mode: mode::GUIDED,
        target_system: 1,
        base_mode: MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
    }));
    g.run_for(20_000);
    // GCS_MAVLINK::handle_set_mode acknowledges with command = 11, SET_MODE's message id.
    assert_eq!(g.raw_acks_since(0).last(), Some(&(11, 0, 0)));
    assert_eq!(g.v().custom_mode(), mode::GUIDED);
    g.arm(false);
    // NAV_TAKEOFF as COMMAND_INT must be in frame GLOBAL_RELATIVE_ALT, else DENIED.
    assert_eq!(
        g.command_int(
            MavCmd::MAV_CMD_NAV_TAKEOFF,
            MavFrame::MAV_FRAME_GLOBAL,
            [0.0; 4],
            0,
            0,
            3.0
        ),
        MAV_RESULT_DENIED
    );
    assert_eq!(
        g.command_int(
            MavCmd::MAV_CMD_NAV_TAKEOFF,
            MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT,
            [0.0; 4],
            0,
            0,
            3.0
        ),
        MAV_RESULT_ACCEPTED
    );
    g.run_for(4_000_000);
    assert!((g.v().relative_alt_m() - 3.0).abs() < 0.01);
    // Addressed to another system: ignored, no ACK.
    let n = g.acks().len();
    g.send(MavMessage::COMMAND_INT(COMMAND_INT_DATA {
        command: MavCmd::MAV_CMD_NAV_LAND,
        target_system: 9,
        target_component: 1,
        ..Default::default()
    }));
    g.run_for(20_000);
    assert_eq!(g.acks().len(), n);
    assert_eq!(g.v().custom_mode(), mode::GUIDED);
}

#[test]
fn gps_fix_comes_after_four_seconds() {
    let mut g = Gcs::new("");
    assert_eq!(
        g.command(
            MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
            [24.0, 500_000.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            0
        ),
        MAV_RESULT_ACCEPTED
    );
    g.run_until(6_000_000);
    let fixes: Vec<(u64, GpsFixType)> = g
        .frames
        .iter()
        .filter_map(|f| match f.message.as_deref() {
            Some(MavMessage::GPS_RAW_INT(m)) => Some((m.time_usec, m.fix_type)),
            _ => None,
        })
        .collect();
    assert!(fixes.len() >= 11);
    for (t, fix) in fixes {
        let want = if t < vehicle::GPS_FIX_AT {
            GpsFixType::GPS_FIX_TYPE_NO_GPS
        } else {
            GpsFixType::GPS_FIX_TYPE_3D_FIX
        };
        assert_eq!(fix, want, "at {t}");
    }
}

#[test]
fn inbound_impairment_drops_gcs_frames() {
    let mut g = Gcs::new("loss=0.5&impair_in=1&seed=4");
    g.run_until(100_000);
    for _ in 0..200 {
        g.send(MavMessage::PARAM_REQUEST_READ(PARAM_REQUEST_READ_DATA {
            param_index: 0,
            target_system: 1,
            target_component: 1,
            param_id: "".into(),
        }));
    }
    g.run_for(100_000);
    let t = g.sim.truth().get(1);
    let replies = g.frames.iter().filter(|f| f.msgid == 22).count() as u64;
    assert!((60..140).contains(&t.inbound_dropped), "{t:?}");
    // Only requests that got through were answered (and some answers were lost on the way out).
    assert!(
        replies > 0 && replies <= 200 - t.inbound_dropped,
        "{replies} {t:?}"
    );
    assert_eq!(g.frames.len() as u64 + t.dropped, t.generated);
}

// ---- Flying from the keyboard: what ArduCopter answers ----------------------------------------

/// DO_SET_MODE to each mode a quad ArduCopter has, disarmed (`Copter::set_mode`: "allow switching
/// to any mode if disarmed"): ACCEPTED, and the HEARTBEAT sent right after the ACK shows it.
#[test]
fn do_set_mode_every_mode_disarmed_and_heartbeat_shows_it() {
    let mut g = Gcs::new("");
    g.run_until(vehicle::EKF_GPS_AT + 100_000);
    for m in [
        mode::ALT_HOLD,
        mode::LOITER,
        mode::GUIDED,
        mode::AUTO,
        mode::RTL,
        mode::LAND,
        mode::POSHOLD,
        mode::BRAKE,
        mode::CIRCLE,
        mode::DRIFT,
        mode::SPORT,
        mode::ACRO,
        mode::AUTOTUNE,
        mode::THROW,
        mode::AVOID_ADSB,
        mode::GUIDED_NOGPS,
        mode::ZIGZAG,
        mode::STABILIZE,
    ] {
        let n = g.frames.len();
        assert_eq!(g.set_mode(m), MAV_RESULT_ACCEPTED, "mode {m}");
        assert_eq!(g.v().custom_mode(), m);
        // ArduCopter sends a HEARTBEAT as soon as the mode changes, after the ACK.
        let after_ack = g.frames[n..]
            .iter()
            .skip_while(|f| f.msgid != COMMAND_ACK_ID)
            .find_map(|f| match f.message.as_deref() {
                Some(MavMessage::HEARTBEAT(h)) => Some(h.custom_mode),
                _ => None,
            });
        assert_eq!(after_ack, Some(m), "heartbeat after mode {m}");
    }
    // SET_MODE (the message) does the same; its ACK carries command 11.
    for m in [mode::LOITER, mode::STABILIZE] {
        let n = g.frames.len();
        #[allow(deprecated)]
        g.send(MavMessage::SET_MODE(SET_MODE_DATA {
            custom_mode: m,
            target_system: 1,
            base_mode: MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
        }));
        g.run_for(20_000);
        assert_eq!(g.raw_acks_since(n), vec![(11, 0, 0)]);
        assert_eq!(g.last_heartbeat().custom_mode, m);
    }
    // SmartRTL has no path before arming: "init failed", and no mode change.
    let n = g.frames.len();
    assert_eq!(g.set_mode(mode::SMART_RTL), MAV_RESULT_FAILED);
    assert_eq!(
        g.events_since(n),
        vec![
            Ev::Ack(176, 4),
            text("Mode change to SMARTRTL failed: init failed")
        ]
    );
    assert_eq!(g.last_heartbeat().custom_mode, mode::STABILIZE);
    // Setting the mode it is already in is accepted.
    assert_eq!(g.set_mode(mode::STABILIZE), MAV_RESULT_ACCEPTED);
}

/// Armed, a mode that needs a position estimate is refused until the EKF uses GPS: FAILED, then
/// "Mode change to X failed: requires position"; modes that need none are fine.
#[test]
fn armed_mode_change_needs_position_estimate() {
    let mut g = Gcs::new("");
    g.run_until(1_000_000);
    // STABILIZE needs no GPS to arm (AP_Arming_Copter::gps_checks skips them).
    assert_eq!(g.arm(false), MAV_RESULT_ACCEPTED);
    for (m, name) in [
        (mode::LOITER, "LOITER"),
        (mode::GUIDED, "GUIDED"),
        (mode::POSHOLD, "POSHOLD"),
        (mode::RTL, "RTL"),
        (mode::BRAKE, "BRAKE"),
        (mode::SMART_RTL, "SMARTRTL"),
    ] {
        let n = g.frames.len();
        assert_eq!(g.set_mode(m), MAV_RESULT_FAILED, "{name}");
        assert_eq!(
            g.events_since(n),
            vec![
                Ev::Ack(176, 4),
                text(&format!("Mode change to {name} failed: requires position"))
            ]
        );
        assert_eq!(g.v().custom_mode(), mode::STABILIZE);
    }
    assert_eq!(g.set_mode(mode::ALT_HOLD), MAV_RESULT_ACCEPTED);
    assert_eq!(g.last_heartbeat().custom_mode, mode::ALT_HOLD);
    assert_eq!(g.set_mode(mode::STABILIZE), MAV_RESULT_ACCEPTED);
    // Armed without a mission, AUTO's init fails.
    g.run_until(vehicle::EKF_GPS_AT + 100_000);
    assert!(g.v().armed());
    let n = g.frames.len();
    assert_eq!(g.set_mode(mode::AUTO), MAV_RESULT_FAILED);
    assert_eq!(
        g.events_since(n),
        vec![
            Ev::Ack(176, 4),
            text("Mode change to AUTO failed: init failed")
        ]
    );
    assert_eq!(g.set_mode(mode::LOITER), MAV_RESULT_ACCEPTED);
}

/// Mode numbers a quad ArduCopter has no mode for: FAILED with "No such mode N"; AUTO RTL needs a
/// mission; the custom mode goes through Copter::set_mode's uint8_t.
#[test]
fn unknown_custom_modes_refused() {
    let mut g = Gcs::new("");
    g.run_until(vehicle::EKF_GPS_AT + 100_000);
    for m in [8, 10, 12, 26, 29, 99] {
        let n = g.frames.len();
        assert_eq!(g.set_mode(m), MAV_RESULT_FAILED, "mode {m}");
        assert_eq!(
            g.events_since(n),
            vec![Ev::Ack(176, 4), text(&format!("No such mode {m}"))]
        );
    }
    let n = g.frames.len();
    assert_eq!(g.set_mode(mode::AUTO_RTL), MAV_RESULT_FAILED);
    assert_eq!(
        g.events_since(n),
        vec![
            Ev::Ack(176, 4),
            text("Mode change to AUTO RTL failed: No return path or landing sequence found")
        ]
    );
    assert_eq!(g.v().custom_mode(), mode::STABILIZE);
    // 256 + 4 is GUIDED to a uint8_t.
    assert_eq!(g.set_mode(260), MAV_RESULT_ACCEPTED);
    assert_eq!(g.v().custom_mode(), mode::GUIDED);
    // Base mode without the custom flag: DENIED; 128 alone is the safety switch.
    let long = |g: &mut Gcs, base: f32, custom: f32| {
        g.command(
            MavCmd::MAV_CMD_DO_SET_MODE,
            [base, custom, 0.0, 0.0, 0.0, 0.0, 0.0],
            0,
        )
    };
    assert_eq!(long(&mut g, 81.0, 5.0), MAV_RESULT_ACCEPTED, "81 has bit 0");
    assert_eq!(long(&mut g, 64.0, 4.0), MAV_RESULT_DENIED);
    assert_eq!(long(&mut g, 128.0, 0.0), MAV_RESULT_ACCEPTED);
    assert_eq!(long(&mut g, 128.0, 5.0), MAV_RESULT_DENIED);
    assert_eq!(g.v().custom_mode(), mode::LOITER);
    // FLTMODE_GCSBLOCK bit 5 blocks LOITER (Copter::gcs_mode_enabled's list order).
    g.send(MavMessage::PARAM_SET(PARAM_SET_DATA {
        param_value: 32.0,
        target_system: 1,
        target_component: 1,
        param_id: "FLTMODE_GCSBLOCK".into(),
        param_type: MavParamType::MAV_PARAM_TYPE_INT32,
    }));
    g.run_for(20_000);
    assert_eq!(g.set_mode(mode::STABILIZE), MAV_RESULT_ACCEPTED);
    let n = g.frames.len();
    assert_eq!(g.set_mode(mode::LOITER), MAV_RESULT_FAILED);
    assert_eq!(
        g.events_since(n),
        vec![
            Ev::Ack(176, 4),
            text("Mode change to LOITER failed: GCS entry disabled (FLTMODE_GCSBLOCK)")
        ]
    );
}

/// The frames of the real ArduCopter session, tests/data/copter-flight.vehicle.tlog.
fn flight_capture() -> Vec<crate::wire::Frame> {
    let tlog = include_bytes!("../../tests/data/copter-flight.vehicle.tlog");
    let mut parser = FrameParser::new();
    let mut frames = Vec::new();
    let mut pos = 0;
    while pos + 8 < tlog.len() {
        pos += 8;
        let len = tlog[pos + 1] as usize;
        let signed = tlog[pos + 2] & 1 != 0;
        let flen = 12 + len + if signed { 13 } else { 0 };
        frames.extend(parser.parse_all(&tlog[pos..pos + flen]));
        pos += flen;
    }
    frames
}

/// The sim introduces itself as the ArduCopter its parameters come from: the capture's banner
/// version ("ArduCopter V4.7.0-dev (hash)"), its AUTOPILOT_VERSION flight_sw_version, and a
/// parameter set that names the system id `MAV_SYSID` (4.7) as the capture's download does, not
/// `SYSID_THISMAV` (4.6 and before).
#[test]
fn banner_version_and_params_are_the_captures() {
    let real = flight_capture();
    let real_banner = real
        .iter()
        .find_map(|f| match f.message.as_deref() {
            Some(MavMessage::STATUSTEXT(t)) => {
                let s = t.text.to_str().unwrap_or_default().to_string();
                s.starts_with("ArduCopter V").then_some(s)
            }
            _ => None,
        })
        .expect("the capture's banner");
    let (real_version, _hash) = real_banner.split_once(" (").unwrap();
    let real_sw = real
        .iter()
        .find_map(|f| match f.message.as_deref() {
            Some(MavMessage::AUTOPILOT_VERSION(a)) => Some(a.flight_sw_version),
            _ => None,
        })
        .expect("the capture's AUTOPILOT_VERSION");

    let mut g = Gcs::new("");
    g.run_until(1_000_000);
    let texts: Vec<String> = g.texts().into_iter().map(|t| t.1).collect();
    assert!(
        texts[0].starts_with(&format!("{real_version} (")),
        "{texts:?} vs {real_banner}"
    );
    assert_eq!(
        g.command(
            MavCmd::MAV_CMD_REQUEST_MESSAGE,
            [148.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            0
        ),
        MAV_RESULT_ACCEPTED
    );
    let sw = g
        .msgs_since(0, |m| match m {
            MavMessage::AUTOPILOT_VERSION(a) => Some(a.flight_sw_version),
            _ => None,
        })
        .remove(0);
    assert_eq!(sw, real_sw, "{sw:#x} vs the capture's {real_sw:#x}");

    let captured = include_str!("../../tests/data/copter-params.parm");
    let has = |text: &str, name: &str| {
        text.lines()
            .any(|l| l.split_whitespace().next() == Some(name))
    };
    assert!(has(captured, "MAV_SYSID") && !has(captured, "SYSID_THISMAV"));
    let ours = super::params::ParamTable::copter(0);
    assert!(ours.index_of("MAV_SYSID").is_some());
    assert!(ours.index_of("SYSID_THISMAV").is_none());
}

/// The real ArduCopter session (tests/data/copter-flight.vehicle.tlog): every refused arm is
/// COMMAND_ACK 400 FAILED followed by its "Arm: " texts; the simulator keeps that order.
#[test]
fn arm_refusal_is_ack_then_arm_text_like_the_capture() {
    let real = Gcs {
        frames: flight_capture(),
        ..Gcs::new("")
    }
    .events_since(0);
    let mut refusals = 0;
    for (i, e) in real.iter().enumerate() {
        if *e == Ev::Ack(400, 4) {
            refusals += 1;
            assert!(
                matches!(&real[i + 1], Ev::Text(t) if t.starts_with("Arm: ")),
                "{:?}",
                &real[i..i + 2]
            );
        }
        if let Ev::Text(t) = e {
            if t.starts_with("Arm: ") {
                assert!(matches!(
                    real[..i].iter().rev().find(|e| matches!(e, Ev::Ack(..))),
                    Some(Ev::Ack(400, 4))
                ));
            }
        }
    }
    assert_eq!(refusals, 7);

    let mut g = Gcs::new("");
    g.run_until(1_000_000);
    assert_eq!(g.set_mode(mode::GUIDED), MAV_RESULT_ACCEPTED);
    let n = g.frames.len();
    assert_eq!(g.arm(false), MAV_RESULT_FAILED);
    assert_eq!(
        g.events_since(n),
        vec![Ev::Ack(400, 4), text("Arm: AHRS: waiting for home")]
    );
    assert!(g.texts().iter().all(|t| !t.1.starts_with("PreArm: ")));
    // A forced arm still runs the mandatory position check for a mode that needs GPS.
    let n = g.frames.len();
    assert_eq!(g.arm(true), MAV_RESULT_FAILED);
    assert_eq!(
        g.events_since(n),
        vec![Ev::Ack(400, 4), text("Arm: Need Position Estimate")]
    );
    // Once the EKF uses GPS: modes that may not be armed in say so by name.
    g.run_until(vehicle::EKF_GPS_AT + 100_000);
    assert_eq!(g.set_mode(mode::RTL), MAV_RESULT_ACCEPTED);
    let n = g.frames.len();
    assert_eq!(g.arm(false), MAV_RESULT_FAILED);
    assert_eq!(
        g.events_since(n),
        vec![Ev::Ack(400, 4), text("Arm: RTL mode not armable")]
    );
    assert_eq!(g.set_mode(mode::GUIDED), MAV_RESULT_ACCEPTED);
    let n = g.frames.len();
    assert_eq!(g.arm(false), MAV_RESULT_ACCEPTED);
    assert_eq!(
        g.events_since(n)[..2],
        [Ev::Ack(400, 0), text("Arming motors")]
    );
    // Arming again when armed: ACCEPTED, nothing else.
    assert_eq!(g.arm(false), MAV_RESULT_ACCEPTED);
}

/// Mode::do_user_takeoff: armed, landed, a mode with user takeoff (GUIDED; LOITER and POSHOLD;
/// ALT_HOLD only when param3 says the pilot may navigate), and upwards; else FAILED.
#[test]
fn takeoff_modes_and_refusals() {
    let mut g = Gcs::new("");
    g.run_until(vehicle::EKF_GPS_AT + 100_000);
    let takeoff = |g: &mut Gcs, p3: f32, alt: f32| {
        g.command(
            MavCmd::MAV_CMD_NAV_TAKEOFF,
            [0.0, 0.0, p3, f32::NAN, 0.0, 0.0, alt],
            0,
        )
    };
    assert_eq!(g.set_mode(mode::ALT_HOLD), MAV_RESULT_ACCEPTED);
    assert_eq!(takeoff(&mut g, 1.0, 5.0), MAV_RESULT_FAILED, "disarmed");
    assert_eq!(g.arm(false), MAV_RESULT_ACCEPTED);
    assert_eq!(
        takeoff(&mut g, 0.0, 5.0),
        MAV_RESULT_FAILED,
        "must navigate"
    );
    assert_eq!(takeoff(&mut g, 1.0, 0.0), MAV_RESULT_FAILED, "not upwards");
    assert_eq!(takeoff(&mut g, 1.0, 5.0), MAV_RESULT_ACCEPTED);
    g.run_for(5_000_000);
    assert!((g.v().relative_alt_m() - 5.0).abs() < 0.01);
    assert_eq!(
        takeoff(&mut g, 1.0, 8.0),
        MAV_RESULT_FAILED,
        "already flying"
    );
    assert_eq!(
        g.command(MavCmd::MAV_CMD_NAV_LAND, [0.0; 7], 0),
        MAV_RESULT_ACCEPTED
    );
    g.run_for(15_000_000);
    assert!(!g.v().armed(), "LAND disarms on the ground");
    // LOITER takes off with param3 = 0 too; STABILIZE never.
    assert_eq!(g.set_mode(mode::STABILIZE), MAV_RESULT_ACCEPTED);
    assert_eq!(g.arm(false), MAV_RESULT_ACCEPTED);
    assert_eq!(takeoff(&mut g, 1.0, 5.0), MAV_RESULT_FAILED, "STABILIZE");
    assert_eq!(g.set_mode(mode::LOITER), MAV_RESULT_ACCEPTED);
    assert_eq!(takeoff(&mut g, 0.0, 5.0), MAV_RESULT_ACCEPTED);
    g.run_for(1_000_000);
    assert!(g.v().climb_rate() > 1.0);
}

/// drop_cmd=ID:N: the first N copies of a command vanish (no ACK, no effect); later copies and
/// other commands are handled.
#[test]
fn drop_cmd_drops_the_first_copies() {
    let mut g = Gcs::new("drop_cmd=400:2,60000:1");
    g.run_until(vehicle::EKF_GPS_AT + 100_000);
    let arm = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    for confirmation in 0..2 {
        let n = g.frames.len();
        g.send_long(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, arm, confirmation);
        g.run_for(1_500_000);
        assert!(
            g.raw_acks_since(n).is_empty(),
            "copy {confirmation} dropped"
        );
        assert!(!g.v().armed());
    }
    assert_eq!(g.v().commands_dropped(), 2);
    assert_eq!(g.set_mode(mode::GUIDED), MAV_RESULT_ACCEPTED, "not listed");
    assert_eq!(
        g.command(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, arm, 2),
        MAV_RESULT_ACCEPTED
    );
    assert!(g.v().armed());
    // A command id the dialect does not know is dropped the same way, then answered.
    let mut payload = vec![0u8; 28];
    payload.extend_from_slice(&60000u16.to_le_bytes());
    payload.extend_from_slice(&[1, 1, 0]);
    let frame = encode_raw(GCS, COMMAND_LONG_ID, &payload);
    let n = g.frames.len();
    g.sim.receive(g.now, &frame);
    g.run_for(20_000);
    assert!(g.raw_acks_since(n).is_empty());
    g.sim.receive(g.now, &frame);
    g.run_for(20_000);
    assert_eq!(g.raw_acks_since(n), vec![(60000, 3, 0)]);
    assert_eq!(g.v().commands_dropped(), 3);
}

/// drop_ack=ID:N: the first N copies of a command are carried out but their ACKs are lost;
/// later ones are answered.
#[test]
fn drop_ack_loses_the_first_answers() {
    let mut g = Gcs::new("drop_ack=400:1");
    g.run_until(vehicle::EKF_GPS_AT + 100_000);
    assert_eq!(g.set_mode(mode::GUIDED), MAV_RESULT_ACCEPTED, "not listed");
    let arm = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    let n = g.frames.len();
    g.send_long(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, arm, 0);
    g.run_for(1_500_000);
    assert!(g.raw_acks_since(n).is_empty(), "its ACK lost");
    assert!(g.v().armed(), "but it armed");
    assert_eq!(
        g.command(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, [0.0; 7], 0),
        MAV_RESULT_ACCEPTED
    );
    assert!(!g.v().armed());
}

/// MAV_CMD_PREFLIGHT_CALIBRATION gyro (param1=1) and simple accel (param5=4): ArduPilot runs them
/// synchronously in its main loop, so the vehicle goes silent, then sends one COMMAND_ACK
/// ACCEPTED (no IN_PROGRESS); what arrived meanwhile is answered after it. Armed: FAILED with
/// "Disarm to allow calibration".
#[test]
fn preflight_calibration_blocks_then_accepts() {
    let mut g = Gcs::new("");
    g.run_until(vehicle::EKF_GPS_AT + 100_000);
    stream_all(&mut g, 1);
    g.run_for(1_000_000);
    for (p, busy) in [
        ([1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], vehicle::GYRO_CAL_TIME),
        ([0.0, 0.0, 0.0, 0.0, 4.0, 0.0, 0.0], vehicle::ACCEL_CAL_TIME),
    ] {
        let n = g.frames.len();
        g.send_long(MavCmd::MAV_CMD_PREFLIGHT_CALIBRATION, p, 0);
        g.run_for(busy - 50_000);
        assert_eq!(g.frames.len(), n, "silent while calibrating");
        assert!(g.v().busy());
        g.send(MavMessage::PARAM_REQUEST_READ(PARAM_REQUEST_READ_DATA {
            param_index: 0,
            target_system: 1,
            target_component: 1,
            param_id: "".into(),
        }));
        g.run_for(30_000);
        assert_eq!(g.frames.len(), n, "the request waits");
        g.run_for(50_000);
        assert!(!g.v().busy());
        let new: Vec<u32> = g.frames[n..].iter().map(|f| f.msgid).collect();
        assert_eq!(new[0], COMMAND_ACK_ID, "the ACK first");
        // The read waited, then went the usual way: answered at the next parameter run.
        g.run_for(100_000);
        let pv = param_values_since(&g, n);
        assert_eq!(pv.len(), 1, "then the waiting PARAM_VALUE");
        assert_eq!(pv[0].param_index, 0);
        assert_eq!(g.raw_acks_since(n), vec![(241, 0, 0)]);
        g.run_for(1_000_000);
        assert!(
            g.frames[n..].iter().any(|f| f.msgid == 0),
            "heartbeats again"
        );
    }
    // Baro (param3=1) without an airspeed sensor: ACCEPTED at once, after its two texts.
    let n = g.frames.len();
    assert_eq!(
        g.command(
            MavCmd::MAV_CMD_PREFLIGHT_CALIBRATION,
            [0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0],
            0
        ),
        MAV_RESULT_ACCEPTED
    );
    assert_eq!(
        g.events_since(n),
        vec![
            Ev::Ack(241, 0),
            text("Updating barometer calibration"),
            text("Barometer calibration complete")
        ]
    );
    // Nothing asked for: UNSUPPORTED.
    assert_eq!(
        g.command(MavCmd::MAV_CMD_PREFLIGHT_CALIBRATION, [0.0; 7], 0),
        MAV_RESULT_UNSUPPORTED
    );
    // Armed: refused.
    assert_eq!(g.arm(false), MAV_RESULT_ACCEPTED);
    let n = g.frames.len();
    assert_eq!(
        g.command(
            MavCmd::MAV_CMD_PREFLIGHT_CALIBRATION,
            [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            0
        ),
        MAV_RESULT_FAILED
    );
    assert_eq!(
        g.events_since(n),
        vec![Ev::Ack(241, 4), text("Disarm to allow calibration")]
    );
    assert!(!g.v().busy());
}

/// The long command ArduPilot does answer IN_PROGRESS: a baro calibration with an airspeed sensor
/// enabled (GCS_MAVLINK_InProgress, checked once a second, progress 0) ends ACCEPTED. A second
/// one from the same GCS meanwhile is TEMPORARILY_REJECTED. ArduPilot has no COMMAND_CANCEL
/// handler: the cancel is ignored, no ACK CANCELLED.
#[test]
fn airspeed_calibration_in_progress_then_accepted_cancel_ignored() {
    let mut g = Gcs::new("");
    g.run_until(vehicle::EKF_GPS_AT + 100_000);
    g.send(MavMessage::PARAM_SET(PARAM_SET_DATA {
        param_value: 1.0,
        target_system: 1,
        target_component: 1,
        param_id: "ARSPD_ENABLE".into(),
        param_type: MavParamType::MAV_PARAM_TYPE_INT8,
    }));
    g.run_for(20_000);
    let t0 = g.now;
    let n = g.frames.len();
    let baro = [0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0];
    g.send_long(MavCmd::MAV_CMD_PREFLIGHT_CALIBRATION, baro, 0);
    g.run_for(20_000);
    assert_eq!(
        g.events_since(n),
        vec![
            Ev::Ack(241, 5),
            text("Updating barometer calibration"),
            text("Barometer calibration complete"),
            text("Airspeed 1 calibration started")
        ]
    );
    g.send(MavMessage::COMMAND_CANCEL(COMMAND_CANCEL_DATA {
        command: MavCmd::MAV_CMD_PREFLIGHT_CALIBRATION,
        target_system: 1,
        target_component: 1,
    }));
    g.run_until(6_000_000 + 10_000);
    assert_eq!(g.raw_acks_since(n), vec![(241, 5, 0), (241, 5, 0)]);
    let m = g.frames.len();
    g.send_long(MavCmd::MAV_CMD_PREFLIGHT_CALIBRATION, baro, 0);
    g.run_for(20_000);
    assert_eq!(g.raw_acks_since(m), vec![(241, 1, 0)]);
    g.run_until(t0 + vehicle::AIRSPEED_CAL_TIME + 10_000);
    assert!(g.texts().iter().any(|t| t.1 == "Airspeed 1 calibrated"));
    g.run_until(8_000_000);
    let acks: Vec<(u16, u8, u8)> = g
        .raw_acks_since(n)
        .into_iter()
        .filter(|a| a.0 == 241)
        .collect();
    assert_eq!(
        acks,
        vec![
            (241, 5, 0),
            (241, 5, 0),
            (241, 1, 0),
            (241, 0, 0), // at 7 s: calibrated at 6.6 s, reported at the next check
        ]
    );
    assert!(g.raw_acks_since(n).iter().all(|a| a.1 != 6), "no CANCELLED");
}

/// What a GCS shows, in ArduCopter's stream groups: EXTENDED_STATUS has SYS_STATUS and
/// GPS_RAW_INT, POSITION has GLOBAL_POSITION_INT, EXTRA2 VFR_HUD, EXTRA3 BATTERY_STATUS and
/// EKF_STATUS_REPORT. HOME_POSITION and GPS_GLOBAL_ORIGIN come unasked when home is set and
/// again at arming (home moves to where the vehicle arms), as in the real capture.
#[test]
#[allow(deprecated)]
fn telemetry_a_gcs_shows() {
    let mut g = Gcs::new("");
    let stream = |g: &mut Gcs, id: MavDataStream| {
        #[allow(deprecated)]
        g.send(MavMessage::REQUEST_DATA_STREAM(REQUEST_DATA_STREAM_DATA {
            req_message_rate: 2,
            target_system: 1,
            target_component: 1,
            req_stream_id: id,
            start_stop: 1,
        }));
    };
    // REQUEST_MESSAGE HOME_POSITION before home is set: ACCEPTED, nothing sent.
    g.run_until(1_000_000);
    let n = g.frames.len();
    assert_eq!(
        g.command(
            MavCmd::MAV_CMD_REQUEST_MESSAGE,
            [242.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            0
        ),
        MAV_RESULT_ACCEPTED
    );
    g.run_for(100_000);
    assert!(g.frames[n..].iter().all(|f| f.msgid != 242));
    stream(&mut g, MavDataStream::MAV_DATA_STREAM_EXTENDED_STATUS);
    g.run_for(2_000_000);
    let ids: std::collections::BTreeSet<u32> = g.frames[n..].iter().map(|f| f.msgid).collect();
    assert!(ids.contains(&1) && ids.contains(&24), "{ids:?}");
    assert!(!ids.contains(&33) && !ids.contains(&74) && !ids.contains(&147));
    for s in [
        MavDataStream::MAV_DATA_STREAM_POSITION,
        MavDataStream::MAV_DATA_STREAM_EXTRA2,
        MavDataStream::MAV_DATA_STREAM_EXTRA3,
    ] {
        stream(&mut g, s);
    }
    // Before any fix: no location.
    g.run_until(3_900_000);
    let gpi = g.msgs_since(0, |m| match m {
        MavMessage::GLOBAL_POSITION_INT(p) => Some(p.clone()),
        _ => None,
    });
    assert!(gpi.iter().all(|p| (p.lat, p.lon, p.alt) == (0, 0, 0)));
    let gps = g.msgs_since(0, |m| match m {
        MavMessage::GPS_RAW_INT(p) => Some(p.clone()),
        _ => None,
    });
    assert_eq!(
        (
            gps.last().unwrap().fix_type,
            gps.last().unwrap().satellites_visible
        ),
        (GpsFixType::GPS_FIX_TYPE_NO_GPS, 0)
    );
    // Home set: HOME_POSITION and GPS_GLOBAL_ORIGIN, unasked, once.
    let n = g.frames.len();
    g.run_until(vehicle::EKF_GPS_AT + 600_000);
    let homes = g.msgs_since(n, |m| match m {
        MavMessage::HOME_POSITION(h) => Some(h.clone()),
        _ => None,
    });
    assert_eq!(homes.len(), 1);
    assert_eq!(
        (homes[0].latitude, homes[0].longitude, homes[0].altitude),
        (-353_632_621, 1_491_652_374, 584_000)
    );
    assert_eq!(g.frames[n..].iter().filter(|f| f.msgid == 49).count(), 1);
    let gps = g.msgs_since(n, |m| match m {
        MavMessage::GPS_RAW_INT(p) => Some(p.clone()),
        _ => None,
    });
    let last = gps.last().unwrap();
    assert_eq!(
        (last.fix_type, last.satellites_visible),
        (GpsFixType::GPS_FIX_TYPE_3D_FIX, 10)
    );
    // SET_MESSAGE_INTERVAL works for HOME_POSITION too (ArduPilot's MSG_HOME).
    assert_eq!(
        g.command(
            MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
            [242.0, 1_000_000.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            0
        ),
        MAV_RESULT_ACCEPTED
    );
    let n = g.frames.len();
    g.run_for(3_000_000);
    assert!((3..=4).contains(&g.frames[n..].iter().filter(|f| f.msgid == 242).count()));
    assert_eq!(
        g.command(
            MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
            [242.0, -1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            0
        ),
        MAV_RESULT_ACCEPTED
    );
    // Fly: GUIDED, arm (home announced again), take off to 10 m.
    assert_eq!(g.set_mode(mode::GUIDED), MAV_RESULT_ACCEPTED);
    let n = g.frames.len();
    assert_eq!(g.arm(false), MAV_RESULT_ACCEPTED);
    assert_eq!(g.frames[n..].iter().filter(|f| f.msgid == 242).count(), 1);
    let sys0 = g
        .msgs_since(0, |m| match m {
            MavMessage::SYS_STATUS(s) => Some(s.clone()),
            _ => None,
        })
        .pop()
        .unwrap();
    let bat0 = g
        .msgs_since(0, |m| match m {
            MavMessage::BATTERY_STATUS(b) => Some(b.clone()),
            _ => None,
        })
        .pop()
        .unwrap();
    assert_eq!(g.takeoff(10.0), MAV_RESULT_ACCEPTED);
    let n = g.frames.len();
    g.run_for(3_000_000);
    let hud = g
        .msgs_since(n, |m| match m {
            MavMessage::VFR_HUD(h) => Some(h.clone()),
            _ => None,
        })
        .pop()
        .unwrap();
    assert!((hud.climb - 1.5).abs() < 0.01, "{hud:?}");
    assert!(
        (hud.airspeed - 1.5).abs() < 0.01,
        "3D airspeed includes the climb"
    );
    assert_eq!(hud.groundspeed, 0.0);
    assert!(hud.throttle > 20);
    let a = g.v().relative_alt_m();
    assert!((hud.alt as f64 - (584.0 + a)).abs() < 0.8, "{hud:?} {a}");
    let gpi = g
        .msgs_since(n, |m| match m {
            MavMessage::GLOBAL_POSITION_INT(p) => Some(p.clone()),
            _ => None,
        })
        .pop()
        .unwrap();
    assert!((gpi.alt - 584_000 - gpi.relative_alt).abs() <= 1, "{gpi:?}");
    assert!(gpi.relative_alt > 3_000 && gpi.vz < -140, "{gpi:?}");
    // A minute of hover drains the battery.
    g.run_for(60_000_000);
    let sys = g
        .msgs_since(n, |m| match m {
            MavMessage::SYS_STATUS(s) => Some(s.clone()),
            _ => None,
        })
        .pop()
        .unwrap();
    let bat = g
        .msgs_since(n, |m| match m {
            MavMessage::BATTERY_STATUS(b) => Some(b.clone()),
            _ => None,
        })
        .pop()
        .unwrap();
    assert!(sys.current_battery > 1000, "{sys:?}");
    assert!(
        sys.battery_remaining < sys0.battery_remaining,
        "{sys:?} {sys0:?}"
    );
    assert!(sys.voltage_battery < sys0.voltage_battery);
    assert!(
        bat.current_consumed >= bat0.current_consumed + 200,
        "{bat:?}"
    );
    assert_eq!(bat.battery_remaining, sys.battery_remaining);
    assert_eq!(
        bat.charge_state,
        MavBatteryChargeState::MAV_BATTERY_CHARGE_STATE_OK
    );
    let ekf = g.msgs_since(n, |m| match m {
        MavMessage::EKF_STATUS_REPORT(e) => Some(e.flags),
        _ => None,
    });
    assert!(ekf
        .last()
        .unwrap()
        .contains(EkfStatusFlags::EKF_POS_HORIZ_ABS));
}

/// DO_REPOSITION as COMMAND_INT (the real capture's: GLOBAL_RELATIVE_ALT_INT, param1 -1,
/// param2 1 = change mode, yaw NaN): ACCEPTED, and GUIDED flies there at WPNAV_SPEED. As
/// COMMAND_LONG ArduPilot has no frame for it: UNSUPPORTED. Not GUIDED and no change-mode
/// flag, lat/lon 0, relative altitude 0, an unknown frame: DENIED.
#[test]
#[allow(deprecated)]
fn reposition_flies_guided_to_the_location() {
    let mut g = Gcs::new("");
    g.fly_guided(10.0);
    let (lat0, lon0, _) = g.v().home();
    let lat = ((lat0 + 100.0 / 111_319.5) * 1e7).round() as i32;
    let lon = (lon0 * 1e7).round() as i32;
    let rel = MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT;
    assert_eq!(g.set_mode(mode::LOITER), MAV_RESULT_ACCEPTED);
    let repo = |g: &mut Gcs, frame, p2: f32, x: i32, y: i32, z: f32| {
        g.command_int(
            MavCmd::MAV_CMD_DO_REPOSITION,
            frame,
            [-1.0, p2, 0.0, f32::NAN],
            x,
            y,
            z,
        )
    };
    assert_eq!(repo(&mut g, rel, 0.0, lat, lon, 18.0), MAV_RESULT_DENIED);
    assert_eq!(repo(&mut g, rel, 1.0, 0, 0, 18.0), MAV_RESULT_DENIED);
    assert_eq!(repo(&mut g, rel, 1.0, lat, lon, 0.0), MAV_RESULT_DENIED);
    assert_eq!(
        repo(&mut g, MavFrame::MAV_FRAME_LOCAL_NED, 1.0, lat, lon, 18.0),
        MAV_RESULT_DENIED
    );
    assert_eq!(g.v().custom_mode(), mode::LOITER);
    assert_eq!(
        g.command(
            MavCmd::MAV_CMD_DO_REPOSITION,
            [
                -1.0,
                1.0,
                0.0,
                f32::NAN,
                lat as f32 * 1e-7,
                lon as f32 * 1e-7,
                18.0
            ],
            0
        ),
        MAV_RESULT_UNSUPPORTED
    );
    assert_eq!(repo(&mut g, rel, 1.0, lat, lon, 18.0), MAV_RESULT_ACCEPTED);
    assert_eq!(g.v().custom_mode(), mode::GUIDED, "changed mode");
    g.run_for(5_000_000);
    let (n, e) = g.v().position_ne();
    assert!((45.0..55.5).contains(&n) && e.abs() < 0.01, "10 m/s: {n}");
    assert!(g.v().heading_deg().abs() < 0.5 || g.v().heading_deg() > 359.5);
    g.run_for(10_000_000);
    let (n, _) = g.v().position_ne();
    assert!((n - 100.0).abs() < 0.1, "{n}");
    assert!((g.v().relative_alt_m() - 18.0).abs() < 0.01);
    // AMSL frame: 584 + 5 m.
    assert_eq!(
        repo(&mut g, MavFrame::MAV_FRAME_GLOBAL, 0.0, lat, lon, 589.0),
        MAV_RESULT_ACCEPTED
    );
    g.run_for(10_000_000);
    assert!((g.v().relative_alt_m() - 5.0).abs() < 0.01);
    assert!(
        g.v().heading_deg() < 0.5,
        "keeps facing north when it stops"
    );
}

/// SMART_RTL once armed with a position estimate: back home and land, then disarm.
#[test]
fn smart_rtl_returns_and_lands() {
    let mut g = Gcs::new("");
    g.fly_guided(10.0);
    g.sim.vehicles[0].east = 40.0; // as if flown away
    assert_eq!(g.set_mode(mode::SMART_RTL), MAV_RESULT_ACCEPTED);
    g.run_for(9_000_000);
    assert_eq!(g.v().position_ne(), (0.0, 0.0));
    assert!(g.v().relative_alt_m() < 10.0);
    g.run_for(30_000_000);
    assert!(g.v().landed() && !g.v().armed());
}

/// Frames the simulator builds by hand or newly sends all pass their CRC: a whole flight with
/// every stream on and no corruption gives no CRC error and nothing undecodable but the
/// SET_MODE ACKs (their command, 11, is not a MAV_CMD).
#[test]
fn a_full_session_has_no_crc_errors() {
    let mut g = Gcs::new("");
    stream_all(&mut g, 1);
    g.fly_guided(5.0);
    #[allow(deprecated)]
    g.send(MavMessage::SET_MODE(SET_MODE_DATA {
        custom_mode: mode::LOITER,
        target_system: 1,
        base_mode: MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
    }));
    g.run_for(1_000_000);
    assert_eq!(
        g.command(MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH, [0.0; 7], 0),
        MAV_RESULT_ACCEPTED
    );
    g.run_for(45_000_000);
    let s = g.parser.stats();
    assert_eq!((s.crc_errors, s.truncated), (0, 0), "{s:?}");
    assert_eq!(s.decode_errors, 1, "the SET_MODE ACK");
    assert!(!g.v().armed());
}

/// A synchronous calibration and an IN_PROGRESS one give the same bytes whatever the poll step.
#[test]
fn deterministic_through_calibrations() {
    let run = |step: Micros| {
        let mut sim = Sim::new(SimConfig::from_query("seed=3&loss=0.05&drop_cmd=241:1").unwrap());
        let cal = |p: [f32; 7], seq: u8| {
            encode(
                Version::V2,
                Header { seq, ..GCS },
                &MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
                    param1: p[0],
                    param3: p[2],
                    param5: p[4],
                    command: MavCmd::MAV_CMD_PREFLIGHT_CALIBRATION,
                    target_system: 1,
                    target_component: 1,
                    ..Default::default()
                }),
            )
        };
        let arspd = encode(
            Version::V2,
            GCS,
            &MavMessage::PARAM_SET(PARAM_SET_DATA {
                param_value: 1.0,
                target_system: 1,
                target_component: 1,
                param_id: "ARSPD_ENABLE".into(),
                param_type: MavParamType::MAV_PARAM_TYPE_INT8,
            }),
        );
        let mut out = Vec::new();
        let mut t = 0;
        while t < 12_000_000 {
            match t {
                1_000_000 => sim.receive(t, &cal([1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], 1)),
                1_500_000 => sim.receive(t, &cal([1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], 2)),
                1_800_000 => sim.receive(t, &cal([0.0, 0.0, 0.0, 0.0, 4.0, 0.0, 0.0], 3)),
                6_000_000 => sim.receive(t, &arspd),
                6_500_000 => sim.receive(t, &cal([0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0], 4)),
                _ => {}
            }
            out.extend(sim.poll(t));
            t += step;
        }
        out.extend(sim.poll(12_000_000));
        out
    };
    let a = run(10_000);
    assert_eq!(a, run(50_000));
    assert_eq!(a, run(100_000));
}

/// The state is saved atomically with a temporary of a unique name: a `state.parm.tmp` planted
/// next to it (here a symlink to another file) is never written through.
#[cfg(unix)]
#[test]
fn state_save_never_writes_through_a_planted_temporary() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("state.parm");
    let victim = dir.path().join("victim");
    std::fs::write(&victim, b"keep").unwrap();
    std::os::unix::fs::symlink(&victim, dir.path().join("state.parm.tmp")).unwrap();
    let q = format!("state={}", path.display());
    let mut g = Gcs::new(&q);
    g.run_until(10_000);
    g.send(MavMessage::PARAM_SET(PARAM_SET_DATA {
        param_value: 2500.0,
        target_system: 1,
        target_component: 1,
        param_id: "RTL_ALT".into(),
        param_type: MavParamType::MAV_PARAM_TYPE_INT32,
    }));
    save_pending(&mut g.sim);
    assert_eq!(std::fs::read(&victim).unwrap(), b"keep");
    assert!(std::fs::read_to_string(&path).unwrap().contains("RTL_ALT"));
}
