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

/// `selected` is what `--device gpu` uses, `auto` what `--device auto`
/// uses ("cpu" when there is no hardware adapter).
pub fn run(_args: &InfoArgs) -> Result<Value> {
    let (selected, backend) = match Device::open(DeviceChoice::Gpu) {
        Ok(device) => {
            let ctx = device.context();
            (json!(ctx.map(|c| &c.name)), json!(ctx.map(|c| &c.backend)))
        }
        Err(e) => {
            eprintln!("penumbra: {}", e.with_names(super::args::flag));
            (Value::Null, Value::Null)
        }
    };
    let auto = Device::open(DeviceChoice::Auto)?;
    Ok(json!({
        "version": env!("CARGO_PKG_VERSION"),
        "adapters": enumerate_adapters(),
        "selected": selected,
        "selected_backend": backend,
        "auto": auto.adapter().unwrap_or_else(|| "cpu".into()),
    }))
}
