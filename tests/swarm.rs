//! 250 simulated vehicles on one link, each streaming from boot at 1 Hz a group as ArduPilot does
//! with its SRn_ rates set (virtual clock): every one is listed, the target's parameters
//! download whole and its commands are answered, the rest start nothing on their own.

mod common;

use mavterm::app::AppConfig;
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::link::LinkSpec;
use mavterm::proto::vehicles::VehicleKey;

#[test]
fn two_hundred_and_fifty_vehicles_are_listed_and_the_target_is_unaffected() {
    let spec: LinkSpec = "sim://?vehicles=250&sr=1&seed=5".parse().unwrap();
    let mut r = VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap();
    common::wait(&mut r, 20.0);

    // Every vehicle is listed, by its own sysid (the sim numbers them 1 to 250).
    let mut sysids: Vec<u8> = r
        .app
        .vehicles
        .iter()
        .filter(|v| v.is_autopilot())
        .map(|v| v.sysid)
        .collect();
    sysids.sort_unstable();
    assert_eq!(sysids, (1..=250).collect::<Vec<u8>>());
    assert_eq!(r.app.vehicles.iter().filter(|v| v.lost).count(), 0);
    let screen = common::screen(&r, 200, 60);
    assert!(screen.contains("Vehicles (250)"), "{screen}");

    // The first heard stays the target and gets all it gets alone: every parameter.
    assert_eq!(r.app.target, Some(VehicleKey(1, 1)));
    let set = r.app.param_set().expect("the target's parameters");
    let (have, of) = set.progress();
    assert!(set.complete(), "{have}/{of:?}");
    assert_eq!(have, common::sim(&r).vehicle(1).unwrap().param_count());

    // A command to the target is answered and its outcome shown, with 249 others talking.
    common::command(&mut r, "mode loiter");
    common::wait(&mut r, 3.0);
    assert_eq!(
        common::sim(&r).vehicle(1).unwrap().custom_mode(),
        5,
        "LOITER"
    );
    assert!(
        r.app
            .notices
            .iter()
            .any(|n| n.text.contains("LOITER: confirmed by the vehicle")),
        "{:?}",
        r.app.notices.iter().map(|n| &n.text).collect::<Vec<_>>()
    );
    // The others were not sent anything of it.
    for k in 2..=250u8 {
        assert_eq!(common::sim(&r).vehicle(k).unwrap().custom_mode(), 0, "{k}");
    }
}
