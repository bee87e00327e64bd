//! Waypoint files, `QGC WPL 110`: what Mission Planner, MAVProxy and ArduPilot's tools write
//! and QGroundControl reads (`.waypoints`, `.txt`, `.mission`).
//!
//! ```text
//! QGC WPL 110
//! 0\t1\t0\t16\t0.00000000\t0.00000000\t0.00000000\t0.00000000\t-35.36326100\t149.16523000\t584.000000\t1
//! 1\t0\t3\t22\t0.00000000\t0.00000000\t0.00000000\t0.00000000\t0.00000000\t0.00000000\t15.000000\t1
//! ```
//!
//! After the header, one item per line: `seq current frame command p1 p2 p3 p4 x y z
//! autocontinue`, tab separated, `x`/`y` in degrees for positional frames. The first line is home
//! (ArduPilot's item 0). MAVProxy (pymavlink `mavwp.py`) reads fields split on any white space,
//! skips blank lines and keeps a `#` comment line for the item after it; so do we. Mission
//! Planner writes eight decimals for p1–p4, x and y and six for z (MAVProxy six everywhere); we
//! write Mission Planner's layout, and more digits where that would not give back the same
//! `f32` (x and y are whole 1e-7° on the wire, so eight decimals always hold them exactly).
//!
//! Reading never fails as a whole: each bad line is reported with its 1-based number and the
//! rest are kept, so the operator sees every problem at once; a file with errors must not be
//! uploaded. Bad: a missing or other header, a line without twelve fields, a field that is not
//! a number (or not a whole number where one is needed), a frame, command or flag out of
//! range, a coordinate that does not fit MISSION_ITEM_INT, sequence numbers that are not 0, 1,
//! 2… in file order (renumbering would move DO_JUMP targets).

use std::collections::BTreeMap;
use std::fmt;

use super::{xy_to_wire, MissionItem, MissionType};

pub const HEADER: &str = "QGC WPL 110";

/// A line that could not be read.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LineError {
    /// 1-based line number.
    pub line: usize,
    pub why: String,
}

impl fmt::Display for LineError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "line {}: {}", self.line, self.why)
    }
}

/// A waypoint file as read.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct WplFile {
    /// In file order; `seq` as written (checked to be 0, 1, 2…).
    pub items: Vec<MissionItem>,
    /// `#` comments, by the `seq` of the item they stand before (MAVProxy keeps them so).
    pub comments: BTreeMap<u16, String>,
    pub errors: Vec<LineError>,
}

impl WplFile {
    pub fn ok(&self) -> bool {
        self.errors.is_empty()
    }
}

/// Read a waypoint file whose items belong in the `mission_type` list.
pub fn parse(text: &str, mission_type: MissionType) -> WplFile {
    let mut out = WplFile::default();
    let mut lines = text.lines().enumerate().map(|(i, l)| (i + 1, l));
    match lines.next() {
        Some((_, l)) if l.trim() == HEADER => {}
        Some((n, l)) => {
            let why = if l.trim_start().starts_with("QGC WPL") {
                format!("{:?} is not a version this reads (only {HEADER})", l.trim())
            } else {
                format!("not a waypoint file: the first line must be {HEADER:?}")
            };
            out.errors.push(LineError { line: n, why });
            return out;
        }
        None => {
            out.errors.push(LineError {
                line: 1,
                why: format!("empty file: no {HEADER:?} header"),
            });
            return out;
        }
    }
    let mut comment: Option<String> = None;
    for (n, raw) in lines {
        let line = raw.trim();
        if line.is_empty() {
            continue;
        }
        if let Some(c) = line.strip_prefix('#') {
            comment = Some(c.trim_start().to_string());
            continue;
        }
        match parse_item(line, mission_type) {
            Ok(item) => {
                let want = out.items.len();
                if item.seq as usize != want {
                    out.errors.push(LineError {
                        line: n,
                        why: format!("sequence number {} where {want} was expected", item.seq),
                    });
                }
                if let Some(c) = comment.take() {
                    out.comments.insert(item.seq, c);
                }
                out.items.push(item);
            }
            Err(why) => {
                comment = None;
                out.errors.push(LineError { line: n, why })
            }
        }
    }
    out
}

fn parse_item(line: &str, mission_type: MissionType) -> Result<MissionItem, String> {
    let f: Vec<&str> = line.split_whitespace().collect();
    if f.len() != 12 {
        return Err(format!("{} fields where 12 were expected", f.len()));
    }
    let whole = |i: usize, name: &str, max: u64| -> Result<u64, String> {
        let v: u64 = f[i]
            .parse()
            .map_err(|_| format!("{name} {:?} is not a whole number", f[i]))?;
        if v > max {
            return Err(format!("{name} {v} is out of range (0-{max})"));
        }
        Ok(v)
    };
    let real = |i: usize, name: &str| -> Result<f64, String> {
        f[i].parse::<f64>()
            .map_err(|_| format!("{name} {:?} is not a number", f[i]))
    };
    let seq = whole(0, "seq", u16::MAX as u64)? as u16;
    let current = whole(1, "current", 255)? != 0;
    let frame = whole(2, "frame", 255)? as u8;
    let command = whole(3, "command", u16::MAX as u64)? as u16;
    let mut params = [0f32; 4];
    for (k, p) in params.iter_mut().enumerate() {
        let v = real(4 + k, &format!("param{}", k + 1))?;
        if v.is_finite() && v.abs() > f32::MAX as f64 {
            return Err(format!("param{} {v} does not fit a float", k + 1));
        }
        *p = v as f32;
    }
    let xy = |i: usize, name: &str| -> Result<i32, String> {
        let v = real(i, name)?;
        xy_to_wire(frame, v).ok_or_else(|| {
            format!("{name} {v} does not fit MISSION_ITEM_INT (degrees ×1e7 in 32 bits)")
        })
    };
    let x = xy(8, "x")?;
    let y = xy(9, "y")?;
    let z = real(10, "z")?;
    if z.is_finite() && z.abs() > f32::MAX as f64 {
        return Err(format!("z {z} does not fit a float"));
    }
    let autocontinue = whole(11, "autocontinue", 255)? != 0;
    Ok(MissionItem {
        seq,
        frame,
        command,
        current,
        autocontinue,
        params,
        x,
        y,
        z: z as f32,
        mission_type,
    })
}

/// `v` with `decimals` decimals when that reads back as the same `f32`, else the shortest text
/// that does. NaN as `nan` (what pymavlink writes and Python, Qt and Rust read).
fn float(v: f32, decimals: usize) -> String {
    if v.is_nan() {
        return "nan".into();
    }
    let s = format!("{:.*}", decimals, v as f64);
    if s.parse::<f64>().map(|p| p as f32) == Ok(v) {
        s
    } else {
        format!("{v}")
    }
}

/// A coordinate with eight decimals (exact for whole 1e-7°), NaN as `nan`.
fn coordinate(v: f64) -> String {
    if v.is_nan() {
        "nan".into()
    } else {
        format!("{v:.8}")
    }
}

/// One item as a line (no line end).
pub fn item_line(i: &MissionItem) -> String {
    format!(
        "{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}",
        i.seq,
        i.current as u8,
        i.frame,
        i.command,
        float(i.params[0], 8),
        float(i.params[1], 8),
        float(i.params[2], 8),
        float(i.params[3], 8),
        coordinate(i.param5()),
        coordinate(i.param6()),
        float(i.z, 6),
        i.autocontinue as u8,
    )
}

/// The file for `items` (home first for a mission), with `comments` before the items they
/// belong to.
pub fn write(items: &[MissionItem], comments: &BTreeMap<u16, String>) -> String {
    let mut s = String::with_capacity(64 + items.len() * 100);
    s.push_str(HEADER);
    s.push('\n');
    for i in items {
        if let Some(c) = comments.get(&i.seq) {
            s.push_str("# ");
            s.push_str(c);
            s.push('\n');
        }
        s.push_str(&item_line(i));
        s.push('\n');
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mission::cmd;

    const MP: &str = "QGC WPL 110\r\n\
0\t1\t0\t16\t0.00000000\t0.00000000\t0.00000000\t0.00000000\t-35.36326100\t149.16523000\t584.000000\t1\r\n\
1\t0\t3\t22\t0.00000000\t0.00000000\t0.00000000\t0.00000000\t0.00000000\t0.00000000\t15.000000\t1\r\n\
2\t0\t3\t16\t0.00000000\t0.00000000\t0.00000000\t0.00000000\t-35.36272200\t149.16523000\t20.000000\t1\r\n";

    #[test]
    fn mission_planner_file_reads_and_writes_back_the_same() {
        let f = parse(MP, MissionType::Mission);
        assert!(f.ok(), "{:?}", f.errors);
        assert_eq!(f.items.len(), 3);
        let home = &f.items[0];
        assert!(home.current);
        assert_eq!((home.frame, home.command), (0, cmd::NAV_WAYPOINT));
        assert_eq!(
            (home.x, home.y, home.z),
            (-353_632_610, 1_491_652_300, 584.0)
        );
        assert_eq!(f.items[1].z, 15.0);
        assert_eq!(write(&f.items, &f.comments), MP.replace("\r\n", "\n"));
    }

    #[test]
    fn mavproxy_layout_and_comments() {
        // pymavlink writes %f everywhere and keeps `#` comments; fields may be spaces.
        let text = "QGC WPL 110\n# home\n0 0 0 16 0.000000 0.000000 0.000000 0.000000 -35.363261 149.165230 584.090000 1\n\n1\t0\t3\t178\t1.000000\t4.000000\t-1.000000\tnan\t0.000000\t0.000000\t0.000000\t1\n";
        let f = parse(text, MissionType::Mission);
        assert!(f.ok(), "{:?}", f.errors);
        assert_eq!(f.comments.get(&0).map(String::as_str), Some("home"));
        assert!(f.items[1].params[3].is_nan());
        assert_eq!(f.items[0].z, 584.09);
        let again = parse(&write(&f.items, &f.comments), MissionType::Mission);
        assert_eq!(again, f);
    }

    #[test]
    fn bad_lines_are_reported_by_number_and_the_rest_kept() {
        let text = "QGC WPL 110\n\
0\t1\t0\t16\t0\t0\t0\t0\t-35.3\t149.1\t584\t1\n\
1\t0\t3\t16\t0\t0\t0\t0\t-35.3\t149.1\n\
2\t0\t3\tWP\t0\t0\t0\t0\t-35.3\t149.1\t20\t1\n\
3\t0\t3\t16\t0\t0\t0\t0\t300\t149.1\t20\t1\n\
4\t0\t3\t16\t0\t0\t0\t0\t-35.3\t149.1\t20\t1\n";
        let f = parse(text, MissionType::Mission);
        let lines: Vec<usize> = f.errors.iter().map(|e| e.line).collect();
        // Line 3: short; 4: command not a number; 5: latitude out of range; 6: seq 4 where 1
        // was expected (lines 3-5 lost).
        assert_eq!(lines, [3, 4, 5, 6], "{:?}", f.errors);
        assert_eq!(
            f.errors[0].to_string(),
            "line 3: 10 fields where 12 were expected"
        );
        assert!(f.errors[1].why.contains("command \"WP\""));
        assert!(f.errors[2].why.contains("does not fit"));
        assert!(f.errors[3].why.contains("sequence number 4 where 1"));
        assert_eq!(f.items.len(), 2);
    }

    #[test]
    fn header_checked() {
        let f = parse(
            "QGC WPL 100\n0\t1\t0\t16\t0\t0\t0\t0\t0\t0\t0\t1\n",
            MissionType::Mission,
        );
        assert_eq!(f.errors.len(), 1);
        assert_eq!(f.errors[0].line, 1);
        assert!(f.items.is_empty());
        assert!(!parse("", MissionType::Mission).ok());
        assert!(!parse("lat,lon\n1,2\n", MissionType::Mission).ok());
    }

    #[test]
    fn floats_keep_what_eight_decimals_would_lose() {
        let mut i = MissionItem::new(MissionType::Mission, 0, 2, 31_000);
        i.params = [1e-9, 0.1, 12345.678, -0.0];
        i.z = 1.234_567_9;
        let line = item_line(&i);
        assert!(
            line.contains("\t0.000000001\t0.10000000\t12345.67773438\t"),
            "{line}"
        );
        let back = parse(&format!("{HEADER}\n{line}\n"), MissionType::Mission);
        assert_eq!(back.items, vec![i]);
    }
}
