//! The complete parameter set from the simulated ArduCopter, by MAVFTP and by the parameter
//! protocol (`ftp=0`), at 0 %, 20 % and 40 % loss of the vehicle's frames, for 3 seeds each, on
//! the virtual clock: every name, value and type equal to the sim's own table.

use mavterm::app::AppConfig;
use mavterm::clock::SECOND;
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::link::LinkSpec;
use mavterm::params::value::ParamType;
use mavterm::proto::vehicles::VehicleKey;
use mavterm::sim::Sim;

fn download(query: &str) -> (VirtualRunner, String) {
    let spec: LinkSpec = format!("sim://?{query}").parse().unwrap();
    let mut r = VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap();
    let mut t = 0;
    loop {
        t += SECOND / 2;
        r.advance_to(t);
        let p = mavterm::headless::params::progress(&r.app);
        if p.ended() {
            return (r, p.line());
        }
        assert!(
            t < 300 * SECOND,
            "{query}: not done after 300 s: {}",
            p.line()
        );
    }
}

fn check(query: &str, method: &str) {
    let (r, line) = download(query);
    assert!(line.contains(method), "{query}: {line}");
    eprintln!("{query}: {line}");
    let sim = r.source(0).unwrap().as_any().downcast_ref::<Sim>().unwrap();
    let table = sim.vehicles()[0].params();
    let set = r.app.sessions[&VehicleKey(1, 1)]
        .params
        .autopilot()
        .unwrap();
    assert!(set.complete(), "{query}: {line}");
    assert_eq!(set.params.len(), table.len(), "{query}");
    let booted = mavterm::sim::params::ParamTable::copter(0);
    for p in table.iter() {
        let got = set
            .get(&p.name)
            .unwrap_or_else(|| panic!("{query}: {} missing", p.name));
        let want_type = mavterm::sim::params::mav_type(p.ptype) as u8;
        assert_eq!(
            got.ptype,
            ParamType::from_code(want_type).unwrap(),
            "{}",
            p.name
        );
        // A calibration of the boot (sim::params::boot_changes) whose PARAM_VALUE was lost on
        // the link leaves the value of before it.
        let boot = mavterm::sim::params::boot_changes()
            .iter()
            .any(|c| c.1 == p.name);
        let before = booted.value(&p.name);
        assert!(
            got.value == p.value || (boot && Some(got.value) == before),
            "{query}: {} is {}, the vehicle has {}",
            p.name,
            got.value,
            p.value
        );
    }
}

#[test]
fn mavftp_at_0_20_40_percent_loss() {
    for loss in ["0", "0.2", "0.4"] {
        for seed in 1..=3 {
            check(&format!("loss={loss}&seed={seed}"), "by MAVFTP");
        }
    }
}

#[test]
fn parameter_protocol_at_0_20_40_percent_loss() {
    for loss in ["0", "0.2", "0.4"] {
        for seed in 1..=3 {
            check(
                &format!("ftp=0&loss={loss}&seed={seed}"),
                "by parameter protocol",
            );
        }
    }
}
