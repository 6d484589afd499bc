//! Procedural test scenes with known ambient occlusion, and the generator of
//! their committed copies in `assets/` (`penumbra gen-assets`).
//!
//! Every scene is deterministic: coordinates are exact binary fractions where
//! the geometry allows (grid coordinates such as `i/32`), seams are welded by
//! construction (shared indices, never by a distance tolerance), and points on
//! circles are computed once per octant and reflected, so rings are exactly
//! symmetric and points on the axes have exact zeros. The one platform
//! dependence left is `f64::sin`/`cos`; their results are rounded to `f32`,
//! which hides the last-bit differences between math libraries.
//!
//! Winding follows the crate's contract: the face normal
//! `cross(v1 - v0, v2 - v0)` points to the side where AO is measured.

use std::f64::consts::TAU;

use glam::Vec3;

use super::mesh::{Mesh, MeshObject};
use super::obj::write_obj;

/// Cells per side of each quad of [`corner`].
pub const CORNER_CELLS: u32 = 32;
/// Half-width of the square through-hole of [`cube_with_hole`].
pub const CUBE_HOLE_HALF_WIDTH: f32 = 0.4;
/// Default edge length of [`closed_box`].
pub const CLOSED_BOX_SIZE: f32 = 1.0;
/// Cells per side of each face of [`closed_box`].
pub const CLOSED_BOX_CELLS: usize = 8;
/// Default radius of [`cylindrical_well`].
pub const WELL_RADIUS: f32 = 1.0;
/// Default depth of [`cylindrical_well`].
pub const WELL_DEPTH: f32 = 2.0;
/// Default number of sides of the polygonal [`cylindrical_well`].
pub const WELL_SEGMENTS: u32 = 64;
/// Outer radius of the well's ground ring, in well radii.
pub const WELL_GROUND_RADII: f32 = 4.0;
/// Default extent of the "infinite" planes of [`wall_on_floor`] and
/// [`open_plane`]: large enough that, seen from points near the origin, the
/// missing part of the plane subtends a negligible solid angle.
pub const INFINITE_EXTENT: f32 = 1000.0;

/// Longitude segments of the sphere of [`sphere_on_plane`].
const SPHERE_SEGMENTS: u32 = 64;
/// Latitude bands of the sphere of [`sphere_on_plane`].
const SPHERE_BANDS: u32 = 32;
/// Half-size of the ground plane of [`sphere_on_plane`].
const SPHERE_PLANE_HALF_SIZE: f32 = 4.0;
/// Cells per side of the ground plane of [`sphere_on_plane`].
const SPHERE_PLANE_CELLS: u32 = 16;

/// The "corner" of the displacement-field AO paper: three mutually orthogonal
/// unit quads meeting at the origin, the floor `y = 0` and the walls `x = 0`
/// and `z = 0`, each over `[0, 1]²` and tessellated into 32×32 cells (a 33×33
/// vertex grid; vertices are not shared between quads), 3267 vertices and
/// 6144 triangles in all. Objects `floor`, `wall-x0`, `wall-z0`; every normal
/// points into the positive octant, where the corner occludes.
pub fn corner() -> Mesh {
    let n = CORNER_CELLS;
    let mut mesh = grid_quad("floor", Vec3::ZERO, Vec3::Z, Vec3::X, n, n);
    mesh.append(&grid_quad("wall-x0", Vec3::ZERO, Vec3::Y, Vec3::Z, n, n));
    mesh.append(&grid_quad("wall-z0", Vec3::ZERO, Vec3::X, Vec3::Y, n, n));
    mesh
}

/// A closed, watertight cube `[-1, 1]³` pierced along the z axis by a square
/// hole of half-width [`CUBE_HOLE_HALF_WIDTH`]: a thick square frame, a
/// genus-1 manifold with outward normals (192 vertices, 384 triangles).
///
/// It is the boundary of a union of cells of the rectilinear lattice
/// `x, y ∈ {-1, -0.7, -0.4, 0, 0.4, 0.7, 1}`, `z ∈ {-1, -0.5, 0, 0.5, 1}`
/// (every cell but the four around the axis), so the front and back faces are
/// quads around the hole and every seam shares its vertices. Objects `front`
/// (z = 1), `back` (z = -1), `sides` (the outer faces x, y = ±1) and `hole`
/// (its four inner walls, facing the axis).
pub fn cube_with_hole() -> Mesh {
    let w = CUBE_HOLE_HALF_WIDTH;
    let xy = [-1.0, -0.7, -w, 0.0, w, 0.7, 1.0];
    let z = [-1.0, -0.5, 0.0, 0.5, 1.0];
    let in_hole = |i: usize| i == 2 || i == 3;
    cell_surface(
        [&xy, &xy, &z],
        |[i, j, _]| !(in_hole(i) && in_hole(j)),
        &["front", "back", "sides", "hole"],
        |face| match (face.axis, face.positive, face.exterior) {
            (2, true, _) => 0,
            (2, false, _) => 1,
            (_, _, true) => 2,
            (_, _, false) => 3,
        },
    )
}

/// A sphere of radius 1 centred at `(0, 1, 0)`, resting on (touching at the
/// origin) a square ground plane `y = 0` of half-size 4 tessellated into 16×16
/// cells. Objects `plane` (normal +y; 289 vertices, 512 triangles) and
/// `sphere` (a UV sphere of 64 segments × 32 bands with single-vertex poles,
/// normals outward; 1986 vertices, 3968 triangles).
pub fn sphere_on_plane() -> Mesh {
    let h = SPHERE_PLANE_HALF_SIZE;
    let mut mesh = grid_quad(
        "plane",
        Vec3::new(-h, 0.0, -h),
        Vec3::new(0.0, 0.0, 2.0 * h),
        Vec3::new(2.0 * h, 0.0, 0.0),
        SPHERE_PLANE_CELLS,
        SPHERE_PLANE_CELLS,
    );
    mesh.append(&uv_sphere("sphere", Vec3::Y, 1.0, SPHERE_SEGMENTS, SPHERE_BANDS));
    mesh
}

/// A closed box `[0, size]³` (default [`CLOSED_BOX_SIZE`]) whose faces are
/// each tessellated into 8×8 cells, with the vertices along edges and corners
/// shared: a watertight closed surface of 386 vertices and 768 triangles.
/// Normals point inward, because the box is for measuring AO inside it: every
/// point inside a closed box has accessibility 0. Objects `wall-x0`,
/// `wall-x1`, `floor` (y = 0), `ceiling`, `wall-z0`, `wall-z1`.
///
/// # Panics
/// If `size` is not positive and finite.
pub fn closed_box(size: f32) -> Mesh {
    assert!(
        size.is_finite() && size > 0.0,
        "closed_box: size must be positive, got {size}"
    );
    let n = CLOSED_BOX_CELLS;
    let coords: Vec<f32> = (0..=n).map(|i| size * (i as f32 / n as f32)).collect();
    let mut mesh = cell_surface(
        [&coords, &coords, &coords],
        |_| true,
        &["wall-x0", "wall-x1", "floor", "ceiling", "wall-z0", "wall-z1"],
        |face| 2 * face.axis + usize::from(face.positive),
    );
    // The boundary of a solid faces out; turn it inside out.
    for t in &mut mesh.triangles {
        t.swap(1, 2);
    }
    mesh
}

/// A cylindrical well of radius `radius` and depth `depth`, approximated by a
/// regular prism of `segments` sides inscribed in the circle (defaults
/// [`WELL_RADIUS`], [`WELL_DEPTH`], [`WELL_SEGMENTS`]):
///
/// - `floor`: a disc at `y = 0`, a triangle fan around its centre, which is
///   vertex 0, at the origin; normal +y;
/// - `wall`: one band of quads from `y = 0` to `y = depth`, open at the top,
///   normals facing the axis;
/// - `ground`: an annulus at `y = depth` from `radius` to
///   [`WELL_GROUND_RADII`]` × radius`, so the rim sits in a ground plane;
///   normal +y.
///
/// The floor's rim is the wall's bottom ring and the wall's top ring is the
/// ground's inner edge (shared vertices), so floor, wall and ground form one
/// consistently wound surface whose only boundary is the ground's outer edge.
///
/// # AO at the centre of the floor
/// For a smooth cylinder the accessibility (cosine-weighted visible fraction of
/// the hemisphere) at the centre of the floor is `a² / (a² + h²)`, 0.2 for the
/// defaults. The polygonal well lets slightly less light in: its opening is
/// the inscribed `n`-gon. By Lambert's polygon formula the exact value is
///
/// ```text
/// A_n = a² / (a² + h²) · (sin δ / δ) · (θ / sin θ),
/// δ = 2π / n,   sin(θ/2) = a · sin(δ/2) / √(a² + h²),
/// ```
///
/// ([`well_floor_accessibility`]), where `sin δ / δ` is the ratio of the
/// polygon's area to the disc's and `θ` is the angle an edge of the opening
/// subtends at the floor's centre. Since `θ < δ`, `A_n` is always below the
/// smooth value, by a relative deficit
///
/// ```text
/// 0 < 1 - A_n / A < δ² / 6 = 2π² / (3 n²),  and  1 - A_n / A ≈ (δ² / 6) · h² / (a² + h²).
/// ```
///
/// For the defaults (`a = 1`, `h = 2`, `n = 64`) that is `A_64 = 0.199743`,
/// 0.128 % below 0.2 (the bound is 0.161 %), far below the noise of a
/// thousand-ray estimate. The unit tests check the formula against direct
/// quadrature of the visible solid angle of the polygonal opening.
///
/// # Panics
/// If `radius` or `depth` is not positive and finite, or `segments < 3`.
pub fn cylindrical_well(radius: f32, depth: f32, segments: u32) -> Mesh {
    assert!(
        radius.is_finite() && radius > 0.0 && depth.is_finite() && depth > 0.0,
        "cylindrical_well: radius and depth must be positive, got {radius} and {depth}"
    );
    assert!(
        segments >= 3,
        "cylindrical_well: need at least 3 segments, got {segments}"
    );
    let n = segments as usize;
    let next = |k: usize| (k + 1) % n;
    let mut b = Builder::default();

    let centre = b.vertex(Vec3::ZERO);
    let rim = b.ring(radius, 0.0, segments);
    for k in 0..n {
        b.triangle([centre, rim[next(k)], rim[k]]);
    }
    b.close_object("floor");

    let top = b.ring(radius, depth, segments);
    for k in 0..n {
        b.quad([rim[k], rim[next(k)], top[next(k)], top[k]]);
    }
    b.close_object("wall");

    let outer = b.ring(WELL_GROUND_RADII * radius, depth, segments);
    for k in 0..n {
        b.quad([top[k], top[next(k)], outer[next(k)], outer[k]]);
    }
    b.close_object("ground");
    b.mesh
}

/// Exact accessibility at the centre of the floor of
/// `cylindrical_well(radius, depth, segments)`, the cosine-weighted fraction
/// of the hemisphere that sees out through the polygonal opening (see
/// [`cylindrical_well`] for the derivation). Tends to
/// `radius² / (radius² + depth²)` as `segments` grows.
pub fn well_floor_accessibility(radius: f64, depth: f64, segments: u32) -> f64 {
    let (a2, r2) = (radius * radius, radius * radius + depth * depth);
    let delta = TAU / f64::from(segments);
    // Half the angle an edge of the opening subtends at the floor's centre,
    // from its chord; acos of a cosine near 1 would lose half the digits.
    let half_theta = (radius * (delta / 2.0).sin() / r2.sqrt()).asin();
    let theta = 2.0 * half_theta;
    a2 / r2 * (delta.sin() / delta) * (theta / theta.sin())
}

/// A floor quad `y = 0` over `x ∈ [0, E]`, `z ∈ [-E, E]` (object `floor`,
/// normal +y) and a wall quad `x = 0` over `y ∈ [0, E]`, `z ∈ [-E, E]`
/// (object `wall`, normal +x), two triangles each, for `E = extent` (default
/// [`INFINITE_EXTENT`]). A point on the floor near the origin sees half of its
/// hemisphere's cosine-weighted light blocked by the wall: accessibility 0.5.
///
/// # Panics
/// If `extent` is not positive and finite.
pub fn wall_on_floor(extent: f32) -> Mesh {
    assert_extent("wall_on_floor", extent);
    let e = extent;
    let mut mesh = grid_quad(
        "floor",
        Vec3::new(0.0, 0.0, -e),
        Vec3::new(0.0, 0.0, 2.0 * e),
        Vec3::new(e, 0.0, 0.0),
        1,
        1,
    );
    mesh.append(&grid_quad(
        "wall",
        Vec3::new(0.0, 0.0, -e),
        Vec3::new(0.0, e, 0.0),
        Vec3::new(0.0, 0.0, 2.0 * e),
        1,
        1,
    ));
    mesh
}

/// One quad `y = 0` over `[-E, E]²` in x and z, two triangles, normal +y, for
/// `E = extent` (default [`INFINITE_EXTENT`]); object `plane`. A point on an
/// open plane has accessibility 1.
///
/// # Panics
/// If `extent` is not positive and finite.
pub fn open_plane(extent: f32) -> Mesh {
    assert_extent("open_plane", extent);
    let e = extent;
    grid_quad(
        "plane",
        Vec3::new(-e, 0.0, -e),
        Vec3::new(0.0, 0.0, 2.0 * e),
        Vec3::new(2.0 * e, 0.0, 0.0),
        1,
        1,
    )
}

fn assert_extent(scene: &str, extent: f32) {
    assert!(
        extent.is_finite() && extent > 0.0,
        "{scene}: extent must be positive, got {extent}"
    );
}

/// One procedural scene with what its asset file's header says about it.
struct ProceduralScene {
    name: &'static str,
    summary: &'static str,
    parameters: String,
    mesh: Mesh,
}

/// Every scene at its default parameters, in asset order.
fn scenes() -> Vec<ProceduralScene> {
    let scene = |name, summary, parameters: String, mesh| ProceduralScene {
        name,
        summary,
        parameters,
        mesh,
    };
    vec![
        scene(
            "corner",
            "Three orthogonal unit quads meeting at the origin; normals into the positive octant.",
            format!("{CORNER_CELLS}x{CORNER_CELLS} cells per quad, vertices not shared between quads"),
            corner(),
        ),
        scene(
            "cube-with-hole",
            "Closed cube [-1,1]^3 with a square through-hole along z; watertight, normals outward.",
            format!("hole half-width {CUBE_HOLE_HALF_WIDTH}"),
            cube_with_hole(),
        ),
        scene(
            "sphere-on-plane",
            "Unit sphere centred at (0,1,0) touching the ground plane y=0; normals outward / up.",
            format!(
                "sphere radius 1, {SPHERE_SEGMENTS} segments x {SPHERE_BANDS} bands; \
                 plane half-size {SPHERE_PLANE_HALF_SIZE}, {SPHERE_PLANE_CELLS}x{SPHERE_PLANE_CELLS} cells"
            ),
            sphere_on_plane(),
        ),
        scene(
            "closed-box",
            "Closed box [0,size]^3, watertight, normals INWARD (accessibility 0 inside).",
            format!("size {CLOSED_BOX_SIZE}, {CLOSED_BOX_CELLS}x{CLOSED_BOX_CELLS} cells per face"),
            closed_box(CLOSED_BOX_SIZE),
        ),
        scene(
            "cylindrical-well",
            "Polygonal well with floor at y=0, open top in a ground ring at y=depth; normals into the well / up.",
            format!(
                "radius {WELL_RADIUS}, depth {WELL_DEPTH}, {WELL_SEGMENTS} segments, \
                 ground to {WELL_GROUND_RADII} radii; floor-centre accessibility {:.6} (smooth cylinder {:.6})",
                well_floor_accessibility(WELL_RADIUS.into(), WELL_DEPTH.into(), WELL_SEGMENTS),
                WELL_RADIUS * WELL_RADIUS / (WELL_RADIUS * WELL_RADIUS + WELL_DEPTH * WELL_DEPTH),
            ),
            cylindrical_well(WELL_RADIUS, WELL_DEPTH, WELL_SEGMENTS),
        ),
        scene(
            "wall-on-floor",
            "Floor y=0 (x>=0) meeting a wall x=0; a floor point near the wall has accessibility 0.5.",
            format!("extent {INFINITE_EXTENT}"),
            wall_on_floor(INFINITE_EXTENT),
        ),
        scene(
            "open-plane",
            "One quad y=0, normal +y; a point on it has accessibility 1.",
            format!("half-size {INFINITE_EXTENT}"),
            open_plane(INFINITE_EXTENT),
        ),
    ]
}

/// Every procedural scene at its default parameters, as (kebab-case name,
/// mesh), in the order `penumbra gen-assets` writes them ([`asset_files`]).
pub fn all_scenes() -> Vec<(&'static str, Mesh)> {
    scenes().into_iter().map(|s| (s.name, s.mesh)).collect()
}

/// Every scene as the file `penumbra gen-assets` writes for it:
/// (`<name>.obj`, its text), byte-for-byte deterministic, with a header
/// naming the generator, the parameters and the counts, in [`all_scenes`]
/// order.
pub fn asset_files() -> Vec<(String, String)> {
    scenes()
        .iter()
        .map(|scene| {
            (
                format!("{}.obj", scene.name),
                write_obj(&scene.mesh, &asset_header(scene)),
            )
        })
        .collect()
}

fn asset_header(scene: &ProceduralScene) -> String {
    let mesh = &scene.mesh;
    let objects: Vec<&str> = mesh.objects.iter().map(|o| o.name.as_str()).collect();
    format!(
        "{name}.obj: generated by `penumbra gen-assets` (crates/penumbra/src/scene/procedural.rs); do not hand-edit.\n\
         {summary}\n\
         parameters: {parameters}\n\
         {nv} vertices, {nt} triangles; objects: {objects}\n",
        name = scene.name,
        summary = scene.summary,
        parameters = scene.parameters,
        nv = mesh.positions.len(),
        nt = mesh.triangles.len(),
        objects = objects.join(", "),
    )
}

/// A planar `nu`×`nv`-cell grid over the parallelogram `origin + s·u_axis +
/// t·v_axis`, `s, t ∈ [0, 1]`, as one object named `name`. Vertex `(i, j)` is
/// `origin + u_axis·(i/nu) + v_axis·(j/nv)`, numbered row by row with `i`
/// fastest; each cell is split into two triangles along the same diagonal.
/// Normals are `u_axis × v_axis`.
fn grid_quad(name: &str, origin: Vec3, u_axis: Vec3, v_axis: Vec3, nu: u32, nv: u32) -> Mesh {
    let mut b = Builder::default();
    for j in 0..=nv {
        for i in 0..=nu {
            let (s, t) = (i as f32 / nu as f32, j as f32 / nv as f32);
            b.vertex(origin + u_axis * s + v_axis * t);
        }
    }
    let index = |i: u32, j: u32| j * (nu + 1) + i;
    for j in 0..nv {
        for i in 0..nu {
            b.quad([index(i, j), index(i + 1, j), index(i + 1, j + 1), index(i, j + 1)]);
        }
    }
    b.close_object(name);
    b.mesh
}

/// A UV sphere with single-vertex poles (top pole first), normals outward,
/// as one object named `name`.
pub fn uv_sphere(name: &str, centre: Vec3, radius: f32, segments: u32, bands: u32) -> Mesh {
    let (c, r) = (centre.as_dvec3(), f64::from(radius));
    let n = segments as usize;
    let next = |k: usize| (k + 1) % n;
    let mut b = Builder::default();
    let top = b.vertex(centre + Vec3::Y * radius);
    // Ring j sits at polar angle πj/bands from the top.
    let rings: Vec<Vec<u32>> = (1..bands)
        .map(|j| {
            let (cos_polar, sin_polar) = unit_circle(j, 2 * bands);
            (0..segments)
                .map(|k| {
                    let (cos_az, sin_az) = unit_circle(k, segments);
                    let p = glam::DVec3::new(sin_polar * cos_az, cos_polar, sin_polar * sin_az);
                    b.vertex((c + r * p).as_vec3())
                })
                .collect()
        })
        .collect();
    let bottom = b.vertex(centre - Vec3::Y * radius);
    let (first, last) = (&rings[0], &rings[rings.len() - 1]);
    for k in 0..n {
        b.triangle([top, first[next(k)], first[k]]);
    }
    for pair in rings.windows(2) {
        let (upper, lower) = (&pair[0], &pair[1]);
        for k in 0..n {
            b.quad([upper[k], upper[next(k)], lower[next(k)], lower[k]]);
        }
    }
    for k in 0..n {
        b.triangle([bottom, last[k], last[next(k)]]);
    }
    b.close_object(name);
    b.mesh
}

/// `(cos, sin)` of the angle `2πk/n`. When `n` is a multiple of 4 only the
/// first octant is evaluated and the rest is reflected, so rings are exactly
/// symmetric and quarter turns give exact zeros (`cos(π/2)` is `6e-17` in
/// floating point). Zeros are positive, so OBJ files never print `-0`.
fn unit_circle(k: u32, n: u32) -> (f64, f64) {
    let angle = |k: u32| TAU * f64::from(k) / f64::from(n);
    if !n.is_multiple_of(4) {
        return (angle(k).cos() + 0.0, angle(k).sin() + 0.0);
    }
    let quarter = n / 4;
    let (q, r) = ((k % n) / quarter, k % quarter);
    let (c, s) = if 2 * r <= quarter {
        (angle(r).cos(), angle(r).sin())
    } else {
        (angle(quarter - r).sin(), angle(quarter - r).cos())
    };
    let (c, s) = match q {
        0 => (c, s),
        1 => (-s, c),
        2 => (-c, -s),
        _ => (s, -c),
    };
    (c + 0.0, s + 0.0)
}

/// A face of a lattice cell on the boundary of a union of cells.
struct CellFace {
    /// The solid cell the face belongs to.
    cell: [usize; 3],
    /// The axis the face is perpendicular to (0 = x, 1 = y, 2 = z).
    axis: usize,
    /// Whether the outward normal points along +axis.
    positive: bool,
    /// Whether the empty cell on the other side lies outside the lattice
    /// (rather than being an empty cell inside it, such as a hole).
    exterior: bool,
}

/// The boundary, with outward normals, of the union of the cells of the
/// rectilinear lattice with vertex `(i, j, k)` at
/// `(coords[0][i], coords[1][j], coords[2][k])` for which `solid` holds.
/// Each boundary face is a quad of two triangles; faces are grouped into
/// objects `object_names[object_of(face)]` (empty objects are left out).
///
/// Vertices are lattice points, identified by index rather than position, so
/// seams are shared exactly and the surface of a union whose cells meet along
/// faces is watertight. Vertices are numbered in order of first use.
fn cell_surface(
    coords: [&[f32]; 3],
    solid: impl Fn([usize; 3]) -> bool,
    object_names: &[&str],
    object_of: impl Fn(&CellFace) -> usize,
) -> Mesh {
    let cells = coords.map(|c| c.len() - 1);
    let mut faces: Vec<Vec<CellFace>> = object_names.iter().map(|_| Vec::new()).collect();
    for i in 0..cells[0] {
        for j in 0..cells[1] {
            for k in 0..cells[2] {
                let cell = [i, j, k];
                if !solid(cell) {
                    continue;
                }
                for axis in 0..3 {
                    for positive in [false, true] {
                        let mut neighbour = cell;
                        let inside = if positive {
                            neighbour[axis] += 1;
                            neighbour[axis] < cells[axis]
                        } else {
                            neighbour[axis] = neighbour[axis].wrapping_sub(1);
                            neighbour[axis] != usize::MAX
                        };
                        if inside && solid(neighbour) {
                            continue;
                        }
                        let face = CellFace {
                            cell,
                            axis,
                            positive,
                            exterior: !inside,
                        };
                        faces[object_of(&face)].push(face);
                    }
                }
            }
        }
    }

    let mut b = Builder::default();
    let mut index = std::collections::HashMap::new();
    let mut vertex = |b: &mut Builder, p: [usize; 3]| {
        *index
            .entry(p)
            .or_insert_with(|| b.vertex(Vec3::new(coords[0][p[0]], coords[1][p[1]], coords[2][p[2]])))
    };
    for (name, group) in object_names.iter().zip(&faces) {
        for face in group {
            // Corners in the face's (axis+1, axis+2) plane, counter-clockwise
            // seen from +axis, since e(axis+1) × e(axis+2) = e(axis).
            let corners = if face.positive {
                [(0, 0), (1, 0), (1, 1), (0, 1)]
            } else {
                [(0, 0), (0, 1), (1, 1), (1, 0)]
            };
            let quad = corners.map(|(du, dv)| {
                let mut p = face.cell;
                p[face.axis] += usize::from(face.positive);
                p[(face.axis + 1) % 3] += du;
                p[(face.axis + 2) % 3] += dv;
                vertex(&mut b, p)
            });
            b.quad(quad);
        }
        b.close_object(name);
    }
    b.mesh
}

/// Accumulates a mesh object by object.
#[derive(Default)]
struct Builder {
    mesh: Mesh,
}

impl Builder {
    fn vertex(&mut self, p: Vec3) -> u32 {
        self.mesh.positions.push(p);
        self.mesh.positions.len() as u32 - 1
    }

    /// `segments` vertices on the circle of radius `radius` around the y
    /// axis at height `y`, starting on +x and turning from +x towards +z.
    fn ring(&mut self, radius: f32, y: f32, segments: u32) -> Vec<u32> {
        (0..segments)
            .map(|k| {
                let (c, s) = unit_circle(k, segments);
                let r = f64::from(radius);
                self.vertex(Vec3::new((r * c) as f32, y, (r * s) as f32))
            })
            .collect()
    }

    fn triangle(&mut self, t: [u32; 3]) {
        self.mesh.triangles.push(t);
    }

    /// Two triangles `(a, b, c)` and `(a, c, d)`, both wound like the quad.
    fn quad(&mut self, [a, b, c, d]: [u32; 4]) {
        self.triangle([a, b, c]);
        self.triangle([a, c, d]);
    }

    /// Names the triangles added since the previous object (if any).
    fn close_object(&mut self, name: &str) {
        let start = self.mesh.objects.last().map_or(0, |o| o.triangles.end);
        let end = self.mesh.triangles.len() as u32;
        if end > start {
            self.mesh.objects.push(MeshObject {
                name: name.into(),
                triangles: start..end,
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use std::collections::HashMap;
    use std::f64::consts::PI;

    use super::*;
    use crate::scene::parse_obj;

    /// How often each directed edge is used.
    fn directed_edges(mesh: &Mesh, triangles: std::ops::Range<u32>) -> HashMap<(u32, u32), u32> {
        let mut edges = HashMap::new();
        for t in triangles {
            let [a, b, c] = mesh.triangles[t as usize];
            for e in [(a, b), (b, c), (c, a)] {
                *edges.entry(e).or_insert(0) += 1;
            }
        }
        edges
    }

    /// Closed and consistently wound: every directed edge is used once and
    /// its opposite once, so every undirected edge is used by exactly two
    /// triangles, in opposite directions.
    fn assert_watertight(mesh: &Mesh) {
        let edges = directed_edges(mesh, 0..mesh.triangles.len() as u32);
        for (&(a, b), &uses) in &edges {
            assert_eq!(uses, 1, "edge {a}->{b} used {uses} times in the same direction");
            assert_eq!(edges.get(&(b, a)), Some(&1), "edge {a}->{b} has no opposite");
        }
    }

    fn centroid(mesh: &Mesh, t: usize) -> Vec3 {
        let [a, b, c] = mesh.triangle(t);
        (a + b + c) / 3.0
    }

    fn object<'m>(mesh: &'m Mesh, name: &str) -> &'m MeshObject {
        mesh.objects.iter().find(|o| o.name == name).unwrap()
    }

    /// Six times the enclosed volume, positive for outward normals.
    fn signed_volume(mesh: &Mesh) -> f64 {
        (0..mesh.triangles.len())
            .map(|t| {
                let [a, b, c] = mesh.triangle(t).map(|p| p.as_dvec3());
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }

    #[test]
    fn corner_has_the_papers_counts_and_faces_the_positive_octant() {
        let m = corner();
        assert_eq!((m.positions.len(), m.triangles.len(), m.objects.len()), (3267, 6144, 3));
        for (name, normal) in [("floor", Vec3::Y), ("wall-x0", Vec3::X), ("wall-z0", Vec3::Z)] {
            let o = object(&m, name);
            assert_eq!(o.triangles.len(), 2048);
            for t in o.triangles.clone() {
                let n = m.face_normal(t as usize).normalize();
                assert!(n.abs_diff_eq(normal, 1e-6), "{name} triangle {t}: {n}");
            }
        }
        assert_eq!(m.bounds().min, Vec3::ZERO);
        assert_eq!(m.bounds().max, Vec3::ONE);
        assert!(
            m.positions.contains(&Vec3::new(0.03125, 0.0, 0.96875)),
            "grid coordinates are i/32"
        );
    }

    #[test]
    fn closed_box_is_watertight_and_faces_inward() {
        let m = closed_box(CLOSED_BOX_SIZE);
        assert_eq!((m.positions.len(), m.triangles.len()), (386, 768));
        assert_watertight(&m);
        let centre = Vec3::splat(CLOSED_BOX_SIZE / 2.0);
        for t in 0..m.triangles.len() {
            assert!(m.face_normal(t).dot(centre - centroid(&m, t)) > 0.0, "triangle {t}");
        }
        assert!((signed_volume(&m) + 1.0).abs() < 1e-9, "inward: volume -1");
        for o in &m.objects {
            assert_eq!(o.triangles.len(), 128, "{}", o.name);
        }
        let floor = object(&m, "floor");
        for t in floor.triangles.clone() {
            assert_eq!(m.face_normal(t as usize).normalize(), Vec3::Y);
        }
        let big = closed_box(3.0);
        assert_eq!(big.bounds().max, Vec3::splat(3.0));
    }

    #[test]
    fn cube_with_hole_is_a_watertight_frame_facing_outward() {
        let m = cube_with_hole();
        assert_eq!((m.positions.len(), m.triangles.len()), (192, 384));
        assert_watertight(&m);
        // Genus 1: V - E + F = 0.
        let edges = m.triangles.len() * 3 / 2;
        assert_eq!(m.positions.len() + m.triangles.len(), edges);
        let w = CUBE_HOLE_HALF_WIDTH;
        let expected = 8.0 - 2.0 * f64::from(2.0 * w).powi(2);
        assert!((signed_volume(&m) - expected).abs() < 1e-5, "{}", signed_volume(&m));
        // Stepping off each triangle along its normal leaves the solid;
        // stepping against it enters.
        let solid = |p: Vec3| p.abs().max_element() < 1.0 && !(p.x.abs() < w && p.y.abs() < w);
        for t in 0..m.triangles.len() {
            let (c, n) = (centroid(&m, t), m.face_normal(t).normalize());
            assert!(
                !solid(c + 0.01 * n) && solid(c - 0.01 * n),
                "triangle {t} at {c}, normal {n}"
            );
        }
        let names: Vec<_> = m.objects.iter().map(|o| o.name.as_str()).collect();
        assert_eq!(names, ["front", "back", "sides", "hole"]);
        for t in object(&m, "hole").triangles.clone() {
            let c = centroid(&m, t as usize);
            assert!(c.x.abs().max(c.y.abs()) == w, "hole wall at {c}");
        }
    }

    #[test]
    fn sphere_rests_on_the_plane_facing_outward() {
        let m = sphere_on_plane();
        let names: Vec<_> = m.objects.iter().map(|o| o.name.as_str()).collect();
        assert_eq!(names, ["plane", "sphere"]);
        let sphere = object(&m, "sphere");
        assert!((2000..=5000).contains(&sphere.triangles.len()));
        for t in object(&m, "plane").triangles.clone() {
            assert_eq!(m.face_normal(t as usize).normalize(), Vec3::Y);
        }
        for t in sphere.triangles.clone() {
            let c = centroid(&m, t as usize);
            assert!(m.face_normal(t as usize).dot(c - Vec3::Y) > 0.0, "triangle {t}");
        }
        let used: Vec<Vec3> = sphere.triangles.clone().flat_map(|t| m.triangle(t as usize)).collect();
        for p in &used {
            assert!((p.distance(Vec3::Y) - 1.0).abs() < 1e-6, "{p}");
        }
        assert!(used.contains(&Vec3::ZERO), "touches the plane at the origin");
        assert_eq!(m.bounds().min, Vec3::new(-4.0, 0.0, -4.0));
        // The sphere alone is closed.
        let edges = directed_edges(&m, sphere.triangles.clone());
        assert!(edges.keys().all(|&(a, b)| edges.get(&(b, a)) == Some(&1)));
    }

    #[test]
    fn well_is_one_consistently_wound_surface_open_at_the_ground_edge() {
        let (a, h) = (WELL_RADIUS, WELL_DEPTH);
        let m = cylindrical_well(a, h, WELL_SEGMENTS);
        assert_eq!((m.positions.len(), m.triangles.len()), (193, 320));
        assert_eq!(m.positions[0], Vec3::ZERO, "vertex 0 is the floor's centre");
        let edges = directed_edges(&m, 0..m.triangles.len() as u32);
        for (&(u, v), &uses) in &edges {
            assert_eq!(uses, 1);
            if edges.get(&(v, u)) != Some(&1) {
                let (p, q) = (m.positions[u as usize], m.positions[v as usize]);
                let r = |p: Vec3| Vec3::new(p.x, 0.0, p.z).length();
                let outer = WELL_GROUND_RADII * a;
                assert!(
                    p.y == h && q.y == h && (r(p) - outer).abs() < 1e-5 && (r(q) - outer).abs() < 1e-5,
                    "open edge {p} -> {q} is not on the ground's outer edge"
                );
            }
        }
        // Floor and wall alone: closed except for the wall's top ring.
        let floor_wall = 0..object(&m, "wall").triangles.end;
        let fw = directed_edges(&m, floor_wall);
        let open = fw.keys().filter(|&&(u, v)| !fw.contains_key(&(v, u))).count();
        assert_eq!(open, WELL_SEGMENTS as usize);

        for name in ["floor", "ground"] {
            for t in object(&m, name).triangles.clone() {
                assert!(m.face_normal(t as usize).normalize().abs_diff_eq(Vec3::Y, 1e-6));
            }
        }
        for t in object(&m, "wall").triangles.clone() {
            let c = centroid(&m, t as usize);
            let n = m.face_normal(t as usize);
            assert!(
                n.y.abs() < 1e-6 && n.dot(Vec3::new(c.x, 0.0, c.z)) < 0.0,
                "wall faces the axis"
            );
        }
        // Quarter turns are exact.
        assert!(m.positions.contains(&Vec3::new(0.0, 0.0, a)));
        assert!(m.positions.contains(&Vec3::new(-a, h, 0.0)));
    }

    #[test]
    fn polygonal_well_accessibility_matches_quadrature_and_bound() {
        // Cosine-weighted visible fraction through the n-gon opening:
        // (1/2π) ∫ ρ²/(ρ² + h²) dψ, ρ(ψ) the opening's radius in direction
        // ψ; per edge ρ = apothem / cos ψ for ψ ∈ [-δ/2, δ/2]. Simpson's rule.
        let quadrature = |a: f64, h: f64, n: u32| {
            let delta = TAU / f64::from(n);
            let apothem = a * (delta / 2.0).cos();
            let f = |psi: f64| {
                let rho = apothem / psi.cos();
                rho * rho / (rho * rho + h * h)
            };
            let steps = 2000;
            let dx = delta / steps as f64;
            let sum: f64 = (0..=steps)
                .map(|i| {
                    let w = if i == 0 || i == steps {
                        1.0
                    } else if i % 2 == 1 {
                        4.0
                    } else {
                        2.0
                    };
                    w * f(-delta / 2.0 + i as f64 * dx)
                })
                .sum();
            f64::from(n) * sum * dx / 3.0 / TAU
        };
        for (a, h, n) in [(1.0, 2.0, 64), (1.0, 0.5, 8), (2.0, 1.0, 3), (0.3, 5.0, 100)] {
            let exact = well_floor_accessibility(a, h, n);
            let smooth = a * a / (a * a + h * h);
            assert!((exact - quadrature(a, h, n)).abs() < 1e-12, "{a} {h} {n}");
            let deficit = 1.0 - exact / smooth;
            let delta = TAU / f64::from(n);
            assert!(deficit > 0.0 && deficit < delta * delta / 6.0, "{a} {h} {n}: {deficit}");
        }
        let defaults = well_floor_accessibility(1.0, 2.0, 64);
        assert!((defaults - 0.199743).abs() < 1e-6, "{defaults}");
        assert!((1.0 - defaults / 0.2 - 2.0 * PI * PI / (3.0 * 64.0 * 64.0) * 0.8).abs() < 1e-5);
    }

    #[test]
    fn infinite_planes_face_the_right_way() {
        let m = wall_on_floor(INFINITE_EXTENT);
        assert_eq!((m.positions.len(), m.triangles.len()), (8, 4));
        for (name, normal) in [("floor", Vec3::Y), ("wall", Vec3::X)] {
            for t in object(&m, name).triangles.clone() {
                assert_eq!(m.face_normal(t as usize).normalize(), normal, "{name}");
            }
        }
        let e = INFINITE_EXTENT;
        assert_eq!(m.bounds().min, Vec3::new(0.0, 0.0, -e));
        assert_eq!(m.bounds().max, Vec3::new(e, e, e));

        let m = open_plane(INFINITE_EXTENT);
        assert_eq!((m.positions.len(), m.triangles.len()), (4, 2));
        for t in 0..2 {
            assert_eq!(m.face_normal(t).normalize(), Vec3::Y);
        }
        assert_eq!(m.bounds().min, Vec3::new(-e, 0.0, -e));
        assert_eq!(m.bounds().max, Vec3::new(e, 0.0, e));
    }

    #[test]
    fn every_scene_is_valid_and_round_trips_through_obj() {
        let names: Vec<_> = all_scenes().into_iter().map(|(name, _)| name).collect();
        assert_eq!(
            names,
            [
                "corner",
                "cube-with-hole",
                "sphere-on-plane",
                "closed-box",
                "cylindrical-well",
                "wall-on-floor",
                "open-plane"
            ]
        );
        for (name, mesh) in all_scenes() {
            mesh.validate().unwrap();
            assert_eq!(mesh.objects.first().unwrap().triangles.start, 0, "{name}");
            assert_eq!(
                mesh.objects.last().unwrap().triangles.end as usize,
                mesh.triangles.len()
            );
            assert!(
                mesh.objects
                    .windows(2)
                    .all(|w| w[0].triangles.end == w[1].triangles.start)
            );
            for t in 0..mesh.triangles.len() {
                assert!(mesh.face_normal(t).length() > 0.0, "{name}: triangle {t} has zero area");
            }
            let used = mesh
                .triangles
                .iter()
                .flatten()
                .collect::<std::collections::HashSet<_>>();
            assert_eq!(used.len(), mesh.positions.len(), "{name}: every vertex is used");
            for p in &mesh.positions {
                for c in p.to_array() {
                    assert!(!(c == 0.0 && c.is_sign_negative()), "{name}: -0 at {p}");
                }
            }
            let text = write_obj(&mesh, name);
            assert!(text.len() < 500_000, "{name}: {} bytes", text.len());
            assert_eq!(parse_obj(&text).unwrap(), mesh, "{name}");
        }
    }

    #[test]
    fn scenes_are_deterministic() {
        assert_eq!(all_scenes(), all_scenes());
    }

    /// The committed `assets/*.obj` are what the generator writes
    /// (regenerate them with `penumbra gen-assets --out assets`).
    #[test]
    fn assets_are_up_to_date() {
        let committed = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../assets"));
        let stale: Vec<String> = asset_files()
            .into_iter()
            .filter_map(|(name, fresh)| {
                // Tolerate a checkout that turned line ends into CRLF.
                let old = std::fs::read_to_string(committed.join(&name)).map(|s| s.replace("\r\n", "\n"));
                (old.ok().as_deref() != Some(fresh.as_str())).then_some(name)
            })
            .collect();
        assert!(
            stale.is_empty(),
            "assets/{stale:?} differ from the generator; regenerate with `penumbra gen-assets --out assets`"
        );
    }
}
