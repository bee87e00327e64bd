//! The vehicle's parameter table: real ArduCopter names, values, types and order.
//!
//! Names and values come from a real ArduCopter's full download (`assets/sim/copter-params.parm`);
//! the order and AP_Param storage types from the same vehicle's `param.pck`
//! (`assets/sim/copter-param-types.txt`), and the defaults of the parameters that differ from
//! theirs from its `param.pck?withdefaults=1` (`assets/sim/copter-param-defaults.txt`), so
//! PARAM_VALUE indices and types and the packed file are what a GCS sees from ArduPilot, not
//! guesses.

use crate::clock::Micros;
use crate::dialect::MavParamType;
use crate::wire::param_pck::{PckParam, PckType};
use std::collections::BTreeMap;

const PARM: &str = include_str!("../../assets/sim/copter-params.parm");
const TYPES: &str = include_str!("../../assets/sim/copter-param-types.txt");
const DEFAULTS: &str = include_str!("../../assets/sim/copter-param-defaults.txt");

/// Parameters ArduPilot declares `AP_PARAM_FLAG_INTERNAL_USE_ONLY` (AP_Baro's `n_GND_PRESS` and
/// `n_DEVID`, AP_Mission's `TOTAL`): `AP_Param::allow_set_via_mavlink` refuses a PARAM_SET of
/// them unless BRD_OPTIONS has ALLOW_SET_INTERNAL_PARM (bit 2).
const INTERNAL_USE_ONLY: [&str; 7] = [
    "BARO1_GND_PRESS",
    "BARO2_GND_PRESS",
    "BARO3_GND_PRESS",
    "BARO1_DEVID",
    "BARO2_DEVID",
    "BARO3_DEVID",
    "MIS_TOTAL",
];

/// One parameter.
#[derive(Debug, Clone, PartialEq)]
pub struct Param {
    pub name: String,
    pub ptype: PckType,
    /// Integers are whole numbers within their type's range; floats are `f32` values widened.
    pub value: f64,
    /// The firmware default, as the float AP_Param keeps it (not converted to the type: a
    /// default can lie outside an integer type's range, see SIM_OH_RELAY_MSK).
    pub default: f64,
    /// `AP_PARAM_FLAG_INTERNAL_USE_ONLY`: refused over MAVLink.
    pub internal: bool,
}

/// The MAVLink type ArduPilot puts in PARAM_VALUE for a storage type.
pub fn mav_type(t: PckType) -> MavParamType {
    match t {
        PckType::Int8 => MavParamType::MAV_PARAM_TYPE_INT8,
        PckType::Int16 => MavParamType::MAV_PARAM_TYPE_INT16,
        PckType::Int32 => MavParamType::MAV_PARAM_TYPE_INT32,
        PckType::Float => MavParamType::MAV_PARAM_TYPE_REAL32,
    }
}

/// Store `v` as a parameter of type `t` holds it, as `AP_Param::set_float` does: the value is a
/// float; integers get 0.01 added away from zero (so 6.9999 stays 7), are clamped to their
/// type's range and then truncated (7.6 becomes 7, -7.6 becomes -7); floats are narrowed to
/// `f32`. Callers reject NaN and infinities first (ArduPilot ignores such a PARAM_SET); here
/// NaN gives 0.
pub fn convert(t: PckType, v: f64) -> f64 {
    let v = v as f32;
    let int = |min: f32, max: f32| {
        let r = if v < 0.0 { -0.01f32 } else { 0.01f32 };
        ((v + r).clamp(min, max) as f64).trunc()
    };
    match t {
        PckType::Int8 => int(i8::MIN as f32, i8::MAX as f32),
        PckType::Int16 => int(i16::MIN as f32, i16::MAX as f32),
        // 2147483647 is not a float: the clamp gives 2^31, which saturates to i32::MAX.
        PckType::Int32 => int(i32::MIN as f32, i32::MAX as f32).min(i32::MAX as f64),
        PckType::Float => v as f64,
    }
}

/// ArduPilot's `is_equal` for floats: closer than `FLT_EPSILON`.
fn is_equal(a: f32, b: f32) -> bool {
    (a - b).abs() < f32::EPSILON
}

/// `default` as `AP_Filesystem_Param::pack_param` stores it in the packed file: a C conversion
/// of the float to the parameter's integer type (two's-complement wrap, so 65535 in an INT16 is
/// -1), or the float itself.
pub fn default_as_stored(t: PckType, default: f64) -> f64 {
    let i = default as i64;
    match t {
        PckType::Int8 => i as i8 as f64,
        PckType::Int16 => i as i16 as f64,
        PckType::Int32 => i as i32 as f64,
        PckType::Float => default as f32 as f64,
    }
}

/// When, after its first heartbeat, ArduCopter's barometer calibration at boot completes
/// (`AP_Baro::calibrate`: "Barometer N calibration complete"), and with it the inertial sensors'
/// device ids are saved (`AP_InertialSensor::_save_gyro_calibration` of the ids found at init).
pub const BARO_CAL_AT: Micros = 910_000;
/// When the gyro calibration at boot (`AP_InertialSensor::init_gyro`) saves its offsets and
/// calibration temperatures ("ArduPilot Ready" follows).
pub const GYRO_CAL_AT: Micros = 1_430_000;

/// The parameters ArduCopter sets itself during its first seconds, and when (from the vehicle's
/// boot): the calibration results its boot saves, each saved with `AP_Param::save`, so each
/// notified to every GCS with PARAM_VALUE index -1 (`save_sync(.., send_to_gcs = true)`).
/// Values and order from a real ArduCopter 4.7-dev SITL booting while a GCS read its
/// `param.pck?withdefaults=1` (`tests/data/copter-mavftp-lossy.gcs.tlog`: the PARAM_VALUEs of
/// its boot, and the file read 80 s later). Each one leaves its default (the table's boot value),
/// so the file gains that default: every later entry moves, as on the real vehicle. The compass
/// declination is set from the first GPS fix (`AP_Compass` with COMPASS_AUTODEC).
pub fn boot_changes() -> &'static [(Micros, &'static str, f64)] {
    const GPS_FIX_AT: Micros = crate::sim::vehicle::GPS_FIX_AT;
    &[
        (BARO_CAL_AT, "BARO2_GND_PRESS", 94502.5390625),
        (BARO_CAL_AT, "INS_GYR_ID", 2752772.0),
        (BARO_CAL_AT, "INS_ACC_ID", 2753028.0),
        (BARO_CAL_AT, "INS_GYR2_ID", 2752780.0),
        (BARO_CAL_AT, "INS_ACC2_ID", 2753036.0),
        (GYRO_CAL_AT, "INS_GYROFFS_X", 2.3449767468264326e-05),
        (GYRO_CAL_AT, "INS_GYROFFS_Y", 2.5720373741933145e-05),
        (GYRO_CAL_AT, "INS_GYROFFS_Z", 2.9012084269197658e-05),
        (GYRO_CAL_AT, "INS_GYR1_CALTEMP", 25.018352508544922),
        (GYRO_CAL_AT, "INS_GYR2OFFS_X", 2.015327481785789e-05),
        (GYRO_CAL_AT, "INS_GYR2OFFS_Y", 2.7733694878406823e-05),
        (GYRO_CAL_AT, "INS_GYR2OFFS_Z", 1.705062277324032e-05),
        (GYRO_CAL_AT, "INS_GYR2_CALTEMP", 25.018352508544922),
        (GPS_FIX_AT, "COMPASS_DEC", 0.2233572155237198),
    ]
}

/// The boot changes still to come, in order: [`ParamTable::settle`] applies those due.
#[derive(Debug, Clone, Default)]
pub struct BootSettle {
    next: usize,
}

impl BootSettle {
    /// When the next change is due, if any is left.
    pub fn next_due(&self) -> Option<Micros> {
        boot_changes().get(self.next).map(|c| c.0)
    }

    /// Apply the changes due by `now` (time since boot) to `params`; returns the table indices
    /// changed, in order, for their PARAM_VALUE notices.
    pub fn settle(&mut self, now: Micros, params: &mut ParamTable) -> Vec<usize> {
        let mut changed = Vec::new();
        while let Some(&(at, name, value)) = boot_changes().get(self.next) {
            if at > now {
                break;
            }
            self.next += 1;
            if let Some(i) = params.set(name, value) {
                changed.push(i);
            }
        }
        changed
    }
}

/// Parameters in ArduPilot's order, with a name index.
#[derive(Debug, Clone)]
pub struct ParamTable {
    params: Vec<Param>,
    by_name: BTreeMap<String, usize>,
}

impl ParamTable {
    /// The real ArduCopter set, padded with extra names or truncated to `count` (0 = as is).
    pub fn copter(count: usize) -> ParamTable {
        let values: BTreeMap<&str, f64> = PARM
            .lines()
            .filter_map(|l| {
                let mut it = l.split_whitespace();
                Some((it.next()?, it.next()?.parse().ok()?))
            })
            .collect();
        let defaults: BTreeMap<&str, f64> = DEFAULTS
            .lines()
            .filter(|l| !l.starts_with('#'))
            .filter_map(|l| {
                let mut it = l.split_whitespace();
                Some((it.next()?, it.next()?.parse().ok()?))
            })
            .collect();
        let mut params: Vec<Param> = Vec::with_capacity(values.len());
        for line in TYPES.lines() {
            let mut it = line.split_whitespace();
            let (Some(name), Some(t)) = (it.next(), it.next()) else {
                continue;
            };
            let ptype = match t {
                "INT8" => PckType::Int8,
                "INT16" => PckType::Int16,
                "INT32" => PckType::Int32,
                _ => PckType::Float,
            };
            let value = convert(ptype, values.get(name).copied().unwrap_or(0.0));
            params.push(Param {
                name: name.to_string(),
                ptype,
                value,
                default: defaults.get(name).copied().unwrap_or(value),
                internal: INTERNAL_USE_ONLY.contains(&name),
            });
        }
        if count > 0 {
            params.truncate(count);
            // Padding: plausible-looking scripting/user parameters, floats defaulting to 0.
            let mut i = 0;
            while params.len() < count {
                i += 1;
                params.push(Param {
                    name: format!("SCR_USER{i}"),
                    ptype: PckType::Float,
                    value: 0.0,
                    default: 0.0,
                    internal: false,
                });
            }
        }
        ParamTable::from_vec(params)
    }

    fn from_vec(params: Vec<Param>) -> ParamTable {
        let mut by_name = BTreeMap::new();
        for (i, p) in params.iter().enumerate() {
            by_name.entry(p.name.clone()).or_insert(i);
        }
        ParamTable { params, by_name }
    }

    pub fn len(&self) -> usize {
        self.params.len()
    }

    pub fn is_empty(&self) -> bool {
        self.params.is_empty()
    }

    pub fn get(&self, index: usize) -> Option<&Param> {
        self.params.get(index)
    }

    pub fn index_of(&self, name: &str) -> Option<usize> {
        self.by_name.get(name).copied()
    }

    pub fn value(&self, name: &str) -> Option<f64> {
        self.index_of(name).map(|i| self.params[i].value)
    }

    /// Set by name, converted to the parameter's type. Returns the index, or `None` for an
    /// unknown name or a value that is NaN or infinite (ArduPilot ignores both).
    pub fn set(&mut self, name: &str, value: f64) -> Option<usize> {
        if !value.is_finite() {
            return None;
        }
        let i = self.index_of(name)?;
        let p = &mut self.params[i];
        p.value = convert(p.ptype, value);
        Some(i)
    }

    pub fn iter(&self) -> impl Iterator<Item = &Param> {
        self.params.iter()
    }

    /// The table as `param.pck` entries (no defaults).
    pub fn to_pck(&self) -> Vec<PckParam> {
        self.to_pck_with(false)
    }

    /// The table as `param.pck` entries; `with_defaults`: each parameter whose value differs
    /// from its default carries the default (`pack_param`: `!is_equal(value, default_val)`,
    /// compared as floats).
    pub fn to_pck_with(&self, with_defaults: bool) -> Vec<PckParam> {
        (0..self.params.len())
            .filter_map(|i| self.pck_entry(i, with_defaults))
            .collect()
    }

    /// Entry `i` as `param.pck` packs it now (see [`ParamTable::to_pck_with`]).
    pub fn pck_entry(&self, i: usize, with_defaults: bool) -> Option<PckParam> {
        let p = self.params.get(i)?;
        Some(PckParam {
            name: p.name.clone(),
            ptype: p.ptype,
            value: p.value,
            default: (with_defaults && !is_equal(p.value as f32, p.default as f32))
                .then(|| default_as_stored(p.ptype, p.default)),
        })
    }

    /// Apply a `NAME VALUE` file (MAVProxy/Mission Planner `.parm` format; `#` comments and
    /// commas accepted). Unknown names and unparsable lines are skipped. Returns how many applied.
    pub fn load_parm_text(&mut self, text: &str) -> usize {
        let mut n = 0;
        for line in text.lines() {
            let line = line.split('#').next().unwrap_or("").replace(',', " ");
            let mut it = line.split_whitespace();
            let (Some(name), Some(v)) = (it.next(), it.next()) else {
                continue;
            };
            if let Ok(v) = v.parse::<f64>() {
                if self.set(name, v).is_some() {
                    n += 1;
                }
            }
        }
        n
    }

    /// The table as `NAME VALUE` lines in table order.
    pub fn to_parm_text(&self) -> String {
        let mut s = String::with_capacity(self.params.len() * 24);
        for p in &self.params {
            s.push_str(&p.name);
            s.push(' ');
            // `{}` on f64 prints the shortest text that parses back to the same value.
            s.push_str(&format!("{}\n", p.value));
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn real_set_has_all_names_types_and_values() {
        let t = ParamTable::copter(0);
        assert_eq!(t.len(), 1354);
        assert_eq!(PARM.lines().count(), 1354);
        // Every name of the .parm is in the table with its value.
        for line in PARM.lines() {
            let mut it = line.split_whitespace();
            let (name, v) = (
                it.next().unwrap(),
                it.next().unwrap().parse::<f64>().unwrap(),
            );
            let got = t.value(name).unwrap_or_else(|| panic!("{name} missing"));
            assert!(
                (got - v).abs() <= 1e-5 * v.abs().max(1.0),
                "{name}: {got} vs {v}"
            );
        }
        // ArduPilot's order starts with FORMAT_VERSION.
        assert_eq!(t.get(0).unwrap().name, "FORMAT_VERSION");
        let ty = |n: &str| t.get(t.index_of(n).unwrap()).unwrap().ptype;
        assert_eq!(ty("MAV_SYSID"), PckType::Int16);
        assert_eq!(ty("COMPASS_DEV_ID"), PckType::Int32);
        assert_eq!(ty("FRAME_CLASS"), PckType::Int8);
        assert_eq!(ty("ANGLE_MAX"), PckType::Int16);
        assert_eq!(ty("ATC_ACCEL_P_MAX"), PckType::Float);
        assert_eq!(
            mav_type(ty("SERIAL1_BAUD")),
            MavParamType::MAV_PARAM_TYPE_INT32
        );
    }

    #[test]
    fn set_converts_per_type_and_ignores_unknown() {
        let mut t = ParamTable::copter(0);
        // AP_Param::set_float: +0.01 away from zero, clamp, truncate.
        let i = t.set("MAV_SYSID", 7.6).unwrap();
        assert_eq!(t.get(i).unwrap().value, 7.0);
        t.set("MAV_SYSID", 6.9999);
        assert_eq!(t.value("MAV_SYSID"), Some(7.0));
        t.set("RTL_ALT", -3.995);
        assert_eq!(t.value("RTL_ALT"), Some(-4.0));
        t.set("RTL_ALT", 3e10);
        assert_eq!(t.value("RTL_ALT"), Some(i32::MAX as f64));
        t.set("FRAME_CLASS", 1000.0);
        assert_eq!(t.value("FRAME_CLASS"), Some(127.0));
        t.set("FRAME_CLASS", -1000.0);
        assert_eq!(t.value("FRAME_CLASS"), Some(-128.0));
        // NaN and infinities are ignored, the value stays.
        assert_eq!(t.set("FRAME_CLASS", f64::NAN), None);
        assert_eq!(t.set("FRAME_CLASS", f64::INFINITY), None);
        assert_eq!(t.value("FRAME_CLASS"), Some(-128.0));
        t.set("ATC_ACCEL_P_MAX", 0.1);
        assert_eq!(t.value("ATC_ACCEL_P_MAX"), Some(0.1f32 as f64));
        assert_eq!(t.set("NO_SUCH_PARAM", 1.0), None);
        assert_eq!(t.len(), 1354);
    }

    #[test]
    fn defaults_and_internal_parameters() {
        let t = ParamTable::copter(0);
        let p = |n: &str| t.get(t.index_of(n).unwrap()).unwrap().clone();
        // At its default: the default is the value.
        assert_eq!((p("RTL_ALT").value, p("RTL_ALT").default), (1500.0, 1500.0));
        assert_eq!(p("COMPASS_DEV_ID").default, 0.0);
        assert_eq!(p("STAT_BOOTCNT").default, 0.0);
        assert!(p("BARO1_GND_PRESS").internal && p("MIS_TOTAL").internal);
        assert!(!p("RTL_ALT").internal);
        let with = t.to_pck_with(true);
        assert_eq!(with.iter().filter(|p| p.default.is_some()).count(), 30);
        let relay = with.iter().find(|p| p.name == "SIM_OH_RELAY_MSK").unwrap();
        assert_eq!((relay.value, relay.default), (-1.0, Some(-1.0)));
        assert!(t.to_pck().iter().all(|p| p.default.is_none()));
        assert_eq!(default_as_stored(PckType::Int16, 65535.0), -1.0);
        // is_equal: within FLT_EPSILON counts as at the default.
        let mut u = ParamTable::copter(0);
        u.set("ACRO_Y_EXPO", 1e-9);
        u.set("ACRO_THR_MID", 1e-3);
        let d = u.to_pck_with(true);
        let at = |n: &str| d.iter().find(|p| p.name == n).unwrap().default;
        assert_eq!(u.value("ACRO_Y_EXPO"), Some(1e-9f32 as f64));
        assert_eq!(at("ACRO_Y_EXPO"), None);
        assert_eq!(at("ACRO_THR_MID"), Some(0.0));
        assert_eq!(default_as_stored(PckType::Int8, 3.0), 3.0);
    }

    #[test]
    fn pads_and_truncates() {
        let t = ParamTable::copter(1400);
        assert_eq!(t.len(), 1400);
        assert_eq!(t.get(1399).unwrap().name, "SCR_USER46");
        assert!(t.iter().all(|p| p.name.len() <= 16));
        assert_eq!(ParamTable::copter(300).len(), 300);
    }

    #[test]
    fn state_text_round_trips() {
        let mut t = ParamTable::copter(0);
        t.set("RTL_ALT", 2500.0);
        t.set("ATC_ACCEL_P_MAX", 123.456);
        let text = t.to_parm_text();
        let mut u = ParamTable::copter(0);
        assert_eq!(u.load_parm_text(&text), 1354);
        assert_eq!(u.value("RTL_ALT"), Some(2500.0));
        assert_eq!(u.value("ATC_ACCEL_P_MAX"), t.value("ATC_ACCEL_P_MAX"));
        assert_eq!(
            u.load_parm_text("garbage\nRTL_ALT x\n# c\nRTL_ALT,100\n"),
            1
        );
        assert_eq!(u.value("RTL_ALT"), Some(100.0));
    }

    #[test]
    fn boot_changes_leave_their_defaults_in_order() {
        let mut t = ParamTable::copter(0);
        let before = t
            .to_pck_with(true)
            .iter()
            .filter(|p| p.default.is_some())
            .count();
        let mut s = BootSettle::default();
        assert_eq!(s.next_due(), Some(BARO_CAL_AT));
        assert!(s.settle(BARO_CAL_AT - 1, &mut t).is_empty());
        let baro = s.settle(BARO_CAL_AT, &mut t);
        assert_eq!(baro.len(), 5);
        assert_eq!(t.value("INS_GYR_ID"), Some(2752772.0));
        assert_eq!(s.next_due(), Some(GYRO_CAL_AT));
        let all = s.settle(10 * crate::clock::SECOND, &mut t);
        assert_eq!(all.len(), boot_changes().len() - 5);
        assert_eq!(s.next_due(), None);
        assert_eq!(t.value("INS_GYR1_CALTEMP"), Some(25.018_353_f32 as f64));
        // Every change but the ground pressure (already away from its default) adds a default.
        let with = t.to_pck_with(true);
        assert_eq!(
            with.iter().filter(|p| p.default.is_some()).count(),
            before + boot_changes().len() - 1
        );
        let gyro = with.iter().find(|p| p.name == "INS_GYROFFS_X").unwrap();
        assert_eq!(gyro.default, Some(0.0));
    }
}
