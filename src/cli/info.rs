//! `penumbra info`: the adapters wgpu sees and the one penumbra picks.

use serde_json::{Value, json};

use crate::device::{Device, DeviceChoice, enumerate_adapters};
use crate::error::Result;

#[derive(clap::Args)]
pub struct InfoArgs {
    /// Print exactly one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

pub fn run(_args: &InfoArgs) -> Result<Value> {
    let selected = match Device::open(DeviceChoice::Gpu) {
        Ok(device) => json!(device.adapter()),
        Err(e) => {
            eprintln!("penumbra: {}", e.with_names(super::args::flag));
            Value::Null
        }
    };
    Ok(json!({
        "version": env!("CARGO_PKG_VERSION"),
        "adapters": enumerate_adapters(),
        "selected": selected,
    }))
}
