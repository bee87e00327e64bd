//! The Camera screen (`6`): the target's cameras, one row each, and the selected one in full:
//! what CAMERA_INFORMATION says (vendor, model, firmware, resolution, lens, each capability flag
//! by name), its mode, storage, capture status, the last images, its video streams, and what can
//! be done with it (an action the camera cannot do is shown with the reason). Below, the
//! system's gimbals, one line each (manager and device, attitude, limits, who controls it) and
//! the selected one's capability flags.

use ratatui::layout::Rect;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Borders, Paragraph, Wrap};
use ratatui::Frame;

use super::Theme;
use crate::app::session::Session;
use crate::app::App;
use crate::proto::camera::{flag_names, mode_name, Camera, CameraAction, Discovery};
use crate::proto::vehicles::VehicleKey;

fn mib(v: f32) -> String {
    format!("{v:.0} MiB")
}

pub fn render(app: &App, frame: &mut Frame, area: Rect, theme: &Theme) {
    let block = Block::default()
        .borders(Borders::ALL)
        .border_style(theme.focus_border());
    let session = app.target.and_then(|k| app.sessions.get(&k));
    let Some(s) =
        session.filter(|s| !s.cameras.cameras.is_empty() || !s.gimbals.gimbals.is_empty())
    else {
        let text = match app.target {
            Some(k) => format!("no camera or gimbal heard on system {}", k.0),
            None => "no target vehicle".into(),
        };
        frame.render_widget(
            Paragraph::new(Line::styled(text, theme.dim())).block(block.title(" Camera ")),
            area,
        );
        return;
    };
    let sel = app.selected_camera();
    let mut lines = Vec::new();
    camera_rows(s, sel, theme, &mut lines);
    if let Some(c) = sel.and_then(|id| s.cameras.cameras.get(&id)) {
        camera_lines(c, theme, &mut lines);
        action_lines(s, c, theme, &mut lines);
    }
    gimbal_lines(app, s, theme, &mut lines);
    let title = title(app, s, sel);
    frame.render_widget(
        Paragraph::new(lines)
            .block(block.title(title))
            .wrap(Wrap { trim: false }),
        area,
    );
}

/// The target's cameras, one row each (`>` the selected one).
fn camera_rows(s: &Session, sel: Option<u8>, theme: &Theme, lines: &mut Vec<Line<'static>>) {
    let sys = s.key.0;
    for c in s.cameras.cameras.values() {
        let mark = if Some(c.compid) == sel { ">" } else { " " };
        let state = match c.discovery {
            Discovery::Found => String::new(),
            Discovery::Failed => "  no CAMERA_INFORMATION".into(),
            _ => "  asking CAMERA_INFORMATION…".into(),
        };
        let style = if Some(c.compid) == sel {
            theme.selected()
        } else {
            theme.border()
        };
        lines.push(Line::styled(
            format!("{mark}{sys}:{:<3} {}{state}", c.compid, c.title()),
            style,
        ));
    }
}

/// The selected camera in full: what CAMERA_INFORMATION says, its mode and storage, capture
/// status, the last images and its video streams.
fn camera_lines(c: &Camera, theme: &Theme, lines: &mut Vec<Line<'static>>) {
    if let Some(i) = &c.info {
        let fw = i.firmware;
        lines.push(Line::raw(format!(
            "fw {}.{}.{}.{}  {}x{}  lens {}  {:.1} mm  sensor {:.1}x{:.1} mm",
            fw.0,
            fw.1,
            fw.2,
            fw.3,
            i.resolution.0,
            i.resolution.1,
            i.lens_id,
            i.focal_length_mm,
            i.sensor_mm.0,
            i.sensor_mm.1
        )));
        lines.push(Line::styled(
            format!("flags {}", flag_names(i.flags).join(" ")),
            theme.dim(),
        ));
    }
    let mode = c.settings.map_or("mode ?".to_string(), |st| {
        format!(
            "mode {}  zoom {:.0}%  focus {:.0}%",
            mode_name(st.mode),
            st.zoom,
            st.focus
        )
    });
    let storage = c.storage.map_or("storage ?".to_string(), |st| {
        let status = match st.status {
            0 => "empty",
            1 => "unformatted",
            2 => "ready",
            _ => "not supported",
        };
        let free = c.status.map_or(st.available, |cs| cs.available_mib);
        format!("storage {} free of {} ({status})", mib(free), mib(st.total))
    });
    lines.push(Line::raw(format!("{mode}  {storage}")));
    let status = match c.status {
        Some(cs) => {
            let video = if cs.video_status == 1 {
                let t = cs.recording_ms / 1000;
                format!("RECORDING {:02}:{:02}", t / 60, t % 60)
            } else {
                "video idle".into()
            };
            let images = match cs.image_status {
                1 => "capturing".to_string(),
                3 => format!("capturing every {:.1} s", cs.image_interval),
                _ => "idle".to_string(),
            };
            format!("images {} captured ({images})  {video}", cs.image_count)
        }
        None => "capture status ?".into(),
    };
    let style = if c.recording() {
        theme.alert()
    } else {
        theme.border()
    };
    lines.push(Line::styled(status, style));
    if let Some(img) = c.last_image.and_then(|i| c.images.get(&i)) {
        let t = chrono::DateTime::from_timestamp_micros(img.time_utc_us as i64)
            .map_or("?".into(), |t| t.format("%H:%M:%S").to_string());
        let result = match img.result {
            1 => "ok",
            0 => "FAILED",
            _ => "?",
        };
        lines.push(Line::raw(format!(
            "last #{} {t} {:.7} {:.7} {:.1} m {result}",
            img.index,
            img.lat_e7 as f64 / 1e7,
            img.lon_e7 as f64 / 1e7,
            img.relative_alt_mm as f64 / 1000.0
        )));
    }
    if !c.images.is_empty() {
        let shown: Vec<String> = c
            .images
            .keys()
            .rev()
            .take(12)
            .rev()
            .map(|i| i.to_string())
            .collect();
        let missing = c.missing();
        let holes = if missing.is_empty() {
            String::new()
        } else {
            format!("  missing {:?}", missing)
        };
        lines.push(Line::raw(format!(
            "list {} ({} kept){holes}",
            shown.join(" "),
            c.images.len()
        )));
    }
    for st in c.streams.values() {
        lines.push(Line::raw(format!(
            "stream {} {} {}x{} {}",
            st.id, st.name, st.resolution.0, st.resolution.1, st.uri
        )));
    }
}

/// What the camera can be asked, as its flags and mode allow, and why not.
fn action_lines(s: &Session, c: &Camera, theme: &Theme, lines: &mut Vec<Line<'static>>) {
    let actions: [(&str, CameraAction); 5] = [
        (
            "shoot",
            CameraAction::Shoot {
                count: 1,
                interval: 0.0,
            },
        ),
        (
            if c.recording() {
                "video stop"
            } else {
                "video start"
            },
            if c.recording() {
                CameraAction::VideoStop
            } else {
                CameraAction::VideoStart
            },
        ),
        (
            "mode",
            CameraAction::Mode(if c.settings.is_some_and(|s| s.mode == 1) {
                0
            } else {
                1
            }),
        ),
        ("zoom", CameraAction::Zoom(0.0)),
        ("focus", CameraAction::Focus(0.0)),
    ];
    let mut spans = Vec::new();
    let mut why = Vec::new();
    for (name, a) in actions {
        match s.cameras.action(c.compid, &a) {
            Ok(_) => spans.push(Span::styled(format!("[{name}] "), theme.good())),
            Err(e) => {
                spans.push(Span::styled(format!("({name}) "), theme.dim()));
                why.push(e);
            }
        }
    }
    lines.push(Line::from(spans));
    for w in why {
        lines.push(Line::styled(format!("  {w}"), theme.dim()));
    }
}

/// The border's title: the selected camera and the keys for it.
fn title(app: &App, s: &Session, sel: Option<u8>) -> String {
    match sel {
        Some(id) => {
            let cam = VehicleKey(s.key.0, id);
            let n = s.cameras.cameras.len();
            let i = s.cameras.cameras.keys().position(|&c| c == id).unwrap_or(0) + 1;
            let keys = |a| {
                app.keymap
                    .keys_for(crate::keymap::Mode::Normal, "camera", a)
                    .first()
                    .map(|k| k.to_string())
                    .unwrap_or_default()
            };
            use crate::keymap::Action as A;
            format!(
                " Camera {cam} ({i} of {n})  {} shoot  {} video  {} mode  {}/{} zoom  {}/{} focus ",
                keys(A::CameraShoot),
                keys(A::CameraVideo),
                keys(A::CameraMode),
                keys(A::CameraZoomIn),
                keys(A::CameraZoomOut),
                keys(A::CameraFocusFar),
                keys(A::CameraFocusNear),
            )
        }
        None => " Camera  alt-arrows point the gimbal  c level ".to_string(),
    }
}

/// The gimbals: one line each (`>` the one the keys point), then the selected one's flags.
fn gimbal_lines(app: &App, s: &Session, theme: &Theme, lines: &mut Vec<Line<'static>>) {
    use crate::proto::gimbal::{names, CAP_FLAGS};
    let sys = s.key.0;
    let sel = s
        .gimbals
        .pick(app.ui.gimbal_sel)
        .map(|g| (g.manager, g.device));
    let us = (app.cfg.sysid, app.cfg.compid);
    for g in s.gimbals.gimbals.values() {
        let picked = sel == Some((g.manager, g.device));
        let mark = if picked { ">" } else { " " };
        let att = match g.attitude {
            Some(a) => format!(
                "pitch {:.1}° roll {:.1}° yaw {:.1}° {}",
                a.pitch,
                a.roll,
                a.yaw,
                if a.yaw_in_vehicle_frame() {
                    "(nose)"
                } else {
                    "(north)"
                }
            ),
            None => "attitude ?".into(),
        };
        let asked = g
            .commanded
            .map_or(String::new(), |(p, y)| format!("  asked {p:.0}°/{y:.0}°"));
        let style = if picked {
            theme.selected()
        } else {
            theme.border()
        };
        lines.push(Line::styled(
            format!("{mark}gimbal {} {att}{asked}", g.name(sys)),
            style,
        ));
        let limits = match g.info {
            Some(i) => format!(
                "pitch {:.0}..{:.0}° yaw {:.0}..{:.0}°",
                i.pitch.0, i.pitch.1, i.yaw.0, i.yaw.1
            ),
            None => "limits ? (no GIMBAL_MANAGER_INFORMATION)".into(),
        };
        let control = match g.status {
            Some(st) if st.primary == (0, 0) => "nobody".to_string(),
            Some(st) if st.primary == us => format!("{} (us)", VehicleKey::from(st.primary)),
            Some(st) => VehicleKey::from(st.primary).to_string(),
            None => "?".into(),
        };
        lines.push(Line::raw(format!("  {limits}  control {control}")));
        if picked {
            if let Some(i) = g.info {
                lines.push(Line::styled(
                    format!("  caps {}", names(CAP_FLAGS, i.cap_flags).join(" ")),
                    theme.dim(),
                ));
            }
        }
    }
}
