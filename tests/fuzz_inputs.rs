//! Fuzzing on stable Rust: a seeded mutation loop over the parsers that read what operators and
//! files hand us — link specs, keymap files, replay scripts and tlogs. Each target starts from a
//! corpus of real inputs, mutates them (bit flips, tokens of the format, splices, cuts), and
//! checks that nothing panics, that every error says where the problem is, and a few invariants
//! of the format.
//!
//! Bounded for CI: each target runs `MAVTERM_FUZZ_SECS` seconds (default 1, and at least
//! [`MIN_INPUTS`] inputs). Run long locally, e.g. for an hour with a new seed:
//!
//! ```text
//! MAVTERM_FUZZ_SECS=3600 MAVTERM_FUZZ_SEED=$RANDOM cargo test --release --test fuzz_inputs -- --nocapture
//! ```
//!
//! A failing input is saved under the cargo target tmp dir and named in the panic message, with
//! the seed and iteration that reproduce it.

use std::io::{self, Read};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;
use std::time::{Duration, Instant};

use mavterm::headless::script::{Script, ScriptError};
use mavterm::keymap::{Key, Keymap, KeymapError, Mode, MAX_PROBLEMS, SCREENS};
use mavterm::link::spec::SpecError;
use mavterm::link::tlog::{read_tlog_counted, Skipped, TlogError, TlogReader};
use mavterm::link::LinkSpec;

/// Every target tries at least this many inputs, however short the time budget.
const MIN_INPUTS: usize = 200;
/// Inputs grow no larger than this (the largest tlog in the corpus is about 0.5 MB).
const MAX_LEN: usize = 1 << 20;

/// splitmix64: small, fast, and the same sequence everywhere for a seed.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in `0..n` (`n > 0`).
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}

fn env_secs() -> f64 {
    std::env::var("MAVTERM_FUZZ_SECS")
        .ok()
        .and_then(|v| v.parse::<f64>().ok())
        .filter(|s| s.is_finite() && *s >= 0.0)
        .unwrap_or(1.0)
}

fn env_seed() -> u64 {
    std::env::var("MAVTERM_FUZZ_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0x6d61_7674_6572_6d31) // "mavterm1"
}

/// One random edit of `v`, using `dict` (tokens of the format) and `corpus` (for splices).
fn mutate_once(rng: &mut Rng, v: &mut Vec<u8>, dict: &[&[u8]], corpus: &[Vec<u8>]) {
    let pos = |rng: &mut Rng, v: &Vec<u8>| rng.below(v.len() + 1);
    match rng.below(10) {
        0 if !v.is_empty() => {
            let i = rng.below(v.len());
            v[i] ^= 1 << rng.below(8);
        }
        1 if !v.is_empty() => {
            let i = rng.below(v.len());
            v[i] = rng.next() as u8;
        }
        2 | 3 if !dict.is_empty() => {
            let tok = dict[rng.below(dict.len())];
            let i = pos(rng, v);
            v.splice(i..i, tok.iter().copied());
        }
        4 if !v.is_empty() => {
            let i = rng.below(v.len());
            let n = 1 + rng.below((v.len() - i).min(64));
            v.drain(i..i + n);
        }
        5 if !v.is_empty() => {
            let i = rng.below(v.len());
            let n = 1 + rng.below((v.len() - i).min(64));
            let chunk: Vec<u8> = v[i..i + n].to_vec();
            let j = pos(rng, v);
            v.splice(j..j, chunk);
        }
        6 => {
            // Splice: our head, another input's tail.
            let other = &corpus[rng.below(corpus.len())];
            let i = pos(rng, v);
            let j = rng.below(other.len() + 1);
            v.truncate(i);
            v.extend_from_slice(&other[j..]);
        }
        7 => {
            let i = pos(rng, v);
            v.truncate(i);
        }
        8 => {
            let n = 1 + rng.below(16);
            let i = pos(rng, v);
            let junk: Vec<u8> = (0..n).map(|_| rng.next() as u8).collect();
            v.splice(i..i, junk);
        }
        _ if !v.is_empty() => {
            const SPECIAL: &[u8] = b"\0\n\r\t \"'[]{}=:,.#\\\xFD\xFE\xFF\x7F";
            let i = rng.below(v.len());
            v[i] = SPECIAL[rng.below(SPECIAL.len())];
        }
        _ => v.push(rng.next() as u8),
    }
}

fn mutate(rng: &mut Rng, dict: &[&[u8]], corpus: &[Vec<u8>]) -> Vec<u8> {
    let mut v = corpus[rng.below(corpus.len())].clone();
    let edits = 1 + rng.below(8);
    for _ in 0..edits {
        mutate_once(rng, &mut v, dict, corpus);
    }
    v.truncate(MAX_LEN);
    v
}

fn save_failure(name: &str, seed: u64, iter: usize, input: &[u8]) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("fuzz-failures");
    let _ = std::fs::create_dir_all(&dir);
    let path = dir.join(format!("{name}-{seed}-{iter}.bin"));
    let _ = std::fs::write(&path, input);
    path
}

/// Feed `check` the corpus as is, then mutated inputs until the time budget is spent.
fn fuzz(name: &str, corpus: Vec<Vec<u8>>, dict: &[&[u8]], check: impl Fn(&[u8], &mut Rng)) {
    assert!(!corpus.is_empty());
    let seed = env_seed();
    let name_hash = name.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
        (h ^ b as u64).wrapping_mul(0x100_0000_01b3)
    });
    let mut rng = Rng(seed ^ name_hash);
    let budget = Duration::from_secs_f64(env_secs());
    let start = Instant::now();
    let mut iter = 0;
    while iter < MIN_INPUTS.max(corpus.len()) || start.elapsed() < budget {
        let input = if iter < corpus.len() {
            corpus[iter].clone()
        } else {
            mutate(&mut rng, dict, &corpus)
        };
        // The check's own randomness (chunk sizes, ...) is derived from the input's iteration.
        let mut check_rng = Rng(seed ^ name_hash ^ (iter as u64).wrapping_mul(0x9E37));
        if let Err(e) = catch_unwind(AssertUnwindSafe(|| check(&input, &mut check_rng))) {
            let path = save_failure(name, seed, iter, &input);
            let msg = e
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| e.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            let shown = String::from_utf8_lossy(&input[..input.len().min(300)]).into_owned();
            panic!(
                "{name}: input {iter} (MAVTERM_FUZZ_SEED={seed}) failed: {msg}\n\
                 input saved to {}\ninput (first 300 bytes): {shown:?}",
                path.display()
            );
        }
        iter += 1;
    }
    eprintln!("{name}: {iter} inputs in {:.1?}", start.elapsed());
}

fn text(input: &[u8]) -> String {
    String::from_utf8_lossy(input).into_owned()
}

/// `line:col` (1-based, column in characters) points into `text` or just past a line's end.
fn assert_in_text(text: &str, line: usize, col: usize) {
    let lines: Vec<&str> = text.split('\n').collect();
    assert!(
        (1..=lines.len()).contains(&line),
        "line {line} outside 1..={}",
        lines.len()
    );
    let width = lines[line - 1].chars().count();
    assert!(
        (1..=width + 1).contains(&col),
        "line {line} column {col} outside 1..={}",
        width + 1
    );
}

// ---- link specs ----

#[test]
fn fuzz_link_specs() {
    let corpus: Vec<Vec<u8>> = [
        "udpin:0.0.0.0:14550",
        "udp:127.0.0.1:14550",
        "udpout:10.0.0.2:14550",
        "tcp:127.0.0.1:5760",
        "tcpin:0.0.0.0:5760",
        "serial:/dev/ttyUSB0",
        "serial:/dev/ttyACM0:115200",
        "serial:/dev/ttyS0,57600",
        "/dev/ttyUSB0,921600",
        "/dev/serial/by-id/usb-X,Y-if00:115200",
        "/dev/serial/by-path/pci-0000:00:14.0-usb-0:2:1.0-port0",
        "COM3,115200",
        "COM4:57600",
        "udp://:14540",
        "udpout://192.168.1.5:14550",
        "tcp://localhost:5760",
        "serial:///dev/ttyAMA0:57600",
        "udpin:[::1]:14550",
        "udpin:::14550",
        "tcp:[fe80::1%eth0]:5760",
        "sim://?vehicles=3&seed=7",
        "sim://",
        "tlog:logs/a,b.tlog",
        "file:///tmp/a.tlog",
        "tlog:",
        "",
    ]
    .iter()
    .map(|s| s.as_bytes().to_vec())
    .collect();
    let dict: &[&[u8]] = &[
        b"udpin:",
        b"udp://",
        b"udpout:",
        b"tcp:",
        b"tcpin:",
        b"serial:",
        b"tlog:",
        b"sim://?",
        b"file://",
        b"[",
        b"]",
        b"::",
        b":",
        b",",
        b"/dev/",
        b"COM",
        b"57600",
        b"0",
        b"65535",
        b"65536",
        b"%",
        b" ",
        "\u{e9}".as_bytes(),
        b"//",
        b"?",
    ];
    fuzz("link_spec", corpus, dict, |input, _| {
        let s = text(input);
        match s.parse::<LinkSpec>() {
            // What we accept prints back as a spec that means the same.
            Ok(spec) => {
                let shown = spec.to_string();
                assert_eq!(
                    shown.parse::<LinkSpec>().as_ref(),
                    Ok(&spec),
                    "{s:?} printed as {shown:?}"
                );
            }
            Err(SpecError::Empty) => assert!(s.trim().is_empty(), "{s:?} called empty"),
            // Every other error quotes the spec it refuses.
            Err(e) => assert!(e.to_string().contains(&format!("`{s}`")), "{e}"),
        }
    });
}

// ---- keymaps ----

/// Every binding `bindings` lists is what `lookup` does, and key names print and parse back.
fn assert_consistent(km: &Keymap) {
    for mode in Mode::ALL {
        for screen in SCREENS {
            for (action, keys) in km.bindings(mode, screen) {
                assert!(!keys.is_empty());
                assert_eq!(keys, km.keys_for(mode, screen, action));
                for key in keys {
                    assert_eq!(km.lookup(mode, screen, &key), Some(action), "{key}");
                    assert_eq!(key.to_string().parse::<Key>(), Ok(key));
                }
            }
        }
    }
}

#[test]
fn fuzz_keymap_files() {
    let corpus: Vec<Vec<u8>> = [
        include_str!("../keymaps/default.toml"),
        include_str!("../keymaps/vim.toml"),
        "[bindings]\nquit = [\"q\", \"ctrl-qq\"]\nfly = [\"f\"]\n",
        "[normal]\nquit = [\"q\"]\n[normal.parameters]\nhelp = [\"q\"]\n",
        "[colours]\nx = 1\n[normal.map]\nquit = [\"q\"]\n[edit]\nsubmit = \"enter\"\n",
        "normal = { quit = [\"x\"], overview = { help = [\"?\"] } }\n",
        "",
    ]
    .iter()
    .map(|s| s.as_bytes().to_vec())
    .collect();
    let dict: &[&[u8]] = &[
        b"[normal]\n",
        b"[normal.overview]\n",
        b"[normal.parameters]\n",
        b"[prompt]\n",
        b"[edit]\n",
        b"[help]\n",
        b"[bindings]\n",
        b"quit = [\"q\"]\n",
        b"submit = [\"enter\"]\n",
        b"screen_1 = [\"1\"]\n",
        b" = [",
        b"\"ctrl-",
        b"\"alt-",
        b"\"shift-",
        b"\"f1\"",
        b"\", \"",
        b"\"",
        b"]",
        b"\n",
        b"'''",
        b"{ ",
        b" }",
        b"[[x]]\n",
        b"# comment\n",
        "\u{e9}".as_bytes(),
        b"\r\n",
    ];
    fuzz("keymap", corpus, dict, |input, _| {
        let t = text(input);
        match Keymap::from_toml(&t, "fuzz.toml") {
            Ok(km) => {
                assert_consistent(&km);
                assert_consistent(&Keymap::default().with_overrides(&km));
            }
            Err(KeymapError::Syntax {
                line, col, origin, ..
            }) => {
                assert_eq!(origin, "fuzz.toml");
                assert_in_text(&t, line, col);
            }
            Err(KeymapError::Invalid(e)) => {
                assert_eq!(e.origin, "fuzz.toml");
                assert!(!e.problems.is_empty());
                assert!(e.problems.len() <= MAX_PROBLEMS);
                assert!(e.more == 0 || e.problems.len() == MAX_PROBLEMS);
                for p in &e.problems {
                    assert_in_text(&t, p.line, p.col);
                    assert!(!p.message.is_empty());
                }
                let places: Vec<(usize, usize)> =
                    e.problems.iter().map(|p| (p.line, p.col)).collect();
                assert!(places.is_sorted(), "listed top to bottom: {places:?}");
            }
            Err(e @ KeymapError::Io { .. }) => panic!("no file was read: {e}"),
        }
    });
}

// ---- replay scripts ----

#[test]
fn fuzz_replay_scripts() {
    let corpus: Vec<Vec<u8>> = [
        include_str!("data/replay/tour.txt"),
        "# start\n\n0.5 key tab\n1.0 key ctrl-p\n1.2 text \"takeoff 10\"  # typed\n\
         1.3 key enter\n1.4 key #\n2.0 snapshot after-takeoff\n30 quit\n",
        "1 text \"a \\\"quoted\\\" \\\\ word\\n\"\n",
        "0.5 key tab\n1 key nosuchkey\n",
        "1 quit\n2 key a\n",
        "",
    ]
    .iter()
    .map(|s| s.as_bytes().to_vec())
    .collect();
    let dict: &[&[u8]] = &[
        b"key ",
        b"text \"",
        b"snapshot ",
        b"quit",
        b"\n",
        b"\r\n",
        b"#",
        b" # c",
        b"\\\"",
        b"\\\\",
        b"\\",
        b"\"",
        b"0.",
        b".5",
        b"1.000001",
        b"99999999999999999999",
        b"ctrl-",
        b"tab",
        b"enter",
        b"\t",
    ];
    fuzz("script", corpus, dict, |input, _| {
        let t = text(input);
        let lines = t.lines().count();
        match Script::parse(&t) {
            Ok(s) => {
                for w in s.steps.windows(2) {
                    assert!(w[0].t <= w[1].t, "times never decrease");
                    assert!(w[0].line < w[1].line, "one step per line, in order");
                }
                for step in &s.steps {
                    assert!((1..=lines).contains(&step.line), "line {}", step.line);
                }
            }
            Err(ScriptError::Parse { line, message }) => {
                assert!((1..=lines).contains(&line), "line {line} of {lines}");
                assert!(!message.is_empty());
            }
            Err(e @ ScriptError::Io { .. }) => panic!("no file was read: {e}"),
        }
    });
}

// ---- tlogs ----

fn tlog_corpus() -> Vec<(String, Vec<u8>)> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "tlog"))
        .map(|p| {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            (name, std::fs::read(&p).unwrap())
        })
        .collect();
    files.sort();
    assert!(files.len() >= 4, "tests/data/*.tlog");
    files
}

/// Record boundaries of a clean tlog, walked by the format's definition (8-byte timestamp, then
/// a v1 frame of 6 + len + 2 bytes or a v2 frame of 10 + len + 2 (+ 13 if signed) bytes): an
/// implementation independent of the reader under test.
fn boundaries(log: &[u8]) -> Vec<usize> {
    let mut at = vec![0];
    let mut i = 0;
    while i < log.len() {
        let f = &log[i + 8..];
        let len = match f[0] {
            0xFE => 6 + f[1] as usize + 2,
            0xFD => 10 + f[1] as usize + 2 + if f[2] & 1 != 0 { 13 } else { 0 },
            b => panic!("byte {i}: {b:#x} is no magic byte"),
        };
        i += 8 + len;
        at.push(i);
    }
    assert_eq!(i, log.len(), "the log ends on a record boundary");
    at
}

/// Hands out the bytes in chunks of random size (1 byte to 4 KiB), with `Interrupted` now and
/// then.
struct Chunky<'a> {
    data: &'a [u8],
    rng: Rng,
}

impl Read for Chunky<'_> {
    fn read(&mut self, out: &mut [u8]) -> io::Result<usize> {
        if self.rng.below(50) == 0 {
            return Err(io::ErrorKind::Interrupted.into());
        }
        let n = (1 + self.rng.below(4096))
            .min(out.len())
            .min(self.data.len());
        out[..n].copy_from_slice(&self.data[..n]);
        self.data = &self.data[n..];
        Ok(n)
    }
}

#[test]
fn corpus_tlogs_are_read_whole() {
    for (name, log) in tlog_corpus() {
        let at = boundaries(&log);
        let (recs, skipped) = read_tlog_counted(&log).unwrap();
        assert_eq!(recs.len(), at.len() - 1, "{name}");
        assert_eq!(skipped, Skipped::default(), "{name}");
        for (r, w) in recs.iter().zip(at.windows(2)) {
            assert_eq!(r.time_us.to_be_bytes(), log[w[0]..w[0] + 8], "{name}");
            assert_eq!(r.frame, &log[w[0] + 8..w[1]], "{name}");
        }
    }
}

#[test]
fn fuzz_tlog_reader() {
    let files = tlog_corpus();
    let corpus: Vec<Vec<u8>> = files.iter().map(|(_, b)| b.clone()).collect();
    let dict: &[&[u8]] = &[
        b"\xFD",
        b"\xFE",
        b"\xFD\x09\x00\x00",
        b"\xFE\x09",
        b"\xFD\xFF\x01",
        b"\0\0\0\0\0\0\0\0",
        b"\xFF\xFF\xFF\xFF\xFF\xFF\xFF\xFF",
    ];
    fuzz("tlog", corpus, dict, |input, rng| {
        let whole = read_tlog_counted(input);
        // Streaming in odd chunks reads the same as reading it all at once.
        let mut reader = TlogReader::new(Chunky {
            data: input,
            rng: Rng(rng.next()),
        });
        let streamed: Vec<_> = reader.by_ref().map(|r| r.unwrap()).collect();
        match whole {
            Ok((recs, skipped)) => {
                assert_eq!(streamed, recs);
                assert_eq!(reader.skipped(), skipped);
                // Every byte is in exactly one record or skipped.
                let used: usize = recs.iter().map(|r| 8 + r.frame.len()).sum();
                assert_eq!(used as u64 + skipped.bytes, input.len() as u64);
                assert!(skipped.gaps <= skipped.bytes);
                assert_eq!(skipped.gaps == 0, skipped.bytes == 0);
                for r in &recs {
                    assert!(matches!(r.frame[0], 0xFD | 0xFE), "a record is a frame");
                }
            }
            Err(TlogError::NoRecords { bytes }) => {
                assert!(streamed.is_empty());
                assert_eq!(bytes, input.len() as u64);
                assert_eq!(reader.skipped().bytes, bytes, "all of it skipped");
            }
        }
        assert_eq!(reader.offset(), input.len() as u64);
    });
}

/// Garbage (no magic byte in it, at least 9 bytes) put between records of a real log: exactly
/// the real records come back, and exactly the garbage is counted.
#[test]
fn fuzz_tlog_garbage_between_records() {
    let files = tlog_corpus();
    let seed = env_seed();
    let budget = Duration::from_secs_f64(env_secs());
    let mut rng = Rng(seed ^ 0x7469_6d65);
    let start = Instant::now();
    let mut iter = 0;
    while iter < 50 || start.elapsed() < budget {
        let (name, log) = &files[rng.below(files.len())];
        let at = boundaries(log);
        let gaps = 1 + rng.below(3);
        let mut cuts: Vec<usize> = (0..gaps).map(|_| at[rng.below(at.len())]).collect();
        cuts.sort();
        cuts.dedup();
        let mut buf = Vec::with_capacity(log.len() + 1024);
        let mut junk_len = 0;
        let mut prev = 0;
        for &c in &cuts {
            buf.extend_from_slice(&log[prev..c]);
            let n = 9 + rng.below(500);
            buf.extend((0..n).map(|_| match rng.next() as u8 {
                0xFD | 0xFE => 0x00,
                b => b,
            }));
            junk_len += n;
            prev = c;
        }
        buf.extend_from_slice(&log[prev..]);
        let (recs, skipped) = read_tlog_counted(&buf)
            .unwrap_or_else(|e| panic!("{name} (seed {seed}, iteration {iter}): {e}"));
        let what = format!("{name}, garbage at {cuts:?} (seed {seed}, iteration {iter})");
        assert_eq!(recs.len(), at.len() - 1, "{what}");
        let frames: usize = recs.iter().map(|r| 8 + r.frame.len()).sum();
        assert_eq!(frames, log.len(), "{what}");
        assert_eq!(
            skipped,
            Skipped {
                bytes: junk_len as u64,
                gaps: cuts.len() as u64
            },
            "{what}"
        );
        iter += 1;
    }
    eprintln!("tlog garbage: {iter} logs in {:.1?}", start.elapsed());
}
