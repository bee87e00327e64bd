//! One tokio task per link: it owns the socket or port, frames what it reads (framing first,
//! decoding second), and writes the frames the core encoded for it.
//!
//! A link that cannot open, or that drops, reports `down: <reason>` and is retried with a capped
//! exponential backoff; the program never stops because one link failed.
//!
//! Every queue is bounded: frames to the core ([`EVENT_QUEUE`] reports), frames from the core
//! ([`OUT_QUEUE`]), and each `tcpin` client's writes. When one is full the frames are dropped and
//! counted (shown on the link), so a peer or a core that cannot keep up never stops our reads nor
//! grows memory.

use std::net::SocketAddr;
use std::time::Duration;

use std::sync::Arc;
use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream, UdpSocket};

use tokio::sync::{mpsc, Semaphore};

use super::replay::{ReplayCmd, ReplayStatus};
use super::source::SourceFactory;
use super::spec::LinkSpec;
use super::state::LinkState;
use super::{Frame, LinkId};
use crate::wire::parser::{FrameParser, ParserStats};

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
    /// Frames dropped because the queue to the core was full.
    Dropped(u64),
    /// Where a replay is (sent in order with its frames).
    Replay(ReplayStatus),
}

/// Reports a link may have waiting for the core (each carries the frames of one read).
pub const EVENT_QUEUE: usize = 1024;
/// Frames the core may have waiting for a link.
pub const OUT_QUEUE: usize = 256;
/// Replay controls waiting for a link.
pub const CONTROL_QUEUE: usize = 16;
/// Reports of frames a replay may have waiting for the core: a replay waits for the core rather
/// than drop frames, and holds at most this many reports of [`REPLAY_CHUNK`] bytes of frames.
///
/// [`REPLAY_CHUNK`]: super::source::REPLAY_CHUNK
pub const REPLAY_CREDITS: usize = 8;

/// The core's handle on a running link task.
#[derive(Debug)]
pub struct LinkHandle {
    pub id: LinkId,
    pub spec: LinkSpec,
    tx: mpsc::Sender<Vec<u8>>,
    ctl: mpsc::Sender<ReplayCmd>,
    /// For a replay: reports it may still send (one comes back as the core takes each).
    credits: Option<Arc<Semaphore>>,
    task: tokio::task::JoinHandle<()>,
}

impl LinkHandle {
    /// Queue a frame for sending. False when it was dropped: the queue is full (the link cannot
    /// keep up) or the task has ended.
    pub fn send(&self, frame: Vec<u8>) -> bool {
        self.tx.try_send(frame).is_ok()
    }

    /// Pass a replay control on; false when it was dropped (queue full, task ended).
    pub fn control(&self, cmd: ReplayCmd) -> bool {
        self.ctl.try_send(cmd).is_ok()
    }

    /// The core took a report of frames from this link: a replay may send another.
    pub fn took_frames(&self) {
        if let Some(c) = &self.credits {
            c.add_permits(1);
        }
    }
}

impl Drop for LinkHandle {
    fn drop(&mut self) {
        self.task.abort();
    }
}

/// Where link tasks report: frames on a bounded queue, state changes (rare) on their own.
#[derive(Debug, Clone)]
pub struct EventTx {
    pub frames: mpsc::Sender<(LinkId, LinkEvent)>,
    pub states: mpsc::UnboundedSender<(LinkId, LinkEvent)>,
}

/// Parser plus the bookkeeping to report counter increases.
struct Ingest {
    id: LinkId,
    parser: FrameParser,
    reported: ParserStats,
    events: EventTx,
    /// Frames dropped on a full queue and not reported yet.
    dropped: u64,
    /// Bytes an in-process source passed over, not reported yet (added to the garbage bytes).
    skipped: u64,
    /// A replay's credits ([`REPLAY_CREDITS`]).
    credits: Option<Arc<Semaphore>>,
}

/// Room for one report to the core, waited for: a place in the queue, and for frames of a
/// replay one of its credits.
struct Room<'a> {
    credit: Option<tokio::sync::SemaphorePermit<'a>>,
    slot: mpsc::Permit<'a, (LinkId, LinkEvent)>,
}

impl Ingest {
    fn new(id: LinkId, events: EventTx) -> Self {
        Self {
            id,
            parser: FrameParser::lazy(),
            reported: ParserStats::default(),
            events,
            dropped: 0,
            skipped: 0,
            credits: None,
        }
    }

    /// Frame `bytes` into a report, with `skipped` bytes counted as garbage.
    fn frames_event(&mut self, bytes: &[u8], skipped: u64) -> LinkEvent {
        let mut frames = self.parser.frame_vec(bytes.len());
        self.parser.push_into(bytes, &mut frames);
        let now = *self.parser.stats();
        let mut stats = now.since(&self.reported);
        self.reported = now;
        stats.garbage_bytes += skipped;
        LinkEvent::Frames { frames, stats }
    }

    /// Wait for room for a report (`credit`: one of a replay's frames reports). `None` when the
    /// core has gone.
    async fn room(&self, credit: bool) -> Option<Room<'_>> {
        let credit = match (&self.credits, credit) {
            (Some(c), true) => Some(c.acquire().await.ok()?),
            _ => None,
        };
        let slot = self.events.frames.reserve().await.ok()?;
        Some(Room { credit, slot })
    }

    /// Frame `bytes`; `datagram` says they were one whole UDP packet.
    fn feed(&mut self, bytes: &[u8], datagram: bool) {
        let mut frames = self.parser.frame_vec(bytes.len());
        self.parser.push_into(bytes, &mut frames);
        if datagram {
            self.parser.end_of_datagram_into(&mut frames);
        }
        let now = *self.parser.stats();
        let delta = now.since(&self.reported);
        self.reported = now;
        let mut stats = delta;
        stats.garbage_bytes += self.skipped;
        if self.dropped > 0
            && self
                .events
                .frames
                .try_send((self.id, LinkEvent::Dropped(self.dropped)))
                .is_ok()
        {
            self.dropped = 0;
        }
        let n = frames.len() as u64;
        let ev = LinkEvent::Frames { frames, stats };
        match self.events.frames.try_send((self.id, ev)) {
            Ok(()) => self.skipped = 0,
            Err(e) => {
                // The core is behind: keep reading, count what could not be handed on. The
                // parser counters (and skipped bytes) still reach it with the next report.
                self.dropped += n;
                if let mpsc::error::TrySendError::Full(_) = e {
                    self.reported = self.reported.since(&delta);
                }
            }
        }
    }

    fn state(&self, s: LinkState) {
        let _ = self.events.states.send((self.id, LinkEvent::State(s)));
    }
}

/// Start the task for one link; `local` builds in-process sources (`sim://`, `tlog:`).
pub fn spawn_link(id: LinkId, spec: LinkSpec, local: SourceFactory, events: EventTx) -> LinkHandle {
    let (tx, rx) = mpsc::channel(OUT_QUEUE);
    let (ctl, ctl_rx) = mpsc::channel(CONTROL_QUEUE);
    let credits =
        matches!(spec, LinkSpec::Tlog { .. }).then(|| Arc::new(Semaphore::new(REPLAY_CREDITS)));
    let task_spec = spec.clone();
    let task_credits = credits.clone();
    let task = tokio::spawn(async move {
        run_link(id, task_spec, local, events, rx, ctl_rx, task_credits).await;
    });
    LinkHandle {
        id,
        spec,
        tx,
        ctl,
        credits,
        task,
    }
}

type OutRx = mpsc::Receiver<Vec<u8>>;

async fn run_link(
    id: LinkId,
    spec: LinkSpec,
    local: SourceFactory,
    events: EventTx,
    mut out: OutRx,
    mut ctl: mpsc::Receiver<ReplayCmd>,
    credits: Option<Arc<Semaphore>>,
) {
    let mut ingest = Ingest::new(id, events);
    ingest.credits = credits;
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
                    Opened::Tcp(s) => stream_loop(s, &mut ingest, &mut out).await,
                    Opened::Serial(s) => stream_loop(s, &mut ingest, &mut out).await,
                    Opened::Udp(sock, fixed) => udp_loop(sock, fixed, &mut ingest, &mut out).await,
                    Opened::Listener(l) => tcp_server(l, &mut ingest, &mut out).await,
                    Opened::Local => {
                        let spec = spec.clone();
                        let local = local.clone();
                        // Building a source may read a file: off the async workers.
                        match tokio::task::spawn_blocking(move || local(&spec)).await {
                            Ok(Ok(src)) => {
                                crate::link::local::run_local(
                                    src,
                                    &mut ingest_adapter(&mut ingest),
                                    &mut out,
                                    &mut ctl,
                                )
                                .await
                            }
                            Ok(Err(e)) => Err(e),
                            Err(e) => Err(format!("opening: {e}")),
                        }
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
    /// Feed `bytes`, and count `skipped` bytes the source passed over as garbage.
    pub fn feed_skipped(&mut self, bytes: &[u8], skipped: u64) {
        self.ingest.skipped += skipped;
        self.ingest.feed(bytes, false);
    }
    pub fn up(&mut self) {
        self.ingest.state(LinkState::Up);
    }

    /// Frame `bytes` into a report, `skipped` bytes counted as garbage, to send with
    /// [`LocalIngest::send_waiting`].
    pub fn frames_event(&mut self, bytes: &[u8], skipped: u64) -> LinkEvent {
        self.ingest.frames_event(bytes, skipped)
    }

    /// Send `ev` to the core, waiting for room (a replay loses nothing), while still taking
    /// what the core sends to the source (`out`, handed to `receive`). False when the core or
    /// the link's handle has gone.
    pub async fn send_waiting(
        &mut self,
        ev: LinkEvent,
        out: &mut mpsc::Receiver<Vec<u8>>,
        mut receive: impl FnMut(Vec<u8>),
    ) -> bool {
        let credit = matches!(ev, LinkEvent::Frames { .. });
        let id = self.ingest.id;
        loop {
            tokio::select! {
                room = self.ingest.room(credit) => {
                    let Some(room) = room else { return false };
                    if let Some(c) = room.credit {
                        c.forget();
                    }
                    room.slot.send((id, ev));
                    return true;
                }
                m = out.recv() => match m {
                    Some(bytes) => receive(bytes),
                    None => return false,
                },
            }
        }
    }
}

fn ingest_adapter(ingest: &mut Ingest) -> LocalIngest<'_> {
    LocalIngest { ingest }
}

async fn stream_loop<S: AsyncRead + AsyncWrite + Unpin>(
    s: S,
    ingest: &mut Ingest,
    out: &mut OutRx,
) -> Result<(), String> {
    // Reading and writing run side by side: a peer that stops reading (its window full, our
    // writes blocked) must not stop us reading what it sends. Frames for it wait in the bounded
    // queue and are dropped, counted, when that is full.
    let (mut rd, mut wr) = tokio::io::split(s);
    let reader = async {
        let mut buf = vec![0u8; 4096];
        loop {
            match rd.read(&mut buf).await {
                Ok(0) => return Err("connection closed".to_string()),
                Ok(n) => ingest.feed(&buf[..n], false),
                Err(e) => return Err(format!("read: {e}")),
            }
        }
    };
    let writer = async {
        while let Some(bytes) = out.recv().await {
            if let Err(e) = wr.write_all(&bytes).await {
                return Err(format!("write: {e}"));
            }
        }
        Ok(())
    };
    tokio::select! {
        r = reader => r,
        w = writer => w,
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
        LinkSpec::UdpIn { addr, port, .. } => UdpSocket::bind((addr.as_str(), *port))
            .await
            .map(|s| Opened::Udp(s, None))
            .map_err(|e| format!("bind {addr}:{port}: {e}")),
        LinkSpec::UdpOut { host, port, .. } => {
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
        LinkSpec::TcpClient { host, port, .. } => {
            let s = TcpStream::connect((host.as_str(), *port))
                .await
                .map_err(|e| format!("connect {host}:{port}: {e}"))?;
            let _ = s.set_nodelay(true);
            Ok(Opened::Tcp(s))
        }
        LinkSpec::TcpServer { addr, port, .. } => TcpListener::bind((addr.as_str(), *port))
            .await
            .map(Opened::Listener)
            .map_err(|e| format!("listen {addr}:{port}: {e}")),
        LinkSpec::Serial { path, .. } => {
            // Opening a tty can block (a USB adapter being reset): off the async workers.
            let (p, b) = (path.clone(), spec.baud());
            tokio::task::spawn_blocking(move || {
                tokio_serial::SerialStream::open(&tokio_serial::new(&p, b))
                    .map_err(|e| format!("{p}: {e}"))
            })
            .await
            .map_err(|e| format!("{path}: {e}"))?
            .map(Opened::Serial)
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
    out: &mut OutRx,
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
                    ingest.feed(&buf[..n], true);
                }
                // ICMP port-unreachable from a peer that went away shows up here on some
                // systems: not a reason to close the socket.
                Err(e) => tracing::debug!("udp recv: {e}"),
            },
            m = out.recv() => match m {
                Some(bytes) => {
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
    out: &mut OutRx,
) -> Result<(), String> {
    // Each client has its own parser (their byte streams must not interleave) and its own task,
    // which reads, and writes what it is handed through a bounded queue: a stalled client loses
    // its own frames (counted on the link) instead of holding up the others or our reads. The
    // JoinSet ends them with the link.
    let mut clients: tokio::task::JoinSet<()> = tokio::task::JoinSet::new();
    let mut writers: Vec<mpsc::Sender<std::sync::Arc<Vec<u8>>>> = Vec::new();
    loop {
        tokio::select! {
            a = listener.accept() => match a {
                Ok((stream, peer)) => {
                    let _ = stream.set_nodelay(true);
                    tracing::info!(%peer, "tcp client connected");
                    let (wtx, wrx) = mpsc::channel(CLIENT_QUEUE);
                    writers.push(wtx);
                    let client = Ingest::new(ingest.id, ingest.events.clone());
                    clients.spawn(serve_client(stream, client, wrx));
                }
                Err(e) => tracing::warn!("accept: {e}"),
            },
            Some(_) = clients.join_next(), if !clients.is_empty() => {}
            m = out.recv() => match m {
                Some(bytes) => {
                    writers.retain(|w| !w.is_closed());
                    let bytes = std::sync::Arc::new(bytes);
                    let mut dropped = 0;
                    for w in &writers {
                        // Full queue: this client is not reading; drop the frame for it alone.
                        if w.try_send(bytes.clone()).is_err() {
                            dropped += 1;
                        }
                    }
                    if dropped > 0 {
                        let _ = ingest.events.frames.try_send((ingest.id, LinkEvent::Dropped(dropped)));
                    }
                }
                None => return Ok(()),
            },
        }
    }
}

/// Frames a `tcpin` client may have waiting before its frames are dropped.
pub const CLIENT_QUEUE: usize = 256;

/// One `tcpin` client: read and frame its bytes; write what the link sends, side by side, so a
/// client that stops reading is still heard.
async fn serve_client(
    stream: TcpStream,
    mut client: Ingest,
    mut out: mpsc::Receiver<std::sync::Arc<Vec<u8>>>,
) {
    let (mut rd, mut wr) = stream.into_split();
    let reader = async {
        let mut buf = vec![0u8; 4096];
        while let Ok(n @ 1..) = rd.read(&mut buf).await {
            client.feed(&buf[..n], false);
        }
    };
    let writer = async {
        while let Some(bytes) = out.recv().await {
            if wr.write_all(&bytes).await.is_err() {
                return;
            }
        }
    };
    tokio::select! {
        () = reader => {}
        () = writer => {}
    }
}
