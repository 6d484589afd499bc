//! `ao --method field --frames N --per-vertex 'v-{}.csv' --shard I/N` (or
//! `--image` with `{}`): a shard computes its contiguous range of the
//! frames, writing each under its final name, and records each frame's
//! times in the part of the output (the name as typed, pattern included);
//! `penumbra merge` checks that every frame's file is there, computes the
//! last frame again for what the report says of it (its outputs' summary,
//! the reference), and reports as one process does.

use std::path::Path;

use serde_json::{Value, json};

use crate::ao::AoArgs;
use crate::io::{merged, note};
use penumbra::error::{Error, Result};
use penumbra::field::report::FieldRunReport;
use penumbra::field::runner::FieldAo;
use penumbra::gpu::device::Device;
use penumbra::io::output::{frame_output, frame_path};
use penumbra::io::shard::{Parts, Shard};
use penumbra::raycast::report::AoOutputs;
use penumbra::raycast::runner::AoRequest;
use penumbra::report::repeats::RunTimes;
use penumbra::scene::Scene;

/// The scene, its fields and the animation's frame count.
type Run<'a, 's> = (&'a Scene, &'a mut FieldAo<'s>, u32);

/// What a sharded run needs: one output, a file per frame, each frame
/// computed once.
pub fn check_split(args: &AoArgs, outputs: &AoOutputs) -> Result<()> {
    let given = [("--per-vertex", outputs.per_vertex), ("--image", outputs.image)];
    crate::shard::one_output(&given.map(|(o, p)| (o, p.is_some())))?;
    let pattern = outputs
        .per_vertex
        .or(outputs.image)
        .is_some_and(|p| frame_path(p, 0).is_some());
    if args.knobs.frames < 2 || !pattern {
        let problem = "splits --method field's frames: give --frames N (N > 1) and a --per-vertex or --image \
                       name holding {} (or {:04}), every frame its own file";
        return Err(Error::param("--shard", problem));
    }
    let runs = args.common.runs.runs(1)?;
    if runs.warmup + runs.repeat > 1 {
        return Err(Error::param(
            "--shard",
            "computes each frame once; leave out --warmup and --repeat",
        ));
    }
    Ok(())
}

/// The output template every frame's name comes from.
fn template<'a>(outputs: &AoOutputs<'a>) -> &'a Path {
    outputs
        .per_vertex
        .or(outputs.image)
        .expect("a split run's output is checked")
}

/// `--shard I/N`: this shard's frames computed, written and recorded one
/// by one (a frame's file is in place before its record).
pub fn part(
    args: &AoArgs,
    (outputs, request): (AoOutputs, &AoRequest),
    (scene, fields, frames): Run,
    shard: Shard,
    (device, threads): (&Device, usize),
) -> Result<Value> {
    let mut writer = crate::shard::open_part(template(&outputs), shard, frames as usize)?;
    let radius = request.settings.radius;
    for piece in writer.todo(1) {
        let f = piece.start as u32;
        let run = fields.run_range(request, (frames, f..f + 1), false, None)?;
        let (vertices, image) = (run.vertices.as_ref(), run.image.as_ref());
        let written = outputs.write_frame(scene, (f, f + 1 == frames), radius, vertices, image)?;
        written.notes.iter().for_each(|n| note(n));
        let record = json!({
            "ao_ms": run.frame_ao_ms[0],
            // Frame 0's self-occlusion is the whole run's; a later frame's
            // is that of the objects that moved.
            "self_ms": run.self_occlusion_ms.as_ref().and_then(|ms| ms.get(1)),
        });
        writer.record(piece, record.to_string().as_bytes())?;
    }
    let (ao_ms, _) = times(&writer.records(), template(&outputs))?;
    let report = json!({ "frame_ao_ms": ao_ms, "frames": ao_ms.len() });
    let report = merged(args.common.report(device, threads), report)?;
    crate::shard::finish_part(writer, report)
}

/// Every frame's field AO time and its moved objects' self-occlusion time
/// (where they were recast), in frame order.
fn times<B: AsRef<[u8]>>(records: &[(std::ops::Range<usize>, B)], out: &Path) -> Result<(Vec<f64>, Vec<f64>)> {
    let (mut ao_ms, mut self_ms) = (Vec::new(), Vec::new());
    for (items, bytes) in records {
        let bad = |problem: String| Error::file(out, "", format!("frame {}'s record: {problem}", items.start));
        let record: Value = serde_json::from_slice(bytes.as_ref()).map_err(|e| bad(e.to_string()))?;
        let ms = record["ao_ms"]
            .as_f64()
            .ok_or_else(|| bad("ao_ms is not a number".into()))?;
        ao_ms.push(ms);
        self_ms.extend(record["self_ms"].as_f64());
    }
    Ok((ao_ms, self_ms))
}

/// `penumbra merge`: every frame's file checked, the last frame computed
/// again for its outputs' summary and the reference (its file written
/// again, the same bytes), the times from the parts' records.
pub fn merge(
    args: &AoArgs,
    (outputs, request): (AoOutputs, &AoRequest),
    (scene, fields, frames): Run,
    parts: &Parts,
) -> Result<FieldRunReport> {
    let out = template(&outputs);
    let records = crate::shard::frame_records(parts, out, frames as usize, |f| {
        frame_output(out, f as u32, f as u32 + 1 == frames).expect("the template holds {}")
    })?;
    let (ao_ms, self_ms) = times(&records, out)?;
    let last = frames - 1;
    let mut run = fields.run_range(request, (frames, last..frames), args.knobs.reference, None)?;
    run.self_occlusion_ms = run
        .self_occlusion_ms
        .map(|ms| std::iter::once(ms[0]).chain(self_ms).collect());
    run.frame_ao_ms = ao_ms;
    let (vertices, image) = (run.vertices.as_ref(), run.image.as_ref());
    let radius = request.settings.radius;
    let written = outputs.write_frame(scene, (last, true), radius, vertices, image)?;
    written.notes.iter().for_each(|n| note(n));
    let last_ms = run.frame_ao_ms.last().copied().unwrap_or(0.0);
    let mut report = FieldRunReport::new(fields, run, &request.settings, written);
    report.ao.runs = Some(RunTimes::of("ao_ms", 0, vec![last_ms]));
    Ok(report)
}
