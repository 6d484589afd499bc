//! `penumbra raytrace --method bounded`: the bounded-error renderer
//! (`bounded::runner`) over the frames of a camera path, with the exact
//! reference, the random-line check and the error image.

use serde_json::{Value, json};

use super::args::check_output;
use super::io::write_rgb_png;
use super::raytrace::{RaytraceArgs, Setup};
use crate::bounded::measure::path_colour;
use crate::bounded::sequence::Measures;
use crate::bounded::{BoundedRenderer, BoundedSettings};
use crate::error::{Error, Result};
use crate::progress::Bars;
use crate::raytrace::WhittedRenderer;

fn settings(args: &RaytraceArgs, setup: &Setup) -> Result<BoundedSettings> {
    if args.check == Some(0) {
        return Err(Error::param("--check", "must be at least 1 line per cell"));
    }
    args.bounded.settings(setup.settings)
}

pub(super) fn run(args: &RaytraceArgs, setup: Setup, whitted: WhittedRenderer) -> Result<Value> {
    let settings = settings(args, &setup)?;
    let error_image = args
        .error_image
        .as_deref()
        .map(|p| check_output(p, "--error-image"))
        .transpose()?;
    let (w, h) = (args.width, args.height);
    let mut bounded = BoundedRenderer::new(whitted, settings)?;
    let measures = Measures {
        reference: args.reference,
        check_lines: args.check,
        seed: args.common.seed,
    };
    let progress = Bars::Stderr.bar(args.frames as u64, "bounded-error frames");
    let (sequence, last) = bounded.render_sequence(
        args.frames,
        |f| setup.camera(f, args.frames),
        (w, h),
        measures,
        &progress,
        |f, frame| setup.write_frame(f, w, h, &frame.radiance, args.exposure),
    )?;
    progress.finish();
    setup.write_last(w, h, &last.radiance, args.exposure)?;
    if let Some(path) = error_image {
        let colours: Vec<[u8; 3]> = last.paths.iter().map(|&p| path_colour(p)).collect();
        write_rgb_png(path, w, h, &colours)?;
    }
    let mut report = setup.report(args, &bounded.whitted, &last.camera);
    report["epsilon"] = json!(settings.epsilon);
    report["bounded"] = json!(settings);
    super::io::merged(report, &sequence)
}
