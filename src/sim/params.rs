//! The vehicle's parameter table: real ArduCopter names, values, types and order.
//!
//! Names and values come from a real ArduCopter's full download (`assets/sim/copter-params.parm`);
//! the order and AP_Param storage types from the same vehicle's `param.pck`
//! (`assets/sim/copter-param-types.txt`), so PARAM_VALUE indices and types are what a GCS sees
//! from ArduPilot, not guesses.

use crate::dialect::MavParamType;
use crate::wire::param_pck::{PckParam, PckType};
use std::collections::BTreeMap;

const PARM: &str = include_str!("../../assets/sim/copter-params.parm");
const TYPES: &str = include_str!("../../assets/sim/copter-param-types.txt");

/// One parameter.
#[derive(Debug, Clone, PartialEq)]
pub struct Param {
    pub name: String,
    pub ptype: PckType,
    /// Integers are whole numbers within their type's range; floats are `f32` values widened.
    pub value: f64,
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

/// Store `v` as a parameter of type `t` holds it: integers rounded and clamped to their range
/// (ArduPilot's PARAM_SET casts the float), floats narrowed to `f32`. NaN becomes 0.
pub fn convert(t: PckType, v: f64) -> f64 {
    let v = if v.is_finite() {
        v
    } else if v.is_nan() {
        0.0
    } else {
        v.signum() * f64::MAX
    };
    match t {
        PckType::Int8 => v.round().clamp(i8::MIN as f64, i8::MAX as f64),
        PckType::Int16 => v.round().clamp(i16::MIN as f64, i16::MAX as f64),
        PckType::Int32 => v.round().clamp(i32::MIN as f64, i32::MAX as f64),
        PckType::Float => v as f32 as f64,
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
            let value = values.get(name).copied().unwrap_or(0.0);
            params.push(Param {
                name: name.to_string(),
                ptype,
                value: convert(ptype, value),
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
    /// unknown name (ArduPilot ignores those).
    pub fn set(&mut self, name: &str, value: f64) -> Option<usize> {
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
        self.params
            .iter()
            .map(|p| PckParam {
                name: p.name.clone(),
                ptype: p.ptype,
                value: p.value,
                default: None,
            })
            .collect()
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
        let i = t.set("MAV_SYSID", 7.6).unwrap();
        assert_eq!(t.get(i).unwrap().value, 8.0);
        t.set("FRAME_CLASS", 1000.0);
        assert_eq!(t.value("FRAME_CLASS"), Some(127.0));
        t.set("FRAME_CLASS", f64::NAN);
        assert_eq!(t.value("FRAME_CLASS"), Some(0.0));
        t.set("ATC_ACCEL_P_MAX", 0.1);
        assert_eq!(t.value("ATC_ACCEL_P_MAX"), Some(0.1f32 as f64));
        assert_eq!(t.set("NO_SUCH_PARAM", 1.0), None);
        assert_eq!(t.len(), 1354);
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
}
