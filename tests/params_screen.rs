//! The Parameters screen (`2`) on the simulated ArduCopter (virtual clock): the list after the
//! download, the filter, editing in place with the vehicle's echo, metadata (enum names,
//! bitmask bits, units and ranges), a value out of its type's range refused, and the progress
//! while a slow download runs.

mod common;

use common::{downloaded, wait};

use std::sync::Arc;

use mavterm::app::AppConfig;
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::keymap::Mode;
use mavterm::link::LinkSpec;
use mavterm::params::meta::MetaSet;
use mavterm::proto::params::EditState;
use mavterm::proto::vehicles::VehicleKey;
use mavterm::sim::Sim;

fn meta() -> Arc<MetaSet> {
    let xml =
        std::fs::read_to_string(common::test_path("data/params/screen.apm.pdef.xml")).unwrap();
    Arc::new(MetaSet::parse(&xml).unwrap())
}

fn runner_with(query: &str, meta: Option<Arc<MetaSet>>) -> VirtualRunner {
    let spec: LinkSpec = format!("sim://{query}").parse().unwrap();
    let cfg = AppConfig {
        param_meta: meta,
        ..AppConfig::default()
    };
    VirtualRunner::from_specs(&[spec], cfg).unwrap()
}

fn sim(r: &VirtualRunner) -> &Sim {
    r.source(0).unwrap().as_any().downcast_ref::<Sim>().unwrap()
}

fn sim_param(r: &VirtualRunner, name: &str) -> f64 {
    sim(r).vehicle(1).unwrap().param(name).unwrap()
}

fn screen(r: &VirtualRunner) -> String {
    common::screen(r, 80, 24)
}

/// `/NAME` then enter: the filter keeps the rows with NAME, the first selected.
fn find(r: &mut VirtualRunner, name: &str) {
    common::keys(r, &["/", "ctrl-u"]);
    common::typed(r, name);
    common::keys(r, &["enter"]);
    assert_eq!(r.app.param_selected().as_deref(), Some(name));
}

/// Select `name`, type `value` over the current one, enter.
fn set_value(r: &mut VirtualRunner, name: &str, value: &str) {
    find(r, name);
    common::keys(r, &["enter", "ctrl-u"]);
    common::typed(r, value);
    common::keys(r, &["enter"]);
}

fn edit_state(r: &VirtualRunner, name: &str) -> Option<EditState> {
    let p = r.app.param_set()?.params.get(name)?;
    p.edit.as_ref().map(|e| e.state.clone())
}

#[test]
fn the_list_after_the_download() {
    let mut r = downloaded(runner_with("", None));
    common::keys(&mut r, &["2"]);
    assert_eq!(r.app.ui.screen, "parameters");
    let s = screen(&r);
    assert!(
        s.contains("Parameters 1:1") && s.contains("1354 parameters"),
        "{s}"
    );
    // Ordered by name, the first selected; its detail below, without metadata.
    assert!(s.contains("ACRO_BAL_PITCH"), "{s}");
    assert!(s.contains("no metadata") && s.contains("REAL32"), "{s}");
    // No download running: nothing about it in the status bar.
    assert!(!s.contains("params "), "{s}");
    insta::assert_snapshot!("params_list_80x24", s);
    // Moving: down, page down, end, home.
    common::keys(&mut r, &["down", "down"]);
    assert_eq!(r.app.ui.params.sel, 2);
    common::keys(&mut r, &["pagedown"]);
    assert_eq!(r.app.ui.params.sel, 12);
    common::keys(&mut r, &["end"]);
    assert_eq!(r.app.ui.params.sel, 1353);
    let last = r.app.param_selected().unwrap();
    let s = screen(&r);
    assert!(s.contains(&last) && s.contains("1354/1354"), "{s}");
    common::keys(&mut r, &["pageup", "home"]);
    assert_eq!(r.app.ui.params.sel, 0);
    // The key help of this screen explains the marks.
    common::keys(&mut r, &["?"]);
    assert_eq!(r.app.ui.mode, Mode::Help);
    let lines = mavterm::ui::help::help_lines(&r.app, 78);
    let text: Vec<&str> = lines.iter().map(|l| l.0.as_str()).collect();
    let text = text.join("\n");
    assert!(
        text.contains("marks: * changed since the download, ≠ differs"),
        "{text}"
    );
    assert!(
        lines.iter().any(|l| l.0.starts_with("/ ")
            && l.0
                .ends_with("filter parameters by name (ATC_ = the ATC_ group; enter keeps, esc")),
        "{text}"
    );
}

#[test]
fn the_filter_narrows_live_and_esc_clears_it() {
    let mut r = downloaded(runner_with("", None));
    common::keys(&mut r, &["2", "/"]);
    assert_eq!(r.app.ui.mode, Mode::Edit);
    common::typed(&mut r, "atc_rat");
    // Live, case-insensitive: ATC_RAT_* and ATC_RATE_*.
    assert_eq!(r.app.param_rows().len(), 43);
    let s = screen(&r);
    assert!(s.lines().last().unwrap().starts_with("/atc_rat"), "{s}");
    common::keys(&mut r, &["ctrl-u"]);
    common::typed(&mut r, "ATC_RAT");
    assert_eq!(r.app.param_rows().len(), 43);
    common::keys(&mut r, &["enter"]);
    assert_eq!(r.app.ui.mode, Mode::Normal);
    let s = screen(&r);
    assert!(s.contains("/ATC_RAT") && s.contains("43 shown"), "{s}");
    assert!(
        r.app.param_rows().iter().all(|n| n.contains("ATC_RAT")),
        "{:?}",
        r.app.param_rows()
    );
    insta::assert_snapshot!("params_filter_atc_rat_80x24", s);
    // A filter ending in `_` is a group: the names starting with it.
    common::keys(&mut r, &["/", "ctrl-u"]);
    common::typed(&mut r, "RLL_");
    assert_eq!(r.app.param_rows().len(), 0);
    assert!(screen(&r).contains("no parameter matches /RLL_"));
    common::keys(&mut r, &["ctrl-u"]);
    common::typed(&mut r, "ATC_");
    let rows = r.app.param_rows();
    assert!(!rows.is_empty() && rows.iter().all(|n| n.starts_with("ATC_")));
    // up/down move through the rows while typing; esc clears the filter and keeps the row.
    common::keys(&mut r, &["down", "down"]);
    let chosen = r.app.param_selected().unwrap();
    assert_eq!(chosen, rows[2]);
    common::keys(&mut r, &["esc"]);
    assert_eq!(r.app.ui.params.filter, "");
    assert_eq!(r.app.param_rows().len(), 1354);
    assert_eq!(r.app.param_selected(), Some(chosen));
}

#[test]
fn an_edit_is_typed_in_place_sent_and_confirmed_by_the_vehicle() {
    let mut r = downloaded(runner_with("", None));
    assert_eq!(sim_param(&r, "PILOT_TKOFF_ALT"), 0.0);
    common::keys(&mut r, &["2"]);
    find(&mut r, "PILOT_TKOFF_ALT");
    common::keys(&mut r, &["enter"]);
    assert_eq!(r.app.ui.mode, Mode::Edit);
    // Pre-filled with the value.
    assert_eq!(r.app.ui.edit.text, "0");
    common::keys(&mut r, &["backspace"]);
    common::typed(&mut r, "250");
    let s = screen(&r);
    assert!(
        s.contains("editing PILOT_TKOFF_ALT (now 0): enter sends  esc cancels"),
        "{s}"
    );
    insta::assert_snapshot!("params_editing_80x24", s);
    common::keys(&mut r, &["enter"]);
    assert_eq!(r.app.ui.mode, Mode::Normal);
    assert_eq!(edit_state(&r, "PILOT_TKOFF_ALT"), Some(EditState::Pending));
    assert!(screen(&r).contains("PILOT_TKOFF_ALT = 250: sent, waiting for the echo"));
    wait(&mut r, 1.0);
    assert_eq!(
        edit_state(&r, "PILOT_TKOFF_ALT"),
        Some(EditState::Confirmed)
    );
    assert_eq!(sim_param(&r, "PILOT_TKOFF_ALT"), 250.0);
    let s = screen(&r);
    // Changed since the download (`*`) and confirmed (`✓`), the old value in the detail.
    assert!(s.contains("* ✓ PILOT_TKOFF_ALT"), "{s}");
    assert!(
        s.contains("250 confirmed by the vehicle") && s.contains("*was 0"),
        "{s}"
    );
    // The outcome in the status bar.
    assert!(
        s.lines()
            .last()
            .unwrap()
            .contains("PILOT_TKOFF_ALT = 250 confirmed"),
        "{s}"
    );
    insta::assert_snapshot!("params_edit_confirmed_80x24", s);
    // esc cancels an edit: nothing sent.
    common::keys(&mut r, &["enter", "ctrl-u"]);
    common::typed(&mut r, "300");
    common::keys(&mut r, &["esc"]);
    wait(&mut r, 1.0);
    assert_eq!(sim_param(&r, "PILOT_TKOFF_ALT"), 250.0);
    assert!(screen(&r).contains("edit cancelled: nothing sent"));
}

#[test]
fn a_value_out_of_its_types_range_is_refused_before_sending() {
    let mut r = downloaded(runner_with("", None));
    common::keys(&mut r, &["2"]);
    // FLTMODE1 is an INT8.
    let before = sim_param(&r, "FLTMODE1");
    set_value(&mut r, "FLTMODE1", "300");
    let s = screen(&r);
    assert!(
        s.contains("300 is out of range for INT8 (-128 to 127)"),
        "{s}"
    );
    assert_eq!(edit_state(&r, "FLTMODE1"), None);
    insta::assert_snapshot!("params_refused_int8_80x24", s);
    wait(&mut r, 1.0);
    assert_eq!(sim_param(&r, "FLTMODE1"), before);
    // Nor a fraction, nor a word without metadata naming values.
    set_value(&mut r, "FLTMODE1", "2.5");
    assert!(screen(&r).contains("INT8 holds whole numbers only"));
    set_value(&mut r, "FLTMODE1", "Loiter");
    assert!(screen(&r).contains("`Loiter` is not a number"));
}

#[test]
fn metadata_names_values_bits_units_and_ranges() {
    let mut r = downloaded(runner_with("", Some(meta())));
    common::keys(&mut r, &["2"]);
    find(&mut r, "FLTMODE1");
    let s = screen(&r);
    // The sim's FLTMODE1 is 7: Circle.
    assert!(
        s.contains("7 (Circle)") && s.contains("Flight Mode 1"),
        "{s}"
    );
    assert!(s.contains("[7 Circle]"), "{s}");
    insta::assert_snapshot!("params_meta_enum_80x24", s);
    // Edited by name; tab goes through the names.
    common::keys(&mut r, &["enter"]);
    assert_eq!(r.app.ui.edit.text, "7");
    common::keys(&mut r, &["tab"]);
    assert_eq!(r.app.ui.edit.text, "Land");
    common::keys(&mut r, &["tab"]);
    assert_eq!(r.app.ui.edit.text, "Drift");
    common::keys(&mut r, &["ctrl-u"]);
    common::typed(&mut r, "loiter");
    common::keys(&mut r, &["enter"]);
    wait(&mut r, 1.0);
    assert_eq!(sim_param(&r, "FLTMODE1"), 5.0);
    assert_eq!(edit_state(&r, "FLTMODE1"), Some(EditState::Confirmed));
    assert!(screen(&r).contains("5 (Loiter)"));

    // A bitmask: the bits set named and marked.
    find(&mut r, "ARMING_CHECK");
    let s = screen(&r);
    assert!(s.contains("1 (All)") && s.contains("[0 All]"), "{s}");
    insta::assert_snapshot!("params_meta_bitmask_80x24", s);
    common::keys(&mut r, &["enter", "ctrl-u"]);
    common::typed(&mut r, "Barometer+GPS lock");
    common::keys(&mut r, &["enter"]);
    wait(&mut r, 1.0);
    assert_eq!(sim_param(&r, "ARMING_CHECK"), 10.0);
    assert!(screen(&r).contains("10 (Barometer+GPS lock)"));

    // Units, range and step; outside the documented range asks first.
    find(&mut r, "PILOT_TKOFF_ALT");
    let s = screen(&r);
    assert!(
        s.contains("range 0 to 1000 cm") && s.contains("step 10"),
        "{s}"
    );
    assert!(s.contains("Pilot takeoff altitude"), "{s}");
    insta::assert_snapshot!("params_meta_units_80x24", s);
    common::keys(&mut r, &["enter", "ctrl-u"]);
    common::typed(&mut r, "1500");
    common::keys(&mut r, &["enter"]);
    let s = screen(&r);
    assert!(
        s.contains("1500 is outside PILOT_TKOFF_ALT's range 0 to 1000"),
        "{s}"
    );
    common::keys(&mut r, &["n"]);
    wait(&mut r, 1.0);
    assert_eq!(sim_param(&r, "PILOT_TKOFF_ALT"), 0.0);

    // Reboot required shows in the detail.
    find(&mut r, "FRAME_CLASS");
    let s = screen(&r);
    assert!(
        s.contains("1 (Quad)") && s.contains("reboot required"),
        "{s}"
    );
}

#[test]
fn progress_shows_while_a_slow_download_runs() {
    // 57600 baud: the MAVFTP download of param.pck takes seconds.
    let mut r = runner_with("?baud=57600", None);
    wait(&mut r, 3.0);
    common::keys(&mut r, &["2"]);
    let (comp, got, count, method) = r.app.sessions[&VehicleKey(1, 1)]
        .params
        .downloading()
        .expect("still downloading");
    assert_eq!((comp, count), (1, Some(1354)));
    assert!(got > 0 && got < 1354, "{got}");
    let s = screen(&r);
    let progress = format!("{} {got}/1354", method.name());
    assert!(s.contains(&progress), "{progress}: {s}");
    // In the status bar too, on every screen.
    let status = format!("params {got}/1354");
    assert!(s.lines().last().unwrap().contains(&status), "{s}");
    insta::assert_snapshot!("params_downloading_80x24", s);
    common::keys(&mut r, &["1"]);
    assert!(screen(&r).lines().last().unwrap().contains("params "));
    let mut r = downloaded(r);
    common::keys(&mut r, &["2"]);
    let s = screen(&r);
    assert!(
        s.contains("1354 parameters") && !s.contains("params "),
        "{s}"
    );
}

#[test]
fn no_panic_at_any_size() {
    let mut r = downloaded(runner_with("", Some(meta())));
    common::keys(&mut r, &["2"]);
    find(&mut r, "FLTMODE1");
    common::keys(&mut r, &["enter"]);
    for w in 0..=90u16 {
        for h in 0..=30u16 {
            let _ = common::screen(&r, w, h);
        }
    }
    common::keys(&mut r, &["esc", "/"]);
    for (w, h) in [(0, 0), (1, 1), (10, 3), (200, 60), (300, 100)] {
        let _ = common::screen(&r, w, h);
    }
}

#[test]
fn a_files_differences_are_marked_and_can_be_shown_alone() {
    let mut r = downloaded(runner_with("", None));
    common::keys(&mut r, &["2", "d"]);
    assert!(!r.app.ui.params.only_diff);
    assert!(screen(&r).contains("no file loaded to compare with"));
    let dir = std::env::temp_dir().join(format!("mavterm-params-screen-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("copter.parm");
    // FLTMODE1 differs (the vehicle has 7), RTL_ALT does not.
    std::fs::write(&path, "FLTMODE1 5\nRTL_ALT 1500\n").unwrap();
    common::keys(&mut r, &[":"]);
    common::typed(&mut r, &format!("param diff {}", path.display()));
    common::keys(&mut r, &["enter"]);
    wait(&mut r, 0.5);
    std::fs::remove_dir_all(&dir).unwrap();
    assert!(r.app.param_file.is_some());
    common::keys(&mut r, &["d"]);
    assert!(r.app.ui.params.only_diff);
    assert_eq!(r.app.param_rows(), vec!["FLTMODE1".to_string()]);
    let s = screen(&r);
    assert!(s.contains(" ≠  FLTMODE1") && s.contains("≠file 5"), "{s}");
    assert!(s.contains("file copter.parm"), "{s}");
    insta::assert_snapshot!("params_file_diff_80x24", s);
    common::keys(&mut r, &["d"]);
    assert_eq!(r.app.param_rows().len(), 1354);
    // `f` downloads again.
    common::keys(&mut r, &["f"]);
    assert!(screen(&r).contains("fetching the parameters of 1:1"));
    assert!(r.app.sessions[&VehicleKey(1, 1)]
        .params
        .downloading()
        .is_some());
}

#[test]
fn at_200x60_value_units_and_description_sit_side_by_side() {
    let mut r = downloaded(runner_with("", Some(meta())));
    common::keys(&mut r, &["2"]);
    // The rate controller's roll gains: six of them documented in the metadata, one with
    // units (ATC_RAT_RLL_FLTT, Hz).
    common::keys(&mut r, &["/"]);
    common::typed(&mut r, "ATC_RAT_RLL_");
    common::keys(&mut r, &["enter"]);
    let s = common::screen(&r, 200, 60);
    insta::assert_snapshot!("params_meta_200x60", s);
    let lines: Vec<&str> = s.lines().collect();
    assert!(lines.iter().all(|l| l.chars().count() <= 200), "{s}");
    let title = lines
        .iter()
        .find(|l| l.contains(" NAME ") && l.contains(" VALUE "))
        .unwrap_or_else(|| panic!("{s}"));
    let col = |l: &str, word: &str| -> usize {
        let b = l.find(word).unwrap_or_else(|| panic!("no {word:?} in {l}"));
        l[..b].chars().count()
    };
    let (value, units, desc) = (
        col(title, " VALUE ") + 1,
        col(title, " UNITS ") + 1,
        col(title, " DESCRIPTION") + 1,
    );
    assert!(value < units && units < desc, "{title}");
    // Every documented row: its value, units and description in their columns, on one line.
    let row = |name: &str| -> String {
        lines
            .iter()
            .find(|l| l.contains(&format!(" {name} ")))
            .unwrap_or_else(|| panic!("no row {name}: {s}"))
            .to_string()
    };
    let cell = |l: &str, from: usize, to: usize| -> String {
        l.chars()
            .skip(from)
            .take(to - from)
            .collect::<String>()
            .trim()
            .to_string()
    };
    let documented = [
        // The human name, then the documentation without its first sentence that only says
        // the name again.
        ("ATC_RAT_RLL_P", "", "Roll axis rate controller P gain: Corrects in proportion to the difference between the desired roll rate vs actual roll rate"),
        ("ATC_RAT_RLL_I", "", "Roll axis rate controller I gain: Corrects long-term difference in desired roll rate vs actual roll rate"),
        // Documentation that only repeats the name: said once.
        ("ATC_RAT_RLL_FLTT", "Hz", "Roll axis rate controller target frequency in Hz"),
        ("ATC_RAT_RLL_FF", "", "Roll axis rate controller feed forward"),
    ];
    for (name, unit, text) in documented {
        let l = row(name);
        let v = sim_param(&r, name);
        // The sim holds REAL32 values.
        let shown = cell(&l, value, units).parse::<f32>().ok();
        assert_eq!(shown, Some(v as f32), "{l}");
        assert_eq!(cell(&l, units, desc), unit, "{l}");
        let d: String = l.chars().skip(desc).collect();
        assert!(d.trim_end_matches('│').trim() == text, "{name}: {d:?}");
    }
    // A row without metadata leaves units and description empty.
    let l = row("ATC_RAT_RLL_SMAX");
    assert_eq!(cell(&l, units, l.chars().count() - 1), "", "{l}");
    // The whole list, from its top (ACRO_*, none with units in view): at 200 columns the
    // columns stay where they are; at 80 the units column only comes with rows that have
    // units.
    common::keys(&mut r, &["/", "ctrl-u", "esc", "home"]);
    let title = |w: u16, h: u16| -> String {
        common::screen(&r, w, h)
            .lines()
            .find(|l| l.contains(" NAME "))
            .unwrap()
            .to_string()
    };
    let wide = title(200, 60);
    assert!(
        wide.contains(" UNITS ") && wide.contains(" DESCRIPTION"),
        "{wide}"
    );
    let narrow = title(80, 24);
    assert!(!narrow.contains(" UNITS "), "{narrow}");
}

#[test]
fn from_60_to_220_columns_a_description_is_whole_or_ends_in_an_ellipsis() {
    let mut r = downloaded(runner_with("", Some(meta())));
    common::keys(&mut r, &["2", "/"]);
    common::typed(&mut r, "ATC_RAT_RLL_");
    common::keys(&mut r, &["enter"]);
    let human = "Roll axis rate controller P gain";
    let doc = "Corrects in proportion to the difference between the desired roll rate vs actual \
               roll rate";
    for w in 60..=220u16 {
        for h in [24u16, 60] {
            let s = common::screen(&r, w, h);
            for l in s.lines() {
                assert!(l.chars().count() <= w as usize, "{w}x{h}: {l}");
            }
            let row = s
                .lines()
                .find(|l| l.contains(" ATC_RAT_RLL_P "))
                .unwrap_or_else(|| panic!("{w}x{h}: {s}"));
            let Some(at) = row.find(human.split(' ').next().unwrap()) else {
                continue; // no room for a description at this width
            };
            let shown = row[at..].trim_end_matches(['│', ' ']);
            let whole = [human.to_string(), format!("{human}: {doc}")];
            let ok = whole.iter().any(|t| t == shown)
                || shown
                    .strip_suffix('…')
                    .is_some_and(|cut| whole.iter().any(|t| t.starts_with(cut)));
            assert!(ok, "{w}x{h}: {shown:?}");
        }
    }
}
