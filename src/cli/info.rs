//! `penumbra info`: the adapters wgpu sees and the one penumbra picks.

use serde_json::{Value, json};

use crate::error::Result;
use crate::gpu::{GpuContext, enumerate_adapters};

#[derive(clap::Args)]
pub struct InfoArgs {
    /// Print exactly one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

pub fn run(_args: &InfoArgs) -> Result<Value> {
    let adapters = enumerate_adapters();
    let selected = match GpuContext::headless() {
        Ok(ctx) => Value::String(ctx.name),
        Err(e) => {
            eprintln!("penumbra: {e}");
            Value::Null
        }
    };
    Ok(json!({
        "version": env!("CARGO_PKG_VERSION"),
        "adapters": adapters,
        "selected": selected,
    }))
}
