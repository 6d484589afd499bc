//! Several independently moving objects (Kautz, Lehtinen and Aila 2004,
//! section 4 "Chess" and 4.1 "Scalability"): each object keeps its own
//! tables, hierarchy and self-shadowing (`PrtRunner`), and receives the
//! other objects' coarse approximations in its masks (`blockers`). The
//! reference is Monte Carlo ray tracing of the *whole* scene at full
//! resolution, so an error measured here includes what the inter-object
//! approximation costs.
//!
//! Roles follow the scene format: a `caster` casts (on others and itself)
//! but is not shaded, a `receiver` is shaded but casts nothing (not even on
//! itself), `both` does both.

use glam::Vec3;

use super::blockers::{BlockerTopology, InterObject, SceneBlockers};
use super::pipeline::{FrameOutput, PrtSettings};
use super::reference::{reference_transfer, relative_l2_error};
use super::runner::{PrtRunner, RayTraced, Shadows};
use crate::accel::Accel;
use crate::accel::kdtree::{KdTree, KdTreeSettings};
use crate::error::{Error, Result};
use crate::gpu::device::Device;
use crate::scene::{Role, Scene};

/// One object of a scene: its mesh and the poses its coarse level is
/// checked on (`poses[0]` the first frame's; world coordinates).
#[derive(Debug, Clone)]
pub struct ObjectSpec {
    /// The object's name, as errors and reports give it.
    pub name: String,
    /// Its triangles, indices into each pose's positions.
    pub triangles: Vec<[u32; 3]>,
    /// Its vertex positions per pose, world coordinates; at least the
    /// first frame's.
    pub poses: Vec<Vec<Vec3>>,
    /// Whether it casts shadows, is shaded, or both.
    pub role: Role,
}

struct Object {
    name: String,
    role: Role,
    runner: PrtRunner,
    topology: BlockerTopology,
    triangles: Vec<[u32; 3]>,
}

/// Transfer of several objects, frame after frame, on a device.
pub struct ObjectsRunner {
    objects: Vec<Object>,
    inter: InterObject,
    shadows: Shadows,
    reference: RayTraced,
    tolerance: f32,
}

/// Per object, the frame's error against ray tracing of the whole scene:
/// (mean relative L2 error, vertices counted, vertices skipped as dark);
/// None for objects that are not shaded.
pub type ObjectErrors = Vec<Option<(f64, usize, usize)>>;

impl ObjectsRunner {
    /// Builds every object's tables and hierarchy from its poses and, on a
    /// GPU, uploads them.
    pub fn new(
        device: &Device,
        specs: Vec<ObjectSpec>,
        settings: &PrtSettings,
        (shadows, reference): (Shadows, RayTraced),
        inter: InterObject,
    ) -> Result<ObjectsRunner> {
        if specs.is_empty() {
            return Err(Error::input("objects", "a scene needs at least one object"));
        }
        let mut objects = Vec::with_capacity(specs.len());
        for (k, spec) in specs.into_iter().enumerate() {
            // A receiver casts nothing, not even on itself.
            let own = match (shadows, spec.role.casts()) {
                (Shadows::On, false) => Shadows::Off,
                (s, _) => s,
            };
            let named = |e: Error| match e {
                Error::BadInput { source, field, problem } => Error::input(
                    format!("object {k} ({})", spec.name),
                    format!("{source}{}{field}: {problem}", if field.is_empty() { "" } else { " " }),
                ),
                other => other,
            };
            let runner =
                PrtRunner::new_posed(device, &spec.poses, &spec.triangles, settings, own, reference).map_err(named)?;
            let topology = BlockerTopology::new(&runner.prt().hierarchy, &spec.poses[0]);
            if !topology.fine.fits() {
                return Err(named(Error::input(
                    "mesh",
                    "a culling group's fine triangles use more than 65,536 vertices; lower `group_size`",
                )));
            }
            objects.push(Object {
                name: spec.name,
                role: spec.role,
                runner,
                topology,
                triangles: spec.triangles,
            });
        }
        Ok(ObjectsRunner {
            objects,
            inter,
            shadows,
            reference,
            tolerance: settings.hierarchy.tolerance,
        })
    }

    /// The runner of a scene's instances at frame 0 (`positions`).
    pub fn for_scene(
        device: &Device,
        scene: &Scene,
        settings: &PrtSettings,
        visibility: (Shadows, RayTraced),
        inter: InterObject,
    ) -> Result<ObjectsRunner> {
        let specs = scene
            .instances
            .iter()
            .map(|inst| ObjectSpec {
                name: inst.name.clone(),
                triangles: scene.meshes[inst.mesh].mesh.triangles.clone(),
                poses: vec![instance_positions(scene, inst, 0)],
                role: inst.role,
            })
            .collect();
        Self::new(device, specs, settings, visibility, inter)
    }

    /// Number of objects, whatever their role.
    pub fn len(&self) -> usize {
        self.objects.len()
    }

    /// Always false once built: a runner has at least one object.
    pub fn is_empty(&self) -> bool {
        self.objects.is_empty()
    }

    /// How other objects shadow each shaded one.
    pub fn inter_object(&self) -> InterObject {
        self.inter
    }

    /// Where visibility comes from (receivers-only objects cast nothing,
    /// even with shadows on).
    pub fn shadows(&self) -> Shadows {
        self.shadows
    }

    /// Rays per vertex and seed of the ray-traced reference.
    pub fn reference(&self) -> RayTraced {
        self.reference
    }

    /// Object `k`'s name, role and runner.
    pub fn object(&self, k: usize) -> (&str, Role, &PrtRunner) {
        let o = &self.objects[k];
        (&o.name, o.role, &o.runner)
    }

    /// Object `k`'s triangles (its own vertex numbering).
    pub fn triangles(&self, k: usize) -> &[[u32; 3]] {
        &self.objects[k].triangles
    }

    /// Triangles of object `k`'s far level and full mesh.
    pub fn approximation(&self, k: usize) -> (usize, usize) {
        let t = &self.objects[k].topology;
        (t.coarse.triangles(), t.fine.triangles())
    }

    /// The device the objects compute on (the first one's: they agree).
    pub fn device(&self) -> &Device {
        self.objects[0].runner.device()
    }

    /// Every object's notes (falling back to the CPU...), once each.
    pub fn notes(&self) -> Vec<String> {
        let mut notes: Vec<String> = self.objects.iter().flat_map(|o| o.runner.notes().to_vec()).collect();
        notes.dedup();
        notes
    }

    /// The shaded objects' triangles in one vertex numbering: theirs
    /// concatenated in object order (as `merge` concatenates their frames).
    pub fn shaded_triangles(&self) -> Vec<[u32; 3]> {
        let mut out = Vec::new();
        let mut first = 0u32;
        for o in self.objects.iter().filter(|o| o.role.receives()) {
            out.extend(o.triangles.iter().map(|t| t.map(|v| v + first)));
            first += o.runner.prt().vertex_count as u32;
        }
        out
    }

    /// The shaded objects' positions and frame outputs concatenated in
    /// object order (`shaded_triangles`' numbering) into `positions`, `out`.
    pub fn merge(&self, poses: &[Vec<Vec3>], outs: &[FrameOutput], positions: &mut Vec<Vec3>, out: &mut FrameOutput) {
        positions.clear();
        out.transfer.clear();
        out.radiance.clear();
        out.normals.clear();
        out.stats = Default::default();
        for ((o, p), f) in self.objects.iter().zip(poses).zip(outs) {
            if o.role.receives() {
                positions.extend_from_slice(p);
                out.transfer.extend_from_slice(&f.transfer);
                out.radiance.extend_from_slice(&f.radiance);
                out.normals.extend_from_slice(&f.normals);
                out.stats += &f.stats;
            }
        }
    }

    /// The casting objects' blockers for `positions` in `mode`.
    pub fn blockers(&self, positions: &[Vec<Vec3>], mode: InterObject) -> SceneBlockers {
        let casting: Vec<(usize, &BlockerTopology, &[Vec3])> = self
            .objects
            .iter()
            .enumerate()
            .filter(|(_, o)| o.role.casts())
            .map(|(k, o)| (k, &o.topology, positions[k].as_slice()))
            .collect();
        SceneBlockers::place(&casting, mode, self.tolerance)
    }

    /// One frame of every shaded object (`outs[k]`; others' are left
    /// empty) for `positions` (per object, world coordinates), seen from
    /// `eye`, under planar RGB SH `lighting`, other objects shadowing as
    /// the runner's `InterObject` says. Returns the GPU kernels' time.
    pub fn frame(
        &mut self,
        positions: &[Vec<Vec3>],
        eye: Option<Vec3>,
        lighting: &[f32],
        profile: bool,
        outs: &mut Vec<FrameOutput>,
    ) -> Result<Option<f64>> {
        let blockers = self.blockers(positions, self.inter);
        self.frame_with(positions, eye, lighting, profile, &blockers, outs)
    }

    /// `frame` with given blockers (`blockers(positions, mode)`): e.g. to
    /// compare inter-object modes on one pose.
    pub fn frame_with(
        &mut self,
        positions: &[Vec<Vec3>],
        eye: Option<Vec3>,
        lighting: &[f32],
        profile: bool,
        blockers: &SceneBlockers,
        outs: &mut Vec<FrameOutput>,
    ) -> Result<Option<f64>> {
        if positions.len() != self.objects.len() {
            return Err(Error::input(
                "frame",
                format!("{} poses for {} objects", positions.len(), self.objects.len()),
            ));
        }
        outs.resize_with(self.objects.len(), FrameOutput::default);
        if self.shadows == Shadows::Raytraced {
            return self.raytraced_frame(positions, eye, lighting, outs).map(|_| None);
        }
        let mut gpu: Option<f64> = None;
        for (k, (o, out)) in self.objects.iter_mut().zip(outs.iter_mut()).enumerate() {
            if !o.role.receives() {
                *out = FrameOutput::default();
                continue;
            }
            let ms = o
                .runner
                .frame_with(&positions[k], eye, lighting, profile, Some((blockers, k)), out)?;
            if let Some(ms) = ms {
                *gpu.get_or_insert(0.0) += ms;
            }
        }
        Ok(gpu)
    }

    fn raytraced_frame(
        &self,
        positions: &[Vec<Vec3>],
        eye: Option<Vec3>,
        lighting: &[f32],
        outs: &mut [FrameOutput],
    ) -> Result<()> {
        for (k, (o, out)) in self.objects.iter().zip(outs.iter_mut()).enumerate() {
            *out = FrameOutput::default();
            if o.role.receives() {
                o.runner.prt().shading_normals(&positions[k], eye, &mut out.normals);
            }
        }
        let normals: Vec<Vec<Vec3>> = outs.iter_mut().map(|o| std::mem::take(&mut o.normals)).collect();
        let reference = self.reference_transfer(positions, &normals, eye)?;
        for ((out, n), t) in outs.iter_mut().zip(normals).zip(reference) {
            let coeffs = self.objects[0].runner.prt().coeffs();
            out.radiance = t
                .chunks(coeffs)
                .map(|t| super::transfer::radiance(lighting, t))
                .collect();
            out.transfer = t;
            out.normals = n;
        }
        Ok(())
    }

    /// Monte Carlo ray-traced transfer of every shaded object (empty for
    /// the others) against the whole scene's casting objects at full
    /// resolution, for the given shading normals (per object).
    pub fn reference_transfer(
        &self,
        positions: &[Vec<Vec3>],
        normals: &[Vec<Vec3>],
        eye: Option<Vec3>,
    ) -> Result<Vec<Vec<f32>>> {
        let soup: Vec<[Vec3; 3]> = self
            .objects
            .iter()
            .enumerate()
            .filter(|(_, o)| o.role.casts())
            .flat_map(|(k, o)| o.triangles.iter().map(move |t| t.map(|i| positions[k][i as usize])))
            .collect();
        let tree = Accel::new(KdTree::from_triangles(soup, &KdTreeSettings::default())?);
        let RayTraced { rays, seed } = self.reference;
        Ok(self
            .objects
            .iter()
            .enumerate()
            .map(|(k, o)| {
                if !o.role.receives() {
                    return Vec::new();
                }
                let prt = o.runner.prt();
                let s = &prt.settings;
                let scale = prt.scale;
                reference_transfer(
                    &tree,
                    &positions[k],
                    &normals[k],
                    scale,
                    s.bands,
                    &s.brdf,
                    eye,
                    rays,
                    seed,
                )
            })
            .collect())
    }

    /// Each shaded object's error in `outs` against `reference`
    /// (`reference_transfer` for the same pose and normals).
    pub fn errors(&self, outs: &[FrameOutput], reference: &[Vec<f32>]) -> ObjectErrors {
        self.objects
            .iter()
            .zip(outs.iter().zip(reference))
            .map(|(o, (out, r))| {
                o.role.receives().then(|| {
                    let t = &o.runner.prt().tables;
                    let unoccluded = t.unoccluded.iter().map(|v| v * v).sum::<f32>().sqrt();
                    relative_l2_error(&out.transfer, r, t.coeffs, 0.01 * unoccluded)
                })
            })
            .collect()
    }
}

/// The vertex positions of `instance` at animation frame
/// `frame`: its mesh placed by its transform and motion, in the scene's frame.
pub fn instance_positions(scene: &Scene, instance: &crate::scene::Instance, frame: u32) -> Vec<Vec3> {
    let transform = instance.transform_at(frame);
    scene.meshes[instance.mesh]
        .mesh
        .positions
        .iter()
        .map(|&p| transform.apply_point(p))
        .collect()
}

/// The error over several objects: the vertex-weighted mean of theirs,
/// with the vertices counted and skipped.
pub fn pooled(errors: &ObjectErrors) -> (f64, usize, usize) {
    let (mut sum, mut counted, mut skipped) = (0.0, 0, 0);
    for &(e, c, s) in errors.iter().flatten() {
        sum += e * c as f64;
        counted += c;
        skipped += s;
    }
    (if counted > 0 { sum / counted as f64 } else { 0.0 }, counted, skipped)
}

/// The first frame's shaded geometry: with `several`, the scene's shaded
/// instances merged in instance order (`ObjectsRunner::shaded_triangles`'
/// numbering); otherwise its first mesh at time `start`.
pub fn shaded_pose(several: bool, scene: &Scene, start: f32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    if several {
        let world = scene.world_mesh(Role::receives);
        return (world.positions, world.triangles);
    }
    let mesh = &scene.meshes[0];
    let mut rest = Vec::new();
    mesh.positions_at(start, &mut rest);
    (rest, mesh.mesh.triangles.clone())
}
