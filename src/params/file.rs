//! Parameter files: MAVProxy's / Mission Planner's `.parm` and QGroundControl's `.params`.
//!
//! **`.parm`** (MAVProxy, pymavlink `mavparm.py`): one `NAME VALUE` per line. MAVProxy's loader
//! strips each line, skips blank lines and lines starting with `#`, turns commas into spaces
//! (Mission Planner writes `NAME,VALUE`), splits on whitespace and wants exactly two fields; a
//! value starting `0x` is hexadecimal. MAVProxy's saver writes the names sorted, as
//! `"%-16.16s %f\n"` (six decimals). We write the same layout (name padded to 16, a space, the
//! value) but the value as [`value::format`] writes it, so nothing is lost to `%f`'s six
//! decimals (`1e-7` stays `0.0000001`, not `0.000000`). Older MAVProxy stripped a `#` comment
//! anywhere on the line; so do we.
//!
//! **`.params`** (QGroundControl, `ParameterManager::writeParametersToStream`):
//!
//! ```text
//! # Onboard parameters for Vehicle 1
//! #
//! # Stack: ArduPilot
//! # Vehicle: Multi-Rotor
//! # Version: 4.6.0 dev
//! # Git Revision: 1a2b3c4d
//! #
//! # Vehicle-Id Component-Id Name Value Type
//! 1\t1\tACRO_BAL_PITCH\t1.000000000000000000\t9
//! 1\t1\tANGLE_MAX\t3000\t4
//! ```
//!
//! (`\t` is a tab.) Data lines are tab-separated `vehicle-id component-id name value type`,
//! `type` the MAV_PARAM_TYPE code, in component order then name order (QMap keys). The value is
//! `Fact::rawValueStringFullPrecision()`: reals as `QString::arg(v, 0, 'f', 18)` (the `float`
//! widened to `double`, 18 decimals: 0.3 is `0.300000011920928955`), integers as
//! `QVariant::toString()` (`3000`). (Values too small for 18 decimals are the one departure:
//! see [`qgc_value`].) QGC's reader skips lines starting with `#` and wants exactly
//! five tab-separated fields.
//!
//! **Which format** a text is in is decided by its content, never its name: if any data line is
//! five tab-separated fields whose first two are integers, it is QGC's; otherwise `.parm`. (A file
//! with no data lines but QGC's header is QGC's.) [`format_for_path`] picks the format to *write*.
//!
//! Parsing never fails as a whole: a bad line goes to [`ParamFile::errors`] with its 1-based line
//! number and the good lines are kept. Bad lines: too few (or too many) fields, a value that is
//! not a finite number (or, with a type, not one that type can hold), a name longer than 16
//! characters or with characters outside `[A-Za-z0-9_]`, an unknown type code, a vehicle or
//! component id that is not 0–255, a name seen before (the later line is the one reported).
//! Names are case-sensitive, as ArduPilot's are.

use std::collections::HashMap;
use std::fmt;
use std::path::Path;

use super::value::{self, ParamType};

/// Longest parameter name MAVLink carries (`param_id` is 16 chars).
pub const MAX_NAME: usize = 16;

/// A parameter file format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// MAVProxy / Mission Planner `NAME VALUE` (or `NAME,VALUE`).
    Parm,
    /// QGroundControl's tab-separated `.params`.
    Qgc,
}

impl Format {
    pub fn name(self) -> &'static str {
        match self {
            Format::Parm => "MAVProxy .parm",
            Format::Qgc => "QGroundControl .params",
        }
    }
}

/// One parameter read from a file.
#[derive(Debug, Clone, PartialEq)]
pub struct FileParam {
    pub name: String,
    pub value: f64,
    /// The MAV_PARAM_TYPE (`.params` only).
    pub ptype: Option<ParamType>,
    /// Vehicle (system) id (`.params` only).
    pub system: Option<u8>,
    /// Component id (`.params` only).
    pub component: Option<u8>,
    /// 1-based line number.
    pub line: usize,
}

/// A line that could not be read.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LineError {
    /// 1-based line number.
    pub line: usize,
    /// The line as it was.
    pub text: String,
    pub why: String,
}

impl fmt::Display for LineError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "line {}: {}", self.line, self.why)
    }
}

/// A parsed parameter file: what could be read and what could not.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamFile {
    pub format: Format,
    /// In file order.
    pub params: Vec<FileParam>,
    /// In file order.
    pub errors: Vec<LineError>,
}

impl ParamFile {
    /// The parameter of that name (the first component that has it).
    pub fn get(&self, name: &str) -> Option<&FileParam> {
        self.params.iter().find(|p| p.name == name)
    }
}

/// A parameter to save, as the vehicle has it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Saved<'a> {
    pub name: &'a str,
    pub value: f64,
    pub ptype: ParamType,
    pub component: u8,
}

/// What [`write`] puts at the top of a `.params` file (QGC's header). Empty fields are left out.
/// `.parm` files get no header: MAVProxy writes none.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Header {
    /// The vehicle's system id: the header line and the first column of every data line.
    pub sysid: u8,
    /// `ArduPilot`, `PX4`, ...
    pub stack: String,
    /// `Multi-Rotor`, `Fixed Wing`, ...
    pub vehicle: String,
    /// `4.6.0 dev` (QGC: major.minor.patch and the version type).
    pub version: String,
    pub git_revision: String,
}

/// The format to write to `path`: `.params` is QGroundControl's, anything else `.parm`.
pub fn format_for_path(path: &Path) -> Format {
    match path.extension().and_then(|e| e.to_str()) {
        Some(ext) if ext.eq_ignore_ascii_case("params") => Format::Qgc,
        _ => Format::Parm,
    }
}

/// The format `text` is written in (see the module docs).
pub fn detect(text: &str) -> Format {
    let mut qgc_header = false;
    for line in text.lines() {
        let t = line.trim();
        if t.is_empty() {
            continue;
        }
        if t.starts_with('#') {
            qgc_header |= t.starts_with("# Onboard parameters for")
                || t.starts_with("# Vehicle-Id Component-Id");
            continue;
        }
        if looks_qgc(line) {
            return Format::Qgc;
        }
    }
    if qgc_header {
        Format::Qgc
    } else {
        Format::Parm
    }
}

fn looks_qgc(line: &str) -> bool {
    let f: Vec<&str> = line.split('\t').collect();
    f.len() == 5 && f[0].trim().parse::<u32>().is_ok() && f[1].trim().parse::<u32>().is_ok()
}

/// Reads a parameter file in either format. Never fails as a whole; see the module docs.
pub fn parse(text: &str) -> ParamFile {
    let format = detect(text);
    let mut out = ParamFile {
        format,
        params: Vec::new(),
        errors: Vec::new(),
    };
    // (component, name) -> line of first appearance.
    let mut seen: HashMap<(Option<u8>, String), usize> = HashMap::new();
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let parsed = match format {
            Format::Parm => parse_parm_line(raw),
            Format::Qgc => parse_qgc_line(raw),
        };
        let err = |why: String| LineError {
            line,
            text: raw.to_string(),
            why,
        };
        match parsed {
            Ok(None) => {}
            Ok(Some(mut p)) => {
                p.line = line;
                match seen.get(&(p.component, p.name.clone())) {
                    Some(first) => out.errors.push(err(format!(
                        "{} appears again (first on line {first}); this line is ignored",
                        p.name
                    ))),
                    None => {
                        seen.insert((p.component, p.name.clone()), line);
                        out.params.push(p);
                    }
                }
            }
            Err(why) => out.errors.push(err(why)),
        }
    }
    out
}

fn parse_parm_line(raw: &str) -> Result<Option<FileParam>, String> {
    // Comments may start anywhere (older MAVProxy: `line.split('#')[0]`).
    let body = raw.split('#').next().unwrap_or("").trim();
    if body.is_empty() {
        return Ok(None);
    }
    let body = body.replace(',', " ");
    let fields: Vec<&str> = body.split_whitespace().collect();
    match fields.len() {
        0 => return Ok(None),
        1 => return Err("expected NAME VALUE, found only one field".into()),
        2 => {}
        n => return Err(format!("expected NAME VALUE, found {n} fields")),
    }
    check_name(fields[0])?;
    let value = parse_number(fields[1])?;
    Ok(Some(FileParam {
        name: fields[0].to_string(),
        value,
        ptype: None,
        system: None,
        component: None,
        line: 0,
    }))
}

fn parse_qgc_line(raw: &str) -> Result<Option<FileParam>, String> {
    let t = raw.trim();
    if t.is_empty() || t.starts_with('#') {
        return Ok(None);
    }
    let fields: Vec<&str> = raw.split('\t').map(str::trim).collect();
    if fields.len() < 5 {
        return Err(format!(
            "expected 5 tab-separated fields (vehicle, component, name, value, type), found {}",
            fields.len()
        ));
    }
    if fields.len() > 5 {
        return Err(format!(
            "expected 5 tab-separated fields (vehicle, component, name, value, type), found {}",
            fields.len()
        ));
    }
    let id = |s: &str, what: &str| {
        s.parse::<u8>()
            .map_err(|_| format!("{what} id {s:?} is not a number from 0 to 255"))
    };
    let system = id(fields[0], "vehicle")?;
    let component = id(fields[1], "component")?;
    let name = fields[2];
    check_name(name)?;
    let value = parse_number(fields[3])?;
    let ptype = fields[4]
        .parse::<u8>()
        .ok()
        .and_then(ParamType::from_code)
        .ok_or_else(|| {
            format!(
                "unknown parameter type {:?} (MAV_PARAM_TYPE 1 to 10)",
                fields[4]
            )
        })?;
    ptype.check(value)?;
    Ok(Some(FileParam {
        name: name.to_string(),
        value,
        ptype: Some(ptype),
        system: Some(system),
        component: Some(component),
        line: 0,
    }))
}

/// Why `name` cannot be a parameter name, if it cannot.
pub fn check_name(name: &str) -> Result<(), String> {
    if name.is_empty() {
        return Err("empty parameter name".into());
    }
    if let Some(c) = name
        .chars()
        .find(|c| !(c.is_ascii_alphanumeric() || *c == '_'))
    {
        return Err(format!(
            "{name:?}: {c:?} cannot be in a parameter name (A-Z, a-z, 0-9, _)"
        ));
    }
    if name.len() > MAX_NAME {
        return Err(format!(
            "{name}: {} characters, a parameter name has at most {MAX_NAME}",
            name.len()
        ));
    }
    Ok(())
}

/// A finite number: decimal (`1`, `-0.5`, `1e-3`) or, as MAVProxy reads it, `0x` hexadecimal.
fn parse_number(s: &str) -> Result<f64, String> {
    let hex = s.strip_prefix("0x").or_else(|| s.strip_prefix("0X"));
    let v = match hex {
        Some(h) => u64::from_str_radix(h, 16).ok().map(|v| v as f64),
        None => s.parse::<f64>().ok(),
    };
    match v {
        Some(v) if v.is_finite() => Ok(v),
        _ => Err(format!("value {s:?} is not a number")),
    }
}

/// The text of a parameter file holding `params`, in `format` (see the module docs for the
/// layouts). `.parm` ignores components: give it one component's parameters.
pub fn write(format: Format, params: &[Saved], header: &Header) -> String {
    // Names are checked as they come from the vehicle; one that is not a name would be file
    // syntax (a newline, a comment), so it never gets here.
    let mut sorted: Vec<&Saved> = params
        .iter()
        .filter(|p| crate::wire::param_pck::name_ok(p.name.as_bytes()))
        .collect();
    let mut out = String::with_capacity(params.len() * 40 + 256);
    match format {
        Format::Parm => {
            sorted.sort_by(|a, b| a.name.cmp(b.name).then(a.component.cmp(&b.component)));
            for p in sorted {
                out.push_str(&format!(
                    "{:<16} {}\n",
                    p.name,
                    value::format(p.value, p.ptype)
                ));
            }
        }
        Format::Qgc => {
            sorted.sort_by(|a, b| a.component.cmp(&b.component).then(a.name.cmp(b.name)));
            out.push_str(&format!(
                "# Onboard parameters for Vehicle {}\n#\n",
                header.sysid
            ));
            for (label, v) in [
                ("Stack", &header.stack),
                ("Vehicle", &header.vehicle),
                ("Version", &header.version),
                ("Git Revision", &header.git_revision),
            ] {
                if !v.is_empty() {
                    out.push_str(&format!("# {label}: {v}\n"));
                }
            }
            out.push_str("#\n# Vehicle-Id Component-Id Name Value Type\n");
            for p in sorted {
                out.push_str(&format!(
                    "{}\t{}\t{}\t{}\t{}\n",
                    header.sysid,
                    p.component,
                    p.name,
                    qgc_value(p.value, p.ptype),
                    p.ptype.code()
                ));
            }
        }
    }
    out
}

/// A value as QGroundControl writes it in `.params`: reals with 18 decimals of the value the
/// type holds (a REAL32 widened from `f32`), integers plain.
///
/// 18 decimals cannot hold values below about 1e-10 (`1e-20` would be `0.000000000000000000`);
/// those, and only those, are written in exponent form (`1e-20`), which QGC reads back too.
pub fn qgc_value(v: f64, t: ParamType) -> String {
    match t {
        ParamType::Real32 => {
            let f = v as f32;
            let fixed = format!("{:.18}", f as f64);
            if fixed.parse::<f32>() == Ok(f) {
                fixed
            } else {
                format!("{f:e}")
            }
        }
        ParamType::Real64 => {
            let fixed = format!("{v:.18}");
            if fixed.parse::<f64>() == Ok(v) {
                fixed
            } else {
                format!("{v:e}")
            }
        }
        _ => value::fmt_plain(v),
    }
}

/// A parameter whose value differs between the vehicle and a file.
#[derive(Debug, Clone, PartialEq)]
pub struct Changed {
    pub name: String,
    pub component: u8,
    pub ptype: ParamType,
    pub vehicle: f64,
    pub file: f64,
}

/// How a file differs from the vehicle's parameters.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Diff {
    /// Sorted by name.
    pub changed: Vec<Changed>,
    /// On the vehicle, not in the file; sorted.
    pub only_vehicle: Vec<String>,
    /// In the file, not on the vehicle; sorted.
    pub only_file: Vec<String>,
    /// How many are in both with the same value.
    pub same: usize,
}

/// Compares the vehicle's parameters with a file's. A file parameter with a component (`.params`)
/// matches the vehicle parameter of that name and component; one without (`.parm`) matches the
/// vehicle parameter of that name. Values are the same when they are once sent as the vehicle
/// parameter's type ([`value::same`]: reals as `f32`, integers exactly).
pub fn diff(vehicle: &[Saved], file: &ParamFile) -> Diff {
    let mut by_name: HashMap<&str, Vec<usize>> = HashMap::with_capacity(vehicle.len());
    for (i, p) in vehicle.iter().enumerate() {
        by_name.entry(p.name).or_default().push(i);
    }
    let mut matched = vec![false; vehicle.len()];
    let mut d = Diff::default();
    for fp in &file.params {
        let hit = by_name.get(fp.name.as_str()).and_then(|ix| {
            ix.iter()
                .copied()
                .filter(|&i| !matched[i])
                .find(|&i| fp.component.is_none_or(|c| c == vehicle[i].component))
        });
        match hit {
            None => d.only_file.push(fp.name.clone()),
            Some(i) => {
                matched[i] = true;
                let v = &vehicle[i];
                if value::same(v.value, fp.value, v.ptype) {
                    d.same += 1;
                } else {
                    d.changed.push(Changed {
                        name: v.name.to_string(),
                        component: v.component,
                        ptype: v.ptype,
                        vehicle: v.value,
                        file: fp.value,
                    });
                }
            }
        }
    }
    d.only_vehicle = vehicle
        .iter()
        .zip(&matched)
        .filter(|(_, m)| !**m)
        .map(|(p, _)| p.name.to_string())
        .collect();
    d.changed
        .sort_by(|a, b| a.name.cmp(&b.name).then(a.component.cmp(&b.component)));
    d.only_vehicle.sort();
    d.only_file.sort();
    d
}

#[cfg(test)]
mod tests {
    use super::*;
    use ParamType::*;

    fn saved(name: &str, value: f64, ptype: ParamType) -> Saved<'_> {
        Saved {
            name,
            value,
            ptype,
            component: 1,
        }
    }

    #[test]
    fn parm_lines_as_mavproxy_reads_them() {
        let text = "# saved by hand\n\
                    \n\
                    ACRO_BAL_PITCH   1.000000\n\
                    ANGLE_MAX,3000\n\
                    \tATC_RAT_RLL_P\t0.135  # trailing comment\n\
                    LOG_BITMASK 0x3FF\n";
        let f = parse(text);
        assert_eq!(f.format, Format::Parm);
        assert!(f.errors.is_empty(), "{:?}", f.errors);
        let got: Vec<(&str, f64, usize)> = f
            .params
            .iter()
            .map(|p| (p.name.as_str(), p.value, p.line))
            .collect();
        assert_eq!(
            got,
            vec![
                ("ACRO_BAL_PITCH", 1.0, 3),
                ("ANGLE_MAX", 3000.0, 4),
                ("ATC_RAT_RLL_P", 0.135, 5),
                ("LOG_BITMASK", 1023.0, 6),
            ]
        );
        assert!(f
            .params
            .iter()
            .all(|p| p.ptype.is_none() && p.component.is_none()));
    }

    #[test]
    fn qgc_lines_as_qgc_writes_them() {
        let text =
            "# Onboard parameters for Vehicle 1\n#\n# Vehicle-Id Component-Id Name Value Type\n\
                    1\t1\tACRO_BAL_PITCH\t1.000000000000000000\t9\n\
                    1\t1\tANGLE_MAX\t3000\t4\n";
        let f = parse(text);
        assert_eq!(f.format, Format::Qgc);
        assert!(f.errors.is_empty());
        assert_eq!(
            f.params[1],
            FileParam {
                name: "ANGLE_MAX".into(),
                value: 3000.0,
                ptype: Some(Int16),
                system: Some(1),
                component: Some(1),
                line: 5,
            }
        );
    }

    #[test]
    fn detection_is_by_content() {
        assert_eq!(detect(""), Format::Parm);
        assert_eq!(detect("A 1\nB\t2\n"), Format::Parm);
        assert_eq!(detect("# Onboard parameters for Vehicle 1\n"), Format::Qgc);
        assert_eq!(detect("# c\nX 1\n1\t1\tA\t1\t9\n"), Format::Qgc);
        assert_eq!(detect("a\tb\tA\t1\t9\n"), Format::Parm);
        assert_eq!(format_for_path(Path::new("x/copter.params")), Format::Qgc);
        assert_eq!(format_for_path(Path::new("x/copter.PARAMS")), Format::Qgc);
        assert_eq!(format_for_path(Path::new("copter.parm")), Format::Parm);
        assert_eq!(format_for_path(Path::new("copter.param")), Format::Parm);
        assert_eq!(format_for_path(Path::new("copter")), Format::Parm);
    }

    #[test]
    fn bad_parm_lines_are_reported_and_good_ones_kept() {
        let text = "GOOD_ONE 1\n\
                    LONELY\n\
                    A B C\n\
                    NOT_NUM abc\n\
                    INF_VAL inf\n\
                    NAN_VAL NaN\n\
                    THIS_NAME_IS_TOO_LONG 1\n\
                    BAD-NAME 1\n\
                    GOOD_ONE 2\n\
                    good_one 3\n";
        let f = parse(text);
        let names: Vec<&str> = f.params.iter().map(|p| p.name.as_str()).collect();
        assert_eq!(names, vec!["GOOD_ONE", "good_one"]);
        assert_eq!(f.params[0].value, 1.0);
        let lines: Vec<usize> = f.errors.iter().map(|e| e.line).collect();
        assert_eq!(lines, vec![2, 3, 4, 5, 6, 7, 8, 9]);
        assert_eq!(f.errors[0].text, "LONELY");
        assert!(f.errors[7]
            .to_string()
            .starts_with("line 9: GOOD_ONE appears again"));
    }

    #[test]
    fn bad_qgc_lines_are_reported() {
        let text = "1\t1\tOK\t1\t6\n\
                    1\t1\tSHORT\t1\n\
                    1\t1\tTYPE\t1\t11\n\
                    1\t1\tFRACT\t1.5\t6\n\
                    1\t1\tBIG\t300\t1\n\
                    1\t300\tCOMP\t1\t6\n\
                    1\t1\tOK\t2\t6\n\
                    1\t2\tOK\t2\t6\n";
        let f = parse(text);
        assert_eq!(f.format, Format::Qgc);
        let kept: Vec<(&str, Option<u8>)> = f
            .params
            .iter()
            .map(|p| (p.name.as_str(), p.component))
            .collect();
        assert_eq!(kept, vec![("OK", Some(1)), ("OK", Some(2))]);
        let lines: Vec<usize> = f.errors.iter().map(|e| e.line).collect();
        assert_eq!(lines, vec![2, 3, 4, 5, 6, 7]);
    }

    #[test]
    fn parm_is_written_like_mavproxy_sorted_and_shortest() {
        let params = [
            saved("WPNAV_SPEED", 1000.0, Real32),
            saved("ACRO_RP_EXPO", 0.3f32 as f64, Real32),
            saved("ANGLE_MAX", 3000.0, Int16),
            saved("TINY", 1e-7f32 as f64, Real32),
            saved("FS_OPTIONS", -1.0, Int32),
        ];
        let text = write(Format::Parm, &params, &Header::default());
        assert_eq!(
            text,
            "ACRO_RP_EXPO     0.3\n\
             ANGLE_MAX        3000\n\
             FS_OPTIONS       -1\n\
             TINY             0.0000001\n\
             WPNAV_SPEED      1000\n"
        );
    }

    #[test]
    fn qgc_values_are_written_with_18_decimals() {
        assert_eq!(qgc_value(0.3, Real32), "0.300000011920928955");
        assert_eq!(qgc_value(1.0, Real32), "1.000000000000000000");
        assert_eq!(qgc_value(-2.5, Real32), "-2.500000000000000000");
        assert_eq!(qgc_value(0.1, Real64), "0.100000000000000006");
        assert_eq!(qgc_value(3000.0, Int16), "3000");
        assert_eq!(qgc_value(-1.0, Int8), "-1");
        assert_eq!(qgc_value(4294967295.0, Uint32), "4294967295");
        // Too small for 18 decimals: exponent form instead of 0.000000000000000000.
        assert_eq!(qgc_value(1e-20f32 as f64, Real32), "1e-20");
        assert_eq!(qgc_value(0.0, Real32), "0.000000000000000000");
        assert_eq!(qgc_value(1e-7f32 as f64, Real32), "0.000000100000001169");
    }

    #[test]
    fn qgc_is_written_with_header_by_component_then_name() {
        let params = [
            Saved {
                name: "MNT1_TYPE",
                value: 1.0,
                ptype: Int8,
                component: 154,
            },
            saved("ZED", 0.5, Real32),
            saved("ANGLE_MAX", 3000.0, Int16),
        ];
        let header = Header {
            sysid: 3,
            stack: "ArduPilot".into(),
            vehicle: "Multi-Rotor".into(),
            version: "4.6.0 dev".into(),
            git_revision: String::new(),
        };
        assert_eq!(
            write(Format::Qgc, &params, &header),
            "# Onboard parameters for Vehicle 3\n\
             #\n\
             # Stack: ArduPilot\n\
             # Vehicle: Multi-Rotor\n\
             # Version: 4.6.0 dev\n\
             #\n\
             # Vehicle-Id Component-Id Name Value Type\n\
             3\t1\tANGLE_MAX\t3000\t4\n\
             3\t1\tZED\t0.500000000000000000\t9\n\
             3\t154\tMNT1_TYPE\t1\t2\n"
        );
    }

    #[test]
    fn round_trips_keep_values_and_types() {
        let params = [
            saved("A_REAL", 0.1f32 as f64, Real32),
            saved("B_INT", -32768.0, Int16),
            saved("C_U32", 4294967295.0, Uint32),
            saved("D_SMALL", f32::MIN_POSITIVE as f64, Real32),
            saved("E_BIG", 3.4e38f32 as f64, Real32),
        ];
        for format in [Format::Parm, Format::Qgc] {
            let f = parse(&write(
                format,
                &params,
                &Header {
                    sysid: 1,
                    ..Header::default()
                },
            ));
            assert_eq!(f.format, format);
            assert!(f.errors.is_empty(), "{format:?}: {:?}", f.errors);
            assert_eq!(f.params.len(), params.len());
            for (p, fp) in params.iter().zip(&f.params) {
                assert_eq!(p.name, fp.name);
                assert!(
                    value::same(p.value, fp.value, p.ptype),
                    "{format:?} {}",
                    p.name
                );
                if format == Format::Qgc {
                    assert_eq!(fp.ptype, Some(p.ptype));
                    assert_eq!(fp.component, Some(1));
                }
            }
        }
    }

    #[test]
    fn diff_compares_as_the_type_carries_it() {
        let vehicle = [
            saved("SAME_REAL", 0.3f32 as f64, Real32),
            saved("CHANGED", 2.0, Int8),
            saved("ONLY_VEH", 1.0, Int8),
        ];
        // 0.3 written by %f as 0.300000 is the same f32.
        let file = parse("SAME_REAL 0.300000\nCHANGED 3\nONLY_FILE 1\n");
        let d = diff(&vehicle, &file);
        assert_eq!(
            d.changed,
            vec![Changed {
                name: "CHANGED".into(),
                component: 1,
                ptype: Int8,
                vehicle: 2.0,
                file: 3.0
            }]
        );
        assert_eq!(d.only_vehicle, vec!["ONLY_VEH".to_string()]);
        assert_eq!(d.only_file, vec!["ONLY_FILE".to_string()]);
        assert_eq!(d.same, 1);
    }
}
