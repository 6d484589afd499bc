//! Users' animations: a mesh whose vertices a file moves with time (a mesh
//! sequence, `scene::sequence`; a glTF clip with skins or morph targets,
//! `scene::gltf::rig`), behind one interface so that PRT and every other
//! method consume them as they do the built-in animations
//! (`animated::Animation::positions_at`).

use glam::Vec3;
use serde::Serialize;

/// Vertex positions as a function of time, over a fixed topology.
pub trait Deformation: Send + Sync + std::fmt::Debug {
    /// The number of vertices, the same at every time.
    fn vertex_count(&self) -> usize;
    /// Positions at `seconds` (clamped to the clip) into `out`.
    fn positions_at(&self, seconds: f32, out: &mut Vec<Vec3>);
    /// The animation's time span and its default frame count.
    fn clip(&self) -> Clip;
    /// Where the animation was read from, for reports.
    fn source(&self) -> AnimationSource;
    /// Problems met while reading that did not stop it (normalised weights...).
    fn warnings(&self) -> Vec<String> {
        Vec::new()
    }
}

/// The length of an animation and the frames it was made with: a sequence
/// of K files at `fps` spans (K - 1) / fps seconds; a glTF clip spans its
/// keyframes' times and is sampled at 30 frames per second by default.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Clip {
    /// Animation time of the first frame and the clip's length, seconds.
    pub start: f32,
    /// Seconds from the first frame to the last (0 for a single frame).
    pub duration: f32,
    /// Frames played by default.
    pub frames: usize,
}

impl Clip {
    /// Frames per second a glTF clip is sampled at when `--frames` is not given.
    pub const DEFAULT_FPS: f32 = 30.0;

    /// The time between frames when `frames` sample the clip evenly, its
    /// first and last keyframes included (one frame: its start).
    pub fn spacing(&self, frames: usize) -> f32 {
        if frames <= 1 || self.duration <= 0.0 {
            // A one-frame clip has no time to spread; any positive step plays it.
            return 1.0 / Self::DEFAULT_FPS;
        }
        self.duration / (frames - 1) as f32
    }
}

/// Where an animation comes from (`prt --json`'s `animation`).
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum AnimationSource {
    /// `--animated cloth|character`.
    BuiltIn {
        /// `cloth` or `character`.
        name: String,
    },
    /// `--mesh-sequence`: the files in frame order and their frame rate.
    Sequence {
        /// The pattern as given.
        pattern: String,
        /// How many files (frames) it matched.
        files: usize,
        /// The first file's path (frame 0, the rest pose).
        first: String,
        /// The last file's path.
        last: String,
        /// Frames per second: frame k is at k / fps seconds.
        fps: f32,
    },
    /// A glTF file's animation clip (`name`, its index), sampled in time;
    /// what it moves.
    Gltf {
        /// The file's path.
        file: String,
        /// The clip's index in the file's `animations`.
        animation: Option<usize>,
        /// The clip's name, where the file gives one.
        name: Option<String>,
        /// Vertices of primitives with a skin.
        skinned_vertices: usize,
        /// Vertices of primitives with morph targets.
        morphed_vertices: usize,
        /// Joints of all its skins together.
        joints: usize,
        /// The most morph targets of any one primitive.
        morph_targets: usize,
        /// The clip's animation channels (one animated property of one
        /// node each).
        channels: usize,
    },
}
