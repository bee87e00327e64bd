//! The simulated camera (`sim://?camera=1`): a MAVLink camera component (compid 100,
//! MAV_TYPE_CAMERA) of each vehicle, on the same link, as a Camera Protocol v2 camera behaves
//! (PX4's camera manager, the Gremsy/Siyi cameras): CAMERA_INFORMATION with image, video and mode
//! flags, modes, image capture (one, or N at an interval) announced by CAMERA_IMAGE_CAPTURED
//! with a growing index, video with CAMERA_CAPTURE_STATUS at the asked rate, storage that fills,
//! a format; a capture asked in the wrong mode is refused with MAV_RESULT_DENIED.
//!
//! `camera_drop=N`: the first CAMERA_IMAGE_CAPTURED of index N is lost (a REQUEST_MESSAGE for it
//! gets it), so a ground station's hole filling can be tested.

use crate::clock::{Micros, SECOND};
use crate::dialect::*;
use mavlink::MessageData;

use super::vehicle::Out;

pub const CAMERA_COMPID: u8 = 100;
/// Card size in MiB (a 32 GB card).
pub const TOTAL_MIB: f32 = 30_528.0;
/// One JPEG of 4000x3000.
pub const IMAGE_MIB: f32 = 8.0;
/// Video at 100 Mbit/s.
pub const VIDEO_MIB_PER_S: f32 = 12.0;
/// Wall-clock origin of CAMERA_IMAGE_CAPTURED.time_utc: the vehicle's GPS time (SYSTEM_TIME).
pub const EPOCH_US: u64 = super::telemetry::GPS_EPOCH_US;

pub const FLAGS: u32 = 1 | 2 | 4 | 32 | 64 | 128 | 256; // video, image, modes, survey, zoom, focus, stream

#[derive(Debug, Clone)]
pub struct SimCamera {
    pub sysid: u8,
    pub compid: u8,
    /// CAMERA_MODE: 0 image, 1 video, 2 survey.
    pub mode: u8,
    pub used_mib: f32,
    /// Index of the next image.
    pub next_index: i32,
    /// Images still to take (u32::MAX = until stopped), their interval, and the next one's time.
    shots: Option<(u32, Micros, Micros)>,
    /// Recording since, with CAMERA_CAPTURE_STATUS every this often (0 = none).
    recording: Option<(Micros, Micros)>,
    next_status: Micros,
    pub zoom: f32,
    pub focus: f32,
    next_heartbeat: Micros,
    /// The image index whose CAMERA_IMAGE_CAPTURED is lost the first time.
    pub drop_index: Option<i32>,
    /// Every image taken: (index, time, lat, lon, amsl mm, relative mm).
    images: Vec<(i32, Micros, i32, i32, i32, i32)>,
    out: Vec<Out>,
    /// The vehicle's position, for the next images (lat, lon degrees e7, amsl mm, relative mm).
    pub position: (i32, i32, i32, i32),
}

fn ack(command: MavCmd, result: MavResult, to: (u8, u8)) -> Out {
    Out::Msg(super::telemetry::command_ack(command, result, to))
}

impl SimCamera {
    pub fn new(sysid: u8, drop_index: Option<i32>) -> SimCamera {
        SimCamera {
            sysid,
            compid: CAMERA_COMPID,
            mode: 0,
            used_mib: 0.0,
            next_index: 0,
            shots: None,
            recording: None,
            next_status: 0,
            zoom: 0.0,
            focus: 0.0,
            next_heartbeat: 0,
            drop_index,
            images: Vec::new(),
            out: Vec::new(),
            position: (0, 0, 0, 0),
        }
    }

    pub fn recording(&self) -> bool {
        self.recording.is_some()
    }

    pub fn images_taken(&self) -> usize {
        self.images.len()
    }

    fn available(&self) -> f32 {
        (TOTAL_MIB - self.used_mib).max(0.0)
    }

    pub(super) fn drain(&mut self) -> Vec<Out> {
        std::mem::take(&mut self.out)
    }

    pub(super) fn next_event(&self) -> Micros {
        let mut t = self.next_heartbeat;
        if let Some((_, _, next)) = self.shots {
            t = t.min(next);
        }
        if self.recording.is_some_and(|(_, every)| every > 0) {
            t = t.min(self.next_status);
        }
        t
    }

    pub(super) fn tick(&mut self, now: Micros) {
        if now >= self.next_heartbeat {
            self.next_heartbeat = now + SECOND;
            self.out
                .push(Out::Msg(MavMessage::HEARTBEAT(HEARTBEAT_DATA {
                    custom_mode: 0,
                    mavtype: MavType::MAV_TYPE_CAMERA,
                    autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
                    base_mode: MavModeFlag::empty(),
                    system_status: MavState::MAV_STATE_ACTIVE,
                    mavlink_version: 3,
                })));
        }
        if let Some((left, every, next)) = self.shots {
            if now >= next {
                self.shoot(now);
                let left = left.saturating_sub(1);
                self.shots = (left > 0 && every > 0).then_some((left, every, next + every));
            }
        }
        if let Some((_, every)) = self.recording {
            if every > 0 && now >= self.next_status {
                self.next_status = now + every;
                self.out.push(Out::Msg(self.status(now)));
            }
        }
    }

    fn shoot(&mut self, now: Micros) {
        if self.available() < IMAGE_MIB {
            return;
        }
        self.used_mib += IMAGE_MIB;
        let index = self.next_index;
        self.next_index += 1;
        let (lat, lon, alt, rel) = self.position;
        self.images.push((index, now, lat, lon, alt, rel));
        if self.drop_index == Some(index) {
            self.drop_index = None;
            return;
        }
        self.out
            .push(Out::Msg(self.captured(self.images.len() - 1)));
    }

    fn captured(&self, i: usize) -> MavMessage {
        let (index, t, lat, lon, alt, rel) = self.images[i];
        MavMessage::CAMERA_IMAGE_CAPTURED(CAMERA_IMAGE_CAPTURED_DATA {
            time_utc: EPOCH_US + t,
            time_boot_ms: (t / 1000) as u32,
            lat,
            lon,
            alt,
            relative_alt: rel,
            q: [1.0, 0.0, 0.0, 0.0],
            image_index: index,
            camera_id: 0,
            capture_result: MavBool::MAV_BOOL_TRUE,
            file_url: format!("http://192.168.144.25/DCIM/IMG_{index:04}.JPG")
                .as_str()
                .into(),
        })
    }

    fn recorded_mib(&self, now: Micros) -> f32 {
        self.recording.map_or(0.0, |(since, _)| {
            now.saturating_sub(since) as f32 / SECOND as f32 * VIDEO_MIB_PER_S
        })
    }

    fn status(&self, now: Micros) -> MavMessage {
        let (image_status, interval) = match self.shots {
            Some((_, every, _)) if every > 0 => (3, every as f32 / SECOND as f32),
            Some(_) => (1, 0.0),
            None => (0, 0.0),
        };
        MavMessage::CAMERA_CAPTURE_STATUS(CAMERA_CAPTURE_STATUS_DATA {
            time_boot_ms: (now / 1000) as u32,
            image_interval: interval,
            recording_time_ms: self
                .recording
                .map_or(0, |(since, _)| (now.saturating_sub(since) / 1000) as u32),
            available_capacity: (self.available() - self.recorded_mib(now)).max(0.0),
            image_status,
            video_status: self.recording.is_some() as u8,
            image_count: self.next_index,
            camera_device_id: 0,
        })
    }

    fn information(&self, now: Micros) -> MavMessage {
        let mut vendor = [0u8; 32];
        vendor[..4].copy_from_slice(b"Sony");
        let mut model = [0u8; 32];
        model[..7].copy_from_slice(b"ILX-LR1");
        MavMessage::CAMERA_INFORMATION(CAMERA_INFORMATION_DATA {
            time_boot_ms: (now / 1000) as u32,
            // 1.4.2 build 7: major in the lowest byte.
            firmware_version: 1 | 4 << 8 | 2 << 16 | 7 << 24,
            focal_length: 24.0,
            sensor_size_h: 35.7,
            sensor_size_v: 23.8,
            flags: CameraCapFlags::from_bits_retain(FLAGS),
            resolution_h: 9504,
            resolution_v: 6336,
            cam_definition_version: 0,
            vendor_name: vendor,
            model_name: model,
            lens_id: 0,
            cam_definition_uri: "".into(),
            gimbal_device_id: 0,
            camera_device_id: 0,
        })
    }

    fn settings(&self, now: Micros) -> MavMessage {
        MavMessage::CAMERA_SETTINGS(CAMERA_SETTINGS_DATA {
            time_boot_ms: (now / 1000) as u32,
            mode_id: match self.mode {
                1 => CameraMode::CAMERA_MODE_VIDEO,
                2 => CameraMode::CAMERA_MODE_IMAGE_SURVEY,
                _ => CameraMode::CAMERA_MODE_IMAGE,
            },
            zoomLevel: self.zoom,
            focusLevel: self.focus,
            camera_device_id: 0,
        })
    }

    fn storage(&self, now: Micros) -> MavMessage {
        let used = self.used_mib + self.recorded_mib(now);
        MavMessage::STORAGE_INFORMATION(STORAGE_INFORMATION_DATA {
            time_boot_ms: (now / 1000) as u32,
            total_capacity: TOTAL_MIB,
            used_capacity: used,
            available_capacity: (TOTAL_MIB - used).max(0.0),
            read_speed: 90.0,
            write_speed: 60.0,
            storage_id: 1,
            storage_count: 1,
            status: StorageStatus::STORAGE_STATUS_READY,
            mavtype: StorageType::STORAGE_TYPE_SD,
            name: "SD".into(),
            storage_usage: StorageUsageFlag::STORAGE_USAGE_FLAG_SET
                | StorageUsageFlag::STORAGE_USAGE_FLAG_PHOTO
                | StorageUsageFlag::STORAGE_USAGE_FLAG_VIDEO,
        })
    }

    fn stream(&self) -> MavMessage {
        MavMessage::VIDEO_STREAM_INFORMATION(VIDEO_STREAM_INFORMATION_DATA {
            framerate: 30.0,
            bitrate: 4_000_000,
            flags: VideoStreamStatusFlags::VIDEO_STREAM_STATUS_FLAGS_RUNNING,
            resolution_h: 1920,
            resolution_v: 1080,
            rotation: 0,
            hfov: 84,
            stream_id: 1,
            count: 1,
            mavtype: VideoStreamType::VIDEO_STREAM_TYPE_RTSP,
            name: "main".into(),
            uri: "rtsp://192.168.144.25:8554/main.264".into(),
            encoding: VideoStreamEncoding::VIDEO_STREAM_ENCODING_H264,
            camera_device_id: 0,
        })
    }

    /// A command for this camera (already known to be addressed to it).
    #[allow(deprecated)] // MAV_CMD_REQUEST_CAMERA_INFORMATION: older cameras and GCSs use it
    pub(super) fn command(&mut self, now: Micros, from: (u8, u8), command: MavCmd, p: [f32; 7]) {
        use MavCmd::*;
        use MavResult::*;
        let mut then = None;
        let result = match command {
            MAV_CMD_REQUEST_MESSAGE => match p[0] as u32 {
                CAMERA_INFORMATION_DATA::ID => {
                    then = Some(self.information(now));
                    MAV_RESULT_ACCEPTED
                }
                CAMERA_SETTINGS_DATA::ID => {
                    then = Some(self.settings(now));
                    MAV_RESULT_ACCEPTED
                }
                STORAGE_INFORMATION_DATA::ID => {
                    then = Some(self.storage(now));
                    MAV_RESULT_ACCEPTED
                }
                CAMERA_CAPTURE_STATUS_DATA::ID => {
                    then = Some(self.status(now));
                    MAV_RESULT_ACCEPTED
                }
                CAMERA_IMAGE_CAPTURED_DATA::ID => {
                    match self.images.iter().position(|i| i.0 == p[1] as i32) {
                        Some(i) => {
                            then = Some(self.captured(i));
                            MAV_RESULT_ACCEPTED
                        }
                        None => MAV_RESULT_DENIED,
                    }
                }
                VIDEO_STREAM_INFORMATION_DATA::ID => {
                    then = Some(self.stream());
                    MAV_RESULT_ACCEPTED
                }
                _ => MAV_RESULT_UNSUPPORTED,
            },
            MAV_CMD_REQUEST_CAMERA_INFORMATION if p[0] == 1.0 => {
                then = Some(self.information(now));
                MAV_RESULT_ACCEPTED
            }
            MAV_CMD_SET_CAMERA_MODE => match p[1] as u8 {
                _ if self.recording.is_some() || self.shots.is_some() => {
                    MAV_RESULT_TEMPORARILY_REJECTED
                }
                m @ 0..=2 => {
                    self.mode = m;
                    then = Some(self.settings(now));
                    MAV_RESULT_ACCEPTED
                }
                _ => MAV_RESULT_DENIED,
            },
            MAV_CMD_IMAGE_START_CAPTURE => {
                let count = p[2] as u32;
                let every = (p[1].max(0.0) as f64 * SECOND as f64) as Micros;
                if self.mode == 1 {
                    MAV_RESULT_DENIED
                } else if self.shots.is_some() {
                    MAV_RESULT_TEMPORARILY_REJECTED
                } else if self.available() < IMAGE_MIB {
                    MAV_RESULT_FAILED
                } else if count != 1 && every == 0 {
                    MAV_RESULT_DENIED
                } else {
                    let left = if count == 0 { u32::MAX } else { count };
                    self.shots = Some((left, every, now));
                    MAV_RESULT_ACCEPTED
                }
            }
            MAV_CMD_IMAGE_STOP_CAPTURE => {
                self.shots = None;
                MAV_RESULT_ACCEPTED
            }
            MAV_CMD_VIDEO_START_CAPTURE => {
                if self.mode != 1 {
                    MAV_RESULT_DENIED
                } else if self.recording.is_some() {
                    MAV_RESULT_TEMPORARILY_REJECTED
                } else {
                    let every = if p[1] > 0.0 {
                        (SECOND as f64 / p[1] as f64) as Micros
                    } else {
                        0
                    };
                    self.recording = Some((now, every));
                    self.next_status = now + every;
                    MAV_RESULT_ACCEPTED
                }
            }
            MAV_CMD_VIDEO_STOP_CAPTURE => {
                if self.recording.is_some() {
                    // The video written stays on the card.
                    self.used_mib = (self.used_mib + self.recorded_mib(now)).min(TOTAL_MIB);
                    self.recording = None;
                    then = Some(self.status(now));
                    MAV_RESULT_ACCEPTED
                } else {
                    MAV_RESULT_DENIED
                }
            }
            MAV_CMD_SET_CAMERA_ZOOM if p[0] == 2.0 && (0.0..=100.0).contains(&p[1]) => {
                self.zoom = p[1];
                MAV_RESULT_ACCEPTED
            }
            MAV_CMD_SET_CAMERA_FOCUS if p[0] == 2.0 && (0.0..=100.0).contains(&p[1]) => {
                self.focus = p[1];
                MAV_RESULT_ACCEPTED
            }
            MAV_CMD_STORAGE_FORMAT => {
                if self.recording.is_some() || self.shots.is_some() {
                    MAV_RESULT_TEMPORARILY_REJECTED
                } else {
                    self.used_mib = 0.0;
                    if p[2] == 1.0 {
                        self.next_index = 0;
                        self.images.clear();
                    }
                    then = Some(self.storage(now));
                    MAV_RESULT_ACCEPTED
                }
            }
            _ => MAV_RESULT_UNSUPPORTED,
        };
        self.out.push(ack(command, result, from));
        if let Some(m) = then {
            self.out.push(Out::Msg(m));
        }
    }

    /// A message from the ground.
    pub(super) fn handle(&mut self, now: Micros, from: (u8, u8), msg: &MavMessage) {
        if let MavMessage::COMMAND_LONG(m) = msg {
            if m.target_system == self.sysid && m.target_component == self.compid {
                let p = [
                    m.param1, m.param2, m.param3, m.param4, m.param5, m.param6, m.param7,
                ];
                self.command(now, from, m.command, p);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::{Sim, SimConfig};
    use crate::wire::frame::{encode, Header, Version};
    use crate::wire::parser::FrameParser;

    fn send(sim: &mut Sim, now: Micros, command: MavCmd, p: [f32; 7]) -> Vec<(u8, MavMessage)> {
        let m = MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
            target_system: 1,
            target_component: CAMERA_COMPID,
            command,
            confirmation: 0,
            param1: p[0],
            param2: p[1],
            param3: p[2],
            param4: p[3],
            param5: p[4],
            param6: p[5],
            param7: p[6],
        });
        let f = encode(
            Version::V2,
            Header {
                sysid: 255,
                compid: 190,
                seq: 0,
            },
            &m,
        );
        sim.receive(now, &f);
        let mut out = Vec::new();
        let mut parser = FrameParser::new();
        parser.push(&sim.poll(now + 1000), |f| {
            if let Some(m) = f.message {
                out.push((f.compid, *m));
            }
        });
        out
    }

    fn acks(out: &[(u8, MavMessage)]) -> Vec<(MavCmd, MavResult)> {
        out.iter()
            .filter_map(|(c, m)| match m {
                MavMessage::COMMAND_ACK(a) if *c == CAMERA_COMPID => Some((a.command, a.result)),
                _ => None,
            })
            .collect()
    }

    #[test]
    fn a_capture_in_the_wrong_mode_is_denied() {
        let mut sim = Sim::new(SimConfig::from_query("camera=1").unwrap());
        let video = [0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let out = send(&mut sim, SECOND, MavCmd::MAV_CMD_SET_CAMERA_MODE, video);
        assert_eq!(
            acks(&out),
            [(
                MavCmd::MAV_CMD_SET_CAMERA_MODE,
                MavResult::MAV_RESULT_ACCEPTED
            )]
        );
        let shot = [0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0];
        let out = send(
            &mut sim,
            2 * SECOND,
            MavCmd::MAV_CMD_IMAGE_START_CAPTURE,
            shot,
        );
        assert_eq!(
            acks(&out),
            [(
                MavCmd::MAV_CMD_IMAGE_START_CAPTURE,
                MavResult::MAV_RESULT_DENIED
            )]
        );
        assert_eq!(sim.camera(1).unwrap().images_taken(), 0);
        // In image mode the same shot is taken and announced.
        let image = [0.0; 7];
        send(&mut sim, 3 * SECOND, MavCmd::MAV_CMD_SET_CAMERA_MODE, image);
        let out = send(
            &mut sim,
            4 * SECOND,
            MavCmd::MAV_CMD_IMAGE_START_CAPTURE,
            shot,
        );
        assert_eq!(
            acks(&out),
            [(
                MavCmd::MAV_CMD_IMAGE_START_CAPTURE,
                MavResult::MAV_RESULT_ACCEPTED
            )]
        );
        let out: Vec<_> = {
            let mut o = Vec::new();
            let mut parser = FrameParser::new();
            parser.push(&sim.poll(5 * SECOND), |f| {
                if let Some(m) = f.message {
                    o.push(*m)
                }
            });
            o
        };
        assert!(out.iter().any(|m| matches!(m,
            MavMessage::CAMERA_IMAGE_CAPTURED(c) if c.image_index == 0)));
        // Video is refused in image mode.
        let out = send(
            &mut sim,
            6 * SECOND,
            MavCmd::MAV_CMD_VIDEO_START_CAPTURE,
            [0.0; 7],
        );
        assert_eq!(
            acks(&out),
            [(
                MavCmd::MAV_CMD_VIDEO_START_CAPTURE,
                MavResult::MAV_RESULT_DENIED
            )]
        );
    }
}
