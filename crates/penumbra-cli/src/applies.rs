//! Options the chosen method or mode does not use are refused (exit 2,
//! naming the option and what it needs), never silently ignored: a user
//! who types `--bits 8` with `ao --method raycast` believes it did
//! something. An option counts as given only when it was on the command
//! line (clap's `ValueSource`), so defaults never trip the check.

use clap::ArgMatches;

use crate::Command;
use crate::options::bounded::BoundedOptions;
use crate::options::field::FieldOptions;
use crate::options::{Applies as Rule, applies as rule};
use penumbra::error::Result;

const CAMERA_AND_SIZE: &[&str] = &["width", "height", "camera", "eye", "target", "fov"];
const PRT_IMAGE: &[&str] = &[
    "width", "height", "camera", "eye", "target", "fov", "exposure", "albedo",
];

fn is_png(path: &Option<std::path::PathBuf>) -> bool {
    let png = |p: &std::path::PathBuf| penumbra::io::image::ImageFormat::check(p, "").ok();
    path.as_ref().and_then(png) == Some(penumbra::io::image::ImageFormat::Png)
}

/// The rules of `command`'s options.
pub fn rules(command: &Command) -> Vec<Rule> {
    match command {
        Command::Ao(a) => ao_rules(a),
        Command::Raytrace(a) => raytrace_rules(a),
        Command::Trace(a) => trace_rules(a),
        Command::Ssao(a) => ssao_rules(a),
        Command::Prt(a) => prt_rules(a),
        Command::Sweep(a) => sweep_rules(a),
        Command::Info(_)
        | Command::TraceRays(_)
        | Command::Field(_)
        | Command::GenAssets(_)
        | Command::Bake(_)
        | Command::Bench(_)
        | Command::Merge(_) => Vec::new(),
    }
}

fn ao_rules(a: &crate::ao::AoArgs) -> Vec<Rule> {
    use crate::ao::Method;
    vec![
        a.knobs.applies(),
        FieldOptions::applies(a.knobs.method == Method::Field, "--method field"),
        rule(a.knobs.method == Method::Field, &["field"], "--method field"),
        rule(a.image.is_some(), CAMERA_AND_SIZE, "--image"),
        rule(a.image.is_some(), &["background"], "--image"),
        rule(is_png(&a.image), &["png_bits"], "--image FILE.png"),
    ]
}

fn raytrace_rules(a: &crate::raytrace::RaytraceArgs) -> Vec<Rule> {
    use crate::raytrace::Method;
    vec![
        BoundedOptions::applies(a.knobs.method == Method::Bounded),
        rule(a.knobs.method == Method::Bounded, &["error_image"], "--method bounded"),
        rule(a.knobs.method == Method::Whitted, &["ray_tree"], "--method whitted"),
        // The bounded renderer's cells carry over from run to run.
        rule(
            a.knobs.method == Method::Whitted,
            &["warmup", "repeat"],
            "--method whitted",
        ),
        rule(a.knobs.frames > 1, &["path"], "--frames above 1"),
    ]
}

fn trace_rules(a: &crate::trace::TraceArgs) -> Vec<Rule> {
    let mut rules = a.knobs.applies();
    rules.push(rule(
        !a.knobs.single_ray,
        &["tiles_image"],
        "packets (without --single-ray)",
    ));
    let aa = a.knobs.aa != penumbra::mlrta::aa::AaMode::None;
    rules.push(rule(aa, &["aa_image"], "--aa adaptive or uniform"));
    rules
}

fn ssao_rules(a: &crate::ssao::SsaoArgs) -> Vec<Rule> {
    let mut rules = a.knobs.applies();
    rules.extend([
        rule(a.image.is_some(), &["ambient"], "--image"),
        rule(a.out.is_some(), &["background"], "--out"),
        rule(is_png(&a.out), &["png_bits"], "--out FILE.png"),
    ]);
    rules
}

fn prt_rules(a: &crate::prt::PrtArgs) -> Vec<Rule> {
    let mut rules = a.knobs.applies();
    rules.extend(a.play.applies());
    rules.extend([
        rule(
            a.motion.may_animate(a.mesh.as_deref(), a.animated.is_some()),
            &["start", "dt"],
            "an animation",
        ),
        rule(a.motion.mesh_sequence.is_some(), &["sequence_fps"], "--mesh-sequence"),
        rule(a.mesh.is_some(), &["animation"], "--mesh (a glTF file)"),
        rule(a.scene.is_some(), &["inter_object"], "--scene"),
        rule(a.scene.is_none(), &["pvs"], "--mesh, --animated or --mesh-sequence"),
        rule(a.per_vertex.is_some(), &["per_vertex_transfer"], "--per-vertex"),
        rule(
            a.out.is_some() || a.out_frames.is_some(),
            PRT_IMAGE,
            "--out or --out-frames",
        ),
    ]);
    rules
}

fn sweep_rules(a: &crate::sweep::SweepArgs) -> Vec<Rule> {
    use crate::sweep::Method::*;
    let m = a.method;
    vec![
        rule(m == Field, &["receiver"], "sweep field"),
        rule(matches!(m, Field | Ssao), &["radius"], "sweep field or ssao"),
        rule(
            matches!(m, Field | Ssao | Prt),
            &["reference_rays"],
            "sweep field, ssao or prt",
        ),
        rule(
            matches!(m, Ssao | Trace | Bounded),
            &["width", "height"],
            "sweep ssao, trace or bounded",
        ),
        rule(
            m != Field,
            &["eye", "target", "fov"],
            "sweep ssao, prt, trace or bounded",
        ),
    ]
}

/// Refuses a given option that `command` does not use; `matches` are the
/// subcommand's.
pub fn refuse_unused(command: &Command, matches: &ArgMatches) -> Result<()> {
    crate::options::refuse_unused(&rules(command), matches)
}
