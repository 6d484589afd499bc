//! Inputs and outputs of each subcommand, checked before any work: an
//! output that is an input (the same file through another spelling, `./`,
//! `..`, a symbolic or a hard link) is refused, so no run destroys what it
//! reads (`refuse_overwrites` compares them). Outputs are
//! then written atomically (`penumbra::io::output`).

use std::path::{Path, PathBuf};

use penumbra::error::{Error, Result};
use penumbra::io::output::frame_path;

use crate::Command;

/// What `command` reads and writes.
pub fn of(command: &Command) -> Files {
    let mut f = Files::default();
    match command {
        Command::Info(_) | Command::GenAssets(_) | Command::Merge(_) => {}
        Command::TraceRays(a) => {
            f.mesh("--mesh", &Some(a.mesh.clone()));
            f.input("--rays", &Some(a.rays.clone()));
            f.output("--out", &Some(a.out.clone()));
        }
        Command::Bake(a) if a.manifest.is_some() => {
            f.input("--manifest", &a.manifest);
            let assets = crate::bake_manifest::asset_paths(a.manifest.as_deref().expect("matched"));
            assets.into_iter().for_each(|p| f.mesh("--manifest", &Some(p)));
        }
        Command::Bake(a) => {
            f.mesh("--mesh", &a.mesh);
            f.scene(&a.scene);
            if a.scene.is_none() {
                f.output("--out", &Some(a.out.clone()));
            }
            f.output("--texture", &a.texture);
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
        Command::Bench(a) => {
            f.mesh("--mesh", &a.mesh);
            f.scene(&a.scene);
            a.outputs().into_iter().for_each(|p| f.output("--out", &Some(p)));
        }
        Command::Sweep(a) => {
            f.mesh("--mesh", &a.mesh);
            f.mesh("--receiver", &a.receiver);
            f.scene(&a.scene);
            a.outputs().into_iter().for_each(|p| f.output("--out", &Some(p)));
        }
        Command::Field(a) => {
            if let crate::field::FieldCommand::Build(b) = &a.command {
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

/// Refuses (an error naming the output's name) any output that is one of
/// the inputs, under any spelling: `./`, `..`, symbolic and hard links.
/// Paths that do not exist yet cannot be inputs.
pub fn refuse_overwrites(inputs: &[(&str, PathBuf)], outputs: &[(&str, PathBuf)]) -> Result<()> {
    let inputs: Vec<_> = inputs
        .iter()
        .filter_map(|(option, p)| identity(p).map(|id| (id, option, p)))
        .collect();
    for (option, out) in outputs {
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

/// The output paths that are given, each checked to have an existing folder.
pub fn check_outputs<'a>(outputs: &[(&'a Option<PathBuf>, &str)]) -> Result<Vec<Option<&'a Path>>> {
    outputs
        .iter()
        .map(|(path, option)| path.as_deref().map(|p| check_output(p, option)).transpose())
        .collect()
}

/// An output path whose folder exists.
pub fn check_output<'a>(path: &'a Path, option: &str) -> Result<&'a Path> {
    let parent = path.parent().filter(|p| !p.as_os_str().is_empty());
    if let Some(dir) = parent
        && !dir.is_dir()
    {
        return Err(Error::param(
            option,
            format!("{}: folder {} does not exist", path.display(), dir.display()),
        ));
    }
    Ok(path)
}

/// What a run reads and writes, each file with the option (or field)
/// that names it: `check` refuses an output that is an input.
#[derive(Default)]
pub struct Files {
    pub inputs: Vec<(&'static str, PathBuf)>,
    pub outputs: Vec<(&'static str, PathBuf)>,
}

impl Files {
    pub fn input(&mut self, option: &'static str, path: &Option<PathBuf>) {
        if let Some(p) = path {
            self.inputs.push((option, p.clone()));
        }
    }

    /// A mesh and the files it names (MTL files, glTF buffers).
    pub fn mesh(&mut self, option: &'static str, path: &Option<PathBuf>) {
        if let Some(p) = path {
            self.inputs.push((option, p.clone()));
            let named = penumbra::scene::companion_files(p);
            self.inputs.extend(named.into_iter().map(|f| (option, f)));
        }
    }

    /// A scene file and every file it names.
    pub fn scene(&mut self, path: &Option<PathBuf>) {
        if let Some(p) = path {
            self.inputs.push(("--scene", p.clone()));
            let named = penumbra::scene::referenced_files(p, crate::args::data_dir().as_deref());
            self.inputs.extend(named.into_iter().map(|f| ("--scene", f)));
        }
    }

    pub fn output(&mut self, option: &'static str, path: &Option<PathBuf>) {
        if let Some(p) = path {
            self.outputs.push((option, p.clone()));
        }
    }

    /// An output that is a file per frame where its name holds `{}`.
    pub fn frames(&mut self, option: &'static str, path: &Option<PathBuf>, frames: u32) {
        if let Some(out) = path {
            let all: Vec<PathBuf> = (0..frames).filter_map(|i| frame_path(out, i)).collect();
            if all.is_empty() {
                self.output(option, path);
            }
            all.into_iter().for_each(|p| self.output(option, &Some(p)));
        }
    }

    /// Refuses an output that is one of the inputs (`refuse_overwrites`).
    pub fn check(&self) -> Result<()> {
        refuse_overwrites(&self.inputs, &self.outputs)
    }
}

/// An output folder option (`--out DIR` of sweep and bench): refused before
/// any work when its parent does not exist.
pub fn check_out_folder(dir: &Path, option: &str) -> Result<()> {
    match dir.parent().filter(|p| !p.as_os_str().is_empty()) {
        Some(parent) if !parent.is_dir() => Err(Error::param(
            option,
            format!("folder {} does not exist", parent.display()),
        )),
        _ => Ok(()),
    }
}

/// Creates the output folder `dir` if it is missing (its parent exists:
/// `check_out_folder`).
pub fn make_out_folder(dir: &Path) -> Result<()> {
    if !dir.is_dir() {
        std::fs::create_dir(dir).map_err(|e| Error::file(dir, "", format!("cannot create the folder: {e}")))?;
    }
    Ok(())
}
