//! Inputs and outputs of each subcommand, checked before any work: an
//! output that is an input (the same file through another spelling, `./`,
//! `..`, a symbolic or a hard link) is refused, so no run destroys what it
//! reads (`crate::output::refuse_overwrites` compares them). Outputs are
//! then written atomically (`crate::output`).

use super::Command;
pub use crate::output::RunFiles as Files;

/// What `command` reads and writes.
pub fn of(command: &Command) -> Files {
    let mut f = Files::default();
    match command {
        Command::Info(_) | Command::GenAssets(_) => {}
        Command::TraceRays(a) => {
            f.mesh("--mesh", &Some(a.mesh.clone()));
            f.input("--rays", &Some(a.rays.clone()));
            f.output("--out", &Some(a.out.clone()));
        }
        Command::Ao(a) => {
            f.mesh("--mesh", &a.mesh);
            f.mesh("--receiver", &a.receiver);
            f.input("--field", &a.field);
            f.scene(&a.scene);
            let frames = a.knobs.frames().unwrap_or(1);
            f.frames("--per-vertex", &a.per_vertex, frames);
            f.frames("--image", &a.image, frames);
        }
        Command::Trace(a) => {
            f.mesh("--mesh", &a.mesh);
            f.scene(&a.scene);
            for (option, path) in [
                ("--out", &a.out),
                ("--tiles-image", &a.tiles_image),
                ("--aa-image", &a.aa_image),
                ("--dump-rays", &a.dump_rays),
            ] {
                f.output(option, path);
            }
        }
        Command::Ssao(a) => {
            f.mesh("--mesh", &a.mesh);
            f.scene(&a.scene);
            f.output("--out", &a.out);
            f.output("--image", &a.image);
        }
        Command::Prt(a) => {
            f.mesh("--mesh", &a.mesh);
            f.scene(&a.scene);
            f.input("--env", &Some(a.env.clone()));
            f.frames("--out", &a.out, a.play.frames.unwrap_or(1).clamp(0, 100_000) as u32);
            f.output("--sh-out", &a.sh_out);
            f.output("--per-vertex", &a.per_vertex);
            if let Some(dir) = &a.out_frames {
                let frames = a.play.frames.unwrap_or(1).clamp(0, 100_000);
                for i in 0..frames {
                    f.output("--out-frames", &Some(dir.join(format!("frame-{i:04}.png"))));
                }
            }
        }
        Command::Sweep(a) => {
            f.mesh("--mesh", &a.mesh);
            f.mesh("--receiver", &a.receiver);
            f.scene(&a.scene);
            a.outputs().into_iter().for_each(|p| f.output("--out", &Some(p)));
        }
        Command::Field(a) => {
            if let super::field::FieldCommand::Build(b) = &a.command {
                f.mesh("--mesh", &Some(b.mesh.clone()));
                f.output("-o", &Some(b.out.clone()));
            }
        }
        Command::Raytrace(a) => {
            f.mesh("--mesh", &a.mesh);
            f.input("--path", &a.path);
            f.scene(&a.scene);
            f.output("--error-image", &a.error_image);
            f.frames("--out", &a.out, a.knobs.frames.min(100_000));
        }
    }
    f
}
