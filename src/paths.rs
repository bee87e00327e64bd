//! Where mavterm's own files live: its config directory, shared by the config file, the keymap
//! and the parameter metadata, and its data directory, for state kept between runs and telemetry
//! logs (a leaf: no other module of mavterm is needed here).

use std::path::PathBuf;

/// mavterm's config directory: `mavterm` in the user's XDG config directory
/// (`$XDG_CONFIG_HOME`, else `~/.config`; on Windows the roaming AppData folder). `None` when
/// there is no home directory.
pub fn config_dir() -> Option<PathBuf> {
    use etcetera::BaseStrategy;
    Some(
        etcetera::choose_base_strategy()
            .ok()?
            .config_dir()
            .join("mavterm"),
    )
}

/// mavterm's data directory: `mavterm` in the user's XDG data directory (`$XDG_DATA_HOME`, else
/// `~/.local/share`; on Windows the roaming AppData folder), for state kept between runs (the
/// MAVLink signing timestamp) and telemetry logs. `None` when there is no home directory.
pub fn data_dir() -> Option<PathBuf> {
    use etcetera::BaseStrategy;
    Some(
        etcetera::choose_base_strategy()
            .ok()?
            .data_dir()
            .join("mavterm"),
    )
}

/// `~/REST` with the home directory put in; anything else as given.
pub fn expand_home(path: &str) -> PathBuf {
    match path.strip_prefix("~/") {
        Some(rest) => match etcetera::home_dir() {
            Ok(home) => home.join(rest),
            Err(_) => PathBuf::from(path),
        },
        None => PathBuf::from(path),
    }
}

/// Where telemetry logs go by default: `logs` in [`data_dir`].
pub fn logs_dir() -> Option<PathBuf> {
    Some(data_dir()?.join("logs"))
}

/// mavterm's cache directory: `mavterm` in the user's XDG cache directory (`$XDG_CACHE_HOME`,
/// else `~/.cache`; on Windows the local AppData folder), for downloads that can be made again
/// (parameter metadata). `None` when there is no home directory.
pub fn cache_dir() -> Option<PathBuf> {
    use etcetera::BaseStrategy;
    Some(
        etcetera::choose_base_strategy()
            .ok()?
            .cache_dir()
            .join("mavterm"),
    )
}
