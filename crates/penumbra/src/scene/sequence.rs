//! Mesh sequences: one mesh file per frame, all of one topology — the form
//! cloth and skin simulators export (`prt --mesh-sequence 'frames/*.obj'`).
//!
//! The pattern's file name may hold `*` (any run of characters) and `?`
//! (one character); its folder is literal. Files are taken in natural order
//! (`f2` before `f10`), and where every name numbers its frame, the numbers
//! must step evenly, so that a frame missing from the export is an error
//! naming it rather than a jump in the animation. Every frame must have the
//! first one's vertex count and triangles (same indices, same order): the
//! first differing frame is named with what differs. Frame 0 is the rest
//! pose. Between frames, positions are interpolated linearly.

use std::cmp::Ordering;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::Vec3;
use rayon::prelude::*;

use super::animated::Animation;
use super::deform::{AnimationSource, Clip, Deformation};
use super::mesh_file::load_mesh;
use crate::error::{Error, Result};

/// The option a pattern comes from, in messages.
const OPTION: &str = "--mesh-sequence";

/// A loaded sequence: positions per frame over one triangle list.
#[derive(Debug, Clone)]
pub struct MeshSequence {
    /// The pattern as given (`--mesh-sequence`).
    pub pattern: String,
    /// The files it matched, in frame order.
    pub files: Vec<PathBuf>,
    /// Each frame's vertex positions, all in frame 0's frame (`origin`).
    pub frames: Vec<Vec<Vec3>>,
    /// Frame 0's triangles, which every frame shares.
    pub triangles: Vec<[u32; 3]>,
    /// Where frame 0's frame (every frame's) is in world coordinates.
    pub origin: glam::DVec3,
    /// Frames per second: frame k is at time k / fps.
    pub fps: f32,
}

/// `mesh`'s positions in the frame whose origin is `origin`.
fn in_frame(mesh: &crate::scene::Mesh, origin: glam::DVec3) -> Vec<Vec3> {
    let shift = mesh.origin - origin;
    match shift == glam::DVec3::ZERO {
        true => mesh.positions.clone(),
        false => mesh
            .positions
            .iter()
            .map(|p| (p.as_dvec3() + shift).as_vec3())
            .collect(),
    }
}

impl MeshSequence {
    /// Reads every file `pattern` matches, checks their topology and
    /// numbering (errors name the option, the file and what differs).
    pub fn load(pattern: &str, fps: f32) -> Result<MeshSequence> {
        if !(fps.is_finite() && fps > 0.0) {
            return Err(Error::param("--sequence-fps", format!("must be positive, got {fps}")));
        }
        let files = expand(pattern)?;
        check_numbering(&files)?;
        let meshes: Vec<_> = files.par_iter().map(|f| load_mesh(f)).collect::<Result<_>>()?;
        let first = &meshes[0];
        for (k, (mesh, file)) in meshes.iter().zip(&files).enumerate().skip(1) {
            if let Some(what) =
                topology_difference(&first.positions, &first.triangles, &mesh.positions, &mesh.triangles)
            {
                return Err(Error::param(
                    OPTION,
                    format!(
                        "frame {k} ({}) does not have frame 0's topology ({}): {what}",
                        file.display(),
                        files[0].display()
                    ),
                ));
            }
        }
        let triangles = first.triangles.clone();
        Ok(MeshSequence {
            origin: first.origin,
            pattern: pattern.into(),
            // One frame for every frame: frame 0's (`scene::frame`), so a
            // far-off sequence moving across a grid line stays one model.
            frames: meshes.iter().map(|m| in_frame(m, first.origin)).collect(),
            files,
            triangles,
            fps,
        })
    }

    /// The sequence as an animation named `name`.
    pub fn into_animation(self, name: &str) -> Animation {
        let triangles = self.triangles.clone();
        Animation::user(name, triangles, Arc::new(self))
    }
}

impl Deformation for MeshSequence {
    fn vertex_count(&self) -> usize {
        self.frames[0].len()
    }

    fn positions_at(&self, seconds: f32, out: &mut Vec<Vec3>) {
        out.clear();
        let last = self.frames.len() - 1;
        let s = (seconds * self.fps).clamp(0.0, last as f32);
        let nearest = s.round();
        // A frame's own time gives its file's positions bit for bit (the
        // time is a sum of float steps, so "exactly" has a tolerance).
        if (s - nearest).abs() < 1e-3 {
            out.extend_from_slice(&self.frames[nearest as usize]);
            return;
        }
        let k = (s.floor() as usize).min(last - 1);
        let w = s - k as f32;
        let (a, b) = (&self.frames[k], &self.frames[k + 1]);
        out.extend(a.iter().zip(b).map(|(a, b)| a.lerp(*b, w)));
    }

    fn clip(&self) -> Clip {
        Clip {
            start: 0.0,
            duration: (self.frames.len() - 1) as f32 / self.fps,
            frames: self.frames.len(),
        }
    }

    fn source(&self) -> AnimationSource {
        let name = |p: &PathBuf| p.display().to_string();
        AnimationSource::Sequence {
            pattern: self.pattern.clone(),
            files: self.files.len(),
            first: name(&self.files[0]),
            last: name(&self.files[self.files.len() - 1]),
            fps: self.fps,
        }
    }
}

/// What makes a frame's topology differ from the first's, if anything.
pub fn topology_difference(p0: &[Vec3], t0: &[[u32; 3]], p: &[Vec3], t: &[[u32; 3]]) -> Option<String> {
    if p.len() != p0.len() {
        return Some(format!("{} vertices, frame 0 has {}", p.len(), p0.len()));
    }
    if t.len() != t0.len() {
        return Some(format!("{} triangles, frame 0 has {}", t.len(), t0.len()));
    }
    let (i, (a, b)) = t.iter().zip(t0).enumerate().find(|(_, (a, b))| a != b)?;
    Some(format!("triangle {i} has vertex indices {a:?}, frame 0's has {b:?}"))
}

/// The files `pattern` matches, in natural order; an error names a missing
/// folder or a pattern that matches nothing.
pub fn expand(pattern: &str) -> Result<Vec<PathBuf>> {
    let path = Path::new(pattern);
    let wild = |s: &str| s.contains(['*', '?']);
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let dir = match path.parent() {
        Some(d) if d.as_os_str().is_empty() => Path::new("."),
        Some(d) => d,
        None => Path::new("."),
    };
    if wild(&dir.to_string_lossy()) {
        return Err(Error::param(
            OPTION,
            format!("'{pattern}': wildcards are read in the file name only, not in its folder"),
        ));
    }
    if name.is_empty() {
        return Err(Error::param(OPTION, format!("'{pattern}' names no file")));
    }
    let entries = std::fs::read_dir(dir).map_err(|e| {
        Error::param(
            OPTION,
            format!("'{pattern}': cannot read the folder {}: {e}", dir.display()),
        )
    })?;
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok())
        .filter(|e| e.file_type().is_ok_and(|t| !t.is_dir()))
        .filter(|e| matches(name.as_bytes(), e.file_name().to_string_lossy().as_bytes()))
        .map(|e| dir.join(e.file_name()))
        .collect();
    if files.is_empty() {
        return Err(Error::param(
            OPTION,
            format!("'{pattern}' matches no file in {}", dir.display()),
        ));
    }
    files.sort_by(|a, b| natural_cmp(&a.to_string_lossy(), &b.to_string_lossy()));
    Ok(files)
}

/// Whether `name` matches the glob `pattern` (`*`, `?`; byte-wise).
fn matches(pattern: &[u8], name: &[u8]) -> bool {
    // Iterative with one backtrack point: the last `*` seen.
    let (mut p, mut n) = (0, 0);
    let mut star: Option<(usize, usize)> = None;
    while n < name.len() {
        match pattern.get(p) {
            Some(b'*') => {
                star = Some((p, n));
                p += 1;
            }
            Some(&c) if c == b'?' || c == name[n] => {
                p += 1;
                n += 1;
            }
            _ => match star {
                Some((sp, sn)) => {
                    p = sp + 1;
                    n = sn + 1;
                    star = Some((sp, sn + 1));
                }
                None => return false,
            },
        }
    }
    pattern[p..].iter().all(|&c| c == b'*')
}

/// Natural order: runs of digits compare as numbers, the rest as text.
pub fn natural_cmp(a: &str, b: &str) -> Ordering {
    let (mut a, mut b) = (a.as_bytes(), b.as_bytes());
    loop {
        match (a.first(), b.first()) {
            (None, None) => return Ordering::Equal,
            (None, _) => return Ordering::Less,
            (_, None) => return Ordering::Greater,
            (Some(x), Some(y)) if x.is_ascii_digit() && y.is_ascii_digit() => {
                let run = |s: &[u8]| s.iter().take_while(|c| c.is_ascii_digit()).count();
                let (da, db) = (&a[..run(a)], &b[..run(b)]);
                let trim = |d: &[u8]| {
                    let z = d.iter().take_while(|&&c| c == b'0').count();
                    d[z..].to_vec()
                };
                let (ta, tb) = (trim(da), trim(db));
                let order = ta.len().cmp(&tb.len()).then(ta.cmp(&tb)).then(da.len().cmp(&db.len()));
                if order != Ordering::Equal {
                    return order;
                }
                a = &a[da.len()..];
                b = &b[db.len()..];
            }
            (Some(x), Some(y)) => {
                if x != y {
                    return x.cmp(y);
                }
                a = &a[1..];
                b = &b[1..];
            }
        }
    }
}

/// The frame number of a file: the last run of digits in its name.
fn frame_number(path: &Path) -> Option<u64> {
    let name = path.file_name()?.to_string_lossy().into_owned();
    let end = name.rfind(|c: char| c.is_ascii_digit())? + 1;
    let start = name[..end].rfind(|c: char| !c.is_ascii_digit()).map_or(0, |i| i + 1);
    name[start..end].parse().ok()
}

/// Where every file numbers its frame, the numbers must step evenly (by
/// the smallest step between neighbours): a gap is a missing frame, named.
fn check_numbering(files: &[PathBuf]) -> Result<()> {
    let Some(numbers) = files.iter().map(|f| frame_number(f)).collect::<Option<Vec<u64>>>() else {
        return Ok(());
    };
    let Some(step) = numbers.windows(2).filter(|w| w[1] > w[0]).map(|w| w[1] - w[0]).min() else {
        return Ok(());
    };
    for (i, w) in numbers.windows(2).enumerate() {
        if w[1] != w[0] + step {
            let missing = w[0] + step;
            return Err(Error::param(
                OPTION,
                format!(
                    "frame number {missing} is missing: {} is followed by {} (the frames step by {step})",
                    files[i].display(),
                    files[i + 1].display()
                ),
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn globs_and_natural_order() {
        assert!(matches(b"f*.obj", b"f10.obj"));
        assert!(matches(b"f?.obj", b"f1.obj"));
        assert!(!matches(b"f?.obj", b"f10.obj"));
        assert!(matches(b"*", b""));
        assert!(!matches(b"*.obj", b"a.ply"));
        assert!(matches(b"a*b*c", b"axxbyyc"));
        let mut v = vec!["f10.obj", "f2.obj", "f1.obj", "f02.obj"];
        v.sort_by(|a, b| natural_cmp(a, b));
        assert_eq!(v, ["f1.obj", "f2.obj", "f02.obj", "f10.obj"]);
    }

    #[test]
    fn numbers_must_step_evenly() {
        let f = |names: &[&str]| names.iter().map(PathBuf::from).collect::<Vec<_>>();
        assert!(check_numbering(&f(&["a0.obj", "a1.obj", "a2.obj"])).is_ok());
        assert!(check_numbering(&f(&["a0.obj", "a5.obj", "a10.obj"])).is_ok());
        let e = check_numbering(&f(&["a0.obj", "a1.obj", "a3.obj"])).unwrap_err();
        assert!(e.to_string().contains("frame number 2 is missing"), "{e}");
        assert_eq!(frame_number(Path::new("x/flag-007.obj")), Some(7));
    }
}
