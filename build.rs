//! The `mavterm` binary of an optimised build is linked with the code an ordinary session runs
//! (start-up, a vehicle streaming, the Overview and help drawn) placed together, listed in
//! `assets/symbol-order.txt` (lld's `--symbol-ordering-file`). The kernel maps a program's code
//! 64 KiB around each page it first runs, so scattered code costs resident memory: together,
//! about 2 MB of code is resident instead of about 5 MB. A name missing from the list (the
//! code changed, another toolchain) only leaves that function where it was; `bench/order.py`
//! makes the list again. Only where the linker is lld: rustc's own on x86-64 Linux since 1.90.

use std::env;
use std::process::Command;

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-changed=assets/symbol-order.txt");
    println!("cargo:rerun-if-env-changed=MAVTERM_NO_SYMBOL_ORDER");
    let optimised = env::var("PROFILE").as_deref() == Ok("release");
    let target = env::var("TARGET").unwrap_or_default();
    if !optimised
        || target != "x86_64-unknown-linux-gnu"
        || env::var_os("MAVTERM_NO_SYMBOL_ORDER").is_some()
        || !linked_by_lld(&target)
    {
        return;
    }
    let Ok(dir) = env::var("CARGO_MANIFEST_DIR") else {
        return;
    };
    let list = format!("{dir}/assets/symbol-order.txt");
    if std::path::Path::new(&list).is_file() {
        println!("cargo:rustc-link-arg-bin=mavterm=-Wl,--symbol-ordering-file={list}");
        println!("cargo:rustc-link-arg-bin=mavterm=-Wl,--no-warn-symbol-ordering");
    }
}

/// rustc links with its own lld here (1.90 and later) unless told to use another linker.
fn linked_by_lld(target: &str) -> bool {
    let flags = env::var("CARGO_ENCODED_RUSTFLAGS").unwrap_or_default();
    if flags.contains("linker") || flags.contains("link-self-contained") {
        return false;
    }
    let var = format!(
        "CARGO_TARGET_{}_LINKER",
        target.to_uppercase().replace('-', "_")
    );
    if env::var_os(var).is_some() {
        return false;
    }
    let rustc = env::var("RUSTC").unwrap_or_else(|_| "rustc".into());
    let Ok(out) = Command::new(rustc).arg("-V").output() else {
        return false;
    };
    // "rustc 1.95.0 (…)": the minor version.
    let version = String::from_utf8_lossy(&out.stdout);
    let minor = version
        .split_whitespace()
        .nth(1)
        .and_then(|v| v.split('.').nth(1))
        .and_then(|m| m.parse::<u32>().ok());
    minor.is_some_and(|m| m >= 90)
}
