//! The file work of onboard log downloads ([`LogIo`]), carried out at the edge in the order the
//! core asked: the log is written as it arrives into `NAME.partial` (always a prefix of the
//! log, so a download resumes from its size), then synced and renamed to `NAME` once it holds
//! every byte. Only regular files are written: a FIFO, a device or a directory in the way is
//! refused.

use std::io::{Seek, SeekFrom, Write};
use std::path::Path;

use crate::proto::logs::{info_of, LogIo, LogIoDone};

fn regular_or_missing(path: &Path) -> std::io::Result<()> {
    match std::fs::symlink_metadata(path) {
        Ok(m) if m.is_file() => Ok(()),
        Ok(_) => Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "not a regular file: refused",
        )),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(e),
    }
}

/// The partial's length, after making sure it is a prefix of the log `tag` names: a partial
/// whose info (`NAME.partial.info`) is missing or names another log (the same id after an
/// erase, another vehicle, a log that grew), or that is longer than `max`, is emptied and
/// tagged anew.
fn open(partial: &Path, max: u64, tag: &str) -> std::io::Result<u64> {
    if let Some(dir) = partial.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)?;
    }
    regular_or_missing(partial)?;
    let info = info_of(partial);
    regular_or_missing(&info)?;
    let f = std::fs::OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(partial)?;
    let len = f.metadata()?.len();
    let same = std::fs::read(&info).is_ok_and(|b| b == tag.as_bytes());
    if same && len <= max {
        return Ok(len);
    }
    // Not this log's prefix (or nothing says it is): start over. Emptied before the new info
    // is written, so a crash between leaves an empty partial, never another log's bytes.
    f.set_len(0)?;
    f.sync_all()?;
    std::fs::write(&info, tag)?;
    Ok(0)
}

fn write(partial: &Path, ofs: u64, bytes: &[u8]) -> std::io::Result<()> {
    regular_or_missing(partial)?;
    let mut f = std::fs::OpenOptions::new().write(true).open(partial)?;
    f.seek(SeekFrom::Start(ofs))?;
    f.write_all(bytes)
}

fn finish(partial: &Path, path: &Path, size: u64) -> std::io::Result<()> {
    regular_or_missing(partial)?;
    regular_or_missing(path)?;
    let f = std::fs::OpenOptions::new().write(true).open(partial)?;
    let len = f.metadata()?.len();
    if len != size {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("holds {len} bytes, the log has {size}"),
        ));
    }
    f.sync_all()?;
    std::fs::rename(partial, path)?;
    match std::fs::remove_file(info_of(partial)) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(e),
        _ => Ok(()),
    }
}

/// Carry out `io`; what the core must be told (a write that worked tells nothing).
pub fn carry_out(io: LogIo) -> Option<LogIoDone> {
    match io {
        LogIo::Open { partial, max, tag } => Some(match open(&partial, max, &tag) {
            Ok(have) => LogIoDone::Opened { partial, have },
            Err(e) => LogIoDone::Failed {
                path: partial,
                error: e.to_string(),
            },
        }),
        LogIo::Write {
            partial,
            ofs,
            bytes,
        } => write(&partial, ofs, &bytes)
            .err()
            .map(|e| LogIoDone::Failed {
                path: partial,
                error: e.to_string(),
            }),
        LogIo::Finish {
            partial,
            path,
            size,
        } => Some(match finish(&partial, &path, size) {
            Ok(()) => LogIoDone::Finished { path },
            Err(e) => LogIoDone::Failed {
                path: partial,
                error: e.to_string(),
            },
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_partial_grows_resumes_and_is_renamed_only_when_whole() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a/b/log1.bin");
        let partial = crate::proto::logs::partial_of(&path);
        let tag = "log 1 of 6 bytes".to_string();
        let opened = carry_out(LogIo::Open {
            partial: partial.clone(),
            max: 6,
            tag: tag.clone(),
        });
        assert_eq!(
            opened,
            Some(LogIoDone::Opened {
                partial: partial.clone(),
                have: 0
            })
        );
        let w = |ofs, b: &[u8]| {
            carry_out(LogIo::Write {
                partial: partial.clone(),
                ofs,
                bytes: b.to_vec(),
            })
        };
        assert_eq!(w(0, b"abc"), None);
        let finish = carry_out(LogIo::Finish {
            partial: partial.clone(),
            path: path.clone(),
            size: 6,
        });
        assert!(
            matches!(finish, Some(LogIoDone::Failed { .. })),
            "{finish:?}"
        );
        assert!(!path.exists());
        // Opened again: resumes from its 3 bytes.
        let again = carry_out(LogIo::Open {
            partial: partial.clone(),
            max: 6,
            tag: tag.clone(),
        });
        assert_eq!(
            again,
            Some(LogIoDone::Opened {
                partial: partial.clone(),
                have: 3
            })
        );
        assert_eq!(w(3, b"def"), None);
        let finish = carry_out(LogIo::Finish {
            partial: partial.clone(),
            path: path.clone(),
            size: 6,
        });
        assert_eq!(finish, Some(LogIoDone::Finished { path: path.clone() }));
        assert_eq!(std::fs::read(&path).unwrap(), b"abcdef");
        assert!(!partial.exists());
        assert!(
            !info_of(&partial).exists(),
            "the info goes with the partial"
        );
    }

    #[test]
    fn a_partial_of_another_log_is_started_over_never_appended_to() {
        let dir = tempfile::tempdir().unwrap();
        let partial = dir.path().join("log1_no-time.bin.partial");
        let open = |tag: &str, max| {
            carry_out(LogIo::Open {
                partial: partial.clone(),
                max,
                tag: tag.into(),
            })
        };
        let have = |n| {
            Some(LogIoDone::Opened {
                partial: partial.clone(),
                have: n,
            })
        };
        assert_eq!(open("log 1, 1000 bytes", 1000), have(0));
        assert_eq!(
            carry_out(LogIo::Write {
                partial: partial.clone(),
                ofs: 0,
                bytes: vec![1; 500],
            }),
            None
        );
        // The same log: resumed.
        assert_eq!(open("log 1, 1000 bytes", 1000), have(500));
        // Erased, and a new log 1 (no time either) of another size: started over.
        assert_eq!(open("log 1, 800 bytes", 800), have(0));
        assert_eq!(std::fs::metadata(&partial).unwrap().len(), 0);
        assert_eq!(
            std::fs::read_to_string(info_of(&partial)).unwrap(),
            "log 1, 800 bytes"
        );
        // A partial nothing says the log of (no info: an older mavterm, or lost): started over.
        std::fs::write(&partial, [2; 300]).unwrap();
        std::fs::remove_file(info_of(&partial)).unwrap();
        assert_eq!(open("log 1, 800 bytes", 800), have(0));
        // Longer than the log: not its prefix.
        std::fs::write(&partial, [2; 900]).unwrap();
        assert_eq!(open("log 1, 800 bytes", 800), have(0));
    }
}
