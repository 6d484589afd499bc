//! Inputs and outputs of each subcommand, checked before any work: an
//! output that is an input (the same file through another spelling, `./`,
//! `..`, a symbolic or a hard link) is refused, so no run destroys what it
//! reads. Outputs are then written atomically (`crate::output`).

use std::path::{Path, PathBuf};

use super::Command;
use crate::error::{Error, Result};

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
}

/// The identity of an existing file (device and inode, links followed).
#[cfg(unix)]
fn identity(path: &Path) -> Option<(u64, u64)> {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata(path).ok().map(|m| (m.dev(), m.ino()))
}

/// The identity of an existing file (its canonical path, hashed).
#[cfg(not(unix))]
fn identity(path: &Path) -> Option<(u64, u64)> {
    use std::hash::{Hash, Hasher};
    let canonical = std::fs::canonicalize(path).ok()?;
    let mut h = std::collections::hash_map::DefaultHasher::new();
    canonical.hash(&mut h);
    Some((0, h.finish()))
}

/// Refuses any output that is one of the inputs.
pub fn refuse_overwrites(files: &Files) -> Result<()> {
    let inputs: Vec<_> = files
        .inputs
        .iter()
        .filter_map(|(option, p)| identity(p).map(|id| (id, option, p)))
        .collect();
    for (option, out) in &files.outputs {
        let Some(id) = identity(out) else { continue };
        if let Some((_, input, p)) = inputs.iter().find(|(i, _, _)| *i == id) {
            let problem = format!(
                "{} is the input {input} {}; penumbra never overwrites an input, choose another output",
                out.display(),
                p.display()
            );
            return Err(Error::param(*option, problem));
        }
    }
    Ok(())
}

/// What `command` reads and writes.
pub fn of(command: &Command) -> Files {
    let mut f = Files::default();
    match command {
        Command::Info(_) | Command::GenAssets(_) => {}
        Command::TraceRays(a) => {
            f.input("--mesh", &Some(a.mesh.clone()));
            f.input("--rays", &Some(a.rays.clone()));
            f.output("--out", &Some(a.out.clone()));
        }
        Command::Ao(a) => {
            f.input("--mesh", &a.mesh);
            f.input("--receiver", &a.receiver);
            f.input("--field", &a.field);
            f.scene(&a.scene);
            f.output("--per-vertex", &a.per_vertex);
            f.output("--image", &a.image);
        }
        Command::Trace(a) => {
            f.input("--mesh", &a.mesh);
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
            f.input("--mesh", &a.mesh);
            f.scene(&a.scene);
            f.output("--out", &a.out);
            f.output("--image", &a.image);
        }
        Command::Prt(a) => {
            f.input("--mesh", &a.mesh);
            f.input("--env", &Some(a.env.clone()));
            f.output("--out", &a.out);
            if let Some(dir) = &a.out_frames {
                let frames = a.frames.clamp(0, 100_000);
                for i in 0..frames {
                    f.output("--out-frames", &Some(dir.join(format!("frame-{i:04}.png"))));
                }
            }
        }
        Command::Field(a) => {
            if let super::field::FieldCommand::Build(b) = &a.command {
                f.input("--mesh", &Some(b.mesh.clone()));
                f.output("-o", &Some(b.out.clone()));
            }
        }
        Command::Raytrace(a) => {
            f.input("--mesh", &a.mesh);
            f.input("--path", &a.path);
            f.scene(&a.scene);
            f.output("--error-image", &a.error_image);
            if let Some(out) = &a.out {
                let frames = a.frames.min(100_000);
                let each = (0..frames).filter_map(|i| super::raytrace::frame_path(out, i));
                let all: Vec<PathBuf> = each.collect();
                if all.is_empty() {
                    f.output("--out", &a.out);
                }
                all.into_iter().for_each(|p| f.output("--out", &Some(p)));
            }
        }
    }
    f
}
