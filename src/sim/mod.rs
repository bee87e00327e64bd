//! The simulated vehicle(s) behind `sim://`.

use crate::headless::runner::{RunnerError, VirtualSource};

/// A `sim://` source for the virtual clock.
pub fn virtual_source(_query: &str) -> Result<Box<dyn VirtualSource>, RunnerError> {
    Err(RunnerError::Sim(
        "simulated vehicle not built in yet".into(),
    ))
}

/// `mavterm sim --listen SPEC`.
pub async fn serve_cli(
    _listen: &crate::link::LinkSpec,
    _vehicles: Option<u8>,
    _options: &str,
) -> anyhow::Result<()> {
    anyhow::bail!("simulated vehicle not built in yet")
}
