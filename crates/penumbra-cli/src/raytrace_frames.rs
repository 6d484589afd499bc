//! `raytrace --method whitted --frames N --out 'walk-{}.png' --shard I/N`:
//! a shard renders its contiguous range of the frames, writing each under
//! its final name, and records each frame's statistics in the part of
//! `--out` (the name as typed, pattern included); `penumbra merge` checks
//! that every frame's file is there and reports as one process does.

use std::path::Path;

use serde_json::{Value, json};

use crate::io::merged;
use crate::raytrace::{RaytraceArgs, Setup};
use penumbra::error::{Error, Result};
use penumbra::io::output::frame_output;
use penumbra::io::shard::{Parts, Shard};
use penumbra::report::repeats::RunTimes;
use penumbra::whitted::{RayCounts, WhittedRenderer};

/// The `--out` template every frame's name comes from.
fn template(args: &RaytraceArgs) -> &Path {
    args.out.as_deref().expect("a split run's --out is checked to hold {}")
}

/// `--shard I/N`: this shard's frames rendered, written and recorded one
/// by one, so a shard killed part-way renders again only the frames whose
/// record is missing (a frame's file is in place before its record).
pub(super) fn part(args: &RaytraceArgs, setup: Setup, mut renderer: WhittedRenderer, shard: Shard) -> Result<Value> {
    let (size, frames) = ((args.size.width, args.size.height), args.knobs.frames);
    let mut writer = crate::shard::open_part(template(args), shard, frames as usize)?;
    let todo = writer.todo(1);
    let pixels = todo.len() as u64 * size.0 as u64 * size.1 as u64;
    let progress = crate::progress::stderr().bar(pixels, "ray tracing");
    for piece in todo {
        let f = piece.start as u32;
        let image = renderer.render(&setup.path.at(f, frames), size.0, size.1, &setup.settings, &progress)?;
        if !renderer.is_gpu() {
            progress.inc(size.0 as u64 * size.1 as u64);
        }
        setup.images.frame((f, frames), &image.radiance())?;
        let stats = serde_json::to_vec(&image.stats).map_err(|e| Error::internal(e.to_string()))?;
        writer.record(piece, &stats)?;
    }
    progress.finish();
    let records: Vec<(std::ops::Range<usize>, Vec<u8>)> =
        writer.records().into_iter().map(|(r, b)| (r, b.to_vec())).collect();
    let items = writer.items();
    let report = report(args, &setup, &renderer, &records, items.end as u32 - 1)?;
    crate::shard::finish_part(writer, report)
}

/// `penumbra merge 'walk-{}.png'`: every frame's file checked, the report
/// summed from the frames' records as one process sums them.
pub(super) fn merge(args: &RaytraceArgs, setup: Setup, renderer: WhittedRenderer, parts: &Parts) -> Result<Value> {
    let (size, frames) = ((args.size.width, args.size.height), args.knobs.frames);
    let out = template(args);
    let records = crate::shard::frame_records(parts, out, frames as usize, |f| {
        frame_output(out, f as u32, f as u32 + 1 == frames).expect("the template holds {}")
    })?;
    let mut report = report(args, &setup, &renderer, &records, frames - 1)?;
    let render_ms = report["render_ms"].as_f64().unwrap_or(0.0);
    report["runs"] = json!(RunTimes::of("render_ms", 0, vec![render_ms]));
    if let Some(pixel) = args.knobs.ray_tree {
        report["ray_tree"] = json!(renderer.pixel_tree_report(&setup.base, size, &setup.settings, pixel)?);
    }
    Ok(report)
}

/// The report of the frames `records` hold, in order, `last` the last of
/// them: what `whitted` reports for a sequence of them.
fn report(
    args: &RaytraceArgs,
    setup: &Setup,
    renderer: &WhittedRenderer,
    records: &[(std::ops::Range<usize>, Vec<u8>)],
    last: u32,
) -> Result<Value> {
    let out = template(args);
    let (mut rays, mut render_ms, mut frame_ms) = (RayCounts::default(), 0.0, Vec::new());
    let mut last_stats = Value::Null;
    for (items, bytes) in records {
        let bad = |problem: String| Error::file(out, "", format!("frame {}'s record: {problem}", items.start));
        let stats: Value = serde_json::from_slice(bytes).map_err(|e| bad(e.to_string()))?;
        let count = |kind: &str| {
            stats["rays"][kind]
                .as_u64()
                .ok_or_else(|| bad(format!("rays.{kind} is not a count")))
        };
        let frame = RayCounts {
            primary: count("primary")?,
            shadow: count("shadow")?,
            reflection: count("reflection")?,
            refraction: count("refraction")?,
        };
        let ms = stats["render_ms"]
            .as_f64()
            .ok_or_else(|| bad("render_ms is not a number".into()))?;
        rays.primary += frame.primary;
        rays.shadow += frame.shadow;
        rays.reflection += frame.reflection;
        rays.refraction += frame.refraction;
        render_ms += ms;
        frame_ms.push(ms);
        last_stats = stats;
    }
    // The fields of the library's sequence report, summed the same way.
    let sequence = json!({
        "rays": rays,
        "render_ms": render_ms,
        "frame_ms": frame_ms,
        "mrays_per_s": penumbra::report::mrays_per_s(rays.total() as usize, render_ms),
    });
    let camera = setup.path.at(last, args.knobs.frames);
    let mut report = merged(setup.report(args, renderer, camera)?, &sequence)?;
    report["timing"] = last_stats["timing"].clone();
    report["path"] = last_stats["path"].clone();
    Ok(report)
}
