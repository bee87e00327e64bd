//! Parameter metadata: what a parameter means, its units, range, values and bits, read from
//! ArduPilot's `apm.pdef.xml` or PX4's `parameters.xml`. The format is told by the root element.
//!
//! **ArduPilot** (`Tools/autotest/param_metadata/param_parse.py`, `xmlemit.py`):
//!
//! ```xml
//! <paramfile>
//!   <vehicles>
//!     <parameters name="ArduCopter">
//!       <param humanName="Frame Class" name="ArduCopter:FRAME_CLASS" documentation="..." user="Standard">
//!         <field name="RebootRequired">True</field>
//!         <values><value code="1">Quad</value></values>
//!       </param>
//!     </parameters>
//!   </vehicles>
//!   <libraries>
//!     <parameters name="ATC_">
//!       <param humanName="..." name="ATC_RAT_RLL_P" documentation="...">
//!         <field name="Range">0.01 0.5</field>
//!         <field name="Increment">0.005</field>
//!       </param>
//!     </parameters>
//!   </libraries>
//! </paramfile>
//! ```
//!
//! Vehicle parameters are named `Vehicle:NAME`; the prefix is dropped. Fields come as
//! `<field name="...">` in any order (`Units`, `Range` "min max", `Increment`,
//! `RebootRequired`/`ReadOnly` "True", ...); unknown ones are ignored. Enumerations are
//! `<values><value code=..>`; bitmasks `<bitmask><bit code="bit number">` (xmlemit also writes
//! them as a `Bitmask` field `"0:Name,1:Name"`, read when there is no `<bitmask>` element).
//!
//! **The same name twice.** `param_parse.py` documents one vehicle at a time, but a group can
//! pull in several source files: Copter's `ATC_` group has
//! `@Path: AC_AttitudeControl.cpp, AC_AttitudeControl_Multi.cpp, AC_AttitudeControl_Heli.cpp`,
//! so `ATC_RAT_RLL_P` and friends appear twice in the one `<parameters name="ATC_">` block, first
//! the multicopter's, then the helicopter's (which of the two is compiled in depends on
//! `FRAME_CONFIG == HELI_FRAME`). param_parse tags such duplicates with the source file's name
//! (`param.path = "AC_AttitudeControl_Heli"`), but that is not one of the `known_param_fields`
//! xmlemit writes, so the XML itself does not say which is which. The rule here:
//!
//! 1. A `<param>` that names its source (a `path` attribute or `<field name="path">`, in case a
//!    generator writes it) is a helicopter's if that contains `Heli`, a multicopter's if `Multi`.
//! 2. Otherwise, of a name repeated inside one `<parameters>` block, the first is the
//!    multicopter's and the second the helicopter's: the order of `@Path` above.
//! 3. [`MetaSet::get`] with a [`Variant`] hint takes the candidate of the vehicle's kind: the
//!    helicopter's for [`Variant::Helicopter`] (MAV_TYPE_HELICOPTER), otherwise the one that is not
//!    a helicopter's. Files that hold several vehicles (older `apm.pdef.xml` with `ArduPlane`,
//!    `ArduCopter`, `APMrover2`... blocks) are told apart the same way by the block's name. On a
//!    tie the first in the file wins.
//!
//! **PX4** (`src/lib/parameters/px4params/xmlout.py`):
//!
//! ```xml
//! <parameters>
//!   <version>3</version>
//!   <group name="Multicopter Attitude Control">
//!     <parameter name="MC_ROLL_P" default="6.5" type="FLOAT">
//!       <short_desc>Roll P gain</short_desc>
//!       <long_desc>...</long_desc>
//!       <min>0.0</min><max>12</max><decimal>2</decimal><increment>0.1</increment>
//!       <reboot_required>true</reboot_required>
//!       <values><value code="0">Disabled</value></values>
//!       <bitmask><bit index="0">...</bit></bitmask>
//!     </parameter>
//!   </group>
//! </parameters>
//! ```
//!
//! with optional attributes `volatile="true"`, `boolean="true"`, `category="..."`.
//!
//! **PX4's JSON** (`parameters.json`, what the component metadata protocol serves:
//! `src/lib/parameters/px4params/jsonout.py`, read as QGroundControl's `CompInfoParam` reads it):
//!
//! ```json
//! {"version": 1, "parameters": [
//!   {"name": "MC_ROLL_P", "type": "Float", "default": 6.5, "group": "Multicopter Attitude Control",
//!    "category": "Standard", "shortDesc": "Roll P gain", "longDesc": "...", "units": "",
//!    "min": 0.0, "max": 12, "decimalPlaces": 2, "increment": 0.1, "rebootRequired": true,
//!    "values": [{"value": 0, "description": "Disabled"}],
//!    "bitmask": [{"index": 0, "description": "..."}]}]}
//! ```
//!
//! Numbers are typed for `Float` and `Int32` and strings for the other types (`jsonout.py`'s
//! `get_typed_value`): both are read. Older generators wrote `shortDescription`,
//! `longDescription`, `defaultValue`, `minValue`, `maxValue`: read too. Only version 1 is known
//! (as QGroundControl); another is refused. The file usually comes xz-compressed
//! (`parameters.json.xz`): [`inflate`] undoes that, bounded.
//!
//! Parsing is one pass over the tree with a hash map keyed by name: linear in the file's size
//! (the Copter file is ~2.4 MB).

use std::collections::HashMap;
use std::fmt;

use roxmltree::{Document, Node};

use super::value::{fmt_plain, ParamType};

/// What we know about one parameter.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ParamMeta {
    pub name: String,
    /// ArduPilot `humanName`, PX4 `short_desc`.
    pub human_name: Option<String>,
    /// ArduPilot `documentation`, PX4 `long_desc` (empty when there is none).
    pub description: String,
    pub units: Option<String>,
    /// Inclusive; PX4 may give one side only, the other is then infinite.
    pub range: Option<(f64, f64)>,
    pub increment: Option<f64>,
    pub reboot_required: bool,
    pub read_only: bool,
    /// Enumeration: code and name, in file order.
    pub values: Vec<(f64, String)>,
    /// Bitmask: bit number and name, in file order.
    pub bits: Vec<(u32, String)>,
    /// PX4 only.
    pub default: Option<f64>,
    /// PX4's `type` attribute (`INT32`, `FLOAT`).
    pub ptype: Option<ParamType>,
    /// PX4's `decimal`: digits to show.
    pub decimals: Option<u8>,
    /// ArduPilot `user` (`Standard`, `Advanced`), PX4 `category`.
    pub user: Option<String>,
    /// ArduPilot: the `<parameters name>` (vehicle or library prefix); PX4: the group name.
    pub group: String,
}

impl ParamMeta {
    /// The name of value `v` in the enumeration.
    pub fn value_name(&self, v: f64) -> Option<&str> {
        self.values
            .iter()
            .find(|(c, _)| *c == v)
            .map(|(_, n)| n.as_str())
    }

    /// The names of the bits set in `v`, in the order the metadata lists them.
    pub fn bits_set(&self, v: f64) -> Vec<&str> {
        if !v.is_finite() {
            return Vec::new();
        }
        let bits = v as i64 as u64;
        self.bits
            .iter()
            .filter(|(b, _)| *b < 64 && bits >> b & 1 == 1)
            .map(|(_, n)| n.as_str())
            .collect()
    }

    /// A value typed by someone: a number; or the name of one of the values (case-insensitive,
    /// whole name); or for a bitmask, bit names separated by `+`, `,` or `|` (the sum of their
    /// `1 << bit`).
    pub fn parse_value(&self, text: &str) -> Option<f64> {
        let t = text.trim();
        if t.is_empty() {
            return None;
        }
        if let Ok(v) = t.parse::<f64>() {
            return v.is_finite().then_some(v);
        }
        if let Some((c, _)) = self
            .values
            .iter()
            .find(|(_, n)| n.trim().eq_ignore_ascii_case(t))
        {
            return Some(*c);
        }
        if self.bits.is_empty() {
            return None;
        }
        let bit = |name: &str| {
            self.bits
                .iter()
                .find(|(_, n)| n.trim().eq_ignore_ascii_case(name))
                .map(|(b, _)| *b)
        };
        if let Some(b) = bit(t) {
            return (b < 64).then(|| (1u64 << b) as f64);
        }
        let mut mask = 0u64;
        let mut any = false;
        for part in t
            .split(['+', ',', '|'])
            .map(str::trim)
            .filter(|p| !p.is_empty())
        {
            let b = bit(part)?;
            if b >= 64 {
                return None;
            }
            mask |= 1 << b;
            any = true;
        }
        any.then_some(mask as f64)
    }

    /// Why `v` is outside the documented range, if it is.
    pub fn check_range(&self, v: f64) -> Result<(), String> {
        match self.range {
            Some((lo, hi)) if !(v >= lo && v <= hi) => {
                let side = |x: f64| {
                    if x.is_finite() {
                        fmt_plain(x)
                    } else {
                        "…".into()
                    }
                };
                Err(format!(
                    "{} is outside {}'s range {} to {}",
                    fmt_plain(v),
                    self.name,
                    side(lo),
                    side(hi)
                ))
            }
            _ => Ok(()),
        }
    }
}

/// The kind of vehicle, to choose between metadata that differ by vehicle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Variant {
    Multicopter,
    Helicopter,
    Plane,
    Rover,
    Sub,
    Tracker,
    Unknown,
}

impl Variant {
    /// From HEARTBEAT's MAV_TYPE.
    pub fn from_mav_type(mav_type: u8) -> Variant {
        match mav_type {
            // QUADROTOR, COAXIAL (ArduCopter's coax/single frames), HEXAROTOR, OCTOROTOR,
            // TRICOPTER, DODECAROTOR, DECAROTOR.
            2 | 3 | 13 | 14 | 15 | 29 | 35 => Variant::Multicopter,
            4 => Variant::Helicopter,
            // FIXED_WING, VTOL types.
            1 | 19..=25 => Variant::Plane,
            10 | 11 => Variant::Rover,
            12 => Variant::Sub,
            5 => Variant::Tracker,
            _ => Variant::Unknown,
        }
    }

    /// Whether an ArduPilot `<vehicles><parameters name>` block is this vehicle's.
    fn matches_block(self, block: &str) -> Option<bool> {
        let names: &[&str] = match self {
            Variant::Multicopter | Variant::Helicopter => &["ArduCopter", "Copter"],
            Variant::Plane => &["ArduPlane", "Plane"],
            Variant::Rover => &["Rover", "APMrover2", "ArduRover"],
            Variant::Sub => &["ArduSub", "Sub"],
            Variant::Tracker => &["AntennaTracker", "Tracker"],
            Variant::Unknown => return None,
        };
        Some(names.contains(&block))
    }
}

/// Which attitude controller a duplicated ArduPilot parameter belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Flavor {
    Any,
    Multi,
    Heli,
}

#[derive(Debug, Clone)]
struct Candidate {
    meta: ParamMeta,
    /// ArduPilot vehicle block name, for vehicle parameters.
    vehicle: Option<String>,
    flavor: Flavor,
}

/// Which file a [`MetaSet`] came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MetaFormat {
    ArduPilot,
    Px4,
}

/// All the metadata of one file, by parameter name.
#[derive(Debug, Clone)]
pub struct MetaSet {
    pub format: MetaFormat,
    by_name: HashMap<String, Vec<Candidate>>,
}

/// XML that cannot be read, or is neither format.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MetaError {
    /// 1-based.
    pub line: u32,
    /// 1-based.
    pub column: u32,
    pub message: String,
}

impl fmt::Display for MetaError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "line {}, column {}: {}",
            self.line, self.column, self.message
        )
    }
}

impl std::error::Error for MetaError {}

impl MetaSet {
    /// Reads ArduPilot's `apm.pdef.xml` or PX4's `parameters.xml`.
    pub fn parse(xml: &str) -> Result<MetaSet, MetaError> {
        let doc = Document::parse(xml).map_err(|e| {
            let p = e.pos();
            MetaError {
                line: p.row,
                column: p.col,
                message: e.to_string(),
            }
        })?;
        let root = doc.root_element();
        let mut set = match root.tag_name().name() {
            "paramfile" => MetaSet {
                format: MetaFormat::ArduPilot,
                by_name: HashMap::new(),
            },
            "parameters" => MetaSet {
                format: MetaFormat::Px4,
                by_name: HashMap::new(),
            },
            other => {
                let p = doc.text_pos_at(root.range().start);
                return Err(MetaError {
                    line: p.row,
                    column: p.col,
                    message: format!(
                        "root element <{other}> is neither ArduPilot's <paramfile> nor PX4's <parameters>"
                    ),
                });
            }
        };
        match set.format {
            MetaFormat::ArduPilot => set.read_ardupilot(root),
            MetaFormat::Px4 => set.read_px4(root),
        }
        Ok(set)
    }

    /// Number of distinct parameter names.
    pub fn len(&self) -> usize {
        self.by_name.len()
    }

    pub fn is_empty(&self) -> bool {
        self.by_name.is_empty()
    }

    /// The metadata for `name` on a vehicle of kind `hint` (see the module docs for how one of
    /// several candidates is chosen).
    pub fn get(&self, name: &str, hint: Variant) -> Option<&ParamMeta> {
        let cands = self.by_name.get(name)?;
        let score = |c: &Candidate| {
            let mut s = 0i32;
            if let Some(block) = &c.vehicle {
                s += match hint.matches_block(block) {
                    Some(true) => 4,
                    Some(false) => -4,
                    None => 0,
                };
            }
            s += match (c.flavor, hint) {
                (Flavor::Any, _) => 0,
                (Flavor::Heli, Variant::Helicopter) => 1,
                (Flavor::Multi, Variant::Helicopter) | (Flavor::Heli, _) => -1,
                (Flavor::Multi, _) => 1,
            };
            s
        };
        // First of the best: max_by_key would return the last of equals.
        let mut best: Option<(&Candidate, i32)> = None;
        for c in cands {
            let s = score(c);
            if best.is_none_or(|(_, b)| s > b) {
                best = Some((c, s));
            }
        }
        best.map(|(c, _)| &c.meta)
    }

    /// Every candidate for `name`, in file order.
    pub fn all(&self, name: &str) -> impl Iterator<Item = &ParamMeta> {
        self.by_name
            .get(name)
            .into_iter()
            .flatten()
            .map(|c| &c.meta)
    }

    /// Every parameter name (in no particular order).
    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.by_name.keys().map(String::as_str)
    }

    fn push(&mut self, c: Candidate) {
        self.by_name.entry(c.meta.name.clone()).or_default().push(c);
    }

    /// Reads PX4's `parameters.json` (see the module docs).
    pub fn parse_px4_json(bytes: &[u8]) -> Result<MetaSet, String> {
        let doc: serde_json::Value =
            serde_json::from_slice(bytes).map_err(|e| format!("not JSON: {e}"))?;
        let root = doc
            .as_object()
            .ok_or("not parameter metadata: the JSON is not an object")?;
        match root.get("version").and_then(serde_json::Value::as_u64) {
            Some(1) => {}
            Some(v) => {
                return Err(format!(
                    "parameter metadata version {v} is not known (1 is)"
                ))
            }
            None => return Err("not parameter metadata: no \"version\"".into()),
        }
        let params = root
            .get("parameters")
            .and_then(serde_json::Value::as_array)
            .ok_or("not parameter metadata: no \"parameters\" list")?;
        let mut set = MetaSet {
            format: MetaFormat::Px4,
            by_name: HashMap::with_capacity(params.len()),
        };
        for p in params {
            if let Some(meta) = px4_json_param(p) {
                set.push(Candidate {
                    meta,
                    vehicle: None,
                    flavor: Flavor::Any,
                });
            }
        }
        Ok(set)
    }

    fn read_ardupilot(&mut self, root: Node) {
        for section in root.children().filter(Node::is_element) {
            let in_vehicles = match section.tag_name().name() {
                "vehicles" => true,
                "libraries" => false,
                _ => continue,
            };
            for block in section.children().filter(|n| n.has_tag_name("parameters")) {
                let group = block.attribute("name").unwrap_or("").to_string();
                let mut in_block: Vec<Candidate> = Vec::new();
                for p in block.children().filter(|n| n.has_tag_name("param")) {
                    if let Some((meta, flavor)) = ardupilot_param(p, &group) {
                        let vehicle = in_vehicles.then(|| group.clone());
                        in_block.push(Candidate {
                            meta,
                            vehicle,
                            flavor,
                        });
                    }
                }
                assign_flavors(&mut in_block);
                for c in in_block {
                    self.push(c);
                }
            }
        }
    }

    fn read_px4(&mut self, root: Node) {
        for group in root.children().filter(|n| n.has_tag_name("group")) {
            let gname = group.attribute("name").unwrap_or("");
            for p in group.children().filter(|n| n.has_tag_name("parameter")) {
                if let Some(meta) = px4_param(p, gname) {
                    self.push(Candidate {
                        meta,
                        vehicle: None,
                        flavor: Flavor::Any,
                    });
                }
            }
        }
    }
}

/// Rule 2 of the module docs: in one block, a name's first unmarked occurrence is the
/// multicopter's and its second the helicopter's. Linear: one map from name to occurrences.
fn assign_flavors(block: &mut [Candidate]) {
    let mut seen: HashMap<&str, Vec<usize>> = HashMap::new();
    for (i, c) in block.iter().enumerate() {
        seen.entry(c.meta.name.as_str()).or_default().push(i);
    }
    let dups: Vec<Vec<usize>> = seen.into_values().filter(|v| v.len() > 1).collect();
    for ix in dups {
        let unmarked: Vec<usize> = ix
            .iter()
            .copied()
            .filter(|&i| block[i].flavor == Flavor::Any)
            .collect();
        let marked_heli = ix.iter().any(|&i| block[i].flavor == Flavor::Heli);
        let marked_multi = ix.iter().any(|&i| block[i].flavor == Flavor::Multi);
        let mut order = unmarked.into_iter();
        if !marked_multi {
            if let Some(i) = order.next() {
                block[i].flavor = Flavor::Multi;
            }
        }
        if !marked_heli {
            if let Some(i) = order.next() {
                block[i].flavor = Flavor::Heli;
            }
        }
    }
}

fn text_of(n: Node) -> String {
    n.text().unwrap_or("").trim().to_string()
}

fn non_empty(s: Option<&str>) -> Option<String> {
    s.map(str::trim)
        .filter(|s| !s.is_empty())
        .map(str::to_string)
}

fn number(s: &str) -> Option<f64> {
    s.trim().parse::<f64>().ok().filter(|v| v.is_finite())
}

fn truthy(s: &str) -> bool {
    matches!(s.trim().to_ascii_lowercase().as_str(), "true" | "1" | "yes")
}

/// `"0 1000"`, `"0.0 1000.0"`, `"-1 to 10"`.
fn parse_range(s: &str) -> Option<(f64, f64)> {
    let parts: Vec<&str> = s.split_whitespace().filter(|t| *t != "to").collect();
    match parts.as_slice() {
        [lo, hi] => Some((number(lo)?, number(hi)?)),
        _ => None,
    }
}

/// `"0:Name,1:Other"` (ArduPilot's `@Values` / `@Bitmask` text).
fn parse_pairs(s: &str) -> Vec<(f64, String)> {
    s.split(',')
        .filter_map(|item| {
            let (code, name) = item.split_once(':')?;
            Some((number(code)?, name.trim().to_string()))
        })
        .collect()
}

fn ardupilot_param(p: Node, group: &str) -> Option<(ParamMeta, Flavor)> {
    let full = p.attribute("name")?;
    let name = full.rsplit(':').next().unwrap_or(full).trim();
    if name.is_empty() {
        return None;
    }
    let mut m = ParamMeta {
        name: name.to_string(),
        human_name: non_empty(p.attribute("humanName")),
        description: p
            .attribute("documentation")
            .unwrap_or("")
            .trim()
            .to_string(),
        user: non_empty(p.attribute("user")),
        group: group.to_string(),
        ..ParamMeta::default()
    };
    let mut path = p.attribute("path").map(str::to_string);
    let mut bitmask_field = None;
    let mut values_field = None;
    for c in p.children().filter(Node::is_element) {
        match c.tag_name().name() {
            "field" => {
                let v = text_of(c);
                match c.attribute("name").unwrap_or("") {
                    "Units" => m.units = non_empty(Some(&v)),
                    "Range" => m.range = parse_range(&v),
                    "Increment" => m.increment = number(&v),
                    "RebootRequired" => m.reboot_required = truthy(&v),
                    "ReadOnly" => m.read_only = truthy(&v),
                    "Bitmask" => bitmask_field = Some(v),
                    "Values" => values_field = Some(v),
                    "path" | "Path" => path = Some(v),
                    _ => {}
                }
            }
            "values" => {
                for v in c.children().filter(|n| n.has_tag_name("value")) {
                    if let Some(code) = v.attribute("code").and_then(number) {
                        m.values.push((code, text_of(v)));
                    }
                }
            }
            "bitmask" => {
                for b in c.children().filter(|n| n.has_tag_name("bit")) {
                    let code = b.attribute("code").or_else(|| b.attribute("index"));
                    if let Some(bit) = code.and_then(|s| s.trim().parse::<u32>().ok()) {
                        m.bits.push((bit, text_of(b)));
                    }
                }
            }
            _ => {}
        }
    }
    if m.bits.is_empty() {
        if let Some(t) = bitmask_field {
            m.bits = parse_pairs(&t)
                .into_iter()
                .filter(|(b, _)| b.fract() == 0.0 && *b >= 0.0 && *b < 64.0)
                .map(|(b, n)| (b as u32, n))
                .collect();
        }
    }
    if m.values.is_empty() {
        if let Some(t) = values_field {
            m.values = parse_pairs(&t);
        }
    }
    let flavor = match path {
        Some(p) if p.contains("Heli") => Flavor::Heli,
        Some(p) if p.contains("Multi") => Flavor::Multi,
        _ => Flavor::Any,
    };
    Some((m, flavor))
}

fn px4_type(s: &str) -> Option<ParamType> {
    Some(match s.trim().to_ascii_uppercase().as_str() {
        "INT32" => ParamType::Int32,
        "FLOAT" => ParamType::Real32,
        "UINT8" => ParamType::Uint8,
        "INT8" => ParamType::Int8,
        "UINT16" => ParamType::Uint16,
        "INT16" => ParamType::Int16,
        "UINT32" => ParamType::Uint32,
        "INT64" => ParamType::Int64,
        "UINT64" => ParamType::Uint64,
        "DOUBLE" => ParamType::Real64,
        _ => return None,
    })
}

fn px4_param(p: Node, group: &str) -> Option<ParamMeta> {
    let name = p.attribute("name")?.trim();
    if name.is_empty() {
        return None;
    }
    let mut m = ParamMeta {
        name: name.to_string(),
        default: p.attribute("default").and_then(number),
        ptype: p.attribute("type").and_then(px4_type),
        user: non_empty(p.attribute("category")),
        group: group.to_string(),
        ..ParamMeta::default()
    };
    let (mut min, mut max) = (None, None);
    for c in p.children().filter(Node::is_element) {
        match c.tag_name().name() {
            "short_desc" => m.human_name = non_empty(Some(&text_of(c))),
            "long_desc" => m.description = text_of(c),
            "min" => min = number(&text_of(c)),
            "max" => max = number(&text_of(c)),
            "unit" => m.units = non_empty(Some(&text_of(c))),
            "decimal" => m.decimals = text_of(c).parse().ok(),
            "increment" => m.increment = number(&text_of(c)),
            "reboot_required" => m.reboot_required = truthy(&text_of(c)),
            "values" => {
                for v in c.children().filter(|n| n.has_tag_name("value")) {
                    if let Some(code) = v.attribute("code").and_then(number) {
                        m.values.push((code, text_of(v)));
                    }
                }
            }
            "bitmask" => {
                for b in c.children().filter(|n| n.has_tag_name("bit")) {
                    let idx = b.attribute("index").or_else(|| b.attribute("code"));
                    if let Some(bit) = idx.and_then(|s| s.trim().parse::<u32>().ok()) {
                        m.bits.push((bit, text_of(b)));
                    }
                }
            }
            _ => {}
        }
    }
    if min.is_some() || max.is_some() {
        m.range = Some((
            min.unwrap_or(f64::NEG_INFINITY),
            max.unwrap_or(f64::INFINITY),
        ));
    }
    Some(m)
}

/// Decompressed metadata files larger than this are refused (PX4's `parameters.json` is ~1 MB).
pub const MAX_JSON: usize = 8 * 1024 * 1024;

/// The xz stream magic (`FD 37 7A 58 5A 00`).
const XZ_MAGIC: &[u8] = &[0xFD, b'7', b'z', b'X', b'Z', 0];

/// A metadata file as it came (`name` is its path or URL): xz-decompressed when it is xz (by its
/// magic, or its name ending in `.xz`), at most `max` bytes either way. A truncated or corrupt
/// stream, or one that inflates past `max`, is an error in words (never a panic, never more
/// than `max` bytes held).
pub fn inflate(name: &str, bytes: &[u8], max: usize) -> Result<Vec<u8>, String> {
    let named = name.to_ascii_lowercase().ends_with(".xz");
    if !bytes.starts_with(XZ_MAGIC) {
        if named {
            return Err(format!("{name} is not xz-compressed data"));
        }
        if bytes.len() > max {
            return Err(format!("{name} is larger than {}: refused", size_text(max)));
        }
        return Ok(bytes.to_vec());
    }
    let mut out = Limited {
        buf: Vec::new(),
        max,
    };
    let mut input = std::io::BufReader::new(bytes);
    match lzma_rs::xz_decompress(&mut input, &mut out) {
        Ok(()) => Ok(out.buf),
        Err(_) if out.buf.len() >= max => Err(format!(
            "{name} inflates to more than {}: refused",
            size_text(max)
        )),
        Err(e) => Err(format!("{name}: corrupt or truncated xz data ({e})")),
    }
}

fn size_text(n: usize) -> String {
    if n >= 1 << 20 {
        format!("{} MB", n >> 20)
    } else {
        format!("{} kB", n >> 10)
    }
}

/// A writer that refuses to hold more than `max` bytes.
struct Limited {
    buf: Vec<u8>,
    max: usize,
}

impl std::io::Write for Limited {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        if self.buf.len() + b.len() > self.max {
            let room = self.max - self.buf.len();
            self.buf.extend_from_slice(&b[..room]);
            return Err(std::io::Error::other("too large"));
        }
        self.buf.extend_from_slice(b);
        Ok(b.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// A number of PX4's JSON: typed, or a string holding one.
fn json_number(v: &serde_json::Value) -> Option<f64> {
    match v {
        serde_json::Value::Number(n) => n.as_f64().filter(|f| f.is_finite()),
        serde_json::Value::String(s) => number(s),
        serde_json::Value::Bool(b) => Some(*b as u8 as f64),
        _ => None,
    }
}

fn json_text(v: Option<&serde_json::Value>) -> Option<String> {
    non_empty(v.and_then(serde_json::Value::as_str))
}

fn px4_json_param(p: &serde_json::Value) -> Option<ParamMeta> {
    let o = p.as_object()?;
    let name = o.get("name")?.as_str()?.trim();
    if name.is_empty() {
        return None;
    }
    let get = |keys: &[&str]| keys.iter().find_map(|k| o.get(*k));
    let mut m = ParamMeta {
        name: name.to_string(),
        human_name: json_text(get(&["shortDesc", "shortDescription"])),
        description: json_text(get(&["longDesc", "longDescription"])).unwrap_or_default(),
        units: json_text(o.get("units")),
        default: get(&["default", "defaultValue"]).and_then(json_number),
        ptype: o.get("type").and_then(|t| t.as_str()).and_then(px4_type),
        increment: o.get("increment").and_then(json_number),
        decimals: o
            .get("decimalPlaces")
            .and_then(json_number)
            .filter(|d| (0.0..=20.0).contains(d))
            .map(|d| d as u8),
        reboot_required: match o.get("rebootRequired") {
            Some(serde_json::Value::Bool(b)) => *b,
            Some(serde_json::Value::String(s)) => truthy(s),
            _ => false,
        },
        user: json_text(o.get("category")),
        group: json_text(o.get("group")).unwrap_or_default(),
        ..ParamMeta::default()
    };
    let min = get(&["min", "minValue"]).and_then(json_number);
    let max = get(&["max", "maxValue"]).and_then(json_number);
    if min.is_some() || max.is_some() {
        m.range = Some((
            min.unwrap_or(f64::NEG_INFINITY),
            max.unwrap_or(f64::INFINITY),
        ));
    }
    for v in o
        .get("values")
        .and_then(|v| v.as_array())
        .into_iter()
        .flatten()
    {
        if let (Some(code), Some(text)) = (
            v.get("value").and_then(json_number),
            v.get("description").and_then(|d| d.as_str()),
        ) {
            m.values.push((code, text.trim().to_string()));
        }
    }
    for b in o
        .get("bitmask")
        .and_then(|v| v.as_array())
        .into_iter()
        .flatten()
    {
        let bit = b
            .get("index")
            .and_then(json_number)
            .filter(|i| i.fract() == 0.0 && (0.0..64.0).contains(i));
        if let (Some(bit), Some(text)) = (bit, b.get("description").and_then(|d| d.as_str())) {
            m.bits.push((bit as u32, text.trim().to_string()));
        }
    }
    Some(m)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn meta_with(values: &[(f64, &str)], bits: &[(u32, &str)]) -> ParamMeta {
        ParamMeta {
            name: "X".into(),
            values: values.iter().map(|(c, n)| (*c, n.to_string())).collect(),
            bits: bits.iter().map(|(b, n)| (*b, n.to_string())).collect(),
            range: Some((0.0, 10.0)),
            ..ParamMeta::default()
        }
    }

    #[test]
    fn values_and_bits_read_and_written() {
        let e = meta_with(&[(0.0, "Disabled"), (1.0, "Enabled"), (-1.0, "Auto")], &[]);
        assert_eq!(e.value_name(1.0), Some("Enabled"));
        assert_eq!(e.value_name(2.0), None);
        assert_eq!(e.parse_value("enabled"), Some(1.0));
        assert_eq!(e.parse_value(" AUTO "), Some(-1.0));
        assert_eq!(e.parse_value("Enab"), None);
        assert_eq!(e.parse_value("7"), Some(7.0));
        assert_eq!(e.parse_value("nan"), None);
        let b = meta_with(&[], &[(0, "GPS"), (3, "Baro"), (4, "Mag+Compass")]);
        assert_eq!(b.bits_set(9.0), vec!["GPS", "Baro"]);
        assert_eq!(b.bits_set(0.0), Vec::<&str>::new());
        assert_eq!(b.parse_value("gps+baro"), Some(9.0));
        assert_eq!(b.parse_value("GPS, Baro"), Some(9.0));
        assert_eq!(b.parse_value("GPS|GPS"), Some(1.0));
        assert_eq!(b.parse_value("mag+compass"), Some(16.0));
        assert_eq!(b.parse_value("GPS+Nope"), None);
        assert_eq!(b.parse_value(""), None);
    }

    #[test]
    fn range_is_checked() {
        let m = meta_with(&[], &[]);
        assert!(m.check_range(0.0).is_ok());
        assert!(m.check_range(10.0).is_ok());
        assert_eq!(
            m.check_range(11.0).unwrap_err(),
            "11 is outside X's range 0 to 10"
        );
        assert!(m.check_range(f64::NAN).is_err());
        let open = ParamMeta {
            range: Some((1.0, f64::INFINITY)),
            ..m.clone()
        };
        assert!(open.check_range(1e30).is_ok());
        assert_eq!(
            open.check_range(0.5).unwrap_err(),
            "0.5 is outside X's range 1 to …"
        );
        let none = ParamMeta { range: None, ..m };
        assert!(none.check_range(-1e9).is_ok());
    }

    #[test]
    fn ranges_and_pairs_parse() {
        assert_eq!(parse_range("0 1000"), Some((0.0, 1000.0)));
        assert_eq!(parse_range(" 0.0  1000.0 "), Some((0.0, 1000.0)));
        assert_eq!(parse_range("-1 to 10"), Some((-1.0, 10.0)));
        assert_eq!(parse_range("0"), None);
        assert_eq!(parse_range("a b"), None);
        assert_eq!(
            parse_pairs("0:Feedback from mid stick,1: High throttle cancels landing"),
            vec![
                (0.0, "Feedback from mid stick".to_string()),
                (1.0, "High throttle cancels landing".to_string())
            ]
        );
    }

    #[test]
    fn variants_from_mav_type() {
        assert_eq!(Variant::from_mav_type(2), Variant::Multicopter);
        assert_eq!(Variant::from_mav_type(4), Variant::Helicopter);
        assert_eq!(Variant::from_mav_type(1), Variant::Plane);
        assert_eq!(Variant::from_mav_type(20), Variant::Plane);
        assert_eq!(Variant::from_mav_type(10), Variant::Rover);
        assert_eq!(Variant::from_mav_type(11), Variant::Rover);
        assert_eq!(Variant::from_mav_type(12), Variant::Sub);
        assert_eq!(Variant::from_mav_type(6), Variant::Unknown);
    }

    #[test]
    fn malformed_xml_is_an_error_with_a_place() {
        let e = MetaSet::parse("<paramfile>\n  <vehicles>\n</paramfile>").unwrap_err();
        assert_eq!(e.line, 3);
        assert!(e.to_string().starts_with("line 3, column"), "{e}");
        let e = MetaSet::parse("<?xml version=\"1.0\"?>\n<params/>").unwrap_err();
        assert_eq!((e.line, e.column), (2, 1));
        assert!(MetaSet::parse("").is_err());
        assert!(MetaSet::parse("not xml at all").is_err());
    }

    /// Made by tests/py/make_px4_metadata.py with Python's json and lzma modules.
    const PX4_JSON: &[u8] = include_bytes!("../../tests/data/param-meta/px4/parameters.json");
    const PX4_XZ: &[u8] = include_bytes!("../../tests/data/param-meta/px4/parameters.json.xz");

    #[test]
    fn px4_json_maps_to_the_metadata_model() {
        let json = inflate("etc/extras/parameters.json.xz", PX4_XZ, MAX_JSON).unwrap();
        assert_eq!(json, PX4_JSON, "Python's lzma stream inflates to its JSON");
        let set = MetaSet::parse_px4_json(&json).unwrap();
        assert_eq!(set.format, MetaFormat::Px4);
        assert_eq!(set.len(), 5);
        let v = set.get("MPC_XY_VEL_MAX", Variant::Multicopter).unwrap();
        assert_eq!(v.human_name.as_deref(), Some("Maximum horizontal velocity"));
        assert_eq!(
            v.description,
            "Absolute maximum for all velocity controlled modes."
        );
        assert_eq!(v.units.as_deref(), Some("m/s"));
        assert_eq!(v.range, Some((0.0, 20.0)));
        assert_eq!(v.default, Some(12.0));
        assert_eq!(v.decimals, Some(1));
        assert_eq!(v.increment, Some(1.0));
        assert_eq!(v.ptype, Some(ParamType::Real32));
        assert_eq!(v.group, "Multicopter Position Control");
        assert_eq!(v.user.as_deref(), Some("Standard"));
        assert!(!v.reboot_required);
        let e = set.get("COM_RC_IN_MODE", Variant::Unknown).unwrap();
        assert_eq!(e.ptype, Some(ParamType::Int32));
        assert_eq!(e.value_name(3.0), Some("RC or Joystick keep first"));
        assert_eq!(e.values.len(), 5);
        assert_eq!(e.units, None, "no units key");
        let b = set.get("SDLOG_PROFILE", Variant::Unknown).unwrap();
        assert!(b.reboot_required);
        assert_eq!(
            b.bits_set(3.0),
            vec![
                "Default set (general log analysis)",
                "Estimator replay (EKF2)"
            ]
        );
        // jsonout.py writes the numbers of types other than Float and Int32 as strings.
        let u = set.get("UAVCAN_NODE_ID", Variant::Unknown).unwrap();
        assert_eq!(u.ptype, Some(ParamType::Uint8));
        assert_eq!((u.default, u.range), (Some(1.0), Some((1.0, 125.0))));
        assert_eq!(u.user.as_deref(), Some("System"));
        // The older generator's keys.
        let old = MetaSet::parse_px4_json(
            br#"{"version":1,"parameters":[{"name":"A","shortDescription":"s","longDescription":"l","defaultValue":2,"minValue":1,"maxValue":3},{"noname":1},{"name":""}]}"#,
        )
        .unwrap();
        assert_eq!(old.len(), 1);
        let a = old.get("A", Variant::Unknown).unwrap();
        assert_eq!(
            (a.human_name.as_deref(), a.description.as_str()),
            (Some("s"), "l")
        );
        assert_eq!((a.default, a.range), (Some(2.0), Some((1.0, 3.0))));
    }

    #[test]
    fn px4_json_that_is_not_metadata_is_an_error() {
        let e = |b: &[u8]| MetaSet::parse_px4_json(b).unwrap_err();
        assert!(e(b"").starts_with("not JSON: "));
        assert!(e(b"[1]").contains("not an object"));
        assert!(e(br#"{"parameters":[]}"#).contains("no \"version\""));
        assert_eq!(
            e(br#"{"version":2,"parameters":[]}"#),
            "parameter metadata version 2 is not known (1 is)"
        );
        assert!(e(br#"{"version":1}"#).contains("no \"parameters\" list"));
    }

    #[test]
    fn truncated_or_corrupt_xz_is_told_never_a_panic() {
        let name = "parameters.json.xz";
        for cut in [6, 12, 40, PX4_XZ.len() / 2, PX4_XZ.len() - 1] {
            let e = inflate(name, &PX4_XZ[..cut], MAX_JSON).unwrap_err();
            assert!(
                e.starts_with("parameters.json.xz: corrupt or truncated xz data"),
                "{cut}: {e}"
            );
        }
        for at in [20, PX4_XZ.len() / 2, PX4_XZ.len() - 6] {
            let mut bad = PX4_XZ.to_vec();
            bad[at] ^= 0x55;
            let e = inflate(name, &bad, MAX_JSON).unwrap_err();
            assert!(e.contains("corrupt or truncated"), "{at}: {e}");
        }
        // Not xz at all, though named so; and plain JSON passes as it is.
        assert_eq!(
            inflate(name, b"{}", MAX_JSON).unwrap_err(),
            "parameters.json.xz is not xz-compressed data"
        );
        assert_eq!(inflate("p.json", b"{}", MAX_JSON).unwrap(), b"{}");
        // A stream that inflates past the limit stops there, and says so.
        let e = inflate(name, PX4_XZ, 1024).unwrap_err();
        assert_eq!(e, "parameters.json.xz inflates to more than 1 kB: refused");
        assert!(inflate("p.json", &[b' '; 2000], 1000).is_err());
    }

    #[test]
    fn many_parameters_parse_in_linear_time() {
        // 20,000 parameters, one block, every name twice: quadratic code would show here.
        let mut xml =
            String::from("<paramfile><vehicles></vehicles><libraries><parameters name=\"L_\">");
        for round in 0..2 {
            for i in 0..10_000 {
                xml.push_str(&format!(
                    "<param name=\"P{i}\" humanName=\"h{round}\" documentation=\"d\"><field name=\"Range\">0 {i}</field></param>"
                ));
            }
        }
        xml.push_str("</parameters></libraries></paramfile>");
        let set = MetaSet::parse(&xml).unwrap();
        assert_eq!(set.len(), 10_000);
        let m = set.get("P42", Variant::Helicopter).unwrap();
        assert_eq!(m.human_name.as_deref(), Some("h1"));
        assert_eq!(m.range, Some((0.0, 42.0)));
        assert_eq!(
            set.get("P42", Variant::Multicopter)
                .unwrap()
                .human_name
                .as_deref(),
            Some("h0")
        );
    }
}
