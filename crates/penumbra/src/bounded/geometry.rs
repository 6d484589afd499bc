//! What the error predicate needs to know of the scene's surfaces, in f64:
//! each primitive as a surface with exact equations (a flat face's plane
//! and polygon, a smooth triangle's plane and vertex normals, a sphere),
//! the objects' bounds for their face pairs, and a query of the kd-tree
//! for the triangles inside a box (the candidates of a shaft).

use std::collections::HashMap;
use std::sync::Mutex;

use glam::DVec3;

use crate::accel::kdtree::KdTree;
use crate::bounded::patch::{NO_PATCH, Patch, patches_of};
use crate::geom::aabb::Aabb;
use crate::whitted::RenderScene;
use crate::whitted::scene::{MISS, NO_NORMAL, SMOOTH_FACE};

/// A convex polygon in a plane, vertices counter-clockwise about `normal`.
#[derive(Debug, Clone)]
pub struct Polygon {
    pub normal: DVec3,
    /// The plane `normal . x = w`.
    pub w: f64,
    pub vertices: Vec<DVec3>,
}

impl Polygon {
    /// For a triangle, its first vertex `v0` and the vectors `k1`, `k2`
    /// whose dot products with `x - v0` are `x`'s barycentric coordinates
    /// of `v1` and `v2` (an affine function of any point `x`).
    pub fn barycentric_duals(&self) -> (DVec3, DVec3, DVec3) {
        let [v0, v1, v2] = [self.vertices[0], self.vertices[1], self.vertices[2]];
        let (e1, e2) = (v1 - v0, v2 - v0);
        let (d00, d01, d11) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
        let denom = d00 * d11 - d01 * d01;
        (v0, (e1 * d11 - e2 * d01) / denom, (e2 * d00 - e1 * d01) / denom)
    }

    /// The polygon's edges as inward half-planes `(m, v)`: a point `x` of
    /// the plane is inside where `m . (x - v) >= 0` for all of them.
    pub fn edges(&self) -> impl Iterator<Item = (DVec3, DVec3)> + '_ {
        let n = self.vertices.len();
        (0..n).map(move |k| {
            let (a, b) = (self.vertices[k], self.vertices[(k + 1) % n]);
            (self.normal.cross(b - a), a)
        })
    }
}

/// What a ray can hit, as the predicate computes with it.
#[derive(Debug, Clone)]
pub enum Surface {
    /// A flat face: a convex polygon (a triangle, or a convex planar
    /// polygon of the OBJ file).
    Flat(Polygon),
    /// A smoothly shaded triangle: its plane and outline, and its corners'
    /// unit shading normals, interpolated barycentrically.
    Smooth {
        polygon: Polygon,
        normals: [DVec3; 3],
    },
    Sphere {
        center: DVec3,
        radius: f64,
    },
}

/// The scene's surfaces by primitive (triangles, then spheres), and the
/// objects' bounds.
pub struct SceneGeometry {
    /// Per triangle, the face (polygon) it belongs to, as an index into
    /// `polygons` (a flat face's polygon, or the triangle alone).
    pub triangle_polygon: Vec<u32>,
    pub polygons: Vec<Polygon>,
    /// The triangles of each polygon.
    pub polygon_triangles: Vec<Vec<u32>>,
    /// Every triangle's vertices.
    triangle_vertices: Vec<[DVec3; 3]>,
    pub spheres: Vec<(DVec3, f64)>,
    /// Per ray-tree object, its bounds (the faces of its linetrees).
    pub object_bounds: Vec<Aabb>,
    /// Per primitive, its largest coordinate (the renderer's ray offsets).
    pub magnitude: Vec<f64>,
    /// The smooth patches (`patch`) and each triangle's (`NO_PATCH`).
    pub patches: Vec<Patch>,
    pub triangle_patch: Vec<u32>,
    /// Per (patch triangle, light): whether every shadow ray from the
    /// triangle to the light is proven clear (`predicate`'s cull of a
    /// patch's pieces, the same for every cell).
    piece_shadows: Mutex<HashMap<(u32, u32), bool>>,
    triangles: usize,
}

fn plane_of(v: [DVec3; 3]) -> Option<(DVec3, f64)> {
    let n = (v[1] - v[0]).cross(v[2] - v[0]).try_normalize()?;
    Some((n, n.dot(v[0])))
}

impl SceneGeometry {
    /// The scene's surfaces; `patches`: smooth triangles grouped into
    /// patches (`BoundedSettings::patches`), else each its own surface.
    pub fn new(scene: &RenderScene, tree: &KdTree, patches: bool) -> SceneGeometry {
        let tri = |t: usize| tree.triangles[t].map(|v| v.as_dvec3());
        // Flat faces: the triangles of one OBJ polygon, in fan order.
        let mut faces: HashMap<u32, Vec<u32>> = HashMap::new();
        for (t, s) in scene.triangles.iter().enumerate() {
            if s.face != SMOOTH_FACE && s.face != MISS && s.normals[0] == NO_NORMAL {
                faces.entry(s.face).or_default().push(t as u32);
            }
        }
        let mut polygons = Vec::new();
        let mut triangle_polygon = vec![u32::MAX; scene.triangles.len()];
        let single = |t: usize, polygons: &mut Vec<Polygon>| {
            let v = tri(t);
            let (normal, w) = plane_of(v).unwrap_or((DVec3::Z, 0.0));
            polygons.push(Polygon {
                normal,
                w,
                vertices: v.to_vec(),
            });
            polygons.len() as u32 - 1
        };
        let mut keys: Vec<u32> = faces.keys().copied().collect();
        keys.sort_unstable();
        for key in keys {
            let ts = &faces[&key];
            match convex_fan(&ts.iter().map(|&t| tri(t as usize)).collect::<Vec<_>>()) {
                Some(p) => {
                    polygons.push(p);
                    for &t in ts {
                        triangle_polygon[t as usize] = polygons.len() as u32 - 1;
                    }
                }
                // Not planar or not convex: each triangle is its own face.
                None => {
                    for &t in ts {
                        triangle_polygon[t as usize] = single(t as usize, &mut polygons);
                    }
                }
            }
        }
        for (t, p) in triangle_polygon.iter_mut().enumerate() {
            if *p == u32::MAX {
                *p = single(t, &mut polygons);
            }
        }
        let spheres: Vec<(DVec3, f64)> = scene
            .spheres
            .iter()
            .map(|s| (s.center().as_dvec3(), s.radius as f64))
            .collect();
        let mut object_bounds = vec![Aabb::EMPTY; scene.objects.len()];
        for (t, s) in scene.triangles.iter().enumerate() {
            if let Some(b) = object_bounds.get_mut(s.object as usize) {
                for v in tree.triangles[t] {
                    *b = b.grow(v);
                }
            }
        }
        for s in &scene.spheres {
            let b = &mut object_bounds[s.object as usize];
            *b = b
                .grow(s.center() - glam::Vec3::splat(s.radius))
                .grow(s.center() + glam::Vec3::splat(s.radius));
        }
        let mut magnitude: Vec<f64> = tree
            .triangles
            .iter()
            .map(|t| t.iter().map(|v| v.abs().max_element() as f64).fold(0.0, f64::max))
            .collect();
        magnitude.extend(scene.spheres.iter().map(|s| s.magnitude() as f64));
        let mut polygon_triangles = vec![Vec::new(); polygons.len()];
        for (t, &p) in triangle_polygon.iter().enumerate() {
            polygon_triangles[p as usize].push(t as u32);
        }
        let (patches, triangle_patch) = if patches {
            patches_of(scene, &tree.triangles)
        } else {
            (Vec::new(), vec![NO_PATCH; scene.triangles.len()])
        };
        SceneGeometry {
            patches,
            triangle_patch,
            piece_shadows: Mutex::new(HashMap::new()),
            triangle_polygon,
            polygon_triangles,
            triangle_vertices: (0..tree.triangles.len()).map(tri).collect(),
            polygons,
            spheres,
            object_bounds,
            magnitude,
            triangles: scene.triangles.len(),
        }
    }

    /// The surface of primitive `p` (a triangle index, or triangles +
    /// sphere index), with the shading normals of `scene`.
    pub fn surface(&self, scene: &RenderScene, p: u32) -> Surface {
        let p = p as usize;
        if p >= self.triangles {
            let (center, radius) = self.spheres[p - self.triangles];
            return Surface::Sphere { center, radius };
        }
        let polygon = self.polygons[self.triangle_polygon[p] as usize].clone();
        let info = &scene.triangles[p];
        if info.normals[0] == NO_NORMAL {
            return Surface::Flat(polygon);
        }
        let normals = info.normals.map(|i| {
            DVec3::from_slice(
                &scene.normals[i as usize][..3]
                    .iter()
                    .map(|&x| x as f64)
                    .collect::<Vec<_>>(),
            )
        });
        Surface::Smooth { polygon, normals }
    }

    /// The bounds of a linetree's surface: a flat face's polygon, a smooth
    /// triangle, a sphere.
    pub fn bounds(&self, surface: crate::bounded::predicate::RootFace) -> Aabb {
        use crate::bounded::predicate::RootFace;
        let points: Vec<glam::Vec3> = match surface {
            RootFace::Polygon(p) => self.polygons[p as usize].vertices.iter().map(|v| v.as_vec3()).collect(),
            RootFace::Triangle(t) => self.polygons[self.triangle_polygon[t as usize] as usize]
                .vertices
                .iter()
                .map(|v| v.as_vec3())
                .collect(),
            RootFace::Sphere(p) => {
                let (c, r) = self.spheres[p as usize - self.triangles];
                vec![(c - DVec3::splat(r)).as_vec3(), (c + DVec3::splat(r)).as_vec3()]
            }
            RootFace::Patch(p) => return self.patches[p as usize].bounds,
        };
        Aabb::from_points(points.iter())
    }

    /// Where the line `o + t d` first meets the root surface of a linetree
    /// from the front (t > 0): its plane for a polygon or a smooth triangle,
    /// a smooth patch's first triangle, the sphere's near side. The
    /// distance and a primitive to shade with; `None` where it misses.
    pub fn root_hit(&self, root: crate::bounded::predicate::RootFace, o: DVec3, d: DVec3) -> Option<(f64, u32)> {
        use crate::bounded::predicate::RootFace;
        let plane = |p: u32| self.plane_distance(p, o, d);
        match root {
            // The triangle of the polygon the point lies in: the renderer
            // shades a point clamped into the triangle it is given. (Outside
            // the polygon the predicate rejects the cell.)
            RootFace::Polygon(p) => plane(p).map(|t| {
                let x = o + t * d;
                let ts = &self.polygon_triangles[p as usize];
                let inside = ts
                    .iter()
                    .copied()
                    .min_by(|&a, &b| self.outside_by(a, x).total_cmp(&self.outside_by(b, x)));
                (t, inside.expect("a polygon has a triangle"))
            }),
            RootFace::Triangle(t) => plane(self.triangle_polygon[t as usize]).map(|d| (d, t)),
            RootFace::Sphere(primitive) => {
                let (c, r) = self.spheres[primitive as usize - self.triangles];
                let (oc, dd) = (o - c, d.length_squared());
                let b = oc.dot(d);
                let disc = b * b - dd * (oc.length_squared() - r * r);
                let t = (-b - disc.sqrt()) / dd;
                (disc >= 0.0 && t > 0.0).then_some((t, primitive))
            }
            // The patch's first triangle along the line, found in f32 as
            // the renderer finds it (`t` per unit of the given `d`).
            RootFace::Patch(p) => {
                let len = d.length();
                let hit = self.patches[p as usize].first_hit(o, d / len);
                hit.map(|(t, tri)| (t / len, tri))
            }
        }
    }

    /// Where `o + t d` meets polygon `p`'s plane, `t > 0`.
    fn plane_distance(&self, p: u32, o: DVec3, d: DVec3) -> Option<f64> {
        let poly = &self.polygons[p as usize];
        let den = poly.normal.dot(d);
        let t = (poly.w - poly.normal.dot(o)) / den;
        (den != 0.0 && t > 0.0).then_some(t)
    }

    /// `root_hit`'s distance, with a primitive of the root's surface that
    /// need not be the triangle holding the point: what a texture lookup
    /// needs (a polygon's triangles are one OBJ face, one surface), without
    /// searching the polygon's triangles for it.
    pub fn root_distance(&self, root: crate::bounded::predicate::RootFace, o: DVec3, d: DVec3) -> Option<(f64, u32)> {
        match root {
            crate::bounded::predicate::RootFace::Polygon(p) => self
                .plane_distance(p, o, d)
                .map(|t| (t, self.polygon_triangles[p as usize][0])),
            _ => self.root_hit(root, o, d),
        }
    }

    /// How far `x` (in the triangle's plane) lies outside triangle `t`: the
    /// most negative barycentric coordinate, 0 inside.
    fn outside_by(&self, t: u32, x: DVec3) -> f64 {
        let [v0, v1, v2] = self.triangle_vertices[t as usize];
        let (e1, e2, vp) = (v1 - v0, v2 - v0, x - v0);
        let (d00, d01, d11) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
        let (d20, d21) = (vp.dot(e1), vp.dot(e2));
        let denom = d00 * d11 - d01 * d01;
        if denom <= 0.0 {
            return f64::INFINITY;
        }
        let b1 = (d11 * d20 - d01 * d21) / denom;
        let b2 = (d00 * d21 - d01 * d20) / denom;
        -(b1.min(b2).min(1.0 - b1 - b2)).min(0.0)
    }

    /// Whether patch triangle `t`'s shadow rays to light `j` are clear,
    /// `cull` deciding the first time it is asked.
    pub fn piece_shadow(&self, t: u32, j: u32, cull: impl FnOnce() -> bool) -> bool {
        let known = self
            .piece_shadows
            .lock()
            .map(|m| m.get(&(t, j)).copied())
            .unwrap_or(None);
        known.unwrap_or_else(|| {
            let clear = cull();
            if let Ok(mut m) = self.piece_shadows.lock() {
                m.insert((t, j), clear);
            }
            clear
        })
    }

    /// Whether primitive `p` is a sphere.
    pub fn is_sphere(&self, p: u32) -> bool {
        p as usize >= self.triangles
    }

    pub fn triangle_count(&self) -> usize {
        self.triangles
    }
}

/// The fan of triangles as one convex planar polygon (vertices in fan
/// order: v0, v1, v2, v3...), or `None`.
fn convex_fan(tris: &[[DVec3; 3]]) -> Option<Polygon> {
    let (normal, w) = plane_of(tris[0])?;
    let mut vertices = vec![tris[0][0], tris[0][1], tris[0][2]];
    for t in &tris[1..] {
        // Fan order: (v0, v[k-1], v[k]).
        if t[0] != vertices[0] || t[1] != *vertices.last()? {
            return None;
        }
        vertices.push(t[2]);
    }
    let scale = vertices.iter().map(|v| v.abs().max_element()).fold(1e-30, f64::max);
    if vertices.iter().any(|v| (normal.dot(*v) - w).abs() > 1e-6 * scale) {
        return None;
    }
    let n = vertices.len();
    for k in 0..n {
        let (a, b, c) = (vertices[k], vertices[(k + 1) % n], vertices[(k + 2) % n]);
        if (b - a).cross(c - b).dot(normal) < 0.0 {
            return None;
        }
    }
    Some(Polygon { normal, w, vertices })
}

/// The triangles of `tree` whose leaf cells overlap the box `[lo, hi]`
/// (each once, ascending), into `out`.
pub fn triangles_in_box(tree: &KdTree, lo: DVec3, hi: DVec3, out: &mut Vec<u32>) {
    out.clear();
    let b = &tree.bounds;
    if hi.x < b.min.x as f64 || hi.y < b.min.y as f64 || hi.z < b.min.z as f64 {
        return;
    }
    if lo.x > b.max.x as f64 || lo.y > b.max.y as f64 || lo.z > b.max.z as f64 {
        return;
    }
    let mut stack = vec![0u32];
    while let Some(i) = stack.pop() {
        let node = tree.nodes[i as usize];
        if node.is_leaf() {
            out.extend_from_slice(&tree.leaf_triangles[node.leaf_range()]);
            continue;
        }
        let (axis, split) = (node.axis(), node.split() as f64);
        if lo[axis] <= split {
            stack.push(i + 1);
        }
        if hi[axis] >= split {
            stack.push(node.above_child());
        }
    }
    out.sort_unstable();
    out.dedup();
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fans_become_convex_polygons_or_stay_triangles() {
        let q = [
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
        ];
        let p = convex_fan(&[[q[0], q[1], q[2]], [q[0], q[2], q[3]]]).unwrap();
        assert_eq!(p.vertices.len(), 4);
        assert!((p.normal - DVec3::Z).length() < 1e-12);
        let inside = DVec3::new(0.5, 0.5, 0.0);
        assert!(p.edges().all(|(m, v)| m.dot(inside - v) >= 0.0));
        let outside = DVec3::new(1.5, 0.5, 0.0);
        assert!(p.edges().any(|(m, v)| m.dot(outside - v) < 0.0));
        // A non-planar quad and a concave one are not one polygon.
        let bent = [q[0], q[1], q[2], DVec3::new(0.0, 1.0, 0.5)];
        assert!(convex_fan(&[[bent[0], bent[1], bent[2]], [bent[0], bent[2], bent[3]]]).is_none());
        let dart = [q[0], q[1], DVec3::new(0.2, 0.2, 0.0), q[3]];
        assert!(convex_fan(&[[dart[0], dart[1], dart[2]], [dart[0], dart[2], dart[3]]]).is_none());
    }
}
