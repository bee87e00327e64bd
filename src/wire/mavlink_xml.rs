//! The dialect's definitions as the MAVLink project writes them: the message definition XML files
//! the dialect is generated from (`ardupilotmega.xml` and every file it includes, in
//! `assets/mavlink/`, embedded at build time), read at first use. What the generated code leaves
//! out comes from here: each field's units and `invalid` value, each MAV_CMD's description and
//! its parameters' labels, units, enums, ranges and defaults.
//!
//! Bad or missing text never fails: an element that cannot be read is left out.

use std::collections::HashMap;
use std::sync::OnceLock;

/// The files, each as shipped by the MAVLink project (see `assets/mavlink/COPYING`).
const FILES: &[(&str, &str)] = &[
    (
        "ardupilotmega.xml",
        include_str!("../../assets/mavlink/ardupilotmega.xml"),
    ),
    (
        "common.xml",
        include_str!("../../assets/mavlink/common.xml"),
    ),
    (
        "standard.xml",
        include_str!("../../assets/mavlink/standard.xml"),
    ),
    (
        "minimal.xml",
        include_str!("../../assets/mavlink/minimal.xml"),
    ),
    (
        "uAvionix.xml",
        include_str!("../../assets/mavlink/uAvionix.xml"),
    ),
    (
        "icarous.xml",
        include_str!("../../assets/mavlink/icarous.xml"),
    ),
    (
        "loweheiser.xml",
        include_str!("../../assets/mavlink/loweheiser.xml"),
    ),
    (
        "cubepilot.xml",
        include_str!("../../assets/mavlink/cubepilot.xml"),
    ),
    (
        "csAirLink.xml",
        include_str!("../../assets/mavlink/csAirLink.xml"),
    ),
];

/// One field of a message.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FieldDef {
    /// As the generated code names it (`type` is `mavtype` there).
    pub name: String,
    /// The wire type (`int32_t`, `char[50]`).
    pub ty: String,
    /// `degE7`, `cm/s`…; empty when none is given.
    pub units: String,
    /// The enum its values are of; empty when none.
    pub enum_name: String,
    /// The value that means "not known" (`INT16_MAX`, `0`…); empty when none.
    pub invalid: String,
    pub description: String,
}

/// One message.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MessageDef {
    pub id: u32,
    pub name: String,
    pub description: String,
    pub fields: Vec<FieldDef>,
}

impl MessageDef {
    /// The field named `name` (as the generated code names it).
    pub fn field(&self, name: &str) -> Option<&FieldDef> {
        self.fields.iter().find(|f| f.name == name)
    }
}

/// One parameter of a MAV_CMD.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ParamDef {
    /// 1..=7.
    pub index: u8,
    /// Empty when none is given.
    pub label: String,
    pub units: String,
    pub enum_name: String,
    pub description: String,
    pub min: Option<f64>,
    pub max: Option<f64>,
    pub increment: Option<f64>,
    /// The `default` attribute (`NaN`, `0`).
    pub default: Option<f64>,
    /// Marked `reserved="true"`.
    pub reserved: bool,
}

/// One entry of an enum; of MAV_CMD, a command with its parameters.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct EntryDef {
    pub value: u64,
    pub name: String,
    pub description: String,
    /// The parameters listed, by index (MAV_CMD entries only).
    pub params: Vec<ParamDef>,
    pub has_location: bool,
}

impl EntryDef {
    /// Parameter `index` (1..=7) as listed, if it is.
    pub fn param(&self, index: u8) -> Option<&ParamDef> {
        self.params.iter().find(|p| p.index == index)
    }
}

/// One enum, its entries from every file that adds to it.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct EnumDef {
    pub name: String,
    pub bitmask: bool,
    pub description: String,
    pub entries: Vec<EntryDef>,
}

/// Every message and enum of the dialect.
#[derive(Debug, Clone, Default)]
pub struct Definitions {
    messages: HashMap<String, MessageDef>,
    enums: HashMap<String, EnumDef>,
    /// MAV_CMD entries by value: an index into `enums["MAV_CMD"].entries`.
    commands: HashMap<u64, usize>,
}

/// The definitions of the files embedded, read once.
pub fn definitions() -> &'static Definitions {
    static DEFS: OnceLock<Definitions> = OnceLock::new();
    DEFS.get_or_init(|| {
        let mut d = Definitions::default();
        for (_, text) in FILES {
            d.add_file(text);
        }
        d.index();
        d
    })
}

impl Definitions {
    /// The message named `name` (`GLOBAL_POSITION_INT`).
    pub fn message(&self, name: &str) -> Option<&MessageDef> {
        self.messages.get(name)
    }

    /// The enum named `name` (`MAV_CMD`).
    pub fn enum_def(&self, name: &str) -> Option<&EnumDef> {
        self.enums.get(name)
    }

    /// The MAV_CMD numbered `command`.
    pub fn command(&self, command: u32) -> Option<&EntryDef> {
        let i = *self.commands.get(&(command as u64))?;
        self.enums.get("MAV_CMD")?.entries.get(i)
    }

    /// Every message and enum of one file's text, added to those read before. Text that is not
    /// XML adds nothing.
    pub fn add_file(&mut self, text: &str) {
        let Ok(doc) = roxmltree::Document::parse(text) else {
            return;
        };
        let root = doc.root_element();
        for section in root.children().filter(|n| n.is_element()) {
            match section.tag_name().name() {
                "enums" => {
                    for e in section.children().filter(|n| n.has_tag_name("enum")) {
                        self.add_enum(e);
                    }
                }
                "messages" => {
                    for m in section.children().filter(|n| n.has_tag_name("message")) {
                        if let Some(m) = message(m) {
                            self.messages.entry(m.name.clone()).or_insert(m);
                        }
                    }
                }
                _ => {}
            }
        }
    }

    fn add_enum(&mut self, node: roxmltree::Node) {
        let Some(name) = node.attribute("name") else {
            return;
        };
        let def = self
            .enums
            .entry(name.to_string())
            .or_insert_with(|| EnumDef {
                name: name.to_string(),
                ..EnumDef::default()
            });
        def.bitmask |= node.attribute("bitmask") == Some("true");
        if def.description.is_empty() {
            def.description = child_text(node, "description");
        }
        for e in node.children().filter(|n| n.has_tag_name("entry")) {
            let (Some(name), Some(value)) = (e.attribute("name"), e.attribute("value")) else {
                continue;
            };
            let Some(value) = parse_value(value) else {
                continue;
            };
            if def.entries.iter().any(|x| x.value == value) {
                continue;
            }
            let params = e
                .children()
                .filter(|n| n.has_tag_name("param"))
                .filter_map(param)
                .collect();
            def.entries.push(EntryDef {
                value,
                name: name.to_string(),
                description: child_text(e, "description"),
                params,
                has_location: e.attribute("hasLocation") == Some("true"),
            });
        }
    }

    fn index(&mut self) {
        if let Some(cmds) = self.enums.get("MAV_CMD") {
            self.commands = cmds
                .entries
                .iter()
                .enumerate()
                .map(|(i, e)| (e.value, i))
                .collect();
        }
    }
}

fn message(node: roxmltree::Node) -> Option<MessageDef> {
    let name = node.attribute("name")?.to_string();
    let id = node.attribute("id")?.trim().parse().ok()?;
    let fields = node
        .children()
        .filter(|n| n.has_tag_name("field"))
        .filter_map(|f| {
            let name = f.attribute("name")?;
            Some(FieldDef {
                name: if name == "type" { "mavtype" } else { name }.to_string(),
                ty: f.attribute("type").unwrap_or_default().to_string(),
                units: f.attribute("units").unwrap_or_default().to_string(),
                enum_name: f.attribute("enum").unwrap_or_default().to_string(),
                invalid: f.attribute("invalid").unwrap_or_default().to_string(),
                description: text_of(f),
            })
        })
        .collect();
    Some(MessageDef {
        id,
        name,
        description: child_text(node, "description"),
        fields,
    })
}

fn param(node: roxmltree::Node) -> Option<ParamDef> {
    let index: u8 = node.attribute("index")?.trim().parse().ok()?;
    if !(1..=7).contains(&index) {
        return None;
    }
    let num = |a: &str| node.attribute(a).and_then(parse_number);
    Some(ParamDef {
        index,
        label: node.attribute("label").unwrap_or_default().to_string(),
        units: node.attribute("units").unwrap_or_default().to_string(),
        enum_name: node.attribute("enum").unwrap_or_default().to_string(),
        description: text_of(node),
        min: num("minValue"),
        max: num("maxValue"),
        increment: num("increment"),
        default: num("default"),
        reserved: node
            .attribute("reserved")
            .is_some_and(|r| r.eq_ignore_ascii_case("true")),
    })
}

/// `NaN`, `-1`, `0.5`.
pub fn parse_number(text: &str) -> Option<f64> {
    let t = text.trim();
    if t.eq_ignore_ascii_case("nan") {
        return Some(f64::NAN);
    }
    t.parse().ok()
}

/// An entry's value: decimal, `0x..` hex, or `2**N`.
fn parse_value(text: &str) -> Option<u64> {
    let t = text.trim();
    if let Some(hex) = t.strip_prefix("0x").or_else(|| t.strip_prefix("0X")) {
        return u64::from_str_radix(hex, 16).ok();
    }
    if let Some(exp) = t.strip_prefix("2**") {
        return 1u64.checked_shl(exp.parse().ok()?);
    }
    t.parse().ok()
}

/// The text of `node`'s child `tag`, its whitespace folded.
fn child_text(node: roxmltree::Node, tag: &str) -> String {
    node.children()
        .find(|n| n.has_tag_name(tag))
        .map(text_of)
        .unwrap_or_default()
}

/// The text in `node`, its whitespace folded to single spaces.
fn text_of(node: roxmltree::Node) -> String {
    let mut s = String::new();
    for t in node.descendants().filter(|n| n.is_text()) {
        for word in t.text().unwrap_or_default().split_whitespace() {
            if !s.is_empty() {
                s.push(' ');
            }
            s.push_str(word);
        }
    }
    s
}

/// A value of a field whose `invalid` attribute is `invalid` (`INT16_MAX`, `0`, `-1`):
/// whether `value` (as the field's text) is that value.
pub fn is_invalid(invalid: &str, value: &str) -> bool {
    let want = match invalid.trim() {
        "" => return false,
        "INT8_MAX" => i8::MAX as f64,
        "UINT8_MAX" => u8::MAX as f64,
        "INT16_MAX" => i16::MAX as f64,
        "UINT16_MAX" => u16::MAX as f64,
        "INT32_MAX" => i32::MAX as f64,
        "UINT32_MAX" => u32::MAX as f64,
        "NaN" | "NAN" | "nan" => return value.trim().eq_ignore_ascii_case("nan"),
        other => match parse_value(other)
            .map(|v| v as f64)
            .or_else(|| parse_number(other))
        {
            Some(v) => v,
            None => return false,
        },
    };
    value.trim().parse::<f64>() == Ok(want)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_file_is_read_with_units_and_commands() {
        let d = definitions();
        let gpi = d.message("GLOBAL_POSITION_INT").unwrap();
        assert_eq!(gpi.id, 33);
        assert_eq!(gpi.field("lat").unwrap().units, "degE7");
        assert_eq!(gpi.field("vx").unwrap().units, "cm/s");
        assert_eq!(gpi.field("hdg").unwrap().units, "cdeg");
        // `type` is `mavtype`, as in the generated code.
        assert!(d.message("HEARTBEAT").unwrap().field("mavtype").is_some());
        // From ardupilotmega.xml and its includes.
        assert!(d.message("AHRS2").is_some());
        assert!(d.message("CUBEPILOT_RAW_RC").is_some());
        let speed = d.command(178).unwrap();
        assert_eq!(speed.name, "MAV_CMD_DO_CHANGE_SPEED");
        assert_eq!(speed.param(3).unwrap().label, "Throttle");
        assert_eq!(speed.param(4).unwrap().default, Some(0.0));
        assert!(speed.param(4).unwrap().reserved);
        let capture = d.command(2000).unwrap();
        assert!(capture.param(7).unwrap().default.unwrap().is_nan());
        // ArduPilot's own commands.
        assert!(d.command(42428).is_some(), "MAV_CMD_DO_SEND_BANNER");
        assert!(d.enum_def("SPEED_TYPE").unwrap().entries.len() >= 2);
    }

    #[test]
    fn bad_text_adds_nothing_and_values_parse() {
        let mut d = Definitions::default();
        d.add_file("not xml <");
        d.add_file("<mavlink><messages><message name=\"X\"/></messages></mavlink>");
        assert!(d.message("X").is_none());
        assert_eq!(parse_value("0x10"), Some(16));
        assert_eq!(parse_value("2**3"), Some(8));
        assert_eq!(parse_value("2**99"), None);
        assert!(parse_number("NaN").unwrap().is_nan());
        assert!(is_invalid("INT16_MAX", "32767"));
        assert!(is_invalid("0", "0"));
        assert!(is_invalid("0xFFFF", "65535"));
        assert!(!is_invalid("", "0"));
        assert!(!is_invalid("-1", "1"));
    }
}
