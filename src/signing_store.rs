//! The MAVLink signing key and timestamp on disk, read and written at the edge.
//!
//! - The key comes from `--signing-key` (or the config file's `signing_key = "file:PATH"`): a
//!   passphrase, `hex:64HEX`, or `file:PATH`, whose first line is read the same way (a
//!   passphrase, or `hex:`). A key file that its group or others may read is refused, as ssh
//!   refuses such a private key: `chmod 600` it.
//! - The timestamp is kept in `signing.json` in mavterm's data directory
//!   (`~/.local/share/mavterm/`): the core writes a reservation 30 s ahead while it signs, and
//!   the edge writes the last timestamp used when the run ends. The next run starts after it, so
//!   our timestamps never go backwards, even when the system clock does. The file's modification
//!   time goes with it: the core repairs a file further ahead of the clock that wrote it than a
//!   sound run leaves one (`app::signing::STATE_LIMIT`).

use std::path::{Path, PathBuf};

use crate::app::signing::SigningConfig;
use crate::app::App;
use crate::wire::signing::{self as codec, KeyError, KeySpec, SecretKey};

/// File name of the signing state in the data directory.
pub const STATE_FILE: &str = "signing.json";
/// A key file longer than this is not a key file.
const MAX_KEY_FILE: u64 = 4096;

/// Why signing could not be set up. Messages name the file, never the key.
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    #[error("--signing-key: {0}")]
    Key(KeyError),
    #[error("signing key file {path}: {error}")]
    KeyFile { path: PathBuf, error: String },
    #[error(
        "signing key file {path} can be read by others (mode {mode:04o}): refused; make it \
         yours only with chmod 600 {path}"
    )]
    Exposed { path: PathBuf, mode: u32 },
    #[error("signing state {path}: {error} (delete it to start from the system clock)")]
    State { path: PathBuf, error: String },
}

/// The key a `--signing-key` value names (reading the file for `file:PATH`).
pub fn read_key(spec: &str) -> Result<SecretKey, StoreError> {
    match codec::parse_key_spec(spec).map_err(StoreError::Key)? {
        KeySpec::Key(k) => Ok(k),
        KeySpec::File(path) => read_key_file(&crate::paths::expand_home(&path)),
    }
}

/// A key file: refused when its group or others may read or write it; its first line is a
/// passphrase or `hex:64HEX`.
pub fn read_key_file(path: &Path) -> Result<SecretKey, StoreError> {
    use std::io::Read;
    let fail = |error: String| StoreError::KeyFile {
        path: path.to_path_buf(),
        error,
    };
    let f = crate::fsio::open_regular(path).map_err(|e| fail(e.to_string()))?;
    let meta = f.metadata().map_err(|e| fail(e.to_string()))?;
    if !meta.is_file() {
        return Err(fail("not a file".into()));
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = meta.permissions().mode() & 0o7777;
        if mode & 0o077 != 0 {
            return Err(StoreError::Exposed {
                path: path.to_path_buf(),
                mode,
            });
        }
    }
    let mut bytes = Vec::new();
    f.take(MAX_KEY_FILE + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| fail(e.to_string()))?;
    if bytes.len() as u64 > MAX_KEY_FILE {
        return Err(fail(format!("longer than {MAX_KEY_FILE} bytes")));
    }
    let text = String::from_utf8(bytes).map_err(|_| fail("not UTF-8 text".into()))?;
    let line = text.lines().next().unwrap_or("");
    codec::parse_key(line).map_err(|e| fail(e.to_string()))
}

/// Where the signing timestamp is kept: [`STATE_FILE`] in the data directory.
pub fn state_path() -> Option<PathBuf> {
    Some(crate::paths::data_dir()?.join(STATE_FILE))
}

/// The timestamp kept at `path` (0 when there is no file yet).
pub fn load_state(path: &Path) -> Result<u64, StoreError> {
    let fail = |error: String| StoreError::State {
        path: path.to_path_buf(),
        error,
    };
    match crate::fsio::read_file(path, 4096) {
        Ok(bytes) => codec::decode_state(&bytes).map_err(fail),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(0),
        Err(e) => Err(fail(e.to_string())),
    }
}

/// When the state file at `path` was last written, as a signing timestamp (`None`: no file, or
/// no time kept for it).
pub fn state_written_at(path: &Path) -> Option<u64> {
    let t = std::fs::metadata(path).ok()?.modified().ok()?;
    let us = t.duration_since(std::time::UNIX_EPOCH).ok()?.as_micros();
    Some(codec::timestamp_from_unix_micros(
        us.min(i64::MAX as u128) as i64
    ))
}

/// The core's signing settings: the key `spec` names, and, when `state` is given, the timestamp
/// kept there and when it was written (its directory is made, so the core's writes can land).
pub fn signing_config(
    spec: &str,
    allow_unsigned_heartbeat: bool,
    state: Option<PathBuf>,
) -> Result<SigningConfig, StoreError> {
    let key = read_key(spec)?;
    let saved_at = state.as_deref().and_then(state_written_at);
    let saved_timestamp = match &state {
        Some(path) => {
            if let Some(dir) = path.parent() {
                std::fs::create_dir_all(dir).map_err(|e| StoreError::State {
                    path: path.clone(),
                    error: format!("cannot make its directory: {e}"),
                })?;
            }
            load_state(path)?
        }
        None => 0,
    };
    Ok(SigningConfig {
        key,
        allow_unsigned_heartbeat,
        state_path: state,
        saved_timestamp,
        saved_at,
    })
}

/// At the end of a run: keep the last timestamp used, for the next run to start after it.
pub fn save_final(app: &App) -> std::io::Result<()> {
    match app.signing.final_state() {
        Some((path, contents)) => crate::driver::write_atomic(&path, &contents),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[cfg(unix)]
    #[test]
    fn key_file_must_be_ours_only() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("k");
        std::fs::write(&path, "correct horse\n").unwrap();
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o644)).unwrap();
        let e = read_key(&format!("file:{}", path.display())).unwrap_err();
        assert!(matches!(e, StoreError::Exposed { mode: 0o644, .. }), "{e}");
        assert!(e.to_string().contains("chmod 600"), "{e}");
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o600)).unwrap();
        let k = read_key(&format!("file:{}", path.display())).unwrap();
        assert_eq!(k, SecretKey::from_passphrase("correct horse"));
        // hex: in a file, and errors that name the file but not the key.
        std::fs::write(&path, format!("hex:{}\r\n", "0a".repeat(32))).unwrap();
        assert_eq!(
            read_key_file(&path).unwrap(),
            SecretKey::from_bytes([10; 32])
        );
        std::fs::write(&path, "hex:zz\n").unwrap();
        let e = read_key_file(&path).unwrap_err().to_string();
        assert!(e.contains("64 hex digits") && e.contains(&path.display().to_string()));
        assert!(!e.contains("zz"), "{e}");
        let e = read_key("file:/no/such/key").unwrap_err().to_string();
        assert!(e.contains("/no/such/key"), "{e}");
    }

    #[test]
    fn state_file_missing_is_zero_and_corrupt_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("sub").join(STATE_FILE);
        let cfg = signing_config("pass", false, Some(path.clone())).unwrap();
        assert_eq!(cfg.saved_timestamp, 0);
        assert!(path.parent().unwrap().is_dir(), "directory made");
        std::fs::write(&path, codec::encode_state(42)).unwrap();
        assert_eq!(load_state(&path).unwrap(), 42);
        std::fs::write(&path, "{\"timestamp\": \"x\"}").unwrap();
        let e = load_state(&path).unwrap_err().to_string();
        assert!(e.contains("delete it"), "{e}");
    }
}
