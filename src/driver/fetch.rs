//! Parameter metadata at the edge: the download `param meta fetch` asks for, and the read of
//! the cached copy, both blocking (the real-time driver runs them on a blocking thread, the
//! virtual one in place) and told back to the core as [`Event::ParamMeta`].

use std::path::PathBuf;
use std::time::Duration;

use crate::app::param_meta::{MetaOrigin, MAX_BYTES};
use crate::app::Event;

/// How long one URL may take to connect, and to come down whole.
const CONNECT_TIMEOUT: Duration = Duration::from_secs(10);
const TOTAL_TIMEOUT: Duration = Duration::from_secs(120);

/// GET `url`, at most [`MAX_BYTES`]; the error says what went wrong in the operator's words.
pub fn http_get(url: &str) -> Result<Vec<u8>, String> {
    let agent: ureq::Agent = ureq::Agent::config_builder()
        .timeout_connect(Some(CONNECT_TIMEOUT))
        .timeout_global(Some(TOTAL_TIMEOUT))
        .http_status_as_error(false)
        .user_agent(concat!("mavterm/", env!("CARGO_PKG_VERSION")))
        .build()
        .into();
    let mut resp = agent
        .get(url)
        .call()
        .map_err(|e| format!("cannot reach {url}: {e}"))?;
    let status = resp.status();
    if !status.is_success() {
        return Err(format!(
            "{url} answered HTTP {} {}",
            status.as_u16(),
            status.canonical_reason().unwrap_or("")
        )
        .trim_end()
        .to_string());
    }
    resp.body_mut()
        .with_config()
        .limit(MAX_BYTES)
        .read_to_vec()
        .map_err(|e| format!("reading {url}: {e}"))
}

/// Try `urls` in order; the first that answers is the origin. `cache_path`'s directory is made
/// for the core's write of the file (which follows only when the bytes parse).
pub fn fetch_param_meta(urls: Vec<String>, cache_path: PathBuf) -> Event {
    let mut errors = Vec::new();
    for url in urls {
        match http_get(&url) {
            Ok(bytes) => {
                // A directory that cannot be made shows as the write's failure; the metadata is
                // used all the same.
                if let Some(dir) = cache_path.parent().filter(|d| !d.as_os_str().is_empty()) {
                    let _ = std::fs::create_dir_all(dir);
                }
                return Event::ParamMeta {
                    origin: MetaOrigin::Url(url),
                    cache_path,
                    result: Ok(bytes),
                };
            }
            Err(e) => errors.push(e),
        }
    }
    Event::ParamMeta {
        origin: MetaOrigin::Url(String::new()),
        cache_path,
        result: Err(if errors.is_empty() {
            "no URL to fetch".to_string()
        } else {
            errors.join("; ")
        }),
    }
}

/// Read the cached copy at `path` (bounded); a missing file comes back as
/// [`MetaOrigin::Missing`] (not an error: the core then reads the metadata from the vehicle, or
/// says nothing), and its directory is made for the core's write of the file once it has it.
pub fn read_param_meta(path: PathBuf) -> Option<Event> {
    if !path.is_file() {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            let _ = std::fs::create_dir_all(dir);
        }
        return Some(Event::ParamMeta {
            origin: MetaOrigin::Missing,
            cache_path: path,
            result: Err("no such file".into()),
        });
    }
    let result = crate::fsio::read_file(&path, MAX_BYTES).map_err(|e| e.to_string());
    Some(Event::ParamMeta {
        origin: MetaOrigin::Cache,
        cache_path: path,
        result,
    })
}
