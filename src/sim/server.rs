pub async fn serve(_l: &crate::link::LinkSpec, _c: SimConfig) -> Result<(), SimError> {
    Ok(())
}
use super::{SimConfig, SimError};
