//! Where mavterm's own files live: its config directory, shared by the config file, the keymap
//! and the parameter metadata (a leaf: no other module of mavterm is needed here).

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
