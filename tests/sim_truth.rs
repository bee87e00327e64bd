//! The impairment truth: what the simulated link dropped and duplicated, per vehicle, is exactly
//! what mavterm's link statistics report, through the whole pipeline (sim bytes → framing →
//! sequence tracking in the core) on the virtual clock.

use mavterm::app::AppConfig;
use mavterm::driver::virtual_time::VirtualRunner;
use mavterm::link::LinkSpec;
use mavterm::proto::vehicles::VehicleKey;
use mavterm::sim::Sim;

fn run(query: &str, secs: u64) -> VirtualRunner {
    let spec: LinkSpec = format!("sim://?{query}").parse().unwrap();
    let mut r = VirtualRunner::from_specs(&[spec], AppConfig::default()).unwrap();
    r.advance_to(secs * 1_000_000);
    r
}

fn sim(r: &VirtualRunner) -> &Sim {
    r.source(0).unwrap().as_any().downcast_ref::<Sim>().unwrap()
}

#[test]
fn dropped_frames_equal_reported_loss() {
    for seed in [3, 11, 2024] {
        let r = run(&format!("vehicles=2&loss=0.2&seed={seed}"), 60);
        let truth = sim(&r).truth();
        for sysid in [1u8, 2] {
            let t = truth.get(sysid);
            let src = &r.app.links[0].sources[&VehicleKey(sysid, 1)];
            // Frames dropped before the first that arrived, or after the last, leave no gap to
            // see: count them from the sequence numbers at the ends.
            let head = src.seq.first_seq().unwrap() as u64;
            let last_sent = (t.generated - 1) as u8;
            let tail = last_sent.wrapping_sub(src.seq.last_seq().unwrap()) as u64;
            assert!(t.generated > 1000, "{t:?}");
            assert_eq!(
                src.seq.lost + head + tail,
                t.dropped,
                "seed {seed} sysid {sysid}: {t:?}"
            );
            assert_eq!(src.seq.received, t.generated - t.dropped);
            let pct = src.seq.loss_pct();
            assert!((17.0..23.0).contains(&pct), "loss {pct}%");
        }
        assert_eq!(r.app.links[0].parser.crc_errors, 0);
    }
}

#[test]
fn duplicated_frames_equal_reported_duplicates() {
    let r = run("dup=0.05&seed=5", 60);
    let t = sim(&r).truth().get(1);
    let src = &r.app.links[0].sources[&VehicleKey(1, 1)];
    assert!(t.duplicated > 20, "{t:?}");
    assert_eq!(src.seq.duplicates, t.duplicated);
    assert_eq!(src.seq.lost, 0);
}

#[test]
fn corrupted_frames_are_rejected_and_counted() {
    for seed in [8, 9, 10] {
        let r = run(&format!("corrupt=0.01&seed={seed}"), 60);
        let t = sim(&r).truth().get(1);
        let link = &r.app.links[0];
        let src = &link.sources[&VehicleKey(1, 1)];
        assert!(t.corrupted > 5, "{t:?}");
        // A flipped bit fails the CRC (or cuts the frame short): the frame is rejected,
        // counted by the parser, and its sequence number shows up as lost.
        let head = src.seq.first_seq().unwrap() as u64;
        let tail = ((t.generated - 1) as u8).wrapping_sub(src.seq.last_seq().unwrap()) as u64;
        assert_eq!(
            src.seq.lost + head + tail,
            t.corrupted,
            "seed {seed}: {t:?}"
        );
        // At least one rejected candidate per corrupted frame (a frame whose length byte was hit
        // can leave stray magic bytes in its payload that are rejected too).
        assert!(
            link.parser.crc_errors + link.parser.truncated >= t.corrupted,
            "seed {seed}: {:?}",
            link.parser
        );
    }
}
