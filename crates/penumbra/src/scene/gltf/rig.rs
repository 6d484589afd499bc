//! A glTF file's animation (glTF 2.0 sections 3.7.2.2 morph targets,
//! 3.7.3 skins, 3.11 animations): node transforms and morph weights sampled
//! from one animation clip at any time, applied to every primitive by morph
//! targets then linear blend skinning,
//!
//!   p = sum_i w_i (G(joint_i) IBM_i) (base + sum_t m_t target_t),
//!
//! or, for a mesh without a skin, its node's global transform (a skinned
//! mesh's own node transform is ignored, as glTF says).
//!
//! Read strictly, every problem named by its field: joint indices past the
//! skin's joints, negative or all-zero weights, keyframe times that are not
//! increasing, outputs of the wrong count, matrices or values that are not
//! finite. Weights that do not sum to 1 are normalised (a warning says how
//! many vertices); a skin without inverse bind matrices takes identities.

use ::gltf::accessor::Dimensions;
use ::gltf::animation::{Interpolation, Property};
use ::gltf::{Primitive, Semantic};
use glam::{DMat4, DQuat, DVec3, Mat4, Vec3};

use super::accessor;
use super::nodes::{Instance, local_transform};
use super::{Reader, Result};
use crate::error::Error;
use crate::scene::animated::Animation;
use crate::scene::deform::{AnimationSource, Clip, Deformation};

/// One primitive's part of the mesh and what moves it.
#[derive(Debug, Clone)]
pub struct Piece {
    node: Option<usize>,
    skin: Option<usize>,
    /// Its first vertex in the mesh and its positions as the file holds them.
    first: usize,
    base: Vec<Vec3>,
    /// Position displacements per morph target (empty: the target has none).
    targets: Vec<Vec<Vec3>>,
    /// Morph weights where no animation sets them (the node's, else the mesh's).
    weights: Vec<f32>,
    /// Per vertex, `influences` (joint, weight) pairs, weights normalised.
    joints: Vec<u32>,
    joint_weights: Vec<f32>,
    influences: usize,
}

/// A node's local transform: a matrix (which glTF does not animate) or
/// translation, rotation and scale.
#[derive(Debug, Clone, Copy)]
enum Local {
    Matrix(DMat4),
    Trs(DVec3, DQuat, DVec3),
}

impl Local {
    fn matrix(&self) -> DMat4 {
        match *self {
            Local::Matrix(m) => m,
            Local::Trs(t, r, s) => DMat4::from_scale_rotation_translation(s, r, t),
        }
    }
}

#[derive(Debug, Clone)]
struct Skin {
    joints: Vec<usize>,
    inverse_bind: Vec<DMat4>,
}

/// One animated property of one node: keyframe times and values
/// (`width` per key, three times that for cubic splines: in-tangent,
/// value, out-tangent).
#[derive(Debug, Clone)]
struct Channel {
    node: usize,
    property: Property,
    interpolation: Interpolation,
    times: Vec<f32>,
    values: Vec<f32>,
    width: usize,
}

impl Channel {
    /// The channel's value at `t` (clamped to its keys) into `out`.
    fn sample(&self, t: f32, out: &mut [f64]) {
        let w = self.width;
        let cubic = self.interpolation == Interpolation::CubicSpline;
        let key = |k: usize, c: usize| {
            let at = if cubic { (3 * k + 1) * w + c } else { k * w + c };
            self.values[at] as f64
        };
        let n = self.times.len();
        let k = self.times.partition_point(|&x| x <= t);
        if k == 0 || k == n || self.interpolation == Interpolation::Step {
            let k = k.saturating_sub(1).min(n - 1);
            (0..w).for_each(|c| out[c] = key(k, c));
            return;
        }
        let (k0, k1) = (k - 1, k);
        let dt = (self.times[k1] - self.times[k0]) as f64;
        let u = if dt > 0.0 {
            (t - self.times[k0]) as f64 / dt
        } else {
            0.0
        };
        match self.interpolation {
            Interpolation::CubicSpline => {
                // Hermite (glTF 2.0 appendix C): out-tangent of k0, in-tangent of k1.
                let (u2, u3) = (u * u, u * u * u);
                let b = |c: usize| self.values[(3 * k0 + 2) * w + c] as f64 * dt;
                let a = |c: usize| self.values[(3 * k1) * w + c] as f64 * dt;
                for (c, o) in out.iter_mut().enumerate().take(w) {
                    *o = (2.0 * u3 - 3.0 * u2 + 1.0) * key(k0, c)
                        + (u3 - 2.0 * u2 + u) * b(c)
                        + (-2.0 * u3 + 3.0 * u2) * key(k1, c)
                        + (u3 - u2) * a(c);
                }
            }
            _ if self.property == Property::Rotation => {
                let q = |k| DQuat::from_xyzw(key(k, 0), key(k, 1), key(k, 2), key(k, 3)).normalize();
                let r = q(k0).slerp(q(k1), u);
                out[..4].copy_from_slice(&r.to_array());
            }
            _ => (0..w).for_each(|c| out[c] = key(k0, c) * (1.0 - u) + key(k1, c) * u),
        }
    }
}

/// A file's meshes with one animation clip.
#[derive(Debug, Clone)]
pub struct Rig {
    file: String,
    name: String,
    animation: usize,
    animation_name: Option<String>,
    vertex_count: usize,
    pub(super) triangles: Vec<[u32; 3]>,
    pieces: Vec<Piece>,
    parents: Vec<Option<usize>>,
    /// Nodes, parents before children.
    order: Vec<usize>,
    locals: Vec<Local>,
    skins: Vec<Skin>,
    channels: Vec<Channel>,
    start: f32,
    end: f32,
    warnings: Vec<String>,
}

impl Rig {
    pub fn into_animation(self) -> Animation {
        let (name, triangles) = (self.name.clone(), self.triangles.clone());
        Animation::user(&name, triangles, std::sync::Arc::new(self))
    }

    /// Global node transforms and animated morph weights at time `t`.
    fn pose(&self, t: f32) -> (Vec<DMat4>, Vec<Option<Vec<f64>>>) {
        let mut locals = self.locals.clone();
        let mut weights: Vec<Option<Vec<f64>>> = vec![None; locals.len()];
        let mut v = [0.0f64; 4];
        for ch in &self.channels {
            if ch.property == Property::MorphTargetWeights {
                let mut w = vec![0.0; ch.width];
                ch.sample(t, &mut w);
                weights[ch.node] = Some(w);
                continue;
            }
            ch.sample(t, &mut v);
            if let Local::Trs(tr, r, s) = &mut locals[ch.node] {
                match ch.property {
                    Property::Translation => *tr = DVec3::new(v[0], v[1], v[2]),
                    Property::Scale => *s = DVec3::new(v[0], v[1], v[2]),
                    _ => *r = DQuat::from_xyzw(v[0], v[1], v[2], v[3]).normalize(),
                }
            }
        }
        let mut global = vec![DMat4::IDENTITY; locals.len()];
        for &n in &self.order {
            let parent = self.parents[n].map_or(DMat4::IDENTITY, |p| global[p]);
            global[n] = parent * locals[n].matrix();
        }
        (global, weights)
    }

    /// Skinned positions of every vertex at `t` (`Deformation::positions_at`).
    fn positions(&self, t: f32, out: &mut Vec<Vec3>) {
        let t = t.clamp(self.start, self.end);
        let (global, weights) = self.pose(t);
        out.clear();
        out.resize(self.vertex_count, Vec3::ZERO);
        for piece in &self.pieces {
            let animated = piece.node.and_then(|n| weights[n].as_deref());
            let morph: Vec<f32> = match animated {
                Some(w) => w.iter().map(|&x| x as f32).collect(),
                None => piece.weights.clone(),
            };
            let joints: Vec<Mat4> = match piece.skin {
                Some(s) => {
                    let skin = &self.skins[s];
                    skin.joints
                        .iter()
                        .zip(&skin.inverse_bind)
                        .map(|(&j, ibm)| (global[j] * *ibm).as_mat4())
                        .collect()
                }
                None => Vec::new(),
            };
            let node = piece.node.map_or(DMat4::IDENTITY, |n| global[n]).as_mat4();
            let k = piece.influences;
            for (i, (o, b)) in out[piece.first..piece.first + piece.base.len()]
                .iter_mut()
                .zip(&piece.base)
                .enumerate()
            {
                let mut p = *b;
                for (m, target) in morph.iter().zip(&piece.targets) {
                    if *m != 0.0 && !target.is_empty() {
                        p += *m * target[i];
                    }
                }
                *o = if piece.skin.is_some() {
                    (0..k)
                        .map(|c| {
                            let w = piece.joint_weights[i * k + c];
                            if w == 0.0 {
                                return Vec3::ZERO;
                            }
                            w * joints[piece.joints[i * k + c] as usize].transform_point3(p)
                        })
                        .sum()
                } else {
                    node.transform_point3(p)
                };
            }
        }
    }
}

impl Deformation for Rig {
    fn vertex_count(&self) -> usize {
        self.vertex_count
    }

    fn positions_at(&self, seconds: f32, out: &mut Vec<Vec3>) {
        self.positions(seconds, out)
    }

    fn clip(&self) -> Clip {
        let duration = self.end - self.start;
        Clip {
            start: self.start,
            duration,
            frames: (duration * Clip::DEFAULT_FPS).round() as usize + 1,
        }
    }

    fn warnings(&self) -> Vec<String> {
        self.warnings.clone()
    }

    fn source(&self) -> AnimationSource {
        let skinned = self
            .pieces
            .iter()
            .filter(|p| p.skin.is_some())
            .map(|p| p.base.len())
            .sum();
        let morphed = self
            .pieces
            .iter()
            .filter(|p| !p.targets.is_empty())
            .map(|p| p.base.len())
            .sum();
        AnimationSource::Gltf {
            file: self.file.clone(),
            animation: Some(self.animation),
            name: self.animation_name.clone(),
            skinned_vertices: skinned,
            morphed_vertices: morphed,
            joints: self.skins.iter().map(|s| s.joints.len()).sum(),
            morph_targets: self.pieces.iter().map(|p| p.targets.len()).max().unwrap_or(0),
            channels: self.channels.len(),
        }
    }
}

impl Reader<'_> {
    fn fail(&self, field: impl Into<String>, problem: impl Into<String>) -> Error {
        Error::file(self.path, field, problem)
    }

    /// A float accessor's values, its problems named by `field`.
    fn floats(&mut self, field: &str, a: &::gltf::Accessor, dimensions: Dimensions) -> Result<Vec<f32>> {
        let path = self.path;
        let buffer = self.buffer_of(a).map_err(|e| Error::file(path, field, e))?;
        accessor::floats(a, buffer, dimensions).map_err(|e| Error::file(path, field, e))
    }

    fn vec3s(&mut self, field: &str, a: &::gltf::Accessor) -> Result<Vec<Vec3>> {
        let path = self.path;
        let buffer = self.buffer_of(a).map_err(|e| Error::file(path, field, e))?;
        let v = accessor::vec3(a, buffer).map_err(|e| Error::file(path, field, e))?;
        if let Some(i) = v.iter().position(|p| !p.is_finite()) {
            return Err(self.fail(field, format!("element {i} is not finite ({})", v[i])));
        }
        Ok(v)
    }

    /// What moves primitive `p` of `instance` (whose vertices start at
    /// `first`): its morph targets and, under a skin, joints and weights.
    pub(super) fn piece(
        &mut self,
        field: &str,
        instance: &Instance,
        p: &Primitive,
        first: usize,
        base: Vec<Vec3>,
    ) -> Result<Piece> {
        let n = base.len();
        let mut targets = Vec::new();
        for (k, target) in p.morph_targets().enumerate() {
            let f = format!("{field} targets[{k}].POSITION");
            let deltas = match target.positions() {
                Some(a) => self.vec3s(&f, &a)?,
                None => Vec::new(),
            };
            if !deltas.is_empty() && deltas.len() != n {
                return Err(self.fail(f, format!("has {} elements, POSITION has {n}", deltas.len())));
            }
            targets.push(deltas);
        }
        let mesh = self
            .document
            .meshes()
            .nth(instance.mesh)
            .expect("instances name meshes of the document");
        let node = instance.node.and_then(|i| self.document.nodes().nth(i));
        let (weights, from) = match (node.as_ref().and_then(|n| n.weights()), mesh.weights()) {
            (Some(w), _) => (w.to_vec(), format!("nodes[{}].weights", instance.node.unwrap_or(0))),
            (None, Some(w)) => (w.to_vec(), format!("meshes[{}].weights", instance.mesh)),
            (None, None) => (vec![0.0; targets.len()], String::new()),
        };
        if weights.len() != targets.len() || weights.iter().any(|w| !w.is_finite()) {
            return Err(self.fail(
                from,
                format!(
                    "{} weights (finite?) for {} morph targets of {field}",
                    weights.len(),
                    targets.len()
                ),
            ));
        }
        let mut piece = Piece {
            node: instance.node,
            skin: instance.skin,
            first,
            base,
            targets,
            weights,
            joints: Vec::new(),
            joint_weights: Vec::new(),
            influences: 0,
        };
        if let Some(skin) = instance.skin {
            self.influences(field, p, skin, &mut piece)?;
        }
        Ok(piece)
    }

    /// JOINTS_n and WEIGHTS_n (every set) of a skinned primitive, checked
    /// against the skin's joints, weights normalised per vertex.
    fn influences(&mut self, field: &str, p: &Primitive, skin: usize, piece: &mut Piece) -> Result<()> {
        let n = piece.base.len();
        let joint_count = self.document.skins().nth(skin).map_or(0, |s| s.joints().len());
        let mut sets: Vec<(Vec<[u32; 4]>, Vec<f32>)> = Vec::new();
        for set in 0.. {
            let (j, w) = (p.get(&Semantic::Joints(set)), p.get(&Semantic::Weights(set)));
            let (j, w) = match (j, w) {
                (None, None) => break,
                (Some(j), Some(w)) => (j, w),
                _ => {
                    return Err(self.fail(field, format!("has only one of JOINTS_{set} and WEIGHTS_{set}")));
                }
            };
            let fj = format!("{field} JOINTS_{set}");
            let path = self.path;
            let buffer = self.buffer_of(&j).map_err(|e| Error::file(path, &fj, e))?;
            let joints = accessor::joints(&j, buffer).map_err(|e| Error::file(path, &fj, e))?;
            let weights = self.floats(&format!("{field} WEIGHTS_{set}"), &w, Dimensions::Vec4)?;
            if joints.len() != n || weights.len() != 4 * n {
                return Err(self.fail(
                    field,
                    format!(
                        "JOINTS_{set} has {} elements and WEIGHTS_{set} {}; POSITION has {n}",
                        joints.len(),
                        weights.len() / 4
                    ),
                ));
            }
            sets.push((joints, weights));
        }
        if sets.is_empty() {
            return Err(self.fail(
                field,
                format!("is drawn with skins[{skin}] but has no JOINTS_0 and WEIGHTS_0"),
            ));
        }
        let k = 4 * sets.len();
        piece.influences = k;
        piece.joints = vec![0; n * k];
        piece.joint_weights = vec![0.0; n * k];
        let mut normalised = 0usize;
        for v in 0..n {
            let mut sum = 0.0f64;
            for (s, (joints, weights)) in sets.iter().enumerate() {
                for c in 0..4 {
                    let (j, w) = (joints[v][c], weights[4 * v + c]);
                    if w < 0.0 {
                        return Err(self.fail(
                            format!("{field} WEIGHTS_{s}"),
                            format!("vertex {v} has a negative weight ({w})"),
                        ));
                    }
                    if w > 0.0 && j as usize >= joint_count {
                        return Err(self.fail(
                            format!("{field} JOINTS_{s}"),
                            format!("vertex {v}: joint {j} is out of range (skins[{skin}] has {joint_count} joints)"),
                        ));
                    }
                    piece.joints[v * k + 4 * s + c] = if w > 0.0 { j } else { 0 };
                    piece.joint_weights[v * k + 4 * s + c] = w;
                    sum += w as f64;
                }
            }
            if sum <= 1e-6 {
                return Err(self.fail(
                    format!("{field} WEIGHTS_0"),
                    format!("vertex {v}'s weights sum to {sum}; a skinned vertex needs a joint"),
                ));
            }
            if (sum - 1.0).abs() > 2e-3 {
                normalised += 1;
            }
            for w in &mut piece.joint_weights[v * k..(v + 1) * k] {
                *w = (*w as f64 / sum) as f32;
            }
        }
        if normalised > 0 {
            self.out.warn(format!(
                "{field}: the weights of {normalised} vertices do not sum to 1; normalised"
            ));
        }
        Ok(())
    }

    /// The animation clip `selector` names (index or name; default the
    /// first), with the nodes, skins and pieces it moves; None for a file
    /// without animations when none is asked for.
    pub(super) fn rig(&mut self, selector: Option<&str>) -> Result<Option<Rig>> {
        let document = self.document;
        let count = document.animations().len();
        let names: Vec<String> = document
            .animations()
            .map(|a| a.name().map_or_else(|| a.index().to_string(), str::to_string))
            .collect();
        let animation = match selector {
            None if count == 0 => return Ok(None),
            None => document.animations().next(),
            Some(s) => document
                .animations()
                .find(|a| a.name() == Some(s))
                .or_else(|| s.parse::<usize>().ok().and_then(|i| document.animations().nth(i))),
        };
        let Some(animation) = animation else {
            return Err(self.fail(
                "animations",
                format!(
                    "no animation '{}' (the file has {count}: {})",
                    selector.unwrap_or(""),
                    if names.is_empty() {
                        "none".to_string()
                    } else {
                        names.join(", ")
                    }
                ),
            ));
        };
        let nodes = document.nodes().len();
        let mut parents = vec![None; nodes];
        let mut locals = Vec::with_capacity(nodes);
        for node in document.nodes() {
            for child in node.children() {
                parents[child.index()] = Some(node.index());
            }
            // Checks that the transform is finite and the rotation one.
            local_transform(self.path, &node)?;
            locals.push(match node.transform() {
                ::gltf::scene::Transform::Matrix { .. } => Local::Matrix(local_transform(self.path, &node)?),
                ::gltf::scene::Transform::Decomposed {
                    translation,
                    rotation,
                    scale,
                } => Local::Trs(
                    DVec3::from(translation.map(f64::from)),
                    DQuat::from_array(rotation.map(f64::from)).normalize(),
                    DVec3::from(scale.map(f64::from)),
                ),
            });
        }
        let order = parents_first(&parents);
        let mut skins = Vec::new();
        for skin in document.skins() {
            let joints: Vec<usize> = skin.joints().map(|j| j.index()).collect();
            let field = format!("skins[{}].inverseBindMatrices", skin.index());
            let inverse_bind = match skin.inverse_bind_matrices() {
                Some(a) => {
                    let m = self.floats(&field, &a, Dimensions::Mat4)?;
                    if m.len() != 16 * joints.len() {
                        return Err(self.fail(
                            field,
                            format!("has {} matrices for {} joints", m.len() / 16, joints.len()),
                        ));
                    }
                    m.chunks_exact(16)
                        .map(|c| DMat4::from_cols_array(&std::array::from_fn(|i| c[i] as f64)))
                        .collect()
                }
                None => vec![DMat4::IDENTITY; joints.len()],
            };
            skins.push(Skin { joints, inverse_bind });
        }
        let mut channels = Vec::new();
        let a = animation.index();
        for channel in animation.channels() {
            let sampler = channel.sampler();
            let field = format!("animations[{a}].samplers[{}]", sampler.index());
            let node = channel.target().node();
            let property = channel.target().property();
            let width = match property {
                Property::Translation | Property::Scale => 3,
                Property::Rotation => 4,
                Property::MorphTargetWeights => self
                    .pieces
                    .iter()
                    .filter(|p| p.node == Some(node.index()))
                    .map(|p| p.targets.len())
                    .max()
                    .unwrap_or(0),
            };
            if width == 0 {
                return Err(self.fail(
                    format!("animations[{a}].channels[{}]", channel.index()),
                    format!(
                        "animates the morph weights of nodes[{}], which draws no morph targets",
                        node.index()
                    ),
                ));
            }
            if matches!(locals[node.index()], Local::Matrix(_)) {
                return Err(self.fail(
                    format!("animations[{a}].channels[{}]", channel.index()),
                    format!(
                        "animates nodes[{}], which has a matrix (glTF animates only TRS nodes)",
                        node.index()
                    ),
                ));
            }
            let times = self.floats(&format!("{field}.input"), &sampler.input(), Dimensions::Scalar)?;
            if let Some(k) = times.windows(2).position(|w| w[1] < w[0]) {
                return Err(self.fail(
                    format!("{field}.input"),
                    format!(
                        "keyframe times decrease at key {} ({} after {})",
                        k + 1,
                        times[k + 1],
                        times[k]
                    ),
                ));
            }
            let dimensions = match width {
                3 => Dimensions::Vec3,
                4 if property == Property::Rotation => Dimensions::Vec4,
                _ => Dimensions::Scalar,
            };
            let values = self.floats(&format!("{field}.output"), &sampler.output(), dimensions)?;
            let interpolation = sampler.interpolation();
            let per_key = width
                * if interpolation == Interpolation::CubicSpline {
                    3
                } else {
                    1
                };
            if values.len() != per_key * times.len() {
                return Err(self.fail(
                    format!("{field}.output"),
                    format!(
                        "has {} values; {} keyframes of {per_key} ({interpolation:?}) need {}",
                        values.len(),
                        times.len(),
                        per_key * times.len()
                    ),
                ));
            }
            channels.push(Channel {
                node: node.index(),
                property,
                interpolation,
                times,
                values,
                width,
            });
        }
        let start = channels.iter().map(|c| c.times[0]).fold(f32::INFINITY, f32::min);
        let end = channels
            .iter()
            .map(|c| c.times[c.times.len() - 1])
            .fold(f32::NEG_INFINITY, f32::max);
        let (start, end) = if start.is_finite() { (start, end) } else { (0.0, 0.0) };
        let file = self.path.display().to_string();
        let stem = self
            .path
            .file_stem()
            .map_or_else(|| file.clone(), |s| s.to_string_lossy().into_owned());
        Ok(Some(Rig {
            file,
            name: stem,
            animation: a,
            animation_name: animation.name().map(str::to_string),
            vertex_count: self.out.positions.len(),
            triangles: Vec::new(),
            pieces: std::mem::take(&mut self.pieces),
            parents,
            order,
            locals,
            skins,
            channels,
            start,
            end,
            warnings: self.out.warnings.clone(),
        }))
    }
}

/// Nodes in an order where every parent comes before its children (nodes
/// in a cycle, which no scene can place, are left out).
fn parents_first(parents: &[Option<usize>]) -> Vec<usize> {
    let mut children = vec![Vec::new(); parents.len()];
    for (n, p) in parents.iter().enumerate() {
        if let Some(p) = *p {
            children[p].push(n);
        }
    }
    let mut order: Vec<usize> = (0..parents.len()).filter(|&n| parents[n].is_none()).collect();
    let mut i = 0;
    while i < order.len() {
        let n = order[i];
        order.extend(children[n].iter().copied());
        i += 1;
        if order.len() > parents.len() {
            break;
        }
    }
    order.truncate(parents.len());
    order
}
