//! The command palette (`ctrl-p`): any MAV_CMD of the dialect, found by fuzzy search, its seven
//! parameters filled in a form labelled with their meaning and units, sent to the target (or any
//! component, `SYSID:COMPID`) after a preview of the COMMAND_LONG.
//!
//! Two stages, both typed in [`Mode::Edit`] with the `[edit]` keys: the list (type to search,
//! up/down to choose, enter or tab to pick, esc to close) and the form (tab/down next field,
//! up/backtab previous, enter to send, esc back to the list). Sending goes through
//! [`App::flight_to`]: the same checks (heard, not lost) and the same confirmation for dangerous
//! commands as the keys and the prompt.

use nucleo_matcher::pattern::{CaseMatching, Normalization, Pattern};
use nucleo_matcher::{Config, Matcher, Utf32Str};

use super::flight::FlightAction;
use super::input::{parse_param, TextLine};
use super::{App, Effect};
use crate::keymap::{Action, Key, KeyCode, Mode};
use crate::proto::mav_cmds;
use crate::proto::vehicles::VehicleKey;
use crate::wire::Severity;

/// Fields of the form: param1..param7, then the target.
pub const FIELDS: usize = 8;
/// The target's field.
pub const TARGET: usize = 7;

/// The palette's state: the search, then the form of the command picked.
#[derive(Debug, Clone, PartialEq)]
pub struct Palette {
    pub query: TextLine,
    /// Commands matching the query, best first.
    pub matches: Vec<u16>,
    /// Index into `matches`.
    pub sel: usize,
    /// The command picked and its fields; `None` while searching.
    pub form: Option<PaletteForm>,
    /// Why enter did not send, until the next key.
    pub error: Option<String>,
}

/// The fields of the command picked.
#[derive(Debug, Clone, PartialEq)]
pub struct PaletteForm {
    pub command: u16,
    /// param1..param7 (empty: the parameter's documented default, [`mav_cmds::ParamInfo`];
    /// `nan` allowed), then the target `SYSID:COMPID`.
    pub fields: [TextLine; FIELDS],
    /// The field typed into.
    pub focus: usize,
}

impl Default for Palette {
    fn default() -> Self {
        Palette {
            query: TextLine::default(),
            matches: search(""),
            sel: 0,
            form: None,
            error: None,
        }
    }
}

impl Palette {
    /// The command selected in the list.
    pub fn selected(&self) -> Option<u16> {
        self.matches.get(self.sel).copied()
    }

    /// Search again for the query as typed; the best match is selected.
    pub fn refilter(&mut self) {
        self.matches = search(&self.query.text);
        self.sel = 0;
    }

    pub fn move_sel(&mut self, step: isize) {
        let last = self.matches.len().saturating_sub(1) as isize;
        self.sel = (self.sel as isize + step).clamp(0, last) as usize;
    }

    /// Open the form of the selected command, addressed to `target`.
    pub fn pick(&mut self, target: Option<VehicleKey>) {
        if let Some(command) = self.selected() {
            self.form = Some(PaletteForm::new(command, target));
        }
    }
}

impl PaletteForm {
    /// Empty parameters; the target filled in when there is one.
    pub fn new(command: u16, target: Option<VehicleKey>) -> Self {
        let mut fields: [TextLine; FIELDS] = Default::default();
        if let Some(key) = target {
            fields[TARGET].set(&key.to_string());
        }
        PaletteForm {
            command,
            fields,
            focus: 0,
        }
    }

    /// Focus the next field (`step` 1) or the previous one (-1), round the end.
    pub fn move_focus(&mut self, step: isize) {
        self.focus = (self.focus as isize + step).rem_euclid(FIELDS as isize) as usize;
    }

    /// Parameter `i` (0-based) as typed (its documented default when empty), or why it is not
    /// a number.
    pub fn param(&self, i: usize) -> Result<f64, String> {
        let text = self.fields[i].text.trim();
        if text.is_empty() {
            return Ok(self.default(i));
        }
        parse_param(text)
            .and_then(|v| match v.is_finite() && (v as f32).is_infinite() {
                true => Err(format!("`{text}` is too large for a float32")),
                false => Ok(v),
            })
            .map_err(|e| {
                let (label, _, _) = mav_cmds::param(self.command, i);
                format!("param{} ({label}): {e}", i + 1)
            })
    }

    /// What parameter `i` (0-based) is when its field is left empty.
    pub fn default(&self, i: usize) -> f64 {
        mav_cmds::param_info(self.command, i).default
    }

    /// All seven parameters, or the first that is wrong.
    pub fn params(&self) -> Result<[f64; 7], String> {
        let mut out = [0.0; 7];
        for (i, p) in out.iter_mut().enumerate() {
            *p = self.param(i)?;
        }
        Ok(out)
    }

    /// The target as typed (`SYSID:COMPID`).
    pub fn target(&self) -> Result<VehicleKey, String> {
        parse_target(&self.fields[TARGET].text)
    }

    /// Every field of the COMMAND_LONG that enter sends, as it goes on the wire (params as f32):
    /// `COMMAND_LONG target 1:1 command 22 NAV_TAKEOFF confirmation 0` then `p1=0 … p7=10`. A
    /// field that does not parse shows `?`.
    pub fn preview(&self) -> [String; 2] {
        let target = match self.target() {
            Ok(key) => key.to_string(),
            Err(_) => "?".into(),
        };
        let head = format!(
            "COMMAND_LONG target {target} command {} {} confirmation 0",
            self.command,
            crate::proto::ack::command_name(self.command)
        );
        let params: Vec<String> = (0..7)
            .map(|i| match self.param(i) {
                Ok(v) => format!("p{}={}", i + 1, wire_value(v)),
                Err(_) => format!("p{}=?", i + 1),
            })
            .collect();
        [head, params.join(" ")]
    }
}

/// A parameter as COMMAND_LONG carries it (f32), written as typed: `nan`, `10`, `0.5`.
pub fn wire_value(v: f64) -> String {
    let f = v as f32;
    if f.is_nan() {
        "nan".into()
    } else {
        format!("{f}")
    }
}

/// `SYSID:COMPID`, each 0..=255 (compid 0: every component of the system).
pub fn parse_target(text: &str) -> Result<VehicleKey, String> {
    let usage = || format!("target `{text}`: use SYSID:COMPID, e.g. 1:1 (a camera: 1:100)");
    let (s, c) = text.trim().split_once(':').ok_or_else(usage)?;
    let s = s.trim().parse::<u8>().map_err(|_| usage())?;
    let c = c.trim().parse::<u8>().map_err(|_| usage())?;
    Ok(VehicleKey(s, c))
}

/// What a commonly used command gains in the ranking: half a matched character, as much as
/// starting a word (`arm`: COMPONENT_ARM_DISARM level with ARM_AUTHORIZATION_REQUEST, and first).
const COMMON_BONUS: u32 = 8;

/// The commands matching `query`, best first: fuzzy over the names (without `MAV_CMD_`; case and
/// a typed `MAV_CMD_` prefix do not matter), the commonly used commands ([`mav_cmds::COMMON`])
/// winning near ties, then the shorter name (`takeoff`: NAV_TAKEOFF before NAV_VTOL_TAKEOFF).
/// Digits find commands by number, the exact one first. An empty query lists every command by
/// number.
pub fn search(query: &str) -> Vec<u16> {
    let all = mav_cmds::all();
    let q = query.trim();
    let upper = q.to_ascii_uppercase();
    let q = upper.strip_prefix("MAV_CMD_").unwrap_or(&upper);
    if q.is_empty() {
        return all.iter().map(|(n, _)| *n).collect();
    }
    if q.bytes().all(|b| b.is_ascii_digit()) {
        let mut hits: Vec<u16> = all
            .iter()
            .filter(|(n, _)| n.to_string().starts_with(q))
            .map(|(n, _)| *n)
            .collect();
        hits.sort_by_key(|n| (n.to_string() != q, *n));
        return hits;
    }
    let mut matcher = Matcher::new(Config::DEFAULT);
    let pattern = Pattern::parse(q, CaseMatching::Ignore, Normalization::Smart);
    let mut buf = Vec::new();
    let mut hits: Vec<(u32, bool, usize, u16)> = all
        .iter()
        .filter_map(|(n, name)| {
            let score = pattern.score(Utf32Str::new(name, &mut buf), &mut matcher)?;
            let common = mav_cmds::is_common(*n);
            let score = score + if common { COMMON_BONUS } else { 0 };
            Some((score, !common, name.len(), *n))
        })
        .collect();
    hits.sort_by(|a, b| b.0.cmp(&a.0).then((a.1, a.2, a.3).cmp(&(b.1, b.2, b.3))));
    hits.into_iter().map(|h| h.3).collect()
}

impl App {
    /// Open the palette with every command listed.
    pub(super) fn open_palette(&mut self) {
        self.ui.palette = Some(Palette::default());
        self.ui.mode = Mode::Edit;
    }

    fn close_palette(&mut self) {
        self.ui.palette = None;
        self.ui.mode = Mode::Normal;
    }

    /// A key while the palette is open (in [`Mode::Edit`]).
    pub(super) fn on_palette_key(
        &mut self,
        key: Key,
        action: Option<Action>,
        fx: &mut Vec<Effect>,
    ) {
        self.ui.message = None;
        let target = self.target;
        let Some(p) = self.ui.palette.as_mut() else {
            return;
        };
        p.error = None;
        let typed = match (key.code, key.ctrl, key.alt, action) {
            (KeyCode::Char(c), false, false, None) => Some(c),
            _ => None,
        };
        match p.form.as_mut() {
            None => match action {
                Some(Action::Submit | Action::Complete) => p.pick(target),
                Some(Action::Cancel) => self.close_palette(),
                Some(Action::HistoryPrev) => p.move_sel(-1),
                Some(Action::HistoryNext) => p.move_sel(1),
                Some(a) => {
                    if p.query.edit(a) {
                        p.refilter();
                    }
                }
                None => match (key.code, typed) {
                    (_, Some(c)) => {
                        p.query.insert(c);
                        p.refilter();
                    }
                    (KeyCode::PageUp, _) => p.move_sel(-10),
                    (KeyCode::PageDown, _) => p.move_sel(10),
                    _ => {}
                },
            },
            Some(form) => match action {
                Some(Action::Submit) => self.send_palette(fx),
                Some(Action::Cancel) => p.form = None,
                Some(Action::HistoryPrev) => form.move_focus(-1),
                Some(Action::HistoryNext | Action::Complete) => form.move_focus(1),
                Some(a) => {
                    form.fields[form.focus].edit(a);
                }
                None => match (key.code, typed) {
                    (_, Some(c)) => form.fields[form.focus].insert(c),
                    (KeyCode::BackTab, _) => form.move_focus(-1),
                    _ => {}
                },
            },
        }
    }

    /// Enter on the form: send the command to the target typed, or say what is wrong and stay.
    fn send_palette(&mut self, fx: &mut Vec<Effect>) {
        let Some(form) = self.ui.palette.as_ref().and_then(|p| p.form.as_ref()) else {
            return;
        };
        let command = form.command;
        let outcome = form
            .params()
            .and_then(|params| Ok((form.target()?, params)))
            .and_then(|(target, params)| {
                self.flight_to(target, FlightAction::Command { command, params }, fx)
            });
        match outcome {
            Ok(text) => {
                self.close_palette();
                self.ui.message = text.map(|t| (Severity::INFO, t));
            }
            Err(e) => {
                if let Some(p) = self.ui.palette.as_mut() {
                    p.error = Some(e);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dialect::MavCmd;

    fn name(n: u16) -> String {
        crate::proto::ack::command_name(n)
    }

    fn names(query: &str, k: usize) -> Vec<String> {
        search(query).into_iter().take(k).map(name).collect()
    }

    #[test]
    fn takeoff_finds_nav_takeoff_first() {
        assert_eq!(names("takeoff", 1), ["NAV_TAKEOFF"]);
        assert_eq!(names("TAKEOFF", 1), ["NAV_TAKEOFF"]);
        assert_eq!(names("mav_cmd_nav_takeoff", 1), ["NAV_TAKEOFF"]);
        assert_eq!(names("nav takeoff", 1), ["NAV_TAKEOFF"]);
    }

    #[test]
    fn arm_finds_component_arm_disarm_among_the_first() {
        let top = names("arm", 3);
        assert!(top.contains(&"COMPONENT_ARM_DISARM".to_string()), "{top:?}");
        // The commonly used one first, though another starts with `ARM`.
        assert_eq!(top[0], "COMPONENT_ARM_DISARM", "{top:?}");
        assert!(
            top.contains(&"ARM_AUTHORIZATION_REQUEST".to_string()),
            "{top:?}"
        );
        assert_eq!(names("armdis", 1), ["COMPONENT_ARM_DISARM"]);
    }

    #[test]
    fn common_commands_are_found_by_a_word_and_numbers_by_number() {
        for (q, want) in [
            ("land", "NAV_LAND"),
            ("rtl", "NAV_RETURN_TO_LAUNCH"),
            ("return", "NAV_RETURN_TO_LAUNCH"),
            ("set_mode", "DO_SET_MODE"),
            ("msg interval", "SET_MESSAGE_INTERVAL"),
            ("request_message", "REQUEST_MESSAGE"),
            ("reboot", "PREFLIGHT_REBOOT_SHUTDOWN"),
            ("calib", "PREFLIGHT_CALIBRATION"),
            ("change speed", "DO_CHANGE_SPEED"),
            ("sethome", "DO_SET_HOME"),
            ("motor test", "DO_MOTOR_TEST"),
            ("reposition", "DO_REPOSITION"),
            ("image start", "IMAGE_START_CAPTURE"),
            ("video start", "VIDEO_START_CAPTURE"),
        ] {
            let top = names(q, 3);
            assert!(top.contains(&want.to_string()), "{q}: {top:?}");
        }
        assert_eq!(search("22")[0], 22);
        assert!(search("22").iter().all(|n| n.to_string().starts_with("22")));
        assert_eq!(search("400")[0], 400);
        assert!(search("zzzzqqq").is_empty());
        assert_eq!(search("").len(), mav_cmds::all().len());
    }

    #[test]
    fn the_form_labels_every_commands_params_from_the_xml() {
        let label = |c: MavCmd, i: usize| mav_cmds::param(c as u16, i);
        // common.xml: <param index="7" label="Altitude" units="m">Altitude</param>, and our
        // note for ArduPilot.
        assert_eq!(
            label(MavCmd::MAV_CMD_NAV_TAKEOFF, 6),
            (
                "Altitude".into(),
                "m",
                "ArduPilot: above home. Altitude".into()
            )
        );
        assert_eq!(label(MavCmd::MAV_CMD_NAV_TAKEOFF, 3).1, "deg");
        assert_eq!(label(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, 0).0, "Arm");
        assert_eq!(label(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, 1).0, "Force");
        assert_eq!(label(MavCmd::MAV_CMD_COMPONENT_ARM_DISARM, 2).0, "(unused)");
        assert_eq!(label(MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL, 1).1, "us");
        let speed = label(MavCmd::MAV_CMD_DO_CHANGE_SPEED, 1);
        assert_eq!((speed.0.as_str(), speed.1), ("Speed", "m/s"));
        assert!(speed.2.contains("-1 indicates no change"), "{}", speed.2);
        assert_eq!(label(MavCmd::MAV_CMD_DO_CHANGE_SPEED, 2).1, "%");
        assert_eq!(label(MavCmd::MAV_CMD_VIDEO_START_CAPTURE, 1).1, "Hz");
        assert_eq!(label(MavCmd::MAV_CMD_IMAGE_START_CAPTURE, 1).1, "s");
        assert_eq!(label(MavCmd::MAV_CMD_DO_MOTOR_TEST, 3).1, "s");
        let land = label(MavCmd::MAV_CMD_NAV_LAND, 0);
        assert_eq!((land.0.as_str(), land.1), ("Abort Alt", "m"));
        assert_eq!(label(MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH, 0).0, "(unused)");
        // A command the hand-written table never described: labelled from the XML too.
        let servo = MavCmd::MAV_CMD_DO_SET_SERVO as u16;
        assert_eq!(mav_cmds::param(servo, 0).0, "Instance");
        assert_eq!(mav_cmds::param(servo, 1).0, "PWM");
        assert_eq!(mav_cmds::param(servo, 1).1, "us");
        assert_eq!(mav_cmds::param(servo, 6).0, "(unused)");
        assert_eq!(
            mav_cmds::description(servo),
            "Set a servo to a desired PWM value."
        );
    }

    #[test]
    fn empty_fields_are_the_default_nan_is_allowed_and_bad_ones_are_named() {
        // DO_CHANGE_SPEED: "-1 indicates no change" for speed and throttle; reserved 0.
        let f = PaletteForm::new(
            MavCmd::MAV_CMD_DO_CHANGE_SPEED as u16,
            Some(VehicleKey(1, 1)),
        );
        assert_eq!(f.params().unwrap(), [0.0, -1.0, -1.0, 0.0, 0.0, 0.0, 0.0]);
        // IMAGE_START_CAPTURE: param7 reserved, default="NaN".
        let f = PaletteForm::new(
            MavCmd::MAV_CMD_IMAGE_START_CAPTURE as u16,
            Some(VehicleKey(1, 1)),
        );
        assert!(f.params().unwrap()[6].is_nan());
        let mut f = PaletteForm::new(22, Some(VehicleKey(1, 1)));
        f.fields[3].set("NaN");
        f.fields[6].set(" 10 ");
        let p = f.params().unwrap();
        assert_eq!(p[0], 0.0);
        assert!(p[3].is_nan());
        assert_eq!(p[6], 10.0);
        f.fields[6].set("1e39");
        assert!(f.params().unwrap_err().contains("too large for a float32"));
        f.fields[6].set("ten");
        let e = f.params().unwrap_err();
        assert!(
            e.starts_with("param7 (Altitude): `ten` is not a number"),
            "{e}"
        );
        assert_eq!(f.target(), Ok(VehicleKey(1, 1)));
        f.fields[TARGET].set("1:100");
        assert_eq!(f.target(), Ok(VehicleKey(1, 100)));
        for bad in ["", "1", "1:", "256:1", "a:b"] {
            f.fields[TARGET].set(bad);
            assert!(f.target().unwrap_err().contains("SYSID:COMPID"), "{bad}");
        }
        assert!(PaletteForm::new(22, None).fields[TARGET].text.is_empty());
    }

    #[test]
    fn the_preview_shows_every_field_of_the_command_long() {
        let mut f = PaletteForm::new(22, Some(VehicleKey(1, 1)));
        f.fields[3].set("nan");
        f.fields[6].set("10");
        assert_eq!(
            f.preview(),
            [
                "COMMAND_LONG target 1:1 command 22 NAV_TAKEOFF confirmation 0".to_string(),
                "p1=0 p2=0 p3=0 p4=nan p5=0 p6=0 p7=10".to_string(),
            ]
        );
        f.fields[0].set("x");
        f.fields[TARGET].set("1:100");
        f.fields[6].set("0.1");
        let [head, params] = f.preview();
        assert!(head.contains("target 1:100 "), "{head}");
        // As sent: a float32.
        assert_eq!(params, "p1=? p2=0 p3=0 p4=nan p5=0 p6=0 p7=0.1");
        f.fields[TARGET].set("one");
        assert!(f.preview()[0].contains("target ? "));
    }

    #[test]
    fn the_list_and_the_form_move_within_bounds() {
        let mut p = Palette::default();
        p.move_sel(-5);
        assert_eq!(p.sel, 0);
        p.move_sel(1 << 20);
        assert_eq!(p.sel, p.matches.len() - 1);
        p.query.set("takeoff");
        p.refilter();
        assert_eq!((p.sel, p.selected()), (0, Some(22)));
        p.pick(Some(VehicleKey(2, 1)));
        let f = p.form.as_mut().unwrap();
        assert_eq!((f.command, f.fields[TARGET].text.as_str()), (22, "2:1"));
        f.move_focus(-1);
        assert_eq!(f.focus, TARGET);
        f.move_focus(1);
        assert_eq!(f.focus, 0);
    }
}
