//! Per-vertex ambient occlusion of a mesh, the whole of it:
//!
//! ```sh
//! cargo run --release --example host_ao -- assets/sphere-on-plane.obj gpu
//! ```
//!
//! prints `index,ao` lines (AO: the fraction of 256 cosine-distributed
//! rays per vertex that escape) on the CPU, or on the GPU with `gpu`.

use std::path::Path;

use penumbra::{AmbientOcclusion, AoSettings, Device, DeviceChoice, Mesh, VertexAo};

/// AO at every vertex of the mesh in the file `path`, on `device`.
pub fn vertex_ao(device: &Device, path: &Path) -> penumbra::Result<VertexAo> {
    let mesh = Mesh::load(path)?;
    AmbientOcclusion::new(device, &mesh)?.vertices(&AoSettings::default())
}

fn main() -> penumbra::Result<()> {
    let mut args = std::env::args().skip(1);
    let path = args.next().unwrap_or_else(|| "assets/sphere-on-plane.obj".into());
    let device = match args.next().as_deref() {
        Some("gpu") => Device::open(DeviceChoice::Gpu)?,
        _ => Device::cpu(),
    };
    let ao = vertex_ao(&device, Path::new(&path))?;
    for (i, a) in ao.ao.iter().enumerate() {
        println!("{i},{a}");
    }
    eprintln!("{} vertices, mean AO {:.4}", ao.ao.len(), ao.mean());
    Ok(())
}
