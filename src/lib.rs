//! mavterm: a terminal ground-control station for MAVLink vehicles.
//!
//! Layers, bottom to top; an arrow reads "is used by", and nothing imports a layer above its own
//! (see `ARCHITECTURE.md` for a frame's and a key's walk through them):
//!
//! ```text
//! wire ──▶ proto ──▶ app ──▶ ui
//!   │        │        │       │
//!   └────────┴────────┴───────┴──▶ link, sim, driver, headless, tui (the edges)
//! ```
//!
//! - [`wire`]: the codec at the bottom: framing, CRC, signing, our sequence numbers, MAVFTP and
//!   `param.pck`, the payload reader, severities. Bytes in, values out.
//! - [`proto`]: sans-I/O protocol machines (streams, commands, parameters, missions, camera,
//!   gimbal, ...), the vehicle registry and the autopilot profiles. Messages and time in, sends out.
//! - [`params`], [`mission`]: parameter and mission data and their files, independent of any link.
//! - [`app`]: the pure core: `App::update(now, Event) -> Vec<Effect>`, one session per vehicle.
//! - [`ui`]: screens and panes rendered from `&App` only; [`screen_list`] is the one list of screens.
//! - [`keymap`]: keys to actions per input mode, from `keymaps/*.toml`.
//! - [`clock`]: the core's time (microseconds handed in with every event).
//! - [`config`], [`paths`], [`cli`]: the config file, where mavterm's files live, command-line options.
//! - [`fsio`], [`signing_store`]: bounded reads and atomic writes; the signing key and timestamp on disk.
//! - [`link`]: transports (serial, UDP, TCP, tlog, sim) and connection strings, at the edge.
//! - [`sim`]: the simulated ArduCopter behind `sim://`, a deterministic test bench.
//! - [`driver`]: runs the core on the wall clock or a virtual one and carries out its effects.
//! - [`headless`]: replay of recorded keys and traffic, and reports, without a terminal.
//! - [`tui`]: the terminal front end (crossterm in, ratatui out).
//! - [`dialect`]: the MAVLink dialect (ardupilotmega, which includes common).

pub mod app;
pub mod cli;
pub mod clock;
pub mod config;
pub mod driver;
pub mod fsio;
pub mod headless;
pub mod keymap;
pub mod link;
pub mod mission;
pub mod params;
pub mod paths;
pub mod proto;
pub mod resident;
pub mod screen_list;
pub mod signing_store;
pub mod sim;
pub mod tui;
pub mod ui;
pub mod wire;

/// The MAVLink dialect mavterm speaks: ardupilotmega, which includes common.
pub use mavlink::dialects::ardupilotmega as dialect;
