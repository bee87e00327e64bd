//! File reads and writes the edges share: bounded reads that never block on a FIFO, and
//! atomic writes (a file is written whole or not at all). Depends on nothing else of mavterm,
//! so every layer may use it.

use std::path::Path;

/// What [`read_bounded`] reads at most.
pub const MAX_READ: u64 = 16 * 1024 * 1024;

const NOT_REGULAR: &str = "not a regular file (a FIFO, device, socket or directory): refused";

/// Open a regular file for reading without ever waiting: a FIFO, a device or a socket is
/// refused before it is opened (`stat` does not block), the open itself never waits
/// (`O_NONBLOCK`), and the file is checked again once open, in case it was swapped in between.
/// A missing file is an error of kind `NotFound`.
pub fn open_regular(path: &Path) -> std::io::Result<std::fs::File> {
    use std::io::{Error, ErrorKind};
    if !std::fs::metadata(path)?.is_file() {
        return Err(Error::new(ErrorKind::InvalidInput, NOT_REGULAR));
    }
    let mut opts = std::fs::OpenOptions::new();
    opts.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        opts.custom_flags(libc::O_NONBLOCK);
    }
    let f = opts.open(path)?;
    if !f.metadata()?.is_file() {
        return Err(Error::new(ErrorKind::InvalidInput, NOT_REGULAR));
    }
    Ok(f)
}

/// Read a regular file ([`open_regular`]) of at most `max` bytes; a larger one is refused
/// (`InvalidData`), never read whole.
pub fn read_file(path: &Path, max: u64) -> std::io::Result<Vec<u8>> {
    use std::io::Read;
    let f = open_regular(path)?;
    let mut out = Vec::new();
    f.take(max + 1).read_to_end(&mut out)?;
    if out.len() as u64 > max {
        let limit = if max >= 1024 * 1024 {
            format!("{} MiB", max / 1024 / 1024)
        } else {
            format!("{max} bytes")
        };
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("larger than {limit}: refused"),
        ));
    }
    Ok(out)
}

/// [`read_file`] of UTF-8 text.
pub fn read_text(path: &Path, max: u64) -> std::io::Result<String> {
    String::from_utf8(read_file(path, max)?)
        .map_err(|_| std::io::Error::new(std::io::ErrorKind::InvalidData, "not UTF-8 text"))
}

/// Read a file the core asked for, bounded ([`MAX_READ`]): parameter files are small, and a
/// wrong path must not fill the memory; only a regular file, never waiting ([`open_regular`]).
pub fn read_bounded(path: &Path) -> Result<Vec<u8>, String> {
    read_file(path, MAX_READ).map_err(|e| e.to_string())
}

/// Write a file so that a crash never leaves it half written: a temporary with a unique name in
/// the target's directory (never a user's file), fsync, rename over the target.
///
/// A symlink is followed: the file it points to is replaced, the link stays (a dangling one is
/// refused). The target, when it exists, must be a regular file: a device, a FIFO, a socket or
/// a directory is refused before anything is opened, and its mode is kept. On any failure the
/// temporary is removed.
pub fn write_atomic(path: &Path, contents: &[u8]) -> std::io::Result<()> {
    use std::io::{Error, ErrorKind, Write};
    let target = match std::fs::symlink_metadata(path) {
        Ok(m) if m.file_type().is_symlink() => std::fs::canonicalize(path)
            .map_err(|e| Error::new(e.kind(), format!("symlink to nowhere ({e})")))?,
        Ok(_) => path.to_path_buf(),
        Err(e) if e.kind() == ErrorKind::NotFound => path.to_path_buf(),
        Err(e) => return Err(e),
    };
    let existing = match std::fs::metadata(&target) {
        Ok(m) if !m.is_file() => {
            return Err(Error::new(
                ErrorKind::InvalidInput,
                "not a regular file (a device, FIFO, socket or directory): refused",
            ))
        }
        Ok(m) => Some(m.permissions()),
        Err(e) if e.kind() == ErrorKind::NotFound => None,
        Err(e) => return Err(e),
    };
    let dir = match target.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let name = target
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let prefix = format!(".{name}.");
    let mut b = tempfile::Builder::new();
    b.prefix(&prefix).suffix(".tmp~");
    #[cfg(unix)]
    if existing.is_none() {
        // A new file gets the mode a plain create would give it (0666 less the umask).
        use std::os::unix::fs::PermissionsExt;
        b.permissions(std::fs::Permissions::from_mode(0o666));
    }
    let mut tmp = b.tempfile_in(dir)?;
    tmp.write_all(contents)?;
    if let Some(perm) = existing {
        tmp.as_file().set_permissions(perm)?;
    }
    tmp.as_file().sync_all()?;
    tmp.persist(&target).map_err(|e| e.error)?;
    Ok(())
}

/// Check that `path` may be created or truncated as a plain file: it does not exist, or is a
/// regular file (a symlink to one is followed). A device, a FIFO, a socket, a directory or a
/// dangling symlink is refused before anything is opened.
pub fn check_plain_target(path: &Path) -> std::io::Result<()> {
    use std::io::{Error, ErrorKind};
    match std::fs::symlink_metadata(path) {
        Err(e) if e.kind() == ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(e),
        Ok(_) => {}
    }
    match std::fs::metadata(path) {
        Ok(m) if m.is_file() => Ok(()),
        Ok(_) => Err(Error::new(
            ErrorKind::InvalidInput,
            "not a regular file (a device, FIFO, socket or directory): refused",
        )),
        Err(e) if e.kind() == ErrorKind::NotFound => Err(Error::new(
            ErrorKind::NotFound,
            "symlink to nowhere: refused",
        )),
        Err(e) => Err(e),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[cfg(unix)]
    #[test]
    fn plain_targets_only() {
        let d = tempfile::tempdir().unwrap();
        assert!(check_plain_target(&d.path().join("new")).is_ok());
        std::fs::write(d.path().join("file"), b"x").unwrap();
        assert!(check_plain_target(&d.path().join("file")).is_ok());
        std::os::unix::fs::symlink(d.path().join("nowhere"), d.path().join("dangling")).unwrap();
        assert!(check_plain_target(&d.path().join("dangling")).is_err());
        assert!(check_plain_target(d.path()).is_err());
        assert!(check_plain_target(Path::new("/dev/null")).is_err());
    }
}
