//! The program's files kept to the pages it runs.
//!
//! The kernel maps a file's page cache into a process 64 KiB around each page it first touches
//! ("fault-around"), and the dynamic loader touches pages of every library it loads (symbol
//! tables, relocations, the resolvers of `libm`'s functions) before `main`. So a process that
//! runs a few hundred KiB of `libc`, `libm` and its own code holds megabytes of them resident.
//! [`trim_file_mappings`], called first thing in `main`, lets go of the pages loaded so far of
//! the file mappings that hold nothing but the file's own bytes (`MADV_DONTNEED`: they come back
//! when next read, with what is around them). What stays resident is what the program goes on
//! to use, not what loading it touched. [`keep_trimmed`] does it again every so often for the
//! files mapped at that first call, so code run once (starting up, connecting, a screen looked
//! at once) does not stay resident either; what the program runs comes back at its next use.
//!
//! Only read-only mappings with no private page (smaps `Anonymous: 0 kB`) are let go of: a page
//! written since it was mapped (the relocations the loader made, then sealed read-only) exists
//! nowhere else, and `MADV_DONTNEED` would put the file's bytes back in its place. Such a mapping
//! cannot gain a private page while it is read-only, so what smaps said still holds at the call.
//! The later trims leave out files mapped after the first (a library loaded while the program
//! runs is relocated then, and could be caught between smaps and the call).

use std::sync::OnceLock;
use std::time::Duration;

/// The files mapped at the first trim: the only ones trimmed again.
static LOADED: OnceLock<Vec<String>> = OnceLock::new();

/// What [`trim_file_mappings`] did.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct Trimmed {
    /// Read-only file mappings whose pages were let go of.
    pub released: usize,
}

/// One mapping of `/proc/self/smaps`.
#[derive(Debug, Clone, PartialEq, Eq)]
struct Mapping {
    start: usize,
    end: usize,
    writable: bool,
    /// Backed by a file (its path), not anonymous memory, a stack or the vDSO.
    file: bool,
    /// The file's path (as smaps gives it), or what stands in its place (`[heap]`, empty).
    path: String,
    /// Private (copied-on-write) pages, kB.
    anonymous_kb: u64,
}

/// The mappings in the text of `/proc/self/smaps`; lines it does not know are passed over.
fn parse_smaps(text: &str) -> Vec<Mapping> {
    let mut out: Vec<Mapping> = Vec::new();
    for line in text.lines() {
        let mut words = line.split_whitespace();
        let Some(first) = words.next() else { continue };
        if let Some((a, b)) = first.split_once('-') {
            if let (Ok(start), Ok(end)) =
                (usize::from_str_radix(a, 16), usize::from_str_radix(b, 16))
            {
                let perms = words.next().unwrap_or("");
                // Offset, device, inode, then the path if any (it may hold spaces).
                let path = words.skip(3).collect::<Vec<_>>().join(" ");
                out.push(Mapping {
                    start,
                    end,
                    writable: perms.contains('w'),
                    file: path.starts_with('/'),
                    path,
                    anonymous_kb: 0,
                });
                continue;
            }
        }
        if first == "Anonymous:" {
            if let (Some(m), Some(kb)) = (out.last_mut(), words.next()) {
                m.anonymous_kb = kb.parse().unwrap_or(u64::MAX);
            }
        }
    }
    out
}

/// Let go of the pages of every read-only file mapping of this process that holds only the file's
/// bytes, and remember which files were mapped (for [`keep_trimmed`]). Errors of one mapping are
/// passed over (it stays as it was); only failing to read smaps is an error.
#[cfg(target_os = "linux")]
pub fn trim_file_mappings() -> std::io::Result<Trimmed> {
    trim(|m, all| {
        LOADED.get_or_init(|| {
            all.iter()
                .filter(|m| m.file)
                .map(|m| m.path.clone())
                .collect()
        });
        m.file
    })
}

/// [`trim_file_mappings`] again, for the files mapped at its first call only.
#[cfg(target_os = "linux")]
pub fn trim_loaded() -> std::io::Result<Trimmed> {
    let Some(loaded) = LOADED.get() else {
        return Ok(Trimmed::default());
    };
    trim(|m, _| loaded.contains(&m.path))
}

/// Let go of the pages of the read-only file mappings of nothing but the file's bytes that `pick`
/// chooses (given each mapping and all of them).
#[cfg(target_os = "linux")]
fn trim(pick: impl Fn(&Mapping, &[Mapping]) -> bool) -> std::io::Result<Trimmed> {
    let text = std::fs::read_to_string("/proc/self/smaps")?;
    let all = parse_smaps(&text);
    let mut done = Trimmed::default();
    for m in &all {
        if !(m.file && !m.writable && m.anonymous_kb == 0 && m.end > m.start && pick(m, &all)) {
            continue;
        }
        let (addr, len) = (m.start as *mut libc::c_void, m.end - m.start);
        // SAFETY: the range is a whole mapping of this process as the kernel listed it, read-only
        // and of nothing but the file's bytes: after MADV_DONTNEED it reads the same.
        if unsafe { libc::madvise(addr, len, libc::MADV_DONTNEED) } == 0 {
            done.released += 1;
        }
    }
    Ok(done)
}

/// Trim the files mapped at start `first` after this call (starting up is over), then every
/// `every`, on a thread of its own, for as long as the program runs (nothing is done when the
/// thread cannot be started).
pub fn keep_trimmed(first: Duration, every: Duration) {
    let _ = std::thread::Builder::new()
        .name("trim".into())
        .stack_size(64 * 1024)
        .spawn(move || {
            std::thread::sleep(first);
            loop {
                let _ = trim_loaded();
                std::thread::sleep(every);
            }
        });
}

/// Elsewhere nothing is done.
#[cfg(not(target_os = "linux"))]
pub fn trim_file_mappings() -> std::io::Result<Trimmed> {
    Ok(Trimmed::default())
}

#[cfg(not(target_os = "linux"))]
pub fn trim_loaded() -> std::io::Result<Trimmed> {
    Ok(Trimmed::default())
}

#[cfg(test)]
mod tests {
    use super::*;

    const SMAPS: &str = "\
5583c2a00000-5583c2b00000 r--p 00000000 08:01 1234 /usr/bin/mavterm
Size:               1024 kB
Rss:                 512 kB
Anonymous:             0 kB
5583c2b00000-5583c2c00000 r--p 00100000 08:01 1234 /usr/bin/mavterm
Size:               1024 kB
Anonymous:            40 kB
5583c2c00000-5583c2c10000 rw-p 00200000 08:01 1234 /usr/bin/mavterm
Anonymous:            64 kB
5583c3000000-5583c3100000 rw-p 00000000 00:00 0 [heap]
Anonymous:          1024 kB
7f0000000000-7f0000010000 r-xp 00000000 08:01 99 /usr/lib/x86_64-linux-gnu/libm.so.6
Anonymous:             0 kB
VmFlags: rd ex mr mw me sd
7ffd00000000-7ffd00002000 r-xp 00000000 00:00 0 [vdso]
Anonymous:             0 kB
7f1000000000-7f1000001000 r--p 00000000 08:01 77                         /opt/my tools/lib x.so
Anonymous:             0 kB
";

    #[test]
    fn smaps_are_read_with_their_private_pages() {
        let m = parse_smaps(SMAPS);
        assert_eq!(m.len(), 7);
        assert_eq!(m[0].path, "/usr/bin/mavterm");
        assert_eq!(
            m[6].path, "/opt/my tools/lib x.so",
            "a path with spaces, whole"
        );
        assert_eq!((m[0].start, m[0].end), (0x5583c2a00000, 0x5583c2b00000));
        assert!(m[0].file && !m[0].writable && m[0].anonymous_kb == 0);
        // Relocations sealed read-only: private pages, never let go of.
        assert!(m[1].file && !m[1].writable && m[1].anonymous_kb == 40);
        assert!(m[2].file && m[2].writable);
        assert!(!m[3].file, "the heap is not a file");
        assert!(m[4].file && m[4].anonymous_kb == 0);
        assert!(!m[5].file, "the vDSO is not a file");
    }

    #[test]
    fn garbage_lines_are_passed_over() {
        let m =
            parse_smaps("zz-yy r--p\nAnonymous: 5 kB\n\n10-20 r--p 0 0:0 1 /x\nAnonymous: x kB\n");
        assert_eq!(m.len(), 1);
        // An unreadable count is taken as private pages: left alone.
        assert_eq!(m[0].anonymous_kb, u64::MAX);
    }

    /// In this very process: the pages let go of come back as they are read, with the same
    /// bytes (code runs, libm answers, a relocated pointer still points where it did).
    #[cfg(target_os = "linux")]
    #[test]
    fn the_process_runs_on_after_a_trim() {
        static TABLE: [&str; 3] = ["alpha", "beta", "gamma"];
        let before: f64 = std::hint::black_box(0.5f64).sin();
        let done = trim_file_mappings().unwrap();
        assert!(done.released > 0, "{done:?}");
        assert_eq!(std::hint::black_box(0.5f64).sin(), before);
        assert_eq!(TABLE[std::hint::black_box(2)], "gamma");
        // Again, for the files mapped the first time only.
        let again = trim_loaded().unwrap();
        assert!(again.released > 0, "{again:?}");
        assert_eq!(std::hint::black_box(0.5f64).sin(), before);
        let text = std::fs::read_to_string("/proc/self/smaps").unwrap();
        assert!(parse_smaps(&text).iter().any(|m| m.file));
    }
}
