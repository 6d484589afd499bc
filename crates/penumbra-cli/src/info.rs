//! `penumbra info`: the adapters wgpu sees and the one penumbra picks.

use serde_json::{Value, json};

use penumbra::error::Result;
use penumbra::gpu::device::{Device, DeviceChoice, enumerate_adapters};

#[derive(clap::Args)]
pub struct InfoArgs {
    /// Print exactly one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// `selected` is what `--device gpu` uses, `auto` what `--device auto`
/// uses ("cpu" when there is no hardware adapter).
pub fn run(_args: &InfoArgs) -> Result<Value> {
    let options = crate::args::adapter_options();
    let (selected, backend) = match Device::open_with(DeviceChoice::Gpu, &options) {
        Ok(device) => {
            let ctx = device.context();
            (json!(ctx.map(|c| &c.name)), json!(ctx.map(|c| &c.backend)))
        }
        Err(e) => {
            eprintln!("penumbra: {}", e.with_names(crate::args::flag));
            (Value::Null, Value::Null)
        }
    };
    let auto = Device::open_with(DeviceChoice::Auto, &options)?;
    Ok(json!({
        "version": env!("CARGO_PKG_VERSION"),
        "adapters": enumerate_adapters(&options),
        "selected": selected,
        "selected_backend": backend,
        "auto": auto.adapter().unwrap_or_else(|| "cpu".into()),
    }))
}
