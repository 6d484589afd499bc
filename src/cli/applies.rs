//! Options the chosen method or mode does not use are refused (exit 2,
//! naming the option and what it needs), never silently ignored: a user
//! who types `--bits 8` with `ao --method raycast` believes it did
//! something. An option counts as given only when it was on the command
//! line (clap's `ValueSource`), so defaults never trip the check.

use clap::ArgMatches;
use clap::parser::ValueSource;

use super::Command;
use super::args::OnOff;
use crate::error::{Error, Result};

/// Options (clap ids, the field names) that apply only where `holds`.
struct Rule {
    holds: bool,
    options: &'static [&'static str],
    needs: &'static str,
}

fn rule(holds: bool, options: &'static [&'static str], needs: &'static str) -> Rule {
    Rule { holds, options, needs }
}

const CAMERA_AND_SIZE: &[&str] = &["width", "height", "eye", "target", "fov"];
const FIELD_ONLY: &[&str] = &[
    "field",
    "positions",
    "res",
    "bits",
    "directions",
    "positional",
    "frames",
    "reference",
];
const BOUNDED_ONLY: &[&str] = &[
    "epsilon",
    "floor",
    "bound",
    "split",
    "reproject",
    "span",
    "memory_mb",
    "min_pixels",
    "reference",
    "check",
    "error_image",
];
const PRT_IMAGE: &[&str] = &["width", "height", "eye", "target", "fov", "exposure", "albedo"];

fn is_png(path: &Option<std::path::PathBuf>) -> bool {
    let png = |p: &std::path::PathBuf| crate::image_out::ImageFormat::check(p, "").ok();
    path.as_ref().and_then(png) == Some(crate::image_out::ImageFormat::Png)
}

fn rules(command: &Command) -> Vec<Rule> {
    match command {
        Command::Ao(a) => ao_rules(a),
        Command::Raytrace(a) => raytrace_rules(a),
        Command::Trace(a) => trace_rules(a),
        Command::Ssao(a) => ssao_rules(a),
        Command::Prt(a) => prt_rules(a),
        Command::Sweep(a) => sweep_rules(a),
        Command::Info(_) | Command::TraceRays(_) | Command::Field(_) | Command::GenAssets(_) => Vec::new(),
    }
}

fn ao_rules(a: &super::ao::AoArgs) -> Vec<Rule> {
    vec![
        rule(a.method == super::ao::Method::Field, FIELD_ONLY, "--method field"),
        rule(a.image.is_some(), CAMERA_AND_SIZE, "--image"),
        rule(a.image.is_some(), &["background"], "--image"),
        rule(is_png(&a.image), &["png_bits"], "--image FILE.png"),
    ]
}

fn raytrace_rules(a: &super::raytrace::RaytraceArgs) -> Vec<Rule> {
    use super::raytrace::Method;
    vec![
        rule(a.method == Method::Bounded, BOUNDED_ONLY, "--method bounded"),
        rule(a.method == Method::Whitted, &["ray_tree"], "--method whitted"),
        rule(a.frames > 1, &["path"], "--frames above 1"),
    ]
}

fn trace_rules(a: &super::trace::TraceArgs) -> Vec<Rule> {
    let tiles = &["tile", "min_tile", "split_factor", "tiles_image"];
    let aa = &["aa_samples", "aa_reference", "aa_image"];
    vec![
        rule(!a.knobs.single_ray, tiles, "packets (without --single-ray)"),
        rule(
            a.knobs.aa != crate::mlrta::aa::AaMode::None,
            aa,
            "--aa adaptive or uniform",
        ),
    ]
}

fn ssao_rules(a: &super::ssao::SsaoArgs) -> Vec<Rule> {
    use crate::ssao::Estimator;
    use crate::ssao::measure::MeasureKind;
    vec![
        rule(a.knobs.measure == MeasureKind::Exp, &["sigma"], "--measure exp"),
        rule(
            matches!(a.knobs.estimator, None | Some(Estimator::Raymarch)),
            &["steps"],
            "--estimator raymarch",
        ),
        rule(a.knobs.filter == OnOff::On, &["filter_depth"], "--filter on"),
        rule(a.image.is_some(), &["ambient"], "--image"),
        rule(a.out.is_some(), &["background"], "--out"),
        rule(is_png(&a.out), &["png_bits"], "--out FILE.png"),
    ]
}

fn prt_rules(a: &super::prt::PrtArgs) -> Vec<Rule> {
    use crate::prt::runner::Shadows;
    use crate::prt::transfer::BrdfKind;
    let raytraced = a.check || a.shadows == Shadows::Raytraced;
    vec![
        rule(
            a.knobs.brdf == BrdfKind::Phong,
            &["shininess", "specular"],
            "--brdf phong",
        ),
        rule(a.pvs == OnOff::On, &["pvs_frames", "pvs_span"], "--pvs on"),
        rule(raytraced, &["check_rays"], "--check or --shadows raytraced"),
        rule(a.check, &["check_frames"], "--check"),
        rule(
            a.knobs.hierarchy == OnOff::On,
            &["near", "ring", "coarse", "coarse_tolerance"],
            "--hierarchy on",
        ),
        rule(a.shadows == Shadows::On, &["self_check"], "--shadows on"),
        rule(
            a.shadows == Shadows::On && a.self_check == OnOff::On,
            &["self_check_threshold"],
            "--self-check on",
        ),
        rule(
            a.motion.may_animate(a.mesh.as_deref(), a.animated.is_some()),
            &["start", "dt"],
            "an animation",
        ),
        rule(a.motion.mesh_sequence.is_some(), &["sequence_fps"], "--mesh-sequence"),
        rule(a.mesh.is_some(), &["animation"], "--mesh (a glTF file)"),
        rule(a.per_vertex.is_some(), &["per_vertex_transfer"], "--per-vertex"),
        rule(
            a.out.is_some() || a.out_frames.is_some(),
            PRT_IMAGE,
            "--out or --out-frames",
        ),
    ]
}

fn sweep_rules(a: &super::sweep::SweepArgs) -> Vec<Rule> {
    use super::sweep::Method::*;
    let m = a.method;
    vec![
        rule(m == Field, &["receiver"], "sweep field"),
        rule(matches!(m, Field | Ssao), &["radius"], "sweep field or ssao"),
        rule(
            matches!(m, Field | Ssao | Prt),
            &["truth_rays"],
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

fn given(matches: &ArgMatches, id: &str) -> bool {
    matches.value_source(id) == Some(ValueSource::CommandLine)
}

/// The long spelling of clap id `id`.
fn spelling(id: &str) -> String {
    format!("--{}", id.replace('_', "-"))
}

/// Refuses a given option that `command` does not use; `matches` are the
/// subcommand's.
pub fn refuse_unused(command: &Command, matches: &ArgMatches) -> Result<()> {
    for r in rules(command).iter().filter(|r| !r.holds) {
        if let Some(id) = r.options.iter().find(|id| given(matches, id)) {
            let option = spelling(id);
            let problem = format!("does not apply here: it is used only with {}", r.needs);
            return Err(Error::param(option, problem));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use clap::{CommandFactory, Parser};

    use super::*;

    /// Every id a rule names is an option of its subcommand (a misspelt id
    /// would never be given, so its rule could never fire).
    #[test]
    fn every_rule_names_a_real_option() {
        let cli = super::super::Cli::command();
        let parse = |line: &str| {
            super::super::Cli::try_parse_from(line.split_whitespace())
                .unwrap()
                .command
        };
        let commands = [
            ("ao", parse("p ao --mesh m --method raycast --rays 1")),
            (
                "raytrace",
                parse("p raytrace --method whitted --mesh m --width 1 --height 1"),
            ),
            ("trace", parse("p trace --mesh m --width 1 --height 1 --mlrta off")),
            (
                "ssao",
                parse("p ssao --mesh m --estimator sphere --spp 1 --radius 1 --width 1 --height 1"),
            ),
            ("prt", parse("p prt --mesh m --env e")),
            ("sweep", parse("p sweep field --mesh m --out d")),
        ];
        for (name, command) in &commands {
            let sub = cli.find_subcommand(name).unwrap();
            for r in rules(command) {
                for id in r.options {
                    assert!(sub.get_arguments().any(|a| a.get_id() == *id), "{name}: no option {id}");
                }
            }
        }
    }
}
