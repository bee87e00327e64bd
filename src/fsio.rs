//! File reads and writes the edges share: bounded reads that never block on a FIFO, and
//! atomic writes (a file is written whole or not at all). Depends on nothing else of mavterm,
//! so every layer may use it.

use std::path::Path;

/// Read a file the core asked for, bounded: parameter files are small, and a wrong path must
/// not fill the memory.
///
/// Only a regular file is read: a FIFO, a device or a socket is refused before it is opened
/// (`stat` does not block), and the open itself never waits (`O_NONBLOCK`; the file is checked
/// again once open, in case it was swapped in between).
pub fn read_bounded(path: &Path) -> Result<Vec<u8>, String> {
    use std::io::Read;
    const MAX: u64 = 16 * 1024 * 1024;
    const NOT_REGULAR: &str = "not a regular file (a FIFO, device, socket or directory): refused";
    let meta = std::fs::metadata(path).map_err(|e| e.to_string())?;
    if !meta.is_file() {
        return Err(NOT_REGULAR.into());
    }
    let mut opts = std::fs::OpenOptions::new();
    opts.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        opts.custom_flags(libc::O_NONBLOCK);
    }
    let f = opts.open(path).map_err(|e| e.to_string())?;
    if !f.metadata().map_err(|e| e.to_string())?.is_file() {
        return Err(NOT_REGULAR.into());
    }
    let mut out = Vec::new();
    f.take(MAX + 1)
        .read_to_end(&mut out)
        .map_err(|e| e.to_string())?;
    if out.len() as u64 > MAX {
        return Err(format!("larger than {} MiB", MAX / 1024 / 1024));
    }
    Ok(out)
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
