//! Inputs and outputs of each subcommand, checked before any work: an
//! output that is an input (the same file through another spelling, `./`,
//! `..`, a symbolic or a hard link) is refused, so no run destroys what it
//! reads (`crate::output::refuse_overwrites` compares them). Outputs are
//! then written atomically (`crate::output`).

use std::path::PathBuf;

use super::Command;

/// A subcommand's files, each with the option that names it.
#[derive(Default)]
pub struct Files {
    pub inputs: Vec<(&'static str, PathBuf)>,
    pub outputs: Vec<(&'static str, PathBuf)>,
}

impl Files {
    fn input(&mut self, option: &'static str, path: &Option<PathBuf>) {
        if let Some(p) = path {
            self.inputs.push((option, p.clone()));
        }
    }

    /// A mesh and the files it names (MTL files, glTF buffers).
    fn mesh(&mut self, option: &'static str, path: &Option<PathBuf>) {
        if let Some(p) = path {
            self.inputs.push((option, p.clone()));
            let named = crate::scene::companion_files(p);
            self.inputs.extend(named.into_iter().map(|f| (option, f)));
        }
    }

    /// A scene file and every file it names.
    fn scene(&mut self, path: &Option<PathBuf>) {
        if let Some(p) = path {
            self.inputs.push(("--scene", p.clone()));
            let named = crate::scene::referenced_files(p);
            self.inputs.extend(named.into_iter().map(|f| ("--scene", f)));
        }
    }

    fn output(&mut self, option: &'static str, path: &Option<PathBuf>) {
        if let Some(p) = path {
            self.outputs.push((option, p.clone()));
        }
    }

    /// An output that is a file per frame where its name holds `{}`.
    fn frames(&mut self, option: &'static str, path: &Option<PathBuf>, frames: u32) {
        if let Some(out) = path {
            let all: Vec<PathBuf> = (0..frames).filter_map(|i| crate::output::frame_path(out, i)).collect();
            if all.is_empty() {
                self.output(option, path);
            }
            all.into_iter().for_each(|p| self.output(option, &Some(p)));
        }
    }
}

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
            f.output("--per-vertex", &a.per_vertex);
            f.output("--image", &a.image);
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
            f.input("--env", &Some(a.env.clone()));
            f.frames("--out", &a.out, a.frames.unwrap_or(1).clamp(0, 100_000) as u32);
            f.output("--sh-out", &a.sh_out);
            f.output("--per-vertex", &a.per_vertex);
            if let Some(dir) = &a.out_frames {
                let frames = a.frames.unwrap_or(1).clamp(0, 100_000);
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
            f.frames("--out", &a.out, a.frames.min(100_000));
        }
    }
    f
}
