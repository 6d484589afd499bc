//! `penumbra raytrace --method bounded`: the bounded-error renderer
//! (`bounded::runner`) over the frames of a camera path, with the exact
//! reference, the random-line check and the error image.

use serde_json::{Value, json};

use crate::args::check_output;
use crate::raytrace::{RaytraceArgs, Setup};
use penumbra::bounded::BoundedRenderer;
use penumbra::bounded::measure::path_colour;
use penumbra::error::Result;
use penumbra::io::image::write_rgb_png;
use penumbra::whitted::WhittedRenderer;

pub(super) fn run(args: &RaytraceArgs, setup: Setup, whitted: WhittedRenderer) -> Result<Value> {
    let measures = args.bounded.measures(args.common.seed)?;
    let settings = args.bounded.settings(setup.settings)?;
    let error_image = args
        .error_image
        .as_deref()
        .map(|p| check_output(p, "--error-image"))
        .transpose()?;
    let (size, frames) = ((args.size.width, args.size.height), args.knobs.frames);
    let mut bounded = BoundedRenderer::new(whitted, settings)?;
    let progress = crate::progress::stderr().bar(frames as u64, "bounded-error frames");
    let (sequence, last) = bounded.render_sequence(
        frames,
        |f| setup.path.at(f, frames),
        size,
        measures,
        &progress,
        |f, frame| setup.images.frame((f, frames), &frame.radiance),
    )?;
    progress.finish();
    if let Some(path) = error_image {
        let colours: Vec<[u8; 3]> = last.paths.iter().map(|&p| path_colour(p)).collect();
        write_rgb_png(path, size.0, size.1, &colours)?;
    }
    let mut report = setup.report(args, &bounded.whitted, last.camera)?;
    report["epsilon"] = json!(settings.epsilon);
    report["bounded"] = json!(settings);
    crate::io::merged(report, &sequence)
}
