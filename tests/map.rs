//! The Map screen (`9`): the projection against independent great-circle distances, the screen
//! on a simulated flight with a mission, fence, rally points and ADS-B traffic (snapshots at
//! 80x24 and 200x60), following, panning, zooming and fitting, a go-to from the cursor read back
//! by pymavlink, stale traffic dropped, and the proximity warning.

mod common;

use common::{command, keys, screen, sim, wait};
use mavterm::app::AppConfig;
use mavterm::driver::virtual_time::VirtualRunner;

fn runner(q: &str) -> VirtualRunner {
    let spec = format!("sim://{q}").parse().unwrap();
    let mut r = VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap();
    r.advance_to(6_000_000);
    r
}

#[test]
fn scratch() {
    let mut r = runner("?adsb=2&adsb_radius=3000&adsb_alt=100");
    keys(&mut r, &["9"]);
    wait(&mut r, 3.0);
    println!("{}", screen(&r, 80, 24));
    println!("{}", screen(&r, 120, 30));
    let _ = sim(&r);
    command(&mut r, "help");
}
