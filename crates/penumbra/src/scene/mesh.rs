//! Indexed triangle meshes, as the command-line contract numbers them.

use std::ops::Range;

use glam::{DVec3, Vec3};

use crate::error::{Error, Result};
use crate::geom::aabb::Aabb;

/// Ray origins for per-vertex (and per-pixel) work are lifted off the
/// surface along the normal by this fraction of the bounding-box diagonal
/// (the command-line contract's offset), so rays do not hit the surface
/// they start on.
pub const ORIGIN_OFFSET: f32 = 1e-4;

/// A named run of consecutive triangles: one `o`/`g` block of an OBJ file or
/// one instance of a scene.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshObject {
    /// An OBJ's `o`/`g` name (`default` before any), a glTF node's or
    /// mesh's name, a scene instance's name, `default` for a PLY, `mesh`
    /// from `Mesh::new`.
    pub name: String,
    /// Its triangles' indices in `Mesh::triangles`.
    pub triangles: Range<u32>,
}

/// An indexed triangle mesh. Vertex and triangle indices are the contract's:
/// file order for vertices, fan order across all objects for triangles.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions, relative to `origin`.
    pub positions: Vec<Vec3>,
    /// Three indices into `positions` per triangle, in the winding the
    /// file gives (`face_normal` follows it).
    pub triangles: Vec<[u32; 3]>,
    /// Per-object triangle ranges, in order, covering all triangles.
    pub objects: Vec<MeshObject>,
    /// Where coordinate zero of `positions` is in world (file) coordinates:
    /// zero, except for a model far from the origin, whose positions are
    /// kept relative to it so f32 keeps their detail (`scene::frame`).
    pub origin: DVec3,
}

impl Mesh {
    /// Builds a mesh with a single object and validates it.
    pub fn new(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Result<Self> {
        let n = triangles.len() as u32;
        let mesh = Mesh {
            positions,
            triangles,
            objects: vec![MeshObject {
                name: "mesh".into(),
                triangles: 0..n,
            }],
            origin: DVec3::ZERO,
        };
        mesh.validate()?;
        Ok(mesh)
    }

    /// Checks what every consumer relies on: at least one triangle, finite
    /// coordinates, indices in range, and a triangle count that fits the
    /// 32-bit indices of the GPU layout (with `u32::MAX` reserved for a miss).
    pub fn validate(&self) -> Result<()> {
        if self.triangles.is_empty() {
            return Err(Error::input(
                "mesh",
                "has no triangles (an empty mesh cannot be traced)",
            ));
        }
        if self.triangles.len() >= u32::MAX as usize || self.positions.len() >= u32::MAX as usize {
            return Err(Error::input("mesh", "has more than 2^32-1 triangles or vertices"));
        }
        for (i, p) in self.positions.iter().enumerate() {
            for (axis, c) in ["x", "y", "z"].iter().zip(p.to_array()) {
                if !c.is_finite() {
                    return Err(Error::input(
                        format!("vertex {}", i + 1),
                        format!("coordinate {axis} is {c}; vertices must be finite"),
                    ));
                }
            }
        }
        check_extent(&self.positions)?;
        let nv = self.positions.len() as u32;
        for (t, tri) in self.triangles.iter().enumerate() {
            if let Some(&bad) = tri.iter().find(|&&v| v >= nv) {
                return Err(Error::input(
                    format!("triangle {t}"),
                    format!("vertex index {} out of range (mesh has {nv} vertices)", bad + 1),
                ));
            }
        }
        Ok(())
    }

    /// Triangle `t`'s three corners.
    pub fn triangle(&self, t: usize) -> [Vec3; 3] {
        let [a, b, c] = self.triangles[t];
        [
            self.positions[a as usize],
            self.positions[b as usize],
            self.positions[c as usize],
        ]
    }

    /// Bounds of the vertices that triangles use.
    pub fn bounds(&self) -> Aabb {
        used_bounds(&self.positions, &self.triangles)
    }

    /// How far ray origins are lifted off this mesh: `ORIGIN_OFFSET` times
    /// its bounding-box diagonal.
    pub fn origin_offset(&self) -> f32 {
        ORIGIN_OFFSET * self.bounds().diagonal()
    }

    /// Face normal as the contract defines it: `cross(v1 - v0, v2 - v0)`,
    /// unnormalised, so its length is twice the triangle's area.
    pub fn face_normal(&self, t: usize) -> Vec3 {
        let [a, b, c] = self.triangle(t);
        (b - a).cross(c - a)
    }

    /// Triangle `t`'s unit normal (zero if degenerate), exact in direction at
    /// any scene size: see `unit_normal`.
    pub fn unit_face_normal(&self, t: usize) -> Vec3 {
        unit_normal(self.triangle(t))
    }

    /// Vertex normals as the contract defines them (see `vertex_normals`).
    pub fn vertex_normals(&self) -> Vec<Vec3> {
        let mut out = Vec::new();
        vertex_normals(&self.positions, &self.triangles, &mut out);
        out
    }

    /// Appends `other`, renumbering its vertices and shifting its objects.
    /// An empty mesh takes `other`'s frame; otherwise `other`'s positions
    /// are moved into this mesh's frame (exactly where both origins agree).
    pub fn append(&mut self, other: &Mesh) {
        let v0 = self.positions.len() as u32;
        let t0 = self.triangles.len() as u32;
        if self.positions.is_empty() {
            self.origin = other.origin;
        }
        if other.origin == self.origin {
            self.positions.extend_from_slice(&other.positions);
        } else {
            let shift = other.origin - self.origin;
            self.positions
                .extend(other.positions.iter().map(|p| (p.as_dvec3() + shift).as_vec3()));
        }
        self.triangles.extend(other.triangles.iter().map(|t| t.map(|v| v + v0)));
        self.objects.extend(other.objects.iter().map(|o| MeshObject {
            name: o.name.clone(),
            triangles: o.triangles.start + t0..o.triangles.end + t0,
        }));
    }

    /// The mesh with every vertex mapped by `f` (a rigid motion with uniform
    /// scale keeps the normals' directions; see `scene::Transform`).
    pub fn map_positions(&self, f: impl Fn(Vec3) -> Vec3) -> Mesh {
        Mesh {
            positions: self.positions.iter().map(|&p| f(p)).collect(),
            triangles: self.triangles.clone(),
            objects: self.objects.clone(),
            origin: self.origin,
        }
    }

    /// `p` (world coordinates) in this mesh's frame.
    pub fn to_local(&self, p: DVec3) -> Vec3 {
        super::frame::to_local(self.origin, p)
    }

    /// `p` (this mesh's frame) in world coordinates.
    pub fn to_world(&self, p: Vec3) -> DVec3 {
        super::frame::to_world(self.origin, p)
    }

    /// Object that contains triangle `t`.
    pub fn object_of(&self, t: u32) -> Option<&MeshObject> {
        self.object_index(t).map(|i| &self.objects[i])
    }

    /// Index of the object that contains triangle `t`.
    pub fn object_index(&self, t: u32) -> Option<usize> {
        let i = self.objects.partition_point(|o| o.triangles.end <= t);
        self.objects.get(i).filter(|o| o.triangles.contains(&t)).map(|_| i)
    }
}

/// Bounds of the vertices that `triangles` use.
pub fn used_bounds(positions: &[Vec3], triangles: &[[u32; 3]]) -> Aabb {
    triangles
        .iter()
        .flatten()
        .fold(Aabb::EMPTY, |b, &v| b.grow(positions[v as usize]))
}

/// Vertex normals as the contract defines them, into `out`: the
/// area-weighted sum of the adjacent face normals (`cross(v1 - v0, v2 -
/// v0)`), normalised. A vertex no triangle uses, or whose adjacent
/// triangles all have zero area, gets the zero vector. Every method's
/// normals (AO points, PRT frames of a deforming mesh) come from here.
pub fn vertex_normals(positions: &[Vec3], triangles: &[[u32; 3]], out: &mut Vec<Vec3>) {
    // Sum in f64: a vertex shared by thousands of needle triangles would
    // otherwise lose the small ones.
    let mut sums = vec![glam::DVec3::ZERO; positions.len()];
    for t in triangles {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        let n = (b - a).cross(c - a).as_dvec3();
        for &v in t {
            sums[v as usize] += n;
        }
    }
    out.clear();
    out.extend(
        sums.into_iter()
            .map(|s| s.try_normalize().map_or(Vec3::ZERO, |n| n.as_vec3())),
    );
}

/// The largest extent of a scene f32 arithmetic handles at full accuracy:
/// squared lengths (of the diagonal, of distances across the scene) stay
/// finite up to about 1.8e19, and normal (not subnormal) down to about
/// 1.1e-19. Inside, every method gives the same answer at every scale
/// (`tests/scale.rs`); outside, a mesh is refused rather than answered wrongly.
pub const MAX_EXTENT: f32 = 9.223_372e18; // 2^63
pub const MIN_EXTENT: f32 = 5.421_011e-20; // 2^-64

/// Refuses vertices whose bounding box is too large or too small for f32.
fn check_extent(positions: &[Vec3]) -> Result<()> {
    let Aabb { min, max } = Aabb::from_points(positions);
    let extent = (max.as_dvec3() - min.as_dvec3()).max_element();
    let outside = extent > MAX_EXTENT as f64 || (extent > 0.0 && extent < MIN_EXTENT as f64);
    if outside {
        let show = |v: Vec3| format!("({:.3e}, {:.3e}, {:.3e})", v.x, v.y, v.z);
        let (min, max) = (show(min), show(max));
        return Err(Error::input(
            "mesh",
            format!(
                "extent {extent:.3e} (bounds {min} to {max}) is outside {MIN_EXTENT:.1e} to {MAX_EXTENT:.1e}, \
                 the sizes f32 arithmetic handles (squared lengths would overflow or underflow); \
                 rescale the model"
            ),
        ));
    }
    Ok(())
}

/// The unit normal of a triangle, zero if it is degenerate. Its edges are
/// first multiplied by a power of two that brings them near 1 (exact), so
/// the cross product neither overflows (edges of 1e19 and up: its squared
/// length is past f32's range) nor underflows (edges of 1e-19 and down)
/// and the direction is the same at every scale.
pub fn unit_normal([a, b, c]: [Vec3; 3]) -> Vec3 {
    let (e1, e2) = (b - a, c - a);
    let largest = e1.abs().max_element().max(e2.abs().max_element());
    if !(largest > 0.0 && largest.is_finite()) {
        return Vec3::ZERO;
    }
    let k = crate::geom::float::frame_scale(largest);
    (e1 * k).cross(e2 * k).normalize_or_zero()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad() -> Mesh {
        Mesh::new(
            vec![
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(2.0, 0.0, 0.0),
                Vec3::new(2.0, 1.0, 0.0),
                Vec3::new(0.0, 1.0, 0.0),
            ],
            vec![[0, 1, 2], [0, 2, 3]],
        )
        .unwrap()
    }

    #[test]
    fn vertex_normals_are_area_weighted_and_normalised() {
        let n = quad().vertex_normals();
        for v in n {
            assert!((v - Vec3::Z).length() < 1e-6);
        }
    }

    #[test]
    fn rejects_empty_nonfinite_and_out_of_range() {
        let e = Mesh::new(vec![Vec3::ZERO], vec![]).unwrap_err();
        assert!(e.to_string().contains("no triangles"), "{e}");
        let e = Mesh::new(
            vec![Vec3::ZERO, Vec3::X, Vec3::new(0.0, f32::NAN, 0.0)],
            vec![[0, 1, 2]],
        )
        .unwrap_err();
        assert!(
            e.to_string().contains("vertex 3") && e.to_string().contains("NaN"),
            "{e}"
        );
        let e = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 3]]).unwrap_err();
        assert!(e.to_string().contains("out of range"), "{e}");
    }

    #[test]
    fn append_renumbers_and_finds_objects() {
        let mut m = quad();
        m.append(&quad());
        assert_eq!(m.triangles[3], [4, 6, 7]);
        assert_eq!(m.objects.len(), 2);
        assert_eq!(m.object_of(3).unwrap().triangles, 2..4);
        assert!(m.object_of(4).is_none());
    }
}
