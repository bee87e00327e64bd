//! mavterm: a terminal ground-control station for MAVLink vehicles.
//!
//! Layout: `link` turns bytes into frames at the edges (transports, framing, connection strings);
//! `proto` holds sans-I/O protocol state machines; `app` is the pure core (state + event in,
//! effects out); `ui` renders panes from state only; `sim` is the simulated vehicle; `headless`
//! runs the core without a terminal.

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
pub mod screen_list;
pub mod signing_store;
pub mod sim;
pub mod tui;
pub mod ui;
pub mod wire;

/// The MAVLink dialect mavterm speaks: ardupilotmega, which includes common.
pub use mavlink::dialects::ardupilotmega as dialect;
