//! Operating cameras from the prompt and the Camera screen's keys: `camera …` and `gimbal …`.
//!
//! Each goes through the target vehicle's command queue to the selected camera (its own
//! component id), so its ACK is shown on the Commands screen and as a notice. What the camera's
//! CAMERA_CAP_FLAGS or mode rule out is not sent: the reason is shown instead.

use super::{App, Effect};
use crate::proto::camera::CameraAction;
use crate::proto::vehicles::VehicleKey;

/// A parsed `camera …` / `gimbal …` line.
#[derive(Debug, Clone, PartialEq)]
pub enum CameraCmd {
    Act(CameraAction),
    /// `camera format`: asks first (`y` formats).
    FormatAsk,
    /// Select the camera of this component id (or the Nth row, 1-based, when small).
    Select(u8),
    Gimbal {
        pitch: f64,
        yaw: f64,
    },
    /// `gimbal control` / `gimbal release`: take or give up primary control.
    GimbalControl(bool),
    /// `gimbal select N`: the Nth gimbal (1-based) the keys and `gimbal` point.
    GimbalSelect(usize),
}

pub const USAGE: &str = "usage: camera mode image|video|survey, shoot [N [SECONDS]], stop, video start|stop, zoom 0-100, focus 0-100, format, select COMPID";

/// Parse what follows `camera`.
pub fn parse(rest: &str) -> Result<CameraCmd, String> {
    let w: Vec<&str> = rest.split_whitespace().collect();
    let num = |s: &str, lo: f64, hi: f64| {
        s.parse::<f64>()
            .ok()
            .filter(|v| v.is_finite() && (lo..=hi).contains(v))
            .ok_or_else(|| format!("`{s}` is not a number from {lo} to {hi}"))
    };
    Ok(match w.as_slice() {
        ["mode", m] => CameraCmd::Act(CameraAction::Mode(match *m {
            "image" | "photo" => 0,
            "video" => 1,
            "survey" => 2,
            _ => return Err("usage: camera mode image|video|survey".into()),
        })),
        ["shoot"] => CameraCmd::Act(CameraAction::Shoot {
            count: 1,
            interval: 0.0,
        }),
        ["shoot", n] => {
            let count = num(n, 0.0, 10_000.0)? as u32;
            CameraCmd::Act(CameraAction::Shoot {
                count,
                interval: if count == 1 { 0.0 } else { 1.0 },
            })
        }
        ["shoot", n, s] => CameraCmd::Act(CameraAction::Shoot {
            count: num(n, 0.0, 10_000.0)? as u32,
            interval: num(s, 0.0, 3600.0)?,
        }),
        ["stop"] => CameraCmd::Act(CameraAction::StopImages),
        ["video", "start"] => CameraCmd::Act(CameraAction::VideoStart),
        ["video", "stop"] => CameraCmd::Act(CameraAction::VideoStop),
        ["zoom", z] => CameraCmd::Act(CameraAction::Zoom(num(z, 0.0, 100.0)?)),
        ["focus", f] => CameraCmd::Act(CameraAction::Focus(num(f, 0.0, 100.0)?)),
        ["format"] => CameraCmd::FormatAsk,
        ["select", n] => CameraCmd::Select(n.parse().map_err(|_| USAGE.to_string())?),
        _ => return Err(USAGE.into()),
    })
}

/// Parse what follows `gimbal`: PITCH YAW in degrees, `control`, `release`, `select N`.
pub fn parse_gimbal(rest: &str) -> Result<CameraCmd, String> {
    let usage = || {
        "usage: gimbal PITCH YAW (degrees, pitch up +, yaw right + of the nose; e.g. gimbal -90 0), \
         gimbal control|release, gimbal select N"
            .to_string()
    };
    let words: Vec<&str> = rest.split_whitespace().collect();
    match words.as_slice() {
        ["control"] => return Ok(CameraCmd::GimbalControl(true)),
        ["release"] => return Ok(CameraCmd::GimbalControl(false)),
        ["select", n] => {
            return n
                .parse::<usize>()
                .ok()
                .filter(|n| *n >= 1)
                .map(CameraCmd::GimbalSelect)
                .ok_or_else(usage)
        }
        _ => {}
    }
    let w: Vec<f64> = words
        .iter()
        .map(|s| s.parse::<f64>().map_err(|_| usage()))
        .collect::<Result<_, _>>()?;
    match w.as_slice() {
        [p, y] if p.is_finite() && y.is_finite() => Ok(CameraCmd::Gimbal { pitch: *p, yaw: *y }),
        _ => Err(usage()),
    }
}

/// Degrees a gimbal key turns.
pub const GIMBAL_STEP: f64 = 5.0;
/// Percent of the zoom or focus range a key moves.
pub const ZOOM_STEP: f64 = 10.0;

impl App {
    /// A Camera screen key.
    pub(super) fn on_camera_action(&mut self, action: crate::keymap::Action, fx: &mut Vec<Effect>) {
        use crate::keymap::Action::*;
        let sel = self.selected_camera();
        let cam = sel.and_then(|id| {
            self.target
                .and_then(|k| self.sessions.get(&k))
                .and_then(|s| s.cameras.cameras.get(&id))
        });
        let (pitch, yaw) = self
            .target
            .and_then(|k| self.sessions.get(&k))
            .and_then(|s| s.gimbals.pick(self.ui.gimbal_sel))
            .map_or((0.0, 0.0), |g| g.base());
        // Zoom and focus step from the camera's CAMERA_SETTINGS (ZOOM_TYPE_RANGE, the type
        // ArduPilot and the Camera Protocol cameras all take).
        let level = |f: fn(&crate::proto::camera::Settings) -> f32| {
            cam.and_then(|c| c.settings)
                .map(|s| f(&s) as f64)
                .filter(|v| v.is_finite())
        };
        let step = |v: Option<f64>, d: f64| (v.unwrap_or(0.0) + d).clamp(0.0, 100.0);
        let cmd = match action {
            CameraShoot => CameraCmd::Act(CameraAction::Shoot {
                count: 1,
                interval: 0.0,
            }),
            CameraVideo => CameraCmd::Act(if cam.is_some_and(|c| c.recording()) {
                CameraAction::VideoStop
            } else {
                CameraAction::VideoStart
            }),
            CameraMode => CameraCmd::Act(CameraAction::Mode(
                if cam.and_then(|c| c.settings).is_some_and(|s| s.mode == 1) {
                    0
                } else {
                    1
                },
            )),
            CameraZoomIn | CameraZoomOut | CameraFocusFar | CameraFocusNear => {
                let zoom = matches!(action, CameraZoomIn | CameraZoomOut);
                let up = matches!(action, CameraZoomIn | CameraFocusFar);
                let d = if up { ZOOM_STEP } else { -ZOOM_STEP };
                let now = if zoom {
                    level(|s| s.zoom)
                } else {
                    level(|s| s.focus)
                };
                if now.is_none() && cam.is_some_and(|c| c.info.is_some()) {
                    let what = if zoom { "zoom" } else { "focus" };
                    let known = cam.and_then(|c| {
                        let flag = if zoom {
                            crate::proto::camera::CAP_ZOOM
                        } else {
                            crate::proto::camera::CAP_FOCUS
                        };
                        c.has(flag).then_some(())
                    });
                    if known.is_some() {
                        self.ui.message = Some((
                            crate::wire::Severity::ERROR,
                            format!(
                                "camera {what} level unknown (CAMERA_SETTINGS not heard): \
                                 `camera {what} 0-100` sets it (not sent)"
                            ),
                        ));
                        return;
                    }
                }
                CameraCmd::Act(if zoom {
                    CameraAction::Zoom(step(now, d))
                } else {
                    CameraAction::Focus(step(now, d))
                })
            }
            CameraNext => {
                let n = self
                    .target
                    .and_then(|k| self.sessions.get(&k))
                    .map_or(0, |s| s.cameras.cameras.len());
                self.ui.camera_sel = if n == 0 {
                    0
                } else {
                    (self.ui.camera_sel.min(n - 1) + 1) % n
                };
                return;
            }
            GimbalUp => CameraCmd::Gimbal {
                pitch: pitch + GIMBAL_STEP,
                yaw,
            },
            GimbalDown => CameraCmd::Gimbal {
                pitch: pitch - GIMBAL_STEP,
                yaw,
            },
            GimbalLeft => CameraCmd::Gimbal {
                pitch,
                yaw: yaw - GIMBAL_STEP,
            },
            GimbalRight => CameraCmd::Gimbal {
                pitch,
                yaw: yaw + GIMBAL_STEP,
            },
            GimbalCenter => CameraCmd::Gimbal {
                pitch: 0.0,
                yaw: 0.0,
            },
            _ => return,
        };
        self.ui.message = Some(match self.run_camera(cmd, fx) {
            Ok(t) => (crate::wire::Severity::INFO, t.unwrap_or_default()),
            Err(e) => (crate::wire::Severity::ERROR, e),
        });
    }

    /// The camera (component id) commands go to: the selected row of the target's cameras.
    pub fn selected_camera(&self) -> Option<u8> {
        let key = self.target?;
        let s = self.sessions.get(&key)?;
        let ids: Vec<u8> = s.cameras.cameras.keys().copied().collect();
        ids.get(self.ui.camera_sel.min(ids.len().saturating_sub(1)))
            .copied()
    }

    pub(super) fn run_camera(
        &mut self,
        cmd: CameraCmd,
        fx: &mut Vec<Effect>,
    ) -> Result<Option<String>, String> {
        let key = self.target.ok_or("no target vehicle")?;
        let now = self.now;
        let us = (self.cfg.sysid, self.cfg.compid);
        let sel = self.ui.gimbal_sel;
        if let CameraCmd::Gimbal { .. } | CameraCmd::GimbalControl(_) = cmd {
            // The vehicle, and the gimbal's manager where one is known, heard and not lost.
            self.commandable_at(key)?;
            let manager = self
                .sessions
                .get(&key)
                .and_then(|s| s.gimbals.pick(sel))
                .map(|g| g.manager);
            if let Some(m) = manager {
                self.commandable_at(VehicleKey(key.0, m))
                    .map_err(|e| format!("gimbal: {e}"))?;
            }
        }
        match cmd {
            CameraCmd::Gimbal { pitch, yaw } => {
                let s = self.sessions.get_mut(&key).ok_or("no session")?;
                let (id, out) = s.gimbal_point(now, sel, pitch, yaw, us)?;
                let name = s.gimbals.name(sel, key.0);
                let label = format!("gimbal {name} pitch {pitch}° yaw {yaw}°");
                return Ok(Some(self.command_action(key, id, label, out, fx)));
            }
            CameraCmd::GimbalControl(take) => {
                let s = self.sessions.get_mut(&key).ok_or("no session")?;
                let (id, out) = s.gimbal_configure(now, sel, take, us)?;
                let name = s.gimbals.name(sel, key.0);
                let what = if take { "take control" } else { "release" };
                let label = format!("gimbal {name} {what}");
                return Ok(Some(self.command_action(key, id, label, out, fx)));
            }
            CameraCmd::GimbalSelect(n) => {
                let s = self.sessions.get(&key).ok_or("no session")?;
                let usable = s.gimbals.usable();
                let g = usable
                    .get(n - 1)
                    .ok_or_else(|| format!("no gimbal {n} ({} known)", usable.len()))?;
                let name = g.name(key.0);
                self.ui.gimbal_sel = n - 1;
                return Ok(Some(format!("gimbal {name} selected")));
            }
            _ => {}
        }
        if let CameraCmd::Select(n) = cmd {
            let s = self.sessions.get(&key).ok_or("no session")?;
            let ids: Vec<u8> = s.cameras.cameras.keys().copied().collect();
            let i = ids
                .iter()
                .position(|&c| c == n)
                .or_else(|| (n >= 1 && (n as usize) <= ids.len()).then(|| n as usize - 1))
                .ok_or_else(|| format!("no camera {n} (cameras: {ids:?})"))?;
            self.ui.camera_sel = i;
            return Ok(Some(format!("camera {}:{} selected", key.0, ids[i])));
        }
        let compid = self
            .selected_camera()
            .ok_or_else(|| format!("no camera heard on {key}"))?;
        let action = match cmd {
            CameraCmd::FormatAsk => {
                self.ask(super::confirm::Ask {
                    text: format!(
                        "FORMAT the storage of camera {} on {}? Every image and video on \
                         it is erased. y = yes, any other key = no",
                        VehicleKey(key.0, compid),
                        self.who_is(key)
                    ),
                    action: super::confirm::Confirmed::Camera(compid, CameraAction::Format),
                    target: key,
                });
                return Ok(None);
            }
            CameraCmd::Act(a) => a,
            _ => unreachable!(),
        };
        self.camera_act(key, compid, action, fx)
    }

    /// Send `action` to camera `compid` of `key`, through its session's command queue.
    pub(super) fn camera_act(
        &mut self,
        key: VehicleKey,
        compid: u8,
        action: CameraAction,
        fx: &mut Vec<Effect>,
    ) -> Result<Option<String>, String> {
        // The camera heard and not lost (and the vehicle it is reached through).
        self.commandable_at(key)?;
        self.commandable_at(VehicleKey(key.0, compid))
            .map_err(|e| format!("camera: {e}"))?;
        let now = self.now;
        let s = self.sessions.get_mut(&key).ok_or("no session")?;
        // Where the camera's images stand before: a capture counts those that come after.
        let before = s.cameras.cameras.get(&compid).map(|c| {
            (
                c.images.keys().next_back().copied(),
                c.status.map(|st| st.image_count),
            )
        });
        let (id, out) = s.camera_action(now, compid, &action)?;
        let label = format!("camera {} {}", VehicleKey(key.0, compid), action.describe());
        let text = match action {
            CameraAction::Shoot { count, interval } if count >= 1 => {
                let (from_index, from_count) = before.unwrap_or((None, None));
                let kind = super::outcome::ActionKind::Capture(super::outcome::Capture {
                    key,
                    compid,
                    label: label.clone(),
                    count,
                    interval,
                    from_index,
                    from_count,
                    accepted: false,
                    taken: 0,
                    last_at: now,
                });
                let text = format!("{label}: sent");
                self.start_action(Some(key), vec![id], kind, text.clone());
                self.session_out(key, out, fx);
                text
            }
            _ => self.command_action(key, id, label, out, fx),
        };
        Ok(Some(text))
    }

    /// Command `id` of `key`'s queue, just submitted, as the action `label`: its line goes from
    /// `LABEL: sent` to `LABEL: RESULT`.
    fn command_action(
        &mut self,
        key: VehicleKey,
        id: u64,
        label: String,
        out: Vec<super::session::SessionOut>,
        fx: &mut Vec<Effect>,
    ) -> String {
        let text = format!("{label}: sent");
        let kind = super::outcome::ActionKind::Named(label);
        self.start_action(Some(key), vec![id], kind, text.clone());
        self.session_out(key, out, fx);
        text
    }
}
