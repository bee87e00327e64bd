//! Recording a telemetry log (`.tlog`): every frame heard and sent, on every link, in the format
//! MAVProxy, QGroundControl and pymavlink read (8 bytes big-endian µs since the Unix epoch, then
//! the frame as on the wire).
//!
//! The driver's loop only appends records to a batch ([`Recorder::record`]) and hands the batch
//! to a writer thread through a bounded queue ([`Recorder::end_step`]) once it is
//! [`HAND_OVER_EVERY`] old or [`HAND_OVER_BYTES`] long, at a step that comes anyway (woken for it
//! only at [`HAND_OVER_WAKE`]): a vehicle streaming at ordinary rates wakes the writer twice a
//! second, not at every step, and the loop not at all; a writer
//! that falls behind (a slow disk) loses batches, counted, and never holds up the screen or the
//! links. The writer flushes what it holds at least once a second, and everything on exit (the
//! recorder's drop, whichever way the program ends). A write error (a full disk) stops the
//! recording; the core is told (a notice, the status bar) and the program goes on.
//!
//! SETUP_SIGNING (it carries the secret key) is never written.

use std::fs::{File, OpenOptions};
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::mpsc::{self, RecvTimeoutError, SyncSender, TrySendError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crate::app::tap::RecordingStatus;
use crate::clock::{Micros, SECOND};
use crate::link::tlog::write_record;

/// Batches the writer may have waiting (two a second at ordinary rates; one per 16 KiB under
/// load).
pub const RECORD_QUEUE: usize = 256;
/// A batch goes to the writer at the first step once its first record is this old (core time)
/// ...
pub const HAND_OVER_EVERY: Micros = SECOND / 2;
/// ... or once it is this long; ...
pub const HAND_OVER_BYTES: usize = 16 * 1024;
/// ... and the driver is woken for it (when nothing else steps it) once it is this old.
pub const HAND_OVER_WAKE: Micros = SECOND;
/// What the writer holds in memory before writing it out.
const WRITE_BUFFER: usize = 64 * 1024;
/// The longest a record waits in the writer before it reaches the file (after at most
/// [`HAND_OVER_EVERY`] in the batch).
pub const FLUSH_EVERY: Duration = Duration::from_secs(1);
/// The fewest core µs between two reports of the log's size.
const REPORT_EVERY: Micros = SECOND;

/// MAVLink 2 message id of SETUP_SIGNING, which carries the secret key.
pub const SETUP_SIGNING_ID: u32 = <crate::dialect::SETUP_SIGNING_DATA as mavlink::MessageData>::ID;

/// True for a frame that must never be logged nor forwarded: SETUP_SIGNING (read from the
/// MAVLink 2 header; MAVLink 1 cannot carry id 256).
#[inline]
pub fn carries_secret(raw: &[u8]) -> bool {
    raw.len() >= 10
        && raw[0] == crate::wire::frame::MAGIC_V2
        && u32::from_le_bytes([raw[7], raw[8], raw[9], 0]) == SETUP_SIGNING_ID
}

/// Where to record.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum TlogTarget {
    /// This file, appended to when it exists (never truncated).
    File(PathBuf),
    /// A new file in this directory (made if missing), named after the local time of the start,
    /// `YYYY-MM-DD_HH-MM-SS.tlog`, with `-1`, `-2`, ... before `.tlog` if that name is taken.
    NewIn(PathBuf),
}

/// The file to record to, opened: the path and the file, and how long it already is.
fn open_target(
    target: &TlogTarget,
    start: chrono::NaiveDateTime,
) -> Result<(PathBuf, File), (PathBuf, String)> {
    match target {
        TlogTarget::File(path) => {
            // A FIFO would block the start, a device would take the log: only a regular file
            // (or a new one), opened without waiting and checked again once open.
            let fail = |e: io::Error| (path.clone(), e.to_string());
            crate::fsio::check_plain_target(path).map_err(fail)?;
            let mut opts = OpenOptions::new();
            opts.create(true).append(true);
            #[cfg(unix)]
            {
                use std::os::unix::fs::OpenOptionsExt;
                opts.custom_flags(libc::O_NONBLOCK);
            }
            let f = opts.open(path).map_err(fail)?;
            if !f.metadata().map_err(fail)?.is_file() {
                return Err((path.clone(), "not a regular file: refused".into()));
            }
            Ok((path.clone(), f))
        }
        TlogTarget::NewIn(dir) => {
            std::fs::create_dir_all(dir).map_err(|e| (dir.clone(), e.to_string()))?;
            let stem = start.format("%Y-%m-%d_%H-%M-%S").to_string();
            for n in 0..1000u32 {
                let name = match n {
                    0 => format!("{stem}.tlog"),
                    n => format!("{stem}-{n}.tlog"),
                };
                let path = dir.join(name);
                match OpenOptions::new().write(true).create_new(true).open(&path) {
                    Ok(f) => return Ok((path, f)),
                    Err(e) if e.kind() == io::ErrorKind::AlreadyExists => continue,
                    Err(e) => return Err((path, e.to_string())),
                }
            }
            Err((
                dir.join(format!("{stem}.tlog")),
                "every name is taken".into(),
            ))
        }
    }
}

/// How long [`Recorder::finish`] waits for the writer to write out and sync.
pub const FINISH_WAIT: Duration = Duration::from_secs(2);

/// The recording: the batch being filled, the queue to the writer thread, and what the core was
/// last told.
pub struct Recorder {
    path: PathBuf,
    tx: Option<SyncSender<Vec<u8>>>,
    thread: Option<JoinHandle<Result<(), String>>>,
    /// Closed when the writer thread ends: [`Recorder::finish`] waits on it, bounded.
    done: Option<mpsc::Receiver<()>>,
    batch: Vec<u8>,
    batch_frames: u64,
    /// When (core time) the batch got its first record, at the end of that step.
    batch_since: Option<Micros>,
    /// File size: what it had at the start plus every batch the writer took.
    bytes: u64,
    dropped: u64,
    error: Option<String>,
    /// (bytes, dropped, error shown) last reported, and when.
    reported: Option<(u64, u64, bool)>,
    reported_at: Micros,
}

impl Recorder {
    /// Open the log and start its writer. `start` names a new file (local time). The error is
    /// the path tried and why it failed, for the operator.
    pub fn start(
        target: &TlogTarget,
        start: chrono::NaiveDateTime,
    ) -> Result<Recorder, RecordingStatus> {
        let (path, file) = open_target(target, start).map_err(|(path, e)| RecordingStatus {
            path,
            bytes: 0,
            dropped: 0,
            error: Some(e),
        })?;
        Self::with_file(path, file)
    }

    /// Start the writer on an open file.
    fn with_file(path: PathBuf, file: File) -> Result<Recorder, RecordingStatus> {
        let bytes = file.metadata().map(|m| m.len()).unwrap_or(0);
        let (tx, rx) = mpsc::sync_channel::<Vec<u8>>(RECORD_QUEUE);
        let (done_tx, done_rx) = mpsc::sync_channel::<()>(1);
        let spawned = std::thread::Builder::new()
            .name("tlog writer".into())
            .spawn(move || {
                let r = write_loop(file, bytes, rx);
                drop(done_tx);
                r
            });
        let thread = spawned.map_err(|e| RecordingStatus {
            path: path.clone(),
            bytes,
            dropped: 0,
            error: Some(format!("starting the writer: {e}")),
        })?;
        Ok(Recorder {
            path,
            tx: Some(tx),
            thread: Some(thread),
            done: Some(done_rx),
            batch: Vec::new(),
            batch_frames: 0,
            batch_since: None,
            bytes,
            dropped: 0,
            error: None,
            reported: None,
            reported_at: 0,
        })
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Add a frame to this step's batch, stamped `wall` µs since the Unix epoch. SETUP_SIGNING
    /// is left out.
    #[inline]
    pub fn record(&mut self, wall: u64, raw: &[u8]) {
        if self.tx.is_none() || carries_secret(raw) {
            return;
        }
        write_record(&mut self.batch, wall, raw);
        self.batch_frames += 1;
    }

    /// [`Recorder::record`] each of a link's frames.
    pub fn record_frames(&mut self, wall: u64, frames: &[crate::link::Frame]) {
        for f in frames {
            self.record(wall, &f.raw);
        }
    }

    /// After a driver step: the batch handed on when due ([`Recorder::end_step`]), and what the
    /// core should be told ([`Recorder::report`]).
    pub fn after_step(&mut self, now: Micros) -> Option<RecordingStatus> {
        self.end_step(now);
        self.report(now)
    }

    /// At the end of a driver step at `now`: the batch handed to the writer once it is
    /// [`HAND_OVER_EVERY`] old or [`HAND_OVER_BYTES`] long.
    pub fn end_step(&mut self, now: Micros) {
        if self.batch.is_empty() {
            return;
        }
        let since = *self.batch_since.get_or_insert(now);
        if self.batch.len() >= HAND_OVER_BYTES || now >= since + HAND_OVER_EVERY {
            self.hand_over();
        }
    }

    /// Hand the batch to the writer now; dropped (and counted) when the writer is behind.
    pub fn hand_over(&mut self) {
        if self.batch.is_empty() {
            return;
        }
        self.batch_since = None;
        let Some(tx) = &self.tx else {
            self.batch.clear();
            return;
        };
        let batch = std::mem::take(&mut self.batch);
        let len = batch.len() as u64;
        match tx.try_send(batch) {
            Ok(()) => self.bytes += len,
            Err(TrySendError::Full(mut b)) => {
                self.dropped += self.batch_frames;
                b.clear();
                self.batch = b; // its room is used again
            }
            Err(TrySendError::Disconnected(_)) => {
                self.dropped += self.batch_frames;
                self.stop();
            }
        }
        self.batch_frames = 0;
    }

    /// The writer ended (it only does on an error): learn why.
    fn stop(&mut self) {
        self.tx = None;
        let why = match self.thread.take().map(JoinHandle::join) {
            Some(Ok(Err(e))) => e,
            Some(Err(_)) => "the writer failed".to_string(),
            _ => "the writer stopped".to_string(),
        };
        self.error.get_or_insert(why);
    }

    /// What the core should be told at `now`: the start, a new size (at most once a second),
    /// an error (at once).
    pub fn report(&mut self, now: Micros) -> Option<RecordingStatus> {
        // A writer that failed while idle is found here, not only on the next batch.
        if self.tx.is_some() && self.thread.as_ref().is_some_and(|t| t.is_finished()) {
            self.stop();
        }
        let state = (self.bytes, self.dropped, self.error.is_some());
        let due = match self.reported {
            None => true,
            Some(r) if r == state => false,
            Some(r) => r.2 != state.2 || now >= self.reported_at + REPORT_EVERY,
        };
        if !due {
            return None;
        }
        self.reported = Some(state);
        self.reported_at = now;
        Some(self.status())
    }

    /// When the driver must step for the recorder: a change not yet reported, or a batch held
    /// ([`Recorder::end_step`]), is due.
    pub fn next_report_at(&self) -> Option<Micros> {
        let report = match self.reported {
            Some(r) if r == (self.bytes, self.dropped, self.error.is_some()) => None,
            _ => Some(self.reported_at + REPORT_EVERY),
        };
        let batch = self.batch_since.map(|t| t + HAND_OVER_WAKE);
        report.into_iter().chain(batch).min()
    }

    pub fn status(&self) -> RecordingStatus {
        RecordingStatus {
            path: self.path.clone(),
            bytes: self.bytes,
            dropped: self.dropped,
            error: self.error.clone(),
        }
    }

    /// Write out everything (waiting for the writer), flush and sync the file; the final status.
    pub fn finish(&mut self) -> RecordingStatus {
        if let Some(tx) = self.tx.take() {
            if !self.batch.is_empty() {
                let batch = std::mem::take(&mut self.batch);
                let len = batch.len() as u64;
                match tx.send(batch) {
                    Ok(()) => self.bytes += len,
                    Err(_) => self.dropped += self.batch_frames,
                }
            }
            drop(tx);
            // A write stuck in the kernel (a dead network file system) must not keep the
            // process alive after quit: waited for FINISH_WAIT, then the thread is given up.
            let ended = match self.done.take() {
                Some(done) => !matches!(
                    done.recv_timeout(FINISH_WAIT),
                    Err(RecvTimeoutError::Timeout)
                ),
                None => true,
            };
            if !ended {
                self.thread = None;
                self.error.get_or_insert(format!(
                    "the writer did not finish within {} s: given up (the log may lack its end)",
                    FINISH_WAIT.as_secs()
                ));
            } else if let Some(Ok(Err(e)) | Err(e)) = self
                .thread
                .take()
                .map(|t| t.join().map_err(|_| "the writer failed".to_string()))
            {
                self.error.get_or_insert(e);
            }
        }
        self.status()
    }
}

impl Drop for Recorder {
    fn drop(&mut self) {
        let st = self.finish();
        if let Some(e) = st.error {
            tracing::warn!(path = %st.path.display(), "tlog: {e}");
        }
    }
}

/// After a write that stopped `done` bytes into `buf` (the file was `len` long before it): cut
/// the file back to the last whole record written.
fn cut(file: &mut File, len: u64, buf: &[u8], done: usize) -> usize {
    let keep = crate::link::tlog::whole_records(buf, done);
    if file.metadata().is_ok_and(|m| m.is_file()) {
        let _ = file.set_len(len + keep as u64);
    }
    keep
}

/// The writer thread: batches in, written through a buffer; written out once the oldest
/// unwritten record is [`FLUSH_EVERY`] old or the buffer holds [`WRITE_BUFFER`], and at the end
/// (the queue closed), then synced to disk. Asleep while nothing comes. Returns the first error,
/// which ends the recording; the file is then cut back to its last whole record (`len` is how
/// long it was at the start), so a full disk never leaves part of one.
fn write_loop(mut file: File, mut len: u64, rx: mpsc::Receiver<Vec<u8>>) -> Result<(), String> {
    let err = |e: io::Error| e.to_string();
    let mut buf: Vec<u8> = Vec::with_capacity(WRITE_BUFFER);
    let mut unflushed_since: Option<Instant> = None;
    // Batches hold whole records: what is written whole ends on a record's end.
    let mut write_out = |file: &mut File, buf: &mut Vec<u8>| -> Result<(), String> {
        if buf.is_empty() {
            return Ok(());
        }
        let mut done = 0;
        while done < buf.len() {
            match file.write(&buf[done..]) {
                Ok(0) => {
                    cut(file, len, buf, done);
                    return Err("the disk took no more".into());
                }
                Ok(n) => done += n,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => {
                    cut(file, len, buf, done);
                    return Err(err(e));
                }
            }
        }
        len += buf.len() as u64;
        buf.clear();
        Ok(())
    };
    loop {
        let got = match unflushed_since {
            None => rx.recv().map_err(|_| RecvTimeoutError::Disconnected),
            Some(t) => rx.recv_timeout(FLUSH_EVERY.saturating_sub(t.elapsed())),
        };
        match got {
            Ok(batch) => {
                buf.extend_from_slice(&batch);
                unflushed_since.get_or_insert_with(Instant::now);
                if buf.len() >= WRITE_BUFFER {
                    write_out(&mut file, &mut buf)?;
                }
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => break,
        }
        if unflushed_since.is_some_and(|t| t.elapsed() >= FLUSH_EVERY) {
            write_out(&mut file, &mut buf)?;
            unflushed_since = None;
        }
    }
    write_out(&mut file, &mut buf)?;
    // A character device (a pipe, /dev/null) cannot be synced: not an error of the log.
    match file.sync_data() {
        Err(e) if e.kind() != io::ErrorKind::InvalidInput => Err(err(e)),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::tlog::read_tlog;

    fn start_time() -> chrono::NaiveDateTime {
        chrono::NaiveDate::from_ymd_opt(2026, 3, 4)
            .unwrap()
            .and_hms_opt(5, 6, 7)
            .unwrap()
    }

    /// A MAVLink 2 frame header with message id `id` and a 2-byte payload (CRC not checked
    /// here: the recorder writes bytes as they are).
    fn frame(id: u32, seq: u8) -> Vec<u8> {
        let id = id.to_le_bytes();
        vec![
            0xFD, 2, 0, 0, seq, 1, 1, id[0], id[1], id[2], 0xAA, 0xBB, 0x12, 0x34,
        ]
    }

    #[test]
    fn setup_signing_is_known_by_its_header() {
        assert!(carries_secret(&frame(256, 0)));
        assert!(!carries_secret(&frame(0, 0)));
        assert!(!carries_secret(&frame(256 + 65536, 0)));
        // MAVLink 1 (id in one byte) and short input.
        assert!(!carries_secret(&[0xFE, 0, 0, 1, 1, 0, 0, 0, 0, 1, 0]));
        assert!(!carries_secret(&[0xFD, 0, 0]));
    }

    #[test]
    fn new_files_are_named_by_time_and_never_overwrite() {
        let dir = tempfile::tempdir().unwrap();
        let logs = dir.path().join("a/logs");
        let target = TlogTarget::NewIn(logs.clone());
        let mut names = Vec::new();
        for _ in 0..3 {
            let mut r = Recorder::start(&target, start_time()).unwrap();
            r.record(7, &frame(0, 1));
            r.hand_over();
            names.push(r.path().file_name().unwrap().to_string_lossy().into_owned());
        }
        assert_eq!(
            names,
            [
                "2026-03-04_05-06-07.tlog",
                "2026-03-04_05-06-07-1.tlog",
                "2026-03-04_05-06-07-2.tlog"
            ]
        );
        // Each one kept its own record (none was truncated by the next).
        for n in names {
            let bytes = std::fs::read(logs.join(n)).unwrap();
            assert_eq!(bytes.len(), 8 + 14);
        }
    }

    #[test]
    fn records_reach_the_file_in_order_without_secrets_and_a_file_is_appended_to() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.tlog");
        std::fs::write(&path, [1u8; 5]).unwrap();
        let mut r = Recorder::start(&TlogTarget::File(path.clone()), start_time()).unwrap();
        assert_eq!(r.report(0).unwrap().bytes, 5);
        r.record(100, &frame(0, 1));
        r.record(200, &frame(256, 2));
        r.hand_over();
        r.record(300, &frame(30, 3));
        r.hand_over();
        assert_eq!(
            r.report(10).map(|s| s.bytes),
            None,
            "sizes at most once a second"
        );
        assert_eq!(r.next_report_at(), Some(SECOND));
        assert_eq!(r.report(SECOND).unwrap().bytes, 5 + 2 * 22);
        assert_eq!(r.next_report_at(), None);
        let st = r.finish();
        assert_eq!((st.bytes, st.dropped, st.error), (49, 0, None));
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(bytes.len(), 49);
        let recs = read_tlog(&bytes[5..]).unwrap();
        let got: Vec<(u64, Vec<u8>)> = recs.into_iter().map(|r| (r.time_us, r.frame)).collect();
        assert_eq!(got, vec![(100, frame(0, 1)), (300, frame(30, 3))]);
    }

    #[test]
    fn a_batch_waits_half_a_second_or_16_kib_and_the_driver_is_woken_for_it_after_a_second() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.tlog");
        let mut r = Recorder::start(&TlogTarget::File(path.clone()), start_time()).unwrap();
        assert_eq!(r.after_step(0).unwrap().bytes, 0);
        assert_eq!(r.next_report_at(), None, "nothing held, nothing to tell");
        let ms = SECOND / 1000;
        r.record(1, &frame(0, 1));
        r.end_step(10 * ms);
        assert_eq!(r.status().bytes, 0, "held");
        assert_eq!(
            r.next_report_at(),
            Some(1010 * ms),
            "woken a second on at the latest"
        );
        r.record(2, &frame(0, 2));
        r.end_step(509 * ms);
        assert_eq!(r.status().bytes, 0, "still held");
        r.end_step(510 * ms);
        assert_eq!(
            r.status().bytes,
            2 * 22,
            "handed over at a step half a second on"
        );
        assert_eq!(
            r.next_report_at(),
            Some(SECOND),
            "the size told a second after the last"
        );
        // 16 KiB in one step goes at once.
        for i in 0..745u64 {
            r.record(i, &frame(0, i as u8));
        }
        r.end_step(511 * ms);
        assert_eq!(r.status().bytes, 2 * 22 + 745 * 22);
        // The end writes what is held.
        r.record(3, &frame(0, 3));
        r.end_step(512 * ms);
        let st = r.finish();
        assert_eq!((st.bytes, st.dropped), (748 * 22, 0));
        assert_eq!(std::fs::read(&path).unwrap().len(), 748 * 22);
    }

    #[test]
    fn an_unopenable_path_says_which_and_why() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("plain");
        std::fs::write(&file, b"x").unwrap();
        let under_a_file = file.join("x.tlog");
        let e = Recorder::start(&TlogTarget::File(under_a_file.clone()), start_time())
            .err()
            .unwrap();
        assert_eq!(e.path, under_a_file);
        assert!(e.error.unwrap().contains("Not a directory"));
        let e = Recorder::start(&TlogTarget::NewIn(file.join("logs")), start_time())
            .err()
            .unwrap();
        assert_eq!(e.path, file.join("logs"));
        assert!(e.error.is_some());
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn a_full_disk_stops_the_recording_and_says_so() {
        // /dev/full takes opens and refuses every write with ENOSPC (as a target it is refused,
        // a device: opened here by hand).
        let full = OpenOptions::new().append(true).open("/dev/full").unwrap();
        let mut r = Recorder::with_file("/dev/full".into(), full).unwrap();
        assert_eq!(r.report(0).unwrap().error, None);
        let mut t = 0;
        // The writer's buffer holds 64 KiB: past that (or at its once-a-second flush) it fails.
        while r.report(t).is_none_or(|s| s.error.is_none()) {
            for i in 0..200u64 {
                r.record(t + i, &frame(0, i as u8));
            }
            r.hand_over();
            t += 1000;
            assert!(t < 60 * SECOND, "no error after {t} µs");
            std::thread::sleep(Duration::from_millis(1));
        }
        let st = r.status();
        assert!(
            st.error.as_deref().unwrap().contains("No space left"),
            "{st:?}"
        );
        // Stopped: nothing more is taken, nothing panics.
        let before = st.bytes;
        r.record(t, &frame(0, 1));
        r.hand_over();
        assert_eq!(r.finish().bytes, before);
    }

    #[cfg(unix)]
    #[test]
    fn a_fifo_or_device_target_is_refused_at_once() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("pipe");
        let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        for p in [fifo, PathBuf::from("/dev/null")] {
            let e = Recorder::start(&TlogTarget::File(p.clone()), start_time())
                .err()
                .unwrap_or_else(|| panic!("{} taken", p.display()));
            assert!(e.error.unwrap().contains("not a regular file"));
        }
    }

    /// A write stuck in the kernel (here: a FIFO nobody reads, opened read-write so the open
    /// itself does not wait) does not keep `finish` waiting: it gives the writer up and says so.
    #[cfg(unix)]
    #[test]
    fn finish_gives_up_on_a_stuck_writer() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("pipe");
        let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        let f = OpenOptions::new()
            .read(true)
            .write(true)
            .open(&fifo)
            .unwrap();
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || {
            let mut r = Recorder::with_file(fifo, f).unwrap();
            // Each batch (88 KB) more than a pipe holds (64 KiB), so the writer blocks in write(2).
            for step in 0..64u64 {
                for i in 0..4000u64 {
                    r.record(step * 4000 + i, &frame(0, i as u8));
                }
                r.hand_over();
            }
            let _ = tx.send(r.finish());
        });
        let st = rx
            .recv_timeout(Duration::from_secs(60))
            .expect("finish waited on a stuck writer");
        assert!(st.error.unwrap().contains("given up"));
    }
}
