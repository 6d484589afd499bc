//! Animated scenes made by the project, for the hemispherical-rasterisation
//! paper's tests and tables: a draped, waving cloth (the paper's Figure 1
//! cloth has 1378 vertices and 2560 triangles; ours 1369 and 2592) and a
//! walking character built from skinned capsules (like its "Fighting Man",
//! 2978 vertices, 4806 triangles).
//!
//! Both are closed-form functions of time: frame k of an animation is
//! `positions_at(k * dt)`, deterministic on every machine, so tests,
//! benches and tables see the same geometry. The topology never changes;
//! the rest pose (t = 0) is what the hierarchy and its simplification see.

use std::f32::consts::{PI, TAU};
use std::sync::Arc;

use glam::{Mat4, Vec3};

use super::Mesh;
pub use super::deform::{AnimationSource, Clip, Deformation};
use crate::error::{Error, Result};

/// Which built-in animation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AnimatedScene {
    /// The draped, waving cloth (`cloth`).
    Cloth,
    /// The walking character of skinned capsules (`character`).
    Character,
}

impl AnimatedScene {
    /// The animation named `cloth` or `character` (`--animated`).
    pub fn parse(name: &str) -> Result<AnimatedScene> {
        match name {
            "cloth" => Ok(AnimatedScene::Cloth),
            "character" => Ok(AnimatedScene::Character),
            other => Err(Error::param(
                "animation",
                format!("unknown scene '{other}' (expected cloth or character)"),
            )),
        }
    }

    /// Its name, as `parse` reads it.
    pub fn name(self) -> &'static str {
        match self {
            AnimatedScene::Cloth => "cloth",
            AnimatedScene::Character => "character",
        }
    }

    /// The animation with its topology built.
    pub fn build(self) -> Animation {
        match self {
            AnimatedScene::Cloth => cloth(),
            AnimatedScene::Character => character(),
        }
    }
}

/// A mesh whose vertices move with time.
#[derive(Debug, Clone)]
pub struct Animation {
    /// The name reports and the mesh's one object take: `cloth`,
    /// `character`, a glTF file's stem, the name a sequence is given.
    pub name: String,
    /// The fixed topology: three vertex indices per triangle.
    pub triangles: Vec<[u32; 3]>,
    kind: Kind,
    /// A camera that frames the whole animation: (eye, target, fov degrees)
    /// (the built-in ones; a user's animation is framed like a mesh).
    pub camera: Option<(Vec3, Vec3, f32)>,
}

#[derive(Debug, Clone)]
enum Kind {
    Cloth {
        n: usize,
    },
    Character {
        rig: Rig,
    },
    /// A user's animation: a mesh sequence or a glTF clip (`scene::deform`).
    User(Arc<dyn Deformation>),
}

impl Animation {
    /// A user's animation of `triangles` (checked by the caller to index
    /// `deformation`'s vertices).
    pub fn user(name: &str, triangles: Vec<[u32; 3]>, deformation: Arc<dyn Deformation>) -> Animation {
        Animation {
            name: name.into(),
            triangles,
            kind: Kind::User(deformation),
            camera: None,
        }
    }

    /// The number of vertices, the same at every time.
    pub fn vertex_count(&self) -> usize {
        match &self.kind {
            Kind::Cloth { n } => n * n,
            Kind::Character { rig } => rig.verts.len(),
            Kind::User(d) => d.vertex_count(),
        }
    }

    /// The frames the animation was made with, if it has a length (the
    /// built-in ones are closed-form and endless).
    pub fn clip(&self) -> Option<Clip> {
        match &self.kind {
            Kind::User(d) => Some(d.clip()),
            _ => None,
        }
    }

    /// Problems met while reading a user's animation that did not stop it.
    pub fn warnings(&self) -> Vec<String> {
        match &self.kind {
            Kind::User(d) => d.warnings(),
            _ => Vec::new(),
        }
    }

    /// What the animation is, for reports (`prt --json`'s `animation`).
    pub fn source(&self) -> AnimationSource {
        match &self.kind {
            Kind::User(d) => d.source(),
            _ => AnimationSource::BuiltIn {
                name: self.name.clone(),
            },
        }
    }

    /// Vertex positions at time `t` (seconds).
    pub fn positions_at(&self, t: f32, out: &mut Vec<Vec3>) {
        out.clear();
        match &self.kind {
            Kind::Cloth { n } => cloth_positions(*n, t, out),
            Kind::Character { rig } => rig.pose(t, out),
            Kind::User(d) => d.positions_at(t, out),
        }
    }

    /// The mesh at time `t`.
    pub fn mesh_at(&self, t: f32) -> Mesh {
        let mut p = Vec::new();
        self.positions_at(t, &mut p);
        let mut m = Mesh::new(p, self.triangles.clone()).expect("animated meshes are valid");
        m.objects[0].name = self.name.clone();
        m
    }
}

// ---------------------------------------------------------------- cloth --

/// Vertices per side of the cloth grid.
pub const CLOTH_GRID: usize = 37;
/// Radius of the invisible sphere the cloth is draped over.
const SUPPORT_RADIUS: f32 = 0.55;
/// Polar angle where the cloth leaves the sphere.
const CAP_ANGLE: f32 = 1.0;

/// A 2 x 2 square cloth, draped over an invisible sphere of radius 0.55 (the
/// cap up to 57 degrees lies on it), its skirt falling away with radial
/// folds (the excess material of the circle mapped to a cone) that travel
/// around, breathe and sway in a gusting wind. 37 x 37 vertices.
pub fn cloth() -> Animation {
    let n = CLOTH_GRID;
    let mut triangles = Vec::with_capacity(2 * (n - 1) * (n - 1));
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let a = (j * n + i) as u32;
            let (b, c, d) = (a + 1, a + 1 + n as u32, a + n as u32);
            // Alternate diagonals so the folds do not follow one direction.
            if (i + j) % 2 == 0 {
                triangles.push([a, d, c]);
                triangles.push([a, c, b]);
            } else {
                triangles.push([a, d, b]);
                triangles.push([b, d, c]);
            }
        }
    }
    Animation {
        name: "cloth".into(),
        triangles,
        kind: Kind::Cloth { n },
        camera: Some((Vec3::new(1.45, 1.55, 2.1), Vec3::new(0.0, 0.05, 0.0), 45.0)),
    }
}

fn cloth_positions(n: usize, t: f32, out: &mut Vec<Vec3>) {
    let r_s = SUPPORT_RADIUS;
    let rho0 = r_s * CAP_ANGLE;
    let gamma0 = PI / 2.0 - CAP_ANGLE; // skirt direction from the downward vertical at the edge
    let gamma_inf = 0.22;
    let folds = 9.0;
    let fold_phase = 0.55 * t;
    let breathe = 1.0 + 0.3 * (2.1 * t).sin();
    let wind = Vec3::new(0.8, 0.0, 0.35).normalize() * (0.16 * (1.3 * t).sin() + 0.05 * (3.7 * t + 1.0).sin());
    for j in 0..n {
        for i in 0..n {
            let u = -1.0 + 2.0 * i as f32 / (n - 1) as f32;
            let v = -1.0 + 2.0 * j as f32 / (n - 1) as f32;
            let rho = (u * u + v * v).sqrt();
            let psi = v.atan2(u);
            let (sp, cp) = psi.sin_cos();
            if rho <= rho0 {
                let th = rho / r_s;
                out.push(Vec3::new(r_s * th.sin() * cp, r_s * th.cos(), r_s * th.sin() * sp));
                continue;
            }
            // Skirt: integrate the direction of fall along the arc length s.
            let s = rho - rho0;
            let steps = 24;
            let ds = s / steps as f32;
            let (mut radial, mut y) = (r_s * CAP_ANGLE.sin(), r_s * CAP_ANGLE.cos());
            for k in 0..steps {
                let sk = (k as f32 + 0.5) * ds;
                let g = gamma_inf + (gamma0 - gamma_inf) * (-sk / 0.35).exp();
                radial += g.sin() * ds;
                y -= g.cos() * ds;
            }
            // Radial folds (travelling, breathing) and a wind sway growing
            // with the square of the distance from the support.
            let fold = 0.085 * s * breathe * (folds * psi + fold_phase + 2.0 * s).sin();
            let ripple = 0.02 * s * (5.0 * psi - 2.6 * t + 6.0 * s).sin();
            let r = radial + fold;
            let sway = wind * (s * s);
            out.push(Vec3::new(r * cp, y + ripple, r * sp) + sway);
        }
    }
}

// ------------------------------------------------------------ character --

/// One vertex of the rig: its rest position in its part's frame and how
/// it is skinned.
#[derive(Debug, Clone, Copy)]
struct RigVertex {
    part: usize,
    local: Vec3,
    /// Weight of the part's second bone (below the joint) or, for the torso,
    /// of the chest frame.
    weight: f32,
}

#[derive(Debug, Clone)]
struct Rig {
    verts: Vec<RigVertex>,
}

/// Parts, in vertex order.
const TORSO: usize = 0;
const HEAD: usize = 1;
const ARM_L: usize = 2;
const ARM_R: usize = 3;
const LEG_L: usize = 4;
const LEG_R: usize = 5;

const TORSO_CENTRE: f32 = 1.28;
const TORSO_RADII: Vec3 = Vec3::new(0.30, 0.45, 0.19);
const SHOULDER: Vec3 = Vec3::new(0.42, 1.55, 0.0);
const HIP: Vec3 = Vec3::new(0.15, 0.72, 0.0);
const ARM: (f32, f32, f32) = (0.07, 0.32, 0.34); // radius, upper, lower
const LEG: (f32, f32, f32) = (0.10, 0.40, 0.42);

fn smoothstep(a: f32, b: f32, x: f32) -> f32 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// A walking figure of capsules and ellipsoids: a torso that leans and
/// twists (skinned between pelvis and chest), a head, and arms and legs that
/// bend at elbows and knees by linear-blend skinning (the joints pinch on
/// the inside, which is where the shadows are). Every part is a closed,
/// outward-facing surface and the parts do not touch, so back-face culling
/// is exact. 2,840 vertices, 5,632 triangles.
pub fn character() -> Animation {
    let mut verts = Vec::new();
    let mut triangles = Vec::new();
    // Torso: an ellipsoid, chest weight rising with height.
    let base = verts.len() as u32;
    let (seg, rings) = (28, 18);
    sphere_grid(seg, rings, &mut triangles, base);
    push_sphere_verts(
        seg,
        rings,
        |d| {
            let p = d * TORSO_RADII + Vec3::new(0.0, TORSO_CENTRE, 0.0);
            RigVertex {
                part: TORSO,
                local: p,
                weight: smoothstep(0.95, 1.6, p.y),
            }
        },
        &mut verts,
    );
    // Head: a sphere above the torso, rigid with the chest.
    let base = verts.len() as u32;
    let (seg, rings) = (20, 12);
    sphere_grid(seg, rings, &mut triangles, base);
    push_sphere_verts(
        seg,
        rings,
        |d| RigVertex {
            part: HEAD,
            local: d * Vec3::new(0.15, 0.17, 0.16) + Vec3::new(0.0, TORSO_CENTRE + TORSO_RADII.y + 0.19, 0.0),
            weight: 1.0,
        },
        &mut verts,
    );
    for part in [ARM_L, ARM_R, LEG_L, LEG_R] {
        let (r, l1, l2) = if part <= ARM_R { ARM } else { LEG };
        let base = verts.len() as u32;
        capsule(part, r, l1, l2, 16, 26, 5, base, &mut verts, &mut triangles);
    }
    Animation {
        name: "character".into(),
        triangles,
        kind: Kind::Character { rig: Rig { verts } },
        camera: Some((Vec3::new(2.2, 1.7, 3.3), Vec3::new(0.0, 1.05, 0.0), 40.0)),
    }
}

/// Triangles of a lat-long sphere with poles (vertex 0 the top pole,
/// `rings - 1` rings of `seg` vertices, then the bottom pole), outward.
pub(crate) fn sphere_grid(seg: u32, rings: u32, tris: &mut Vec<[u32; 3]>, base: u32) {
    let ring = |k: u32, i: u32| base + 1 + (k - 1) * seg + i % seg;
    let bottom = base + 1 + (rings - 1) * seg;
    for i in 0..seg {
        tris.push([base, ring(1, i), ring(1, i + 1)]);
        tris.push([bottom, ring(rings - 1, i + 1), ring(rings - 1, i)]);
    }
    for k in 1..rings - 1 {
        for i in 0..seg {
            let (a, b, c, d) = (ring(k, i), ring(k, i + 1), ring(k + 1, i + 1), ring(k + 1, i));
            tris.push([a, c, b]);
            tris.push([a, d, c]);
        }
    }
}

fn push_sphere_verts(seg: u32, rings: u32, f: impl Fn(Vec3) -> RigVertex, out: &mut Vec<RigVertex>) {
    out.push(f(Vec3::Y));
    for k in 1..rings {
        let th = PI * k as f32 / rings as f32;
        for i in 0..seg {
            let ph = TAU * i as f32 / seg as f32;
            out.push(f(Vec3::new(th.sin() * ph.cos(), th.cos(), -th.sin() * ph.sin())));
        }
    }
    out.push(f(-Vec3::Y));
}

/// A capsule along -y from its joint at the origin: radius r, bones of
/// lengths l1 and l2 (the elbow or knee at -l1), `seg` sides, `body` rings
/// along the cylinder and `cap` rings per hemispherical end.
#[allow(clippy::too_many_arguments)]
fn capsule(
    part: usize,
    r: f32,
    l1: f32,
    l2: f32,
    seg: u32,
    body: u32,
    cap: u32,
    base: u32,
    verts: &mut Vec<RigVertex>,
    tris: &mut Vec<[u32; 3]>,
) {
    // Profile from the top pole down: (y, radius) pairs.
    let mut profile = Vec::new();
    for k in 1..=cap {
        let a = PI / 2.0 * k as f32 / cap as f32;
        profile.push((r * a.cos(), r * a.sin()));
    }
    for k in 1..body {
        profile.push((-(l1 + l2) * k as f32 / body as f32, r));
    }
    for k in 0..cap {
        let a = PI / 2.0 * k as f32 / cap as f32;
        profile.push((-(l1 + l2) - r * a.sin(), r * a.cos()));
    }
    let rings = profile.len() as u32 + 1;
    sphere_grid(seg, rings, tris, base);
    let skin = |y: f32| smoothstep(l1 - 0.6 * r, l1 + 0.6 * r, -y);
    verts.push(RigVertex {
        part,
        local: Vec3::new(0.0, r, 0.0),
        weight: 0.0,
    });
    for &(y, rad) in &profile {
        for i in 0..seg {
            let ph = TAU * i as f32 / seg as f32;
            verts.push(RigVertex {
                part,
                local: Vec3::new(rad * ph.cos(), y, -rad * ph.sin()),
                weight: skin(y),
            });
        }
    }
    let bottom = -(l1 + l2) - r;
    verts.push(RigVertex {
        part,
        local: Vec3::new(0.0, bottom, 0.0),
        weight: 1.0,
    });
}

impl Rig {
    fn pose(&self, t: f32, out: &mut Vec<Vec3>) {
        let w = TAU / 1.2 * t; // one stride per 1.2 s
        let bob = 0.02 * (2.0 * w).sin();
        let pelvis = Mat4::from_translation(Vec3::new(0.0, bob, 0.0));
        let chest_pivot = Vec3::new(0.0, 0.95, 0.0);
        let chest = pelvis
            * Mat4::from_translation(chest_pivot)
            * Mat4::from_rotation_x(0.12 + 0.05 * (2.0 * w).sin())
            * Mat4::from_rotation_y(0.22 * w.sin())
            * Mat4::from_rotation_z(0.05 * w.cos())
            * Mat4::from_translation(-chest_pivot);
        // Limb bone pairs: (upper, lower) world transforms.
        let limb = |root: Mat4, joint: Vec3, side: f32, abduct: f32, swing: f32, bend: f32, l1: f32| {
            let upper = root
                * Mat4::from_translation(joint)
                * Mat4::from_rotation_z(side * abduct)
                * Mat4::from_rotation_x(swing);
            let knee = Vec3::new(0.0, -l1, 0.0);
            let lower =
                upper * Mat4::from_translation(knee) * Mat4::from_rotation_x(bend) * Mat4::from_translation(-knee);
            (upper, lower)
        };
        let s = w.sin();
        let arm_l = limb(
            chest,
            SHOULDER,
            1.0,
            0.12,
            -0.55 * s,
            -(0.45 + 0.35 * (0.5 + 0.5 * s)),
            ARM.1,
        );
        let arm_r = limb(
            chest,
            SHOULDER * Vec3::new(-1.0, 1.0, 1.0),
            -1.0,
            0.12,
            0.55 * s,
            -(0.45 + 0.35 * (0.5 - 0.5 * s)),
            ARM.1,
        );
        let knee = |phase: f32| 0.15 + 0.75 * (0.5 + 0.5 * (w + phase).sin()).powi(2);
        let leg_l = limb(pelvis, HIP, 1.0, 0.04, 0.5 * s, knee(-1.3), LEG.1);
        let leg_r = limb(
            pelvis,
            HIP * Vec3::new(-1.0, 1.0, 1.0),
            -1.0,
            0.04,
            -0.5 * s,
            knee(PI - 1.3),
            LEG.1,
        );
        for v in &self.verts {
            let (a, b) = match v.part {
                TORSO => (pelvis, chest),
                HEAD => (chest, chest),
                ARM_L => arm_l,
                ARM_R => arm_r,
                LEG_L => leg_l,
                _ => leg_r,
            };
            let p = a.transform_point3(v.local) * (1.0 - v.weight) + b.transform_point3(v.local) * v.weight;
            out.push(p);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scenes_are_valid_closed_or_open_and_finite() {
        for scene in [AnimatedScene::Cloth, AnimatedScene::Character] {
            let anim = scene.build();
            for k in 0..10 {
                let m = anim.mesh_at(k as f32 * 0.37);
                m.validate().unwrap();
                assert_eq!(m.positions.len(), anim.vertex_count());
            }
        }
        let cloth = cloth();
        assert_eq!(cloth.vertex_count(), 1369);
        assert_eq!(cloth.triangles.len(), 2592);
        assert!(!crate::prt::sides::is_closed(&cloth.triangles));
        let ch = character();
        assert!(crate::prt::sides::is_closed(&ch.triangles), "every part is closed");
        // Outward: the head's top vertex has an upward normal.
        let m = ch.mesh_at(0.0);
        let normals = m.vertex_normals();
        let top = (0..m.positions.len())
            .max_by(|&a, &b| m.positions[a].y.total_cmp(&m.positions[b].y))
            .unwrap();
        assert!(normals[top].y > 0.9, "{}", normals[top]);
    }
}
