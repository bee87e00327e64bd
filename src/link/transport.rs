//! One tokio task per link: it owns the socket or port, frames what it reads (framing first,
//! decoding second), and encodes what the core asks it to send with its own sequence numbers.
//!
//! A link that cannot open, or that drops, reports `down: <reason>` and is retried with a capped
//! exponential backoff; the program never stops because one link failed.

use std::net::SocketAddr;
use std::time::Duration;

use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream, UdpSocket};
use tokio::sync::mpsc;

use super::spec::LinkSpec;
use super::state::LinkState;
use super::{Frame, LinkId};
use crate::dialect::MavMessage;
use crate::wire::parser::{FrameParser, ParserStats};
use crate::wire::tx::LinkTx;

/// First retry delay after a link fails.
pub const BACKOFF_START: Duration = Duration::from_millis(500);
/// Longest retry delay.
pub const BACKOFF_MAX: Duration = Duration::from_secs(5);
/// How many UDP peers an `udpin` link replies to.
const MAX_UDP_PEERS: usize = 8;

/// What a link task reports to the core.
#[derive(Debug, Clone)]
pub enum LinkEvent {
    /// Frames read, and the increase of the parser counters that produced them.
    Frames {
        frames: Vec<Frame>,
        stats: ParserStats,
    },
    State(LinkState),
}

/// Our identity on the links.
#[derive(Debug, Clone, Copy)]
pub struct LinkIdentity {
    pub sysid: u8,
    pub compid: u8,
}

/// The core's handle on a running link task.
#[derive(Debug)]
pub struct LinkHandle {
    pub id: LinkId,
    pub spec: LinkSpec,
    tx: mpsc::UnboundedSender<MavMessage>,
    task: tokio::task::JoinHandle<()>,
}

impl LinkHandle {
    /// Queue a message for sending. Dropped silently if the link task has ended.
    pub fn send(&self, msg: MavMessage) {
        let _ = self.tx.send(msg);
    }
}

impl Drop for LinkHandle {
    fn drop(&mut self) {
        self.task.abort();
    }
}

type EventTx = mpsc::UnboundedSender<(LinkId, LinkEvent)>;

/// Parser plus the bookkeeping to report counter increases.
struct Ingest {
    id: LinkId,
    parser: FrameParser,
    reported: ParserStats,
    events: EventTx,
}

impl Ingest {
    fn new(id: LinkId, events: EventTx) -> Self {
        Self {
            id,
            parser: FrameParser::new(),
            reported: ParserStats::default(),
            events,
        }
    }

    /// Frame `bytes`; `datagram` says they were one whole UDP packet.
    fn feed(&mut self, bytes: &[u8], datagram: bool, tx: &mut LinkTx) {
        let mut frames = Vec::new();
        self.parser.push(bytes, |f| frames.push(f));
        if datagram {
            self.parser.end_of_datagram(|f| frames.push(f));
        }
        let now = *self.parser.stats();
        let delta = now.since(&self.reported);
        self.reported = now;
        tx.observe(&now);
        let _ = self.events.send((
            self.id,
            LinkEvent::Frames {
                frames,
                stats: delta,
            },
        ));
    }

    fn state(&self, s: LinkState) {
        let _ = self.events.send((self.id, LinkEvent::State(s)));
    }
}

/// Start the task for one link.
pub fn spawn_link(id: LinkId, spec: LinkSpec, me: LinkIdentity, events: EventTx) -> LinkHandle {
    let (tx, rx) = mpsc::unbounded_channel();
    let task_spec = spec.clone();
    let task = tokio::spawn(async move {
        run_link(id, task_spec, me, events, rx).await;
    });
    LinkHandle { id, spec, tx, task }
}

async fn run_link(
    id: LinkId,
    spec: LinkSpec,
    me: LinkIdentity,
    events: EventTx,
    mut out: mpsc::UnboundedReceiver<MavMessage>,
) {
    let mut ingest = Ingest::new(id, events);
    let mut tx = LinkTx::new(me.sysid, me.compid);
    let mut backoff = BACKOFF_START;
    loop {
        ingest.state(LinkState::Connecting);
        let result = match open(&spec).await {
            Err(e) => Err(e),
            Ok(opened) => {
                backoff = BACKOFF_START;
                if !matches!(opened, Opened::Local) {
                    ingest.state(LinkState::Up);
                }
                match opened {
                    Opened::Tcp(s) => stream_loop(s, &mut ingest, &mut tx, &mut out).await,
                    Opened::Serial(s) => stream_loop(s, &mut ingest, &mut tx, &mut out).await,
                    Opened::Udp(sock, fixed) => {
                        udp_loop(sock, fixed, &mut ingest, &mut tx, &mut out).await
                    }
                    Opened::Listener(l) => tcp_server(l, &mut ingest, &mut tx, &mut out).await,
                    Opened::Local => {
                        crate::link::local::run_local(
                            &spec,
                            &mut ingest_adapter(&mut ingest),
                            &mut tx,
                            &mut out,
                        )
                        .await
                    }
                }
            }
        };
        let reason = match result {
            Ok(()) => return,
            Err(r) => r,
        };
        tracing::warn!(link = id, %reason, "link down");
        ingest.state(LinkState::Down(reason));
        // Keep draining outgoing messages while down so the queue does not grow.
        let sleep = tokio::time::sleep(backoff);
        tokio::pin!(sleep);
        loop {
            tokio::select! {
                _ = &mut sleep => break,
                m = out.recv() => if m.is_none() { return },
            }
        }
        backoff = (backoff * 2).min(BACKOFF_MAX);
    }
}

/// Feeds bytes read by a local (in-process) link into the link's parser.
pub struct LocalIngest<'a> {
    ingest: &'a mut Ingest,
}

impl LocalIngest<'_> {
    pub fn feed(&mut self, bytes: &[u8], tx: &mut LinkTx) {
        self.ingest.feed(bytes, false, tx);
    }
    pub fn up(&mut self) {
        self.ingest.state(LinkState::Up);
    }
}

fn ingest_adapter(ingest: &mut Ingest) -> LocalIngest<'_> {
    LocalIngest { ingest }
}

async fn stream_loop<S: AsyncRead + AsyncWrite + Unpin>(
    mut s: S,
    ingest: &mut Ingest,
    tx: &mut LinkTx,
    out: &mut mpsc::UnboundedReceiver<MavMessage>,
) -> Result<(), String> {
    let mut buf = vec![0u8; 4096];
    loop {
        tokio::select! {
            r = s.read(&mut buf) => match r {
                Ok(0) => return Err("connection closed".into()),
                Ok(n) => ingest.feed(&buf[..n], false, tx),
                Err(e) => return Err(format!("read: {e}")),
            },
            m = out.recv() => match m {
                Some(msg) => {
                    let bytes = tx.encode(&msg);
                    if let Err(e) = s.write_all(&bytes).await {
                        return Err(format!("write: {e}"));
                    }
                }
                None => return Ok(()),
            },
        }
    }
}

/// A link's transport, opened and ready to run.
enum Opened {
    Tcp(TcpStream),
    Serial(tokio_serial::SerialStream),
    /// A UDP socket, with the fixed peer of `udpout` (none for `udpin`).
    Udp(UdpSocket, Option<SocketAddr>),
    Listener(TcpListener),
    /// In-process links open (and report up) themselves.
    Local,
}

/// Open the transport a spec names; the error is the "down" reason.
async fn open(spec: &LinkSpec) -> Result<Opened, String> {
    match spec {
        LinkSpec::UdpIn { addr, port } => UdpSocket::bind((addr.as_str(), *port))
            .await
            .map(|s| Opened::Udp(s, None))
            .map_err(|e| format!("bind {addr}:{port}: {e}")),
        LinkSpec::UdpOut { host, port } => {
            let target = tokio::net::lookup_host((host.as_str(), *port))
                .await
                .map_err(|e| format!("resolve {host}: {e}"))?
                .next()
                .ok_or_else(|| format!("resolve {host}: no address"))?;
            let local: SocketAddr = if target.is_ipv6() {
                "[::]:0".parse().expect("addr")
            } else {
                "0.0.0.0:0".parse().expect("addr")
            };
            UdpSocket::bind(local)
                .await
                .map(|s| Opened::Udp(s, Some(target)))
                .map_err(|e| format!("bind: {e}"))
        }
        LinkSpec::TcpClient { host, port } => {
            let s = TcpStream::connect((host.as_str(), *port))
                .await
                .map_err(|e| format!("connect {host}:{port}: {e}"))?;
            let _ = s.set_nodelay(true);
            Ok(Opened::Tcp(s))
        }
        LinkSpec::TcpServer { addr, port } => TcpListener::bind((addr.as_str(), *port))
            .await
            .map(Opened::Listener)
            .map_err(|e| format!("listen {addr}:{port}: {e}")),
        LinkSpec::Serial { path, baud } => {
            tokio_serial::SerialStream::open(&tokio_serial::new(path, *baud))
                .map(Opened::Serial)
                .map_err(|e| format!("{path}: {e}"))
        }
        LinkSpec::Sim { .. } | LinkSpec::Tlog { .. } => Ok(Opened::Local),
    }
}

/// Datagrams in, frames out. With a `fixed` peer (udpout) everything goes there; without one
/// (udpin) replies go to every peer heard, most recent first.
async fn udp_loop(
    sock: UdpSocket,
    fixed: Option<SocketAddr>,
    ingest: &mut Ingest,
    tx: &mut LinkTx,
    out: &mut mpsc::UnboundedReceiver<MavMessage>,
) -> Result<(), String> {
    let mut peers: Vec<SocketAddr> = fixed.into_iter().collect();
    let mut buf = vec![0u8; 65536];
    loop {
        tokio::select! {
            r = sock.recv_from(&mut buf) => match r {
                Ok((n, from)) => {
                    if fixed.is_none() {
                        peers.retain(|p| *p != from);
                        peers.insert(0, from);
                        peers.truncate(MAX_UDP_PEERS);
                    }
                    ingest.feed(&buf[..n], true, tx);
                }
                // ICMP port-unreachable from a peer that went away shows up here on some
                // systems: not a reason to close the socket.
                Err(e) => tracing::debug!("udp recv: {e}"),
            },
            m = out.recv() => match m {
                Some(msg) => {
                    if peers.is_empty() { continue; }
                    let bytes = tx.encode(&msg);
                    for p in &peers {
                        let _ = sock.send_to(&bytes, p).await;
                    }
                }
                None => return Ok(()),
            },
        }
    }
}

async fn tcp_server(
    listener: TcpListener,
    ingest: &mut Ingest,
    tx: &mut LinkTx,
    out: &mut mpsc::UnboundedReceiver<MavMessage>,
) -> Result<(), String> {
    // Each client has its own parser (their byte streams must not interleave) and its own task,
    // which reads, and writes what it is handed through a bounded queue: a stalled client loses
    // its own frames instead of holding up the others. The JoinSet ends them with the link.
    let mut clients: tokio::task::JoinSet<()> = tokio::task::JoinSet::new();
    let mut writers: Vec<mpsc::Sender<std::sync::Arc<Vec<u8>>>> = Vec::new();
    let (totals_tx, mut totals_rx) = mpsc::unbounded_channel::<ParserStats>();
    let mut totals = ParserStats::default();
    loop {
        tokio::select! {
            a = listener.accept() => match a {
                Ok((stream, peer)) => {
                    let _ = stream.set_nodelay(true);
                    tracing::info!(%peer, "tcp client connected");
                    let (wtx, wrx) = mpsc::channel(CLIENT_QUEUE);
                    writers.push(wtx);
                    let client = Ingest::new(ingest.id, ingest.events.clone());
                    clients.spawn(serve_client(stream, client, wrx, totals_tx.clone()));
                }
                Err(e) => tracing::warn!("accept: {e}"),
            },
            Some(d) = totals_rx.recv() => {
                totals.add(&d);
                tx.observe(&totals);
            }
            Some(_) = clients.join_next(), if !clients.is_empty() => {}
            m = out.recv() => match m {
                Some(msg) => {
                    writers.retain(|w| !w.is_closed());
                    if writers.is_empty() { continue; }
                    let bytes = std::sync::Arc::new(tx.encode(&msg));
                    for w in &writers {
                        // Full queue: this client is not reading; drop the frame for it alone.
                        let _ = w.try_send(bytes.clone());
                    }
                }
                None => return Ok(()),
            },
        }
    }
}

/// Frames a `tcpin` client may have waiting before its frames are dropped.
const CLIENT_QUEUE: usize = 256;

/// One `tcpin` client: read and frame its bytes; write what the link sends.
async fn serve_client(
    stream: TcpStream,
    mut client: Ingest,
    mut out: mpsc::Receiver<std::sync::Arc<Vec<u8>>>,
    totals: mpsc::UnboundedSender<ParserStats>,
) {
    let (mut rd, mut wr) = stream.into_split();
    let mut buf = vec![0u8; 4096];
    // Clients' own versions are not tracked: the link's sender decides for all of them.
    let mut unused_tx = LinkTx::new(0, 0);
    loop {
        tokio::select! {
            r = rd.read(&mut buf) => match r {
                Ok(0) | Err(_) => return,
                Ok(n) => {
                    let before = *client.parser.stats();
                    client.feed(&buf[..n], false, &mut unused_tx);
                    let _ = totals.send(client.parser.stats().since(&before));
                }
            },
            m = out.recv() => match m {
                Some(bytes) => {
                    if wr.write_all(&bytes).await.is_err() {
                        return;
                    }
                }
                None => return,
            },
        }
    }
}
