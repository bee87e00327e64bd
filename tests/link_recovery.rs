//! Links that fail: a TCP peer that goes away and comes back, a serial device that is missing.
//! The program keeps running, shows the link down with a reason, and reconnects.
//!
//! On the real clock, so nothing here is timed: every wait is for an event (a state, a frame, a
//! count), bounded only against a hang ([`HANG`]); and no test takes loopback UDP to deliver
//! every datagram (peers send again, as vehicles do, and the kernel's own drop count is read).

mod common;

use std::time::Duration;

use mavterm::app::links::LinkState;
use mavterm::app::{App, AppConfig};
use mavterm::driver::real_time::{NoFrontend, RealTime};
use mavterm::link::LinkSpec;
use mavterm::proto::vehicles::VehicleKey;
use tokio::io::AsyncWriteExt;
use tokio::net::TcpListener;

/// The bound on a wait for something that does come: far past what any load makes of it.
const HANG: Duration = Duration::from_secs(30);

/// The core on one real link.
fn start(spec: &LinkSpec) -> RealTime {
    RealTime::start(std::slice::from_ref(spec), AppConfig::default())
}

/// Run the core until `cond` holds or `timeout` passes.
async fn pump_until(rt: &mut RealTime, timeout: Duration, cond: impl Fn(&App) -> bool) -> bool {
    let end = rt.now() + timeout.as_micros() as u64;
    while !cond(&rt.app) {
        if rt.now() >= end {
            return false;
        }
        let _ = rt.run(Some(rt.now() + 20_000), &mut NoFrontend).await;
    }
    true
}

#[tokio::test]
async fn tcp_peer_goes_away_and_comes_back() {
    let port = common::free_tcp_port();
    let spec: LinkSpec = format!("tcp:127.0.0.1:{port}").parse().unwrap();
    let mut rt = start(&spec);

    // Nobody listening yet: down with a reason.
    assert!(
        pump_until(&mut rt, HANG, |a| {
            matches!(&a.links[0].state, LinkState::Down(r) if r.contains("connect"))
        })
        .await,
        "{:?}",
        rt.app.links[0].state
    );

    // Server up: the link connects and counts frames.
    let listener = TcpListener::bind(("127.0.0.1", port)).await.unwrap();
    let (mut sock, _) = tokio::time::timeout(HANG, listener.accept())
        .await
        .expect("mavterm reconnects")
        .unwrap();
    for seq in 0..5 {
        sock.write_all(&common::copter_heartbeat(1, seq, 0))
            .await
            .unwrap();
    }
    assert!(
        pump_until(&mut rt, HANG, |a| {
            a.links[0].parser.frames == 5 && a.links[0].state == LinkState::Up
        })
        .await
    );

    // Server goes away: down again.
    drop(sock);
    drop(listener);
    assert!(
        pump_until(&mut rt, HANG, |a| {
            matches!(a.links[0].state, LinkState::Down(_))
        })
        .await
    );

    // And comes back: reconnect, count again.
    let listener = TcpListener::bind(("127.0.0.1", port)).await.unwrap();
    let (mut sock, _) = tokio::time::timeout(HANG, listener.accept())
        .await
        .expect("mavterm reconnects again")
        .unwrap();
    for seq in 5..10 {
        sock.write_all(&common::copter_heartbeat(1, seq, 0))
            .await
            .unwrap();
    }
    assert!(
        pump_until(&mut rt, HANG, |a| {
            a.links[0].parser.frames == 10 && a.links[0].state == LinkState::Up
        })
        .await
    );
    let src = &rt.app.links[0].sources[&VehicleKey(1, 1)];
    assert_eq!((src.seq.received, src.seq.lost), (10, 0));
    // The operator was told.
    let texts: Vec<&str> = rt.app.notices.iter().map(|n| n.text.as_str()).collect();
    assert!(
        texts.iter().filter(|t| t.contains(" down: ")).count() >= 2,
        "{texts:?}"
    );
    assert!(
        texts.iter().filter(|t| t.ends_with(" up")).count() >= 2,
        "{texts:?}"
    );
}

#[tokio::test]
async fn missing_serial_device_is_down_not_fatal() {
    let spec: LinkSpec = "serial:/dev/mavterm-no-such-port:115200".parse().unwrap();
    let udp: LinkSpec = format!("udpin:127.0.0.1:{}", common::free_udp_port())
        .parse()
        .unwrap();
    let mut rt = RealTime::start(&[spec, udp], AppConfig::default());
    // Until both links have a state (the serial one tried, the UDP one bound).
    assert!(
        pump_until(&mut rt, HANG, |a| {
            matches!(a.links[0].state, LinkState::Down(_)) && a.links[1].state == LinkState::Up
        })
        .await,
        "{:?}",
        rt.app.links.iter().map(|l| &l.state).collect::<Vec<_>>()
    );
    let rep = rt.app.report();
    let serial = &rep["links"][0];
    assert_eq!(serial["state"], "down");
    assert!(
        serial["reason"]
            .as_str()
            .unwrap()
            .contains("/dev/mavterm-no-such-port"),
        "{serial}"
    );
    // The other link is unaffected.
    assert_eq!(rep["links"][1]["state"], "up");
}

#[tokio::test]
async fn tcpin_serves_several_clients() {
    use tokio::io::AsyncReadExt;
    let port = common::free_tcp_port();
    let spec: LinkSpec = format!("tcpin:127.0.0.1:{port}").parse().unwrap();
    let mut rt = start(&spec);
    assert!(pump_until(&mut rt, HANG, |a| { a.links[0].state == LinkState::Up }).await);
    let mut a = tokio::net::TcpStream::connect(("127.0.0.1", port))
        .await
        .unwrap();
    let mut b = tokio::net::TcpStream::connect(("127.0.0.1", port))
        .await
        .unwrap();
    // Each client's stream is framed on its own: interleaved halves must not corrupt.
    let fa = common::copter_heartbeat(1, 0, 0);
    let fb = common::copter_heartbeat(2, 0, 0);
    a.write_all(&fa[..5]).await.unwrap();
    b.write_all(&fb[..7]).await.unwrap();
    tokio::time::sleep(Duration::from_millis(50)).await;
    a.write_all(&fa[5..]).await.unwrap();
    b.write_all(&fb[7..]).await.unwrap();
    assert!(pump_until(&mut rt, HANG, |a| { a.vehicles.len() == 2 }).await);
    assert_eq!(rt.app.links[0].parser.crc_errors, 0);
    // Both clients get our heartbeat.
    // Our heartbeat goes out once a second.
    let _ = rt.run(Some(rt.now() + 1_500_000), &mut NoFrontend).await;
    for s in [&mut a, &mut b] {
        let mut buf = [0u8; 512];
        let n = tokio::time::timeout(HANG, s.read(&mut buf))
            .await
            .expect("heartbeat arrives")
            .unwrap();
        let frames = mavterm::link::FrameParser::new().parse_all(&buf[..n]);
        assert!(
            frames.iter().any(|f| f.sysid == 255 && f.compid == 190),
            "{frames:?}"
        );
    }
}

#[tokio::test]
async fn udpin_replies_to_every_peer_heard() {
    let port = common::free_udp_port();
    let spec: LinkSpec = format!("udpin:127.0.0.1:{port}").parse().unwrap();
    let mut rt = start(&spec);
    assert!(pump_until(&mut rt, HANG, |a| { a.links[0].state == LinkState::Up }).await);
    let a = tokio::net::UdpSocket::bind("127.0.0.1:0").await.unwrap();
    let b = tokio::net::UdpSocket::bind("127.0.0.1:0").await.unwrap();
    // Each peer sends its heartbeat until it is heard (a datagram may be lost), as a vehicle
    // sends one a second.
    let end = rt.now() + HANG.as_micros() as u64;
    while rt.app.vehicles.len() < 2 {
        assert!(rt.now() < end, "{} vehicles heard", rt.app.vehicles.len());
        for (s, sysid) in [(&a, 1), (&b, 2)] {
            if rt.app.vehicles.get(VehicleKey(sysid, 1)).is_none() {
                s.send_to(&common::copter_heartbeat(sysid, 0, 0), ("127.0.0.1", port))
                    .await
                    .unwrap();
            }
        }
        let _ = rt.run(Some(rt.now() + 100_000), &mut NoFrontend).await;
    }
    // Our heartbeat goes out once a second, to every peer heard: wait for one at each (a lost
    // one is followed by the next).
    let mut got = [false, false];
    while got != [true, true] {
        assert!(rt.now() < end, "our heartbeat reached {got:?}");
        let _ = rt.run(Some(rt.now() + 100_000), &mut NoFrontend).await;
        for (i, s) in [&a, &b].into_iter().enumerate() {
            let mut buf = [0u8; 512];
            while let Ok((n, _)) = s.try_recv_from(&mut buf) {
                let frames = mavterm::link::FrameParser::new().parse_all(&buf[..n]);
                got[i] |= frames.iter().any(|f| f.sysid == 255 && f.compid == 190);
            }
        }
    }
}

/// Start a link manager on `specs` (no in-process links needed).
fn manager(specs: &[LinkSpec]) -> mavterm::link::manager::LinkManager {
    mavterm::link::manager::LinkManager::start(specs, mavterm::driver::local_sources())
}

#[tokio::test]
async fn a_peer_that_stops_reading_does_not_stop_our_reads() {
    use mavterm::link::transport::LinkEvent;
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let port = listener.local_addr().unwrap().port();
    let spec: LinkSpec = format!("tcp:127.0.0.1:{port}").parse().unwrap();
    let mut mgr = manager(&[spec]);
    let (mut peer, _) = listener.accept().await.unwrap();
    // The peer sends 3000 heartbeats and never reads a byte.
    let sender = tokio::spawn(async move {
        for i in 0..3000u32 {
            peer.write_all(&common::copter_heartbeat(1, i as u8, 0))
                .await
                .unwrap();
            if i % 100 == 0 {
                tokio::time::sleep(Duration::from_millis(5)).await;
            }
        }
        peer // kept open, still not reading
    });
    // Meanwhile we send 20 MB to it: its window fills, our queue fills, the rest is dropped.
    let frame = vec![0u8; 280];
    let (mut accepted, mut dropped, mut frames) = (0u64, 0u64, 0u64);
    let deadline = tokio::time::Instant::now() + HANG;
    while frames < 3000 {
        assert!(
            tokio::time::Instant::now() < deadline,
            "reads stopped at {frames} frames"
        );
        for _ in 0..1000 {
            if mgr.send(0, frame.clone()) {
                accepted += 1;
            } else {
                dropped += 1;
            }
        }
        while let Ok(Some((_, ev))) =
            tokio::time::timeout(Duration::from_millis(2), mgr.next_event()).await
        {
            if let LinkEvent::Frames { frames: f, .. } = ev {
                frames += f.len() as u64;
            }
        }
    }
    let _peer = sender.await.unwrap();
    assert_eq!(frames, 3000, "every frame the peer sent was read");
    assert!(dropped > 0, "a full queue drops");
    // What was taken is bounded by the queue and the socket buffers, not by what was offered.
    assert!(
        accepted * 280 < 16 << 20,
        "accepted {accepted} frames of {}",
        accepted + dropped
    );
}

/// (receive queue bytes, datagrams dropped) of the UDP socket bound to 127.0.0.1:`port`, as
/// the kernel counts them (`/proc/net/udp`), when it tells.
fn kernel_udp(port: u16) -> Option<(u64, u64)> {
    let table = std::fs::read_to_string("/proc/net/udp").ok()?;
    let local = format!("0100007F:{port:04X}");
    table.lines().skip(1).find_map(|l| {
        let f: Vec<&str> = l.split_whitespace().collect();
        if f.get(1) != Some(&local.as_str()) {
            return None;
        }
        let rx = u64::from_str_radix(f.get(4)?.split(':').nth(1)?, 16).ok()?;
        let drops = f.last()?.parse().ok()?;
        Some((rx, drops))
    })
}

#[tokio::test]
async fn a_core_that_falls_behind_gets_a_count_of_what_was_dropped() {
    use mavterm::link::transport::{LinkEvent, EVENT_QUEUE};
    let port = common::free_udp_port();
    let spec: LinkSpec = format!("udpin:127.0.0.1:{port}").parse().unwrap();
    let mut mgr = manager(&[spec]);
    // Wait until the link is up.
    loop {
        if let Some((_, LinkEvent::State(mavterm::link::LinkState::Up))) = mgr.next_event().await {
            break;
        }
    }
    if std::path::Path::new("/proc/net/udp").exists() {
        assert!(
            kernel_udp(port).is_some(),
            "the link's socket in /proc/net/udp"
        );
    }
    let sock = tokio::net::UdpSocket::bind("127.0.0.1:0").await.unwrap();
    let n = 3 * EVENT_QUEUE as u64;
    for i in 0..n {
        sock.send_to(
            &common::copter_heartbeat(1, i as u8, 0),
            ("127.0.0.1", port),
        )
        .await
        .unwrap();
        if i % 64 == 0 {
            tokio::task::yield_now().await;
        }
    }
    // The link reads everything while the core reads nothing: wait until the socket's queue is
    // empty (where the kernel tells), not for a time.
    let start = std::time::Instant::now();
    while kernel_udp(port).is_some_and(|(rx, _)| rx > 0) {
        assert!(start.elapsed() < HANG, "the link stopped reading");
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    // Read the queue; once there is room, one more datagram (from 2:1) carries the count. Read
    // until its frame comes: the count goes before it, on the same queue.
    let (mut frames, mut dropped, mut events) = (0u64, 0u64, 0usize);
    let mut sent_last = false;
    let mut last_came = false;
    while !last_came {
        let ev = tokio::time::timeout(HANG, mgr.next_event())
            .await
            .expect("the last datagram's frame comes");
        let Some((_, ev)) = ev else { break };
        events += 1;
        match ev {
            LinkEvent::Frames { frames: f, .. } => {
                frames += f.len() as u64;
                last_came |= f.iter().any(|f| f.sysid == 2);
            }
            LinkEvent::Dropped(d) => dropped += d,
            LinkEvent::State(_) | LinkEvent::Replay(_) => {}
        }
        if !sent_last && events > EVENT_QUEUE / 2 {
            sent_last = true;
            sock.send_to(&common::copter_heartbeat(2, 0, 0), ("127.0.0.1", port))
                .await
                .unwrap();
        }
    }
    assert!(dropped > 0, "frames {frames}, dropped {dropped}");
    assert!(
        events <= EVENT_QUEUE + 2,
        "the queue is bounded: {events} events"
    );
    // Nothing vanished without a count: what the link read and handed on or counted, and what
    // the kernel dropped before the link could read it (loopback drops only on a full socket
    // buffer; without /proc to tell, none is assumed).
    let kernel = kernel_udp(port).map_or(0, |(_, d)| d);
    assert_eq!(frames + dropped + kernel, n + 1, "kernel dropped {kernel}");
}
