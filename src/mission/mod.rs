//! Missions, geofences and rally points as data, independent of any link or vehicle: the items
//! ([`MissionItem`], as MISSION_ITEM_INT carries them), what their frames mean, the checks made
//! before an upload, and the files other tools write: QGroundControl/Mission Planner/MAVProxy
//! waypoint files ([`wpl`], `QGC WPL 110`) and QGroundControl plans ([`plan`], `.plan` JSON).
//!
//! **Coordinates.** An item holds `x`/`y` as the wire does: degrees ×1e7 in an `i32` for every
//! frame except `MAV_FRAME_MISSION`, whose `x`/`y` are plain numbers (QGroundControl's
//! `PlanManager`, MAVProxy and ArduPilot all scale every other frame by 1e7; the MAVLink guide's
//! ×1e4 for local frames is not what autopilots read from a mission). A latitude in a file is
//! rounded to the nearest 1e-7°; nothing finer reaches a vehicle. `x`/`y` not given (NaN in a
//! file, `null` in a plan) travel as `i32::MAX`, COMMAND_INT's "not set".
//!
//! **Frames are never implicit**: [`AltRef`] names what an altitude is measured from (`AMSL`,
//! `REL` above home, `TERR` above terrain), and [`upload_warnings`] lists what an operator must
//! confirm before an upload: altitudes in more than one frame, AMSL altitudes below home.
//!
//! **Home.** On ArduPilot, mission item 0 is home (written by the vehicle, ignored on upload);
//! waypoint files keep it as their first line and QGroundControl plans as
//! `plannedHomePosition`. A mission here is always the list as ArduPilot holds it, home first;
//! [`without_home`] makes the list PX4 takes (as QGroundControl does for it).

pub mod plan;
pub mod wpl;

use std::fmt;

/// MAV_MISSION_TYPE: the three lists a vehicle keeps.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum MissionType {
    Mission,
    Fence,
    Rally,
}

impl MissionType {
    pub const ALL: [MissionType; 3] =
        [MissionType::Mission, MissionType::Fence, MissionType::Rally];

    /// The MAV_MISSION_TYPE value.
    pub fn code(self) -> u8 {
        match self {
            MissionType::Mission => 0,
            MissionType::Fence => 1,
            MissionType::Rally => 2,
        }
    }

    pub fn from_code(code: u8) -> Option<Self> {
        match code {
            0 => Some(MissionType::Mission),
            1 => Some(MissionType::Fence),
            2 => Some(MissionType::Rally),
            _ => None,
        }
    }

    /// `mission`, `fence`, `rally`: the words of the prompt commands.
    pub fn name(self) -> &'static str {
        match self {
            MissionType::Mission => "mission",
            MissionType::Fence => "fence",
            MissionType::Rally => "rally",
        }
    }

    /// 0, 1, 2: for arrays kept per type.
    pub fn index(self) -> usize {
        self.code() as usize
    }
}

impl fmt::Display for MissionType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// MAV_FRAME values a mission uses.
pub mod frame {
    pub const GLOBAL: u8 = 0;
    pub const LOCAL_NED: u8 = 1;
    pub const MISSION: u8 = 2;
    pub const GLOBAL_RELATIVE_ALT: u8 = 3;
    pub const LOCAL_ENU: u8 = 4;
    pub const GLOBAL_INT: u8 = 5;
    pub const GLOBAL_RELATIVE_ALT_INT: u8 = 6;
    pub const LOCAL_OFFSET_NED: u8 = 7;
    pub const BODY_NED: u8 = 8;
    pub const BODY_OFFSET_NED: u8 = 9;
    pub const GLOBAL_TERRAIN_ALT: u8 = 10;
    pub const GLOBAL_TERRAIN_ALT_INT: u8 = 11;
    pub const BODY_FRD: u8 = 12;
    pub const LOCAL_FRD: u8 = 20;
    pub const LOCAL_FLU: u8 = 21;
}

/// MAV_CMD values, from the dialect.
pub use crate::wire::cmd;

/// What an item's altitude (`z`) is measured from, by its frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum AltRef {
    /// Above mean sea level: MAV_FRAME_GLOBAL, MAV_FRAME_GLOBAL_INT.
    Amsl,
    /// Above home: MAV_FRAME_GLOBAL_RELATIVE_ALT(_INT).
    Rel,
    /// Above the terrain below: MAV_FRAME_GLOBAL_TERRAIN_ALT(_INT).
    Terr,
    /// A local or body frame: metres from an origin, not an altitude.
    Local,
    /// MAV_FRAME_MISSION: the item carries no position.
    NoPosition,
    /// A frame number this list does not know.
    Other(u8),
}

impl AltRef {
    pub fn of(frame: u8) -> AltRef {
        use frame::*;
        match frame {
            GLOBAL | GLOBAL_INT => AltRef::Amsl,
            GLOBAL_RELATIVE_ALT | GLOBAL_RELATIVE_ALT_INT => AltRef::Rel,
            GLOBAL_TERRAIN_ALT | GLOBAL_TERRAIN_ALT_INT => AltRef::Terr,
            LOCAL_NED | LOCAL_ENU | LOCAL_OFFSET_NED | BODY_NED | BODY_OFFSET_NED | BODY_FRD
            | LOCAL_FRD | LOCAL_FLU => AltRef::Local,
            MISSION => AltRef::NoPosition,
            n => AltRef::Other(n),
        }
    }

    /// `AMSL`, `REL`, `TERR`, `LOCAL`, `MISSION`, or `frame N`: what is shown beside an
    /// altitude.
    pub fn label(self) -> String {
        match self {
            AltRef::Amsl => "AMSL".into(),
            AltRef::Rel => "REL".into(),
            AltRef::Terr => "TERR".into(),
            AltRef::Local => "LOCAL".into(),
            AltRef::NoPosition => "MISSION".into(),
            AltRef::Other(n) => format!("frame {n}"),
        }
    }
}

impl fmt::Display for AltRef {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.label())
    }
}

/// Commands whose `z` is an altitude in the item's frame.
pub fn command_has_altitude(command: u16) -> bool {
    use cmd::*;
    matches!(
        command,
        NAV_WAYPOINT
            | NAV_LOITER_UNLIM
            | NAV_LOITER_TURNS
            | NAV_LOITER_TIME
            | NAV_LAND
            | NAV_TAKEOFF
            | NAV_FOLLOW
            | NAV_CONTINUE_AND_CHANGE_ALT
            | NAV_LOITER_TO_ALT
            | NAV_ROI
            | NAV_SPLINE_WAYPOINT
            | NAV_VTOL_TAKEOFF
            | NAV_VTOL_LAND
            | NAV_PAYLOAD_PLACE
            | DO_SET_HOME
            | DO_LAND_START
            | DO_REPOSITION
            | DO_SET_ROI_LOCATION
            | DO_SET_ROI
            | NAV_FENCE_RETURN_POINT
            | NAV_RALLY_POINT
    )
}

/// Commands whose `x`/`y` are a latitude and longitude.
pub fn command_has_position(command: u16) -> bool {
    use cmd::*;
    command_has_altitude(command) && command != NAV_CONTINUE_AND_CHANGE_ALT
        || matches!(
            command,
            NAV_FENCE_POLYGON_VERTEX_INCLUSION
                | NAV_FENCE_POLYGON_VERTEX_EXCLUSION
                | NAV_FENCE_CIRCLE_INCLUSION
                | NAV_FENCE_CIRCLE_EXCLUSION
        )
}

/// Landing commands: their `z` is the ground's altitude, which may lie below home.
fn is_landing(command: u16) -> bool {
    matches!(
        command,
        cmd::NAV_LAND | cmd::NAV_VTOL_LAND | cmd::NAV_LAND_LOCAL | cmd::NAV_PAYLOAD_PLACE
    )
}

/// The list a set of commands belongs in: fence items in the fence, rally points in the rally
/// list, anything else (or nothing) in the mission.
pub fn infer_type(items: &[MissionItem]) -> MissionType {
    let fence =
        |c: u16| (cmd::NAV_FENCE_RETURN_POINT..=cmd::NAV_FENCE_CIRCLE_EXCLUSION).contains(&c);
    if !items.is_empty() && items.iter().all(|i| fence(i.command)) {
        MissionType::Fence
    } else if !items.is_empty() && items.iter().all(|i| i.command == cmd::NAV_RALLY_POINT) {
        MissionType::Rally
    } else {
        MissionType::Mission
    }
}

/// `x`/`y` of `frame` as the wire carries them: degrees ×1e7 rounded, or the number itself for
/// MAV_FRAME_MISSION; NaN (not set) as `i32::MAX`. `None` when it does not fit an `i32`.
pub fn xy_to_wire(frame: u8, v: f64) -> Option<i32> {
    if v.is_nan() {
        return Some(i32::MAX);
    }
    let w = if frame == frame::MISSION {
        v.round()
    } else {
        (v * 1e7).round()
    };
    (w >= i32::MIN as f64 && w <= i32::MAX as f64).then_some(w as i32)
}

/// `x`/`y` as a file writes them: degrees, or the number for MAV_FRAME_MISSION; `i32::MAX`
/// (not set) as NaN.
pub fn xy_from_wire(frame: u8, v: i32) -> f64 {
    if v == i32::MAX {
        f64::NAN
    } else if frame == frame::MISSION {
        v as f64
    } else {
        v as f64 / 1e7
    }
}

/// One mission item, fence vertex or rally point, as MISSION_ITEM_INT carries it.
#[derive(Debug, Clone, Copy)]
pub struct MissionItem {
    pub seq: u16,
    /// MAV_FRAME (kept as a number: a frame our dialect does not know is still shown).
    pub frame: u8,
    /// MAV_CMD.
    pub command: u16,
    pub current: bool,
    pub autocontinue: bool,
    /// param1..param4.
    pub params: [f32; 4],
    /// Latitude ×1e7 (or param5 itself for MAV_FRAME_MISSION); see [`xy_to_wire`].
    pub x: i32,
    /// Longitude ×1e7 (or param6).
    pub y: i32,
    /// Altitude in the frame's reference (or param7).
    pub z: f32,
    pub mission_type: MissionType,
}

fn same_f32(a: f32, b: f32) -> bool {
    a == b || a.is_nan() && b.is_nan()
}

/// Equal field for field, a NaN parameter equal to a NaN.
impl PartialEq for MissionItem {
    fn eq(&self, o: &Self) -> bool {
        self.seq == o.seq
            && self.frame == o.frame
            && self.command == o.command
            && self.current == o.current
            && self.autocontinue == o.autocontinue
            && self
                .params
                .iter()
                .zip(&o.params)
                .all(|(a, b)| same_f32(*a, *b))
            && self.x == o.x
            && self.y == o.y
            && same_f32(self.z, o.z)
            && self.mission_type == o.mission_type
    }
}

impl MissionItem {
    /// An item with every parameter zero, `autocontinue` set.
    pub fn new(mission_type: MissionType, seq: u16, frame: u8, command: u16) -> Self {
        Self {
            seq,
            frame,
            command,
            current: false,
            autocontinue: true,
            params: [0.0; 4],
            x: 0,
            y: 0,
            z: 0.0,
            mission_type,
        }
    }

    /// A positional item at `lat`, `lon` (degrees) and `z` in `frame`.
    pub fn at(
        mission_type: MissionType,
        seq: u16,
        frame: u8,
        command: u16,
        lat: f64,
        lon: f64,
        z: f32,
    ) -> Self {
        let mut i = Self::new(mission_type, seq, frame, command);
        i.x = xy_to_wire(frame, lat).unwrap_or(i32::MAX);
        i.y = xy_to_wire(frame, lon).unwrap_or(i32::MAX);
        i.z = z;
        i
    }

    /// param5 as a file writes it (latitude in degrees for positional frames).
    pub fn param5(&self) -> f64 {
        xy_from_wire(self.frame, self.x)
    }

    /// param6 as a file writes it (longitude in degrees for positional frames).
    pub fn param6(&self) -> f64 {
        xy_from_wire(self.frame, self.y)
    }

    /// What `z` is measured from.
    pub fn alt_ref(&self) -> AltRef {
        AltRef::of(self.frame)
    }

    /// True when `z` is an altitude (its frame matters).
    pub fn has_altitude(&self) -> bool {
        command_has_altitude(self.command)
    }

    /// `15.0 m REL`, `606.0 m AMSL`: the altitude with its frame, for items that have one.
    pub fn altitude_text(&self) -> Option<String> {
        self.has_altitude()
            .then(|| format!("{:.1} m {}", self.z, self.alt_ref()))
    }

    /// `NAV_WAYPOINT`, `DO_CHANGE_SPEED`; a number the dialect does not know stays a number.
    pub fn command_name(&self) -> String {
        command_name(self.command)
    }
}

/// `MAV_CMD_NAV_TAKEOFF` → `NAV_TAKEOFF`; a number the dialect does not know stays a number.
pub fn command_name(command: u16) -> String {
    use num_traits::FromPrimitive;
    match crate::dialect::MavCmd::from_u16(command) {
        Some(c) => {
            let s = format!("{c:?}");
            s.strip_prefix("MAV_CMD_").unwrap_or(&s).to_string()
        }
        None => format!("command {command}"),
    }
}

/// `1-4, 6` for a list of sequence numbers.
fn seq_list(seqs: &[u16]) -> String {
    let mut out: Vec<String> = Vec::new();
    let mut i = 0;
    while i < seqs.len() {
        let mut j = i;
        while j + 1 < seqs.len() && seqs[j + 1] == seqs[j] + 1 {
            j += 1;
        }
        out.push(if j > i {
            format!("{}-{}", seqs[i], seqs[j])
        } else {
            seqs[i].to_string()
        });
        i = j + 1;
    }
    out.join(", ")
}

/// What an operator must confirm before `items` are uploaded: altitudes given in more than one
/// frame, AMSL altitudes below home (`home_amsl`, metres; when unknown, AMSL altitudes cannot
/// be checked and that is said). `home_at_0`: item 0 is home (ArduPilot's mission), so it is
/// not checked. Landing items are not compared with home: their altitude is the ground's.
/// Empty when there is nothing to confirm.
pub fn upload_warnings(
    items: &[MissionItem],
    home_amsl: Option<f64>,
    home_at_0: bool,
) -> Vec<String> {
    let checked = || {
        items
            .iter()
            .filter(move |i| i.has_altitude() && !(home_at_0 && i.seq == 0))
    };
    let mut by_ref: std::collections::BTreeMap<AltRef, Vec<u16>> = Default::default();
    for i in checked() {
        by_ref.entry(i.alt_ref()).or_default().push(i.seq);
    }
    let mut out = Vec::new();
    if by_ref.len() > 1 {
        let parts: Vec<String> = by_ref
            .iter()
            .map(|(r, seqs)| {
                let s = if seqs.len() == 1 { "" } else { "s" };
                format!("{r} (item{s} {})", seq_list(seqs))
            })
            .collect();
        out.push(format!("altitudes in mixed frames: {}", parts.join(", ")));
    }
    let amsl: Vec<&MissionItem> = checked()
        .filter(|i| i.alt_ref() == AltRef::Amsl && !is_landing(i.command))
        .collect();
    match home_amsl {
        Some(home) => {
            for i in amsl.iter().filter(|i| (i.z as f64) < home) {
                out.push(format!(
                    "item {}: {:.1} m AMSL is {:.1} m below home ({:.1} m AMSL)",
                    i.seq,
                    i.z,
                    home - i.z as f64,
                    home
                ));
            }
        }
        None if !amsl.is_empty() => {
            let seqs: Vec<u16> = amsl.iter().map(|i| i.seq).collect();
            let s = if seqs.len() == 1 { "" } else { "s" };
            out.push(format!(
                "item{s} {} AMSL, home altitude unknown: not checked against home",
                seq_list(&seqs)
            ));
        }
        None => {}
    }
    out
}

/// Sequence numbers 0, 1, 2… in list order.
pub fn renumber(items: &mut [MissionItem]) {
    for (i, item) in items.iter_mut().enumerate() {
        item.seq = i as u16;
    }
}

/// The mission as a vehicle without a home item takes it (PX4), from the list with home first:
/// item 0 dropped, the rest renumbered, DO_JUMP targets moved down by one (QGroundControl's
/// `PlanManager::writeMissionItems`).
pub fn without_home(items: &[MissionItem]) -> Vec<MissionItem> {
    let mut out: Vec<MissionItem> = items.iter().skip(1).copied().collect();
    renumber(&mut out);
    for i in &mut out {
        if i.command == cmd::DO_JUMP {
            i.params[0] -= 1.0;
        }
    }
    out
}

/// The reverse of [`without_home`]: a list as PX4 holds it, with `home` put first.
pub fn with_home(home: MissionItem, items: &[MissionItem]) -> Vec<MissionItem> {
    let mut out = Vec::with_capacity(items.len() + 1);
    out.push(home);
    out.extend(items.iter().copied());
    renumber(&mut out);
    for i in out.iter_mut().skip(1) {
        if i.command == cmd::DO_JUMP {
            i.params[0] += 1.0;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wp(seq: u16, frame: u8, z: f32) -> MissionItem {
        MissionItem::at(
            MissionType::Mission,
            seq,
            frame,
            cmd::NAV_WAYPOINT,
            -35.36,
            149.16,
            z,
        )
    }

    #[test]
    fn frames_are_named() {
        assert_eq!(AltRef::of(0).label(), "AMSL");
        assert_eq!(AltRef::of(5).label(), "AMSL");
        assert_eq!(AltRef::of(3).label(), "REL");
        assert_eq!(AltRef::of(6).label(), "REL");
        assert_eq!(AltRef::of(10).label(), "TERR");
        assert_eq!(AltRef::of(11).label(), "TERR");
        assert_eq!(AltRef::of(1).label(), "LOCAL");
        assert_eq!(AltRef::of(2).label(), "MISSION");
        assert_eq!(AltRef::of(42).label(), "frame 42");
        assert_eq!(wp(1, 3, 15.0).altitude_text().unwrap(), "15.0 m REL");
        let speed = MissionItem::new(MissionType::Mission, 3, 0, cmd::DO_CHANGE_SPEED);
        assert_eq!(speed.altitude_text(), None);
    }

    #[test]
    fn coordinates_scale_by_1e7_except_in_the_mission_frame() {
        assert_eq!(xy_to_wire(0, -35.3632621), Some(-353_632_621));
        assert_eq!(xy_to_wire(3, 149.1652374), Some(1_491_652_374));
        assert_eq!(xy_to_wire(2, 5.0), Some(5));
        assert_eq!(xy_to_wire(0, 300.0), None, "3e9 does not fit an i32");
        assert_eq!(xy_to_wire(0, f64::NAN), Some(i32::MAX));
        assert!(xy_from_wire(0, i32::MAX).is_nan());
        assert_eq!(xy_from_wire(0, -353_632_621), -35.3632621);
        assert_eq!(xy_from_wire(2, 7), 7.0);
    }

    #[test]
    fn a_mission_in_one_frame_above_home_needs_no_confirmation() {
        let home = wp(0, 0, 584.0);
        let items = [home, wp(1, 3, 15.0), wp(2, 3, 20.0)];
        assert!(upload_warnings(&items, Some(584.0), true).is_empty());
        // Home (AMSL) is not counted as a second frame; a DO command's frame is irrelevant.
        let mut speed = MissionItem::new(MissionType::Mission, 3, 0, cmd::DO_CHANGE_SPEED);
        speed.params = [1.0, 4.0, -1.0, 0.0];
        let items = [home, wp(1, 3, 15.0), speed];
        assert!(upload_warnings(&items, Some(584.0), true).is_empty());
    }

    #[test]
    fn mixed_frames_and_amsl_below_home_are_said() {
        let items = [
            wp(0, 0, 584.0),
            wp(1, 3, 15.0),
            wp(2, 3, 20.0),
            wp(3, 6, 25.0),
            wp(4, 0, 580.0),
            wp(5, 10, 30.0),
        ];
        let w = upload_warnings(&items, Some(584.0), true);
        assert_eq!(
            w,
            vec![
                "altitudes in mixed frames: AMSL (item 4), REL (items 1-3), TERR (item 5)"
                    .to_string(),
                "item 4: 580.0 m AMSL is 4.0 m below home (584.0 m AMSL)".to_string(),
            ]
        );
        // Home unknown: said, not guessed.
        let w = upload_warnings(&items[..5], None, true);
        assert_eq!(
            w[1],
            "item 4 AMSL, home altitude unknown: not checked against home"
        );
        // A landing's altitude is the ground's.
        let mut land = wp(1, 0, 570.0);
        land.command = cmd::NAV_LAND;
        assert!(upload_warnings(&[wp(0, 0, 584.0), land], Some(584.0), true).is_empty());
    }

    #[test]
    fn home_comes_off_for_px4_and_jumps_follow() {
        let mut jump = MissionItem::new(MissionType::Mission, 3, 2, cmd::DO_JUMP);
        jump.params = [1.0, 2.0, 0.0, 0.0];
        let items = [wp(0, 0, 584.0), wp(1, 3, 15.0), wp(2, 3, 20.0), jump];
        let px4 = without_home(&items);
        assert_eq!(px4.len(), 3);
        assert_eq!(px4.iter().map(|i| i.seq).collect::<Vec<_>>(), [0, 1, 2]);
        assert_eq!(px4[2].params[0], 0.0, "jump to old 1 is new 0");
        assert_eq!(with_home(items[0], &px4), items);
    }

    #[test]
    fn the_list_a_file_belongs_in() {
        let v = MissionItem::at(MissionType::Fence, 0, 0, 5001, 1.0, 2.0, 0.0);
        let r = MissionItem::at(MissionType::Rally, 0, 3, 5100, 1.0, 2.0, 15.0);
        assert_eq!(infer_type(&[v, v]), MissionType::Fence);
        assert_eq!(infer_type(&[r]), MissionType::Rally);
        assert_eq!(infer_type(&[wp(0, 0, 1.0), r]), MissionType::Mission);
        assert_eq!(infer_type(&[]), MissionType::Mission);
    }
}
