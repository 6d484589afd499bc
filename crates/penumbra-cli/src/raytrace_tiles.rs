//! `raytrace --method whitted --out IMG --shard I/N` for one image: a
//! shard renders its contiguous rows, sixteen rows a record (the CPU's
//! shadow tiles), each pixel the one the whole image gives; `penumbra
//! merge IMG` writes the image and reports as one process does.

use serde_json::{Value, json};

use crate::io::merged;
use crate::raytrace::{RaytraceArgs, Setup};
use penumbra::error::{Error, Result};
use penumbra::io::shard::{Parts, Shard};
use penumbra::report::repeats::RunTimes;
use penumbra::whitted::{PixelOut, RayCounts, WhittedRenderer};

/// Rows a record holds.
const BAND: usize = 16;

fn out(args: &RaytraceArgs) -> &std::path::Path {
    args.out.as_deref().expect("a split image's --out is checked")
}

/// A record: the band's milliseconds (f64), then its pixels as the GPU
/// writes them.
fn encode(ms: f64, pixels: &[PixelOut]) -> Vec<u8> {
    let mut bytes = ms.to_le_bytes().to_vec();
    bytes.extend_from_slice(bytemuck::cast_slice(pixels));
    bytes
}

/// `--shard I/N`: this shard's rows, band by band.
pub(super) fn part(args: &RaytraceArgs, setup: Setup, mut renderer: WhittedRenderer, shard: Shard) -> Result<Value> {
    let (width, height) = (args.size.width, args.size.height);
    let mut writer = crate::shard::open_part(out(args), shard, height as usize)?;
    let bands = (0..height as usize)
        .step_by(BAND)
        .map(|s| s..(s + BAND).min(height as usize));
    let left = writer.left(bands);
    let rows: u64 = left.iter().map(|r| r.len() as u64).sum();
    let progress = crate::progress::stderr().bar(rows * width as u64, "ray tracing");
    let camera = setup.path.at(0, 1);
    let (mut render_ms, mut stats) = (0.0, None);
    for piece in left {
        let rows = piece.start as u32..piece.end as u32;
        let band = renderer.render_rows(&camera, (width, height), rows, &setup.settings, &progress)?;
        if !renderer.is_gpu() {
            progress.inc(piece.len() as u64 * width as u64);
        }
        render_ms += band.stats.render_ms;
        writer.record(piece, &encode(band.stats.render_ms, &band.pixels))?;
        stats = Some(band.stats);
    }
    progress.finish();
    let mut report = setup.report(args, &renderer, camera)?;
    report["render_ms"] = json!(render_ms);
    if let Some(s) = stats {
        report["timing"] = json!(s.timing);
        report["path"] = json!(s.path);
    }
    crate::shard::finish_part(writer, report)
}

/// `penumbra merge IMG`: the image from every band, written and reported
/// as `whitted` does for one frame.
pub(super) fn merge(args: &RaytraceArgs, setup: Setup, renderer: WhittedRenderer, parts: &Parts) -> Result<Value> {
    let (width, height) = (args.size.width, args.size.height);
    if parts.total_items() != height as usize {
        let problem = format!("the parts hold {} rows, the image {height}", parts.total_items());
        return Err(Error::file(out(args), "", problem));
    }
    let mut pixels: Vec<PixelOut> = Vec::with_capacity(width as usize * height as usize);
    let mut render_ms = 0.0;
    for (rows, bytes) in parts.records()? {
        let size = std::mem::size_of::<PixelOut>();
        let want = 8 + rows.len() * width as usize * size;
        if bytes.len() != want {
            let problem = format!("the record of rows {rows:?} holds {} bytes, not {want}", bytes.len());
            return Err(Error::file(out(args), "", problem));
        }
        render_ms += f64::from_le_bytes(bytes[..8].try_into().expect("8 bytes"));
        pixels.extend(
            bytes[8..]
                .chunks_exact(size)
                .map(bytemuck::pod_read_unaligned::<PixelOut>),
        );
    }
    let radiance: Vec<glam::Vec3> = pixels.iter().map(|p| glam::Vec3::from_array(p.radiance)).collect();
    setup.images.frame((0, 1), &radiance)?;
    let rays = RayCounts::of(&pixels);
    let sequence = json!({
        "rays": rays,
        "render_ms": render_ms,
        "frame_ms": [render_ms],
        "mrays_per_s": penumbra::report::mrays_per_s(rays.total() as usize, render_ms),
    });
    let camera = setup.path.at(0, 1);
    let mut report = merged(setup.report(args, &renderer, camera)?, &sequence)?;
    let first = &parts.sidecars[0].report;
    report["timing"] = first["timing"].clone();
    report["path"] = first["path"].clone();
    report["runs"] = json!(RunTimes::of("render_ms", 0, vec![render_ms]));
    if let Some(pixel) = args.knobs.ray_tree {
        let size = (width, height);
        report["ray_tree"] = json!(renderer.pixel_tree_report(&setup.base, size, &setup.settings, pixel)?);
    }
    Ok(report)
}
