//! `mavterm sim --listen SPEC`: the simulator on a real socket, in real time.
//!
//! This is the one place the simulator meets a wall clock: a ~10 ms interval calls
//! [`Sim::poll`] with the time since start and writes the bytes to every peer; bytes from peers
//! go to [`Sim::receive`]. On the command line `tcp:ADDR:PORT` means *listen* here (the sim is
//! the server a GCS connects to), as does `tcpin:`; `udpin:` answers every peer heard;
//! `udpout:` sends to a fixed peer.

use super::{SimConfig, SimError};
use crate::clock::{Clock, Micros, RealClock};
use crate::link::LinkSpec;
use std::collections::BTreeMap;
use std::net::SocketAddr;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, UdpSocket};
use tokio::sync::mpsc;
use tokio::time::{interval, Duration, MissedTickBehavior};

/// Poll period of the real-time loop.
const PERIOD: Duration = Duration::from_millis(10);
/// Chunks buffered per TCP client before its data is dropped (a stalled client must not stall
/// the others or the simulation).
const CLIENT_QUEUE: usize = 512;

fn host_port(host: &str, port: u16) -> String {
    if host.contains(':') {
        format!("[{host}]:{port}")
    } else {
        format!("{host}:{port}")
    }
}

/// A socket the sim can serve on, bound (or, for `udpout:`, its peer resolved) before anything
/// says it is serving.
#[derive(Debug)]
pub enum Bound {
    Tcp(TcpListener),
    /// A UDP socket and, for `udpout:`, the fixed peer.
    Udp(UdpSocket, Option<SocketAddr>),
}

/// Bind `listen`; the error names the spec (`cannot listen on tcp:127.0.0.1:5760: Address in
/// use`).
pub async fn bind(listen: &LinkSpec) -> Result<Bound, SimError> {
    let named = |source: std::io::Error| SimError::Listen {
        spec: listen.to_string(),
        source,
    };
    match listen {
        LinkSpec::TcpClient { host, port, .. }
        | LinkSpec::TcpServer {
            addr: host, port, ..
        } => {
            let listener = TcpListener::bind(host_port(host, *port))
                .await
                .map_err(named)?;
            Ok(Bound::Tcp(listener))
        }
        LinkSpec::UdpIn { addr, port, .. } => {
            let sock = UdpSocket::bind(host_port(addr, *port))
                .await
                .map_err(named)?;
            Ok(Bound::Udp(sock, None))
        }
        LinkSpec::UdpOut { host, port, .. } => {
            let peer = tokio::net::lookup_host(host_port(host, *port))
                .await
                .map_err(named)?
                .next()
                .ok_or_else(|| {
                    named(std::io::Error::new(
                        std::io::ErrorKind::NotFound,
                        format!("cannot resolve {host}"),
                    ))
                })?;
            let bind = if peer.is_ipv6() {
                "[::]:0"
            } else {
                "0.0.0.0:0"
            };
            let sock = UdpSocket::bind(bind).await.map_err(named)?;
            Ok(Bound::Udp(sock, Some(peer)))
        }
        other => Err(SimError::UnsupportedListen(other.to_string())),
    }
}

/// Serve on a socket [`bind`] made, until the future is dropped or Ctrl-C.
pub async fn serve_bound(bound: Bound, cfg: SimConfig) -> Result<(), SimError> {
    match bound {
        Bound::Tcp(listener) => serve_tcp(listener, cfg).await,
        Bound::Udp(sock, peer) => serve_udp(sock, peer, cfg).await,
    }
}

/// Serve the simulated vehicle(s) on `listen` until the future is dropped or Ctrl-C.
pub async fn serve(listen: &LinkSpec, cfg: SimConfig) -> Result<(), SimError> {
    serve_bound(bind(listen).await?, cfg).await
}

fn now(clock: &RealClock) -> Micros {
    clock.now()
}

/// TCP server on an already bound listener: every client gets every byte; all clients' frames
/// go to the one simulation.
pub async fn serve_tcp(listener: TcpListener, cfg: SimConfig) -> Result<(), SimError> {
    let clock = RealClock::new();
    let mut sim = super::open(cfg);
    let (in_tx, mut in_rx) = mpsc::channel::<Vec<u8>>(1024);
    let mut clients: BTreeMap<u64, mpsc::Sender<Vec<u8>>> = BTreeMap::new();
    let mut next_id = 0u64;
    let mut tick = interval(PERIOD);
    tick.set_missed_tick_behavior(MissedTickBehavior::Delay);
    let ctrl_c = tokio::signal::ctrl_c();
    tokio::pin!(ctrl_c);
    loop {
        tokio::select! {
            _ = &mut ctrl_c => return Ok(()),
            accepted = listener.accept() => {
                let (stream, peer) = match accepted {
                    Ok(x) => x,
                    Err(e) => {
                        tracing::warn!("sim: accept failed: {e}");
                        continue;
                    }
                };
                let _ = stream.set_nodelay(true);
                tracing::info!("sim: client {peer} connected");
                let (mut rd, mut wr) = stream.into_split();
                let (out_tx, mut out_rx) = mpsc::channel::<Vec<u8>>(CLIENT_QUEUE);
                clients.insert(next_id, out_tx);
                next_id += 1;
                let in_tx = in_tx.clone();
                tokio::spawn(async move {
                    // Frame each client's stream on its own, and hand the sim whole frames only:
                    // two GCSs' partial frames must not interleave in the sim's parser.
                    let mut parser = crate::wire::FrameParser::new();
                    let mut buf = vec![0u8; 4096];
                    loop {
                        match rd.read(&mut buf).await {
                            Ok(0) | Err(_) => break,
                            Ok(n) => {
                                let mut whole = Vec::new();
                                parser.push(&buf[..n], |f| whole.extend_from_slice(&f.raw));
                                if !whole.is_empty() && in_tx.send(whole).await.is_err() {
                                    break;
                                }
                            }
                        }
                    }
                });
                tokio::spawn(async move {
                    while let Some(chunk) = out_rx.recv().await {
                        if wr.write_all(&chunk).await.is_err() {
                            break;
                        }
                    }
                });
            }
            Some(bytes) = in_rx.recv() => {
                sim.receive(now(&clock), &bytes);
                super::save_pending(&mut sim);
            }
            _ = tick.tick() => {
                let out = sim.poll(now(&clock));
                if !out.is_empty() {
                    // A closed client's writer has ended: forget it. A full queue: skip this chunk.
                    clients.retain(|_, tx| !matches!(tx.try_send(out.clone()), Err(mpsc::error::TrySendError::Closed(_))));
                }
            }
        }
    }
}

/// Split concatenated MAVLink frames at frame boundaries (the sim's corruption never touches the
/// length byte, so lengths are reliable); anything unparsable goes out as one piece.
fn frames(bytes: &[u8]) -> Vec<&[u8]> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        let len = match bytes[i] {
            0xFD if i + 2 < bytes.len() => {
                12 + bytes[i + 1] as usize + if bytes[i + 2] & 1 != 0 { 13 } else { 0 }
            }
            0xFE if i + 1 < bytes.len() => 8 + bytes[i + 1] as usize,
            _ => bytes.len() - i,
        };
        let end = (i + len).min(bytes.len());
        out.push(&bytes[i..end]);
        i = end;
    }
    out
}

/// UDP: one frame per datagram, to the fixed peer (udpout) and every peer heard (udpin).
pub async fn serve_udp(
    sock: UdpSocket,
    fixed: Option<SocketAddr>,
    cfg: SimConfig,
) -> Result<(), SimError> {
    let clock = RealClock::new();
    let mut sim = super::open(cfg);
    let mut peers: Vec<SocketAddr> = fixed.into_iter().collect();
    let mut buf = vec![0u8; 65_536];
    let mut tick = interval(PERIOD);
    tick.set_missed_tick_behavior(MissedTickBehavior::Delay);
    let ctrl_c = tokio::signal::ctrl_c();
    tokio::pin!(ctrl_c);
    loop {
        tokio::select! {
            _ = &mut ctrl_c => return Ok(()),
            r = sock.recv_from(&mut buf) => match r {
                Ok((n, peer)) => {
                    if !peers.contains(&peer) {
                        tracing::info!("sim: UDP peer {peer}");
                        peers.push(peer);
                    }
                    sim.receive(now(&clock), &buf[..n]);
                    super::save_pending(&mut sim);
                }
                // ICMP port unreachable from a departed peer shows up here on some systems.
                Err(e) => tracing::debug!("sim: UDP receive: {e}"),
            },
            _ = tick.tick() => {
                let out = sim.poll(now(&clock));
                for f in frames(&out) {
                    for p in &peers {
                        let _ = sock.send_to(f, p).await;
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splits_frames() {
        let a = [0xFD, 1, 0, 0, 0, 1, 1, 0, 0, 0, 7, 0xAA, 0xBB];
        let b = [0xFE, 1, 0, 1, 1, 0, 7, 0xAA, 0xBB];
        let mut all = a.to_vec();
        all.extend_from_slice(&b);
        all.extend_from_slice(&[1, 2, 3]);
        let f = frames(&all);
        assert_eq!(f, vec![&a[..], &b[..], &[1, 2, 3][..]]);
        assert_eq!(frames(&[0xFD]), vec![&[0xFD][..]]);
    }

    #[tokio::test]
    async fn udp_in_answers_the_peer_heard() {
        let sock = UdpSocket::bind("127.0.0.1:0").await.unwrap();
        let addr = sock.local_addr().unwrap();
        let server = tokio::spawn(serve_udp(sock, None, SimConfig::default()));
        let client = UdpSocket::bind("127.0.0.1:0").await.unwrap();
        let hb = crate::wire::frame::encode(
            crate::wire::Version::V2,
            crate::wire::Header {
                sysid: 255,
                compid: 190,
                seq: 0,
            },
            &crate::dialect::MavMessage::HEARTBEAT(Default::default()),
        );
        client.send_to(&hb, addr).await.unwrap();
        let mut buf = [0u8; 300];
        let (n, _) = tokio::time::timeout(Duration::from_secs(3), client.recv_from(&mut buf))
            .await
            .unwrap()
            .unwrap();
        let f = crate::wire::frame::decode_one(&buf[..n]).unwrap();
        assert_eq!((f.sysid, f.compid), (1, 1));
        server.abort();
    }

    /// Read until a heartbeat from each of two vehicles arrived; returns their sysids.
    async fn read_heartbeats(s: &mut tokio::net::TcpStream) -> std::collections::BTreeSet<u8> {
        let mut parser = crate::wire::FrameParser::new();
        let mut buf = vec![0u8; 4096];
        let mut seen = std::collections::BTreeSet::new();
        while seen.len() < 2 {
            let n = s.read(&mut buf).await.unwrap();
            assert!(n > 0, "server closed");
            parser.push(&buf[..n], |f| {
                if f.msgid == 0 {
                    seen.insert(f.sysid);
                }
            });
        }
        seen
    }

    #[tokio::test]
    async fn every_tcp_client_gets_every_byte() {
        let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
        let addr = listener.local_addr().unwrap();
        let server = tokio::spawn(serve_tcp(
            listener,
            SimConfig::from_query("vehicles=2").unwrap(),
        ));
        let mut a = tokio::net::TcpStream::connect(addr).await.unwrap();
        let mut b = tokio::net::TcpStream::connect(addr).await.unwrap();
        let got = tokio::time::timeout(Duration::from_secs(5), async {
            (read_heartbeats(&mut a).await, read_heartbeats(&mut b).await)
        })
        .await
        .expect("heartbeats within 5 s");
        let want: std::collections::BTreeSet<u8> = [1, 2].into();
        assert_eq!(got, (want.clone(), want));
        server.abort();
    }

    #[tokio::test]
    async fn unsupported_spec_is_an_error() {
        let e = serve(
            &LinkSpec::Sim {
                query: String::new(),
            },
            SimConfig::default(),
        )
        .await
        .unwrap_err();
        assert!(e.to_string().contains("cannot listen"), "{e}");
    }
}
