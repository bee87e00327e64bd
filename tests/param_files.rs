//! Parameter files and parameter metadata against fixtures written in the real formats:
//! `tests/data/params/qgc.params` (QGroundControl `writeParametersToStream`),
//! `mavproxy.parm` (pymavlink `mavparm.py` `save()`: `"%-16.16s %f\n"`, sorted), `bad.parm`,
//! `apm.pdef.xml` (ArduPilot `xmlemit.py`), `px4-parameters.xml` (PX4 `xmlout.py`), and the real
//! ArduCopter download `tests/data/copter-params.parm`. Expected values are written out by hand
//! from the fixtures.

use std::path::PathBuf;

use mavterm::params::file::{self, Changed, Format, Header, Saved};
use mavterm::params::meta::{MetaFormat, MetaSet, Variant};
use mavterm::params::value::{self, ParamType};

fn data(name: &str) -> String {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name);
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

fn nv(f: &file::ParamFile) -> Vec<(&str, f64)> {
    f.params
        .iter()
        .map(|p| (p.name.as_str(), p.value))
        .collect()
}

#[test]
fn qgc_fixture_is_read_with_types_and_ids() {
    let f = file::parse(&data("params/qgc.params"));
    assert_eq!(f.format, Format::Qgc);
    assert!(f.errors.is_empty(), "{:?}", f.errors);
    assert_eq!(
        nv(&f),
        vec![
            ("ACRO_BAL_PITCH", 1.0),
            ("ACRO_RP_EXPO", 0.3f32 as f64), // 0.300000011920928955: the float, widened
            ("ACRO_TRAINER", 2.0),
            ("ANGLE_MAX", 3000.0),
            ("ATC_RAT_RLL_P", 0.135f32 as f64), // 0.135000005364418030
            ("FRAME_CLASS", 1.0),
            ("LOG_BITMASK", 176126.0),
            ("PILOT_TKOFF_ALT", 0.0),
            ("WPNAV_SPEED", 1000.0),
        ]
    );
    use ParamType::*;
    let types: Vec<ParamType> = f.params.iter().map(|p| p.ptype.unwrap()).collect();
    assert_eq!(
        types,
        vec![Real32, Real32, Int8, Int16, Real32, Int8, Int32, Real32, Real32]
    );
    assert!(f
        .params
        .iter()
        .all(|p| p.system == Some(1) && p.component == Some(1)));
    // Eight header lines, data from line 9.
    assert_eq!(f.params[0].line, 9);
    assert_eq!(f.params[8].line, 17);
}

#[test]
fn mavproxy_fixture_is_read() {
    let f = file::parse(&data("params/mavproxy.parm"));
    assert_eq!(f.format, Format::Parm);
    assert!(f.errors.is_empty(), "{:?}", f.errors);
    assert_eq!(
        nv(&f),
        vec![
            ("ACRO_BAL_PITCH", 1.0),
            ("ACRO_RP_EXPO", 0.3),
            ("ACRO_TRAINER", 1.0),
            ("ANGLE_MAX", 4500.0),
            ("ATC_RAT_RLL_P", 0.135),
            ("FENCE_ENABLE", 1.0),
            ("FRAME_CLASS", 1.0),
            ("LOG_BITMASK", 176126.0),
            ("PILOT_TKOFF_ALT", 0.0),
        ]
    );
    assert!(f
        .params
        .iter()
        .all(|p| p.ptype.is_none() && p.component.is_none()));
}

#[test]
fn mission_planner_comma_form_is_read() {
    // As in QGroundControl's own ParameterEditorControllerTest fixture for Mission Planner files.
    let f = file::parse("# Mission Planner parameter file\nSYS_AUTOSTART,4002\n");
    assert_eq!(f.format, Format::Parm);
    assert!(f.errors.is_empty());
    assert_eq!(nv(&f), vec![("SYS_AUTOSTART", 4002.0)]);
}

#[test]
fn real_copter_download_is_read_whole() {
    // `NAME VALUE` with one space: not MAVProxy's padded %f layout, but the same format.
    let f = file::parse(&data("copter-params.parm"));
    assert_eq!(f.format, Format::Parm);
    assert!(
        f.errors.is_empty(),
        "{:?}",
        &f.errors[..f.errors.len().min(3)]
    );
    assert_eq!(f.params.len(), 1354);
    assert_eq!(f.get("ACRO_BAL_PITCH").map(|p| p.value), Some(1.0));
    assert_eq!(f.get("ACRO_RP_EXPO").map(|p| p.value), Some(0.3));
    assert_eq!(f.get("ACRO_Y_RATE").map(|p| p.value), Some(202.5));
    assert_eq!(f.get("ANGLE_MAX").map(|p| p.value), Some(3000.0));
    assert_eq!(f.get("ARMING_ACCTHRESH").map(|p| p.value), Some(0.75));
    assert_eq!(f.params[0].line, 1);
}

#[test]
fn bad_lines_are_reported_with_line_numbers_and_good_lines_kept() {
    let f = file::parse(&data("params/bad.parm"));
    assert_eq!(f.format, Format::Parm);
    assert_eq!(
        nv(&f),
        vec![
            ("ACRO_BAL_PITCH", 1.0),
            ("ANGLE_MAX", 3000.0),
            ("LOG_BITMASK", 176126.0)
        ]
    );
    let lines: Vec<usize> = f.params.iter().map(|p| p.line).collect();
    assert_eq!(lines, vec![2, 4, 8]);
    let errs: Vec<(usize, &str)> = f.errors.iter().map(|e| (e.line, e.text.as_str())).collect();
    assert_eq!(
        errs,
        vec![
            (3, "ACRO_RP_EXPO"),
            (5, "ATC_RAT_RLL_P zero"),
            (6, "THIS_IS_A_VERY_LONG_NAME 1"),
            (7, "FRAME-CLASS 1"),
            (9, "ANGLE_MAX 4500"),
            (10, "WPNAV_SPEED 1e400"),
            (11, "PILOT_TKOFF_ALT 1 2"),
        ]
    );
    assert!(f
        .errors
        .iter()
        .all(|e| e.to_string().starts_with(&format!("line {}: ", e.line))));
}

fn saved(f: &file::ParamFile) -> Vec<Saved<'_>> {
    f.params
        .iter()
        .map(|p| Saved {
            name: &p.name,
            value: p.value,
            ptype: p.ptype.unwrap(),
            component: p.component.unwrap(),
        })
        .collect()
}

fn qgc_header() -> Header {
    Header {
        sysid: 1,
        stack: "ArduPilot".into(),
        vehicle: "Multi-Rotor".into(),
        version: "4.7.0 dev".into(),
        git_revision: "8a0ba7ff".into(),
    }
}

#[test]
fn qgc_fixture_is_written_back_byte_for_byte() {
    let text = data("params/qgc.params");
    let f = file::parse(&text);
    // Shuffled input: the writer sorts by component, then name.
    let mut params = saved(&f);
    params.reverse();
    assert_eq!(file::write(Format::Qgc, &params, &qgc_header()), text);
}

#[test]
fn parm_is_written_in_mavproxy_layout_with_shortest_values() {
    let f = file::parse(&data("params/qgc.params"));
    let text = file::write(Format::Parm, &saved(&f), &Header::default());
    assert_eq!(
        text,
        "ACRO_BAL_PITCH   1\n\
         ACRO_RP_EXPO     0.3\n\
         ACRO_TRAINER     2\n\
         ANGLE_MAX        3000\n\
         ATC_RAT_RLL_P    0.135\n\
         FRAME_CLASS      1\n\
         LOG_BITMASK      176126\n\
         PILOT_TKOFF_ALT  0\n\
         WPNAV_SPEED      1000\n"
    );
}

#[test]
fn both_formats_round_trip() {
    let f = file::parse(&data("params/qgc.params"));
    let original = saved(&f);
    for format in [Format::Parm, Format::Qgc] {
        let back = file::parse(&file::write(format, &original, &qgc_header()));
        assert_eq!(back.format, format);
        assert!(back.errors.is_empty(), "{format:?}: {:?}", back.errors);
        assert_eq!(back.params.len(), original.len());
        for (o, b) in original.iter().zip(&back.params) {
            assert_eq!(o.name, b.name);
            assert!(
                value::same(o.value, b.value, o.ptype),
                "{format:?} {}",
                o.name
            );
        }
        // And nothing differs.
        let d = file::diff(&original, &back);
        assert!(d.changed.is_empty() && d.only_file.is_empty() && d.only_vehicle.is_empty());
        assert_eq!(d.same, original.len());
    }
}

#[test]
fn diff_of_a_known_pair() {
    let vehicle_file = file::parse(&data("params/qgc.params"));
    let vehicle = saved(&vehicle_file);
    let other = file::parse(&data("params/mavproxy.parm"));
    let d = file::diff(&vehicle, &other);
    assert_eq!(
        d.changed,
        vec![
            Changed {
                name: "ACRO_TRAINER".into(),
                component: 1,
                ptype: ParamType::Int8,
                vehicle: 2.0,
                file: 1.0
            },
            Changed {
                name: "ANGLE_MAX".into(),
                component: 1,
                ptype: ParamType::Int16,
                vehicle: 3000.0,
                file: 4500.0
            },
        ]
    );
    assert_eq!(d.only_vehicle, vec!["WPNAV_SPEED".to_string()]);
    assert_eq!(d.only_file, vec!["FENCE_ENABLE".to_string()]);
    // ACRO_BAL_PITCH, ACRO_RP_EXPO (0.300000 is 0.3 as f32), ATC_RAT_RLL_P, FRAME_CLASS,
    // LOG_BITMASK, PILOT_TKOFF_ALT.
    assert_eq!(d.same, 6);
}

#[test]
fn ardupilot_metadata_fixture() {
    let set = MetaSet::parse(&data("params/apm.pdef.xml")).unwrap();
    assert_eq!(set.format, MetaFormat::ArduPilot);
    // PILOT_TKOFF_ALT, PILOT_THR_BHV, FRAME_CLASS, ANGLE_MAX, ATC_SLEW_YAW, ATC_RAT_RLL_P,
    // ATC_HOVR_ROL_TRM, STAT_BOOTCNT.
    assert_eq!(set.len(), 8);
    let hint = Variant::Multicopter;

    let m = set.get("PILOT_TKOFF_ALT", hint).unwrap();
    assert_eq!(m.name, "PILOT_TKOFF_ALT");
    assert_eq!(m.human_name.as_deref(), Some("Pilot takeoff altitude"));
    assert_eq!(
        m.description,
        "Altitude that altitude control modes will climb to when a takeoff is triggered with the throttle stick."
    );
    assert_eq!(m.units.as_deref(), Some("cm"));
    assert_eq!(m.range, Some((0.0, 1000.0)));
    assert_eq!(m.increment, Some(10.0));
    assert!(!m.reboot_required && !m.read_only);
    assert!(m.values.is_empty() && m.bits.is_empty());
    assert_eq!(m.user.as_deref(), Some("Standard"));
    assert_eq!(m.group, "ArduCopter");
    assert_eq!(m.default, None);
    assert!(m.check_range(1000.0).is_ok());
    assert!(m.check_range(1001.0).is_err());

    let m = set.get("PILOT_THR_BHV", hint).unwrap();
    assert_eq!(
        m.bits,
        vec![
            (0, "Feedback from mid stick".to_string()),
            (1, "High throttle cancels landing".to_string()),
            (2, "Disarm on land detection".to_string()),
        ]
    );
    assert!(m.description.contains("PILOT_THR_BHV to \"1\""));
    assert_eq!(
        m.bits_set(5.0),
        vec!["Feedback from mid stick", "Disarm on land detection"]
    );
    assert_eq!(
        m.parse_value("feedback from mid stick + disarm on land detection"),
        Some(5.0)
    );
    assert_eq!(m.parse_value("High throttle cancels landing"), Some(2.0));

    let m = set.get("FRAME_CLASS", hint).unwrap();
    assert!(m.reboot_required);
    assert_eq!(
        m.values,
        vec![
            (0.0, "Undefined".to_string()),
            (1.0, "Quad".to_string()),
            (2.0, "Hexa".to_string()),
            (6.0, "Heli".to_string()),
        ]
    );
    assert_eq!(m.value_name(6.0), Some("Heli"));
    assert_eq!(m.parse_value("hexa"), Some(2.0));
    assert_eq!(m.range, None);

    // Fields in another order.
    let m = set.get("ANGLE_MAX", hint).unwrap();
    assert_eq!(
        (m.units.as_deref(), m.range, m.increment),
        (Some("cdeg"), Some((1000.0, 8000.0)), Some(10.0))
    );
    assert_eq!(m.user.as_deref(), Some("Advanced"));

    let m = set.get("STAT_BOOTCNT", hint).unwrap();
    assert!(m.read_only);
    assert_eq!(m.group, "STAT");

    let m = set.get("ATC_SLEW_YAW", Variant::Helicopter).unwrap();
    assert_eq!(m.range, Some((500.0, 18000.0)));
    assert_eq!(m.units.as_deref(), Some("cdeg/s"));
    assert_eq!(m.group, "ATC_");

    assert!(set.get("NO_SUCH_PARAM", hint).is_none());
}

#[test]
fn ardupilot_multicopter_and_heli_duplicates_follow_the_vehicle() {
    let set = MetaSet::parse(&data("params/apm.pdef.xml")).unwrap();
    assert_eq!(set.all("ATC_RAT_RLL_P").count(), 2);
    let multi = set.get("ATC_RAT_RLL_P", Variant::Multicopter).unwrap();
    assert_eq!(
        (multi.range, multi.increment),
        (Some((0.01, 0.5)), Some(0.005))
    );
    let heli = set.get("ATC_RAT_RLL_P", Variant::Helicopter).unwrap();
    assert_eq!(
        (heli.range, heli.increment),
        (Some((0.0, 0.35)), Some(0.001))
    );
    // MAV_TYPE 4 is a helicopter; 2 a quadrotor; without a vehicle, the multicopter's.
    assert_eq!(
        set.get("ATC_RAT_RLL_P", Variant::from_mav_type(4)),
        Some(heli)
    );
    assert_eq!(
        set.get("ATC_RAT_RLL_P", Variant::from_mav_type(2)),
        Some(multi)
    );
    assert_eq!(set.get("ATC_RAT_RLL_P", Variant::Unknown), Some(multi));
    // A heli-only parameter is found whatever the hint.
    assert_eq!(
        set.get("ATC_HOVR_ROL_TRM", Variant::Multicopter)
            .unwrap()
            .range,
        Some((0.0, 1000.0))
    );
}

#[test]
fn ardupilot_explicit_source_path_wins_over_order() {
    // If a generator writes the source file (param_parse's `path` for duplicates), use it even
    // when the helicopter's comes first.
    let xml = r#"<paramfile><vehicles/><libraries><parameters name="ATC_">
        <param name="ATC_RAT_RLL_P" path="AC_AttitudeControl_Heli" humanName="heli"/>
        <param name="ATC_RAT_RLL_P" path="AC_AttitudeControl_Multi" humanName="multi"/>
      </parameters></libraries></paramfile>"#;
    let set = MetaSet::parse(xml).unwrap();
    let h = |v| set.get("ATC_RAT_RLL_P", v).unwrap().human_name.as_deref();
    assert_eq!(h(Variant::Helicopter), Some("heli"));
    assert_eq!(h(Variant::Multicopter), Some("multi"));
}

#[test]
fn ardupilot_multi_vehicle_file_follows_the_vehicle() {
    // Older apm.pdef.xml held every vehicle in one file.
    let xml = r#"<paramfile><vehicles>
        <parameters name="ArduPlane"><param name="ArduPlane:RTL_ALT" humanName="plane"/></parameters>
        <parameters name="ArduCopter"><param name="ArduCopter:RTL_ALT" humanName="copter"/></parameters>
        <parameters name="Rover"><param name="Rover:RTL_ALT" humanName="rover"/></parameters>
      </vehicles><libraries/></paramfile>"#;
    let set = MetaSet::parse(xml).unwrap();
    assert_eq!(set.len(), 1);
    let h = |v| set.get("RTL_ALT", v).unwrap().human_name.as_deref();
    assert_eq!(h(Variant::Plane), Some("plane"));
    assert_eq!(h(Variant::Multicopter), Some("copter"));
    assert_eq!(h(Variant::Helicopter), Some("copter"));
    assert_eq!(h(Variant::Rover), Some("rover"));
    assert_eq!(h(Variant::Unknown), Some("plane"));
}

#[test]
fn px4_metadata_fixture() {
    let set = MetaSet::parse(&data("params/px4-parameters.xml")).unwrap();
    assert_eq!(set.format, MetaFormat::Px4);
    assert_eq!(set.len(), 6);
    let any = Variant::Unknown;

    let m = set.get("MC_ROLL_P", any).unwrap();
    assert_eq!(m.human_name.as_deref(), Some("Roll P gain"));
    assert_eq!(
        m.description,
        "Roll proportional gain, i.e. desired angular speed in rad/s for error 1 rad."
    );
    assert_eq!(m.default, Some(6.5));
    assert_eq!(m.ptype, Some(ParamType::Real32));
    assert_eq!(m.range, Some((0.0, 12.0)));
    assert_eq!(m.decimals, Some(2));
    assert_eq!(m.increment, Some(0.1));
    assert!(!m.reboot_required);
    assert_eq!(m.group, "Multicopter Attitude Control");
    assert_eq!(m.units, None);

    let m = set.get("COM_RC_IN_MODE", any).unwrap();
    assert_eq!(m.ptype, Some(ParamType::Int32));
    assert_eq!(m.default, Some(3.0));
    assert_eq!(m.values.len(), 5);
    assert_eq!(m.value_name(3.0), Some("RC or Joystick keep first"));
    assert_eq!(m.parse_value("joystick only"), Some(1.0));

    let m = set.get("COM_ARM_SDCARD", any).unwrap();
    assert_eq!(m.description, "");
    assert_eq!(m.range, None);

    let m = set.get("CA_R_REV", any).unwrap();
    assert_eq!(
        m.bits,
        vec![
            (0, "Motor 1".to_string()),
            (1, "Motor 2".to_string()),
            (2, "Motor 3".to_string()),
            (3, "Motor 4".to_string()),
        ]
    );
    assert_eq!(m.parse_value("Motor 1|Motor 4"), Some(9.0));
    assert_eq!(m.bits_set(6.0), vec!["Motor 2", "Motor 3"]);
    assert_eq!(m.range, Some((0.0, 4095.0)));

    let m = set.get("SYS_AUTOSTART", any).unwrap();
    assert!(m.reboot_required);
    assert_eq!(m.user.as_deref(), Some("System"));
    assert_eq!(m.range, Some((0.0, 9999999.0)));

    // Only a minimum: the maximum is open.
    let m = set.get("SYS_HITL", any).unwrap();
    assert_eq!(m.range, Some((-1.0, f64::INFINITY)));
    assert!(m.check_range(5.0).is_ok());
    assert!(m.check_range(-2.0).is_err());
}

#[test]
fn malformed_metadata_is_an_error_with_its_place() {
    let mut xml = data("params/apm.pdef.xml");
    // Break the closing tag on the last line (line 67).
    xml = xml.replace("</paramfile>", "</paramfil>");
    let e = MetaSet::parse(&xml).unwrap_err();
    assert_eq!(e.line, 67);
    assert!(e.to_string().starts_with("line 67, column "), "{e}");
    // A truncated file.
    let full = data("params/px4-parameters.xml");
    assert!(MetaSet::parse(&full[..full.len() / 2]).is_err());
    // Some other XML.
    let e = MetaSet::parse("<mission>\n</mission>").unwrap_err();
    assert_eq!((e.line, e.column), (1, 1));
}
