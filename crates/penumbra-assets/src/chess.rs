//! The chess-like scene of several independently moving objects (Kautz,
//! Lehtinen and Aila 2004, figure 4(c)-(d)), written by `penumbra
//! gen-assets` into `assets/chess/` (the meshes) and
//! `assets/scenes/chess.json` (the scene): a board and lathe-turned pieces
//! (pawn, rook, bishop), each a closed mesh of a few thousand triangles,
//! sliding, spinning and circling over the frames (`prt --scene`).
//!
//! Coordinates are rounded to 1e-4 so that the files do not depend on the
//! last bit of a math library's `sin`/`cos`.

use std::f64::consts::TAU;

use glam::Vec3;

use penumbra::scene::{Mesh, write_obj};

/// Segments around a piece's axis.
const SEGMENTS: u32 = 32;
/// Cells per side of the board's top.
const BOARD_CELLS: u32 = 40;

fn round(x: f64) -> f32 {
    ((x * 1e4).round() / 1e4) as f32
}

/// A closed solid of revolution about +y: `profile` is (radius, height)
/// from the bottom to the top; its first and last points on the axis
/// (radius 0) become single poles. Faces point outwards.
pub fn lathe(profile: &[(f64, f64)], segments: u32) -> Mesh {
    let profile = &refined(profile, 0.08);
    let n = segments;
    let mut positions = vec![Vec3::new(0.0, round(profile[0].1), 0.0)];
    let rings = &profile[1..profile.len() - 1];
    for &(r, y) in rings {
        for k in 0..n {
            let a = TAU * k as f64 / n as f64;
            positions.push(Vec3::new(round(r * a.cos()), round(y), round(r * a.sin())));
        }
    }
    let top = positions.len() as u32;
    positions.push(Vec3::new(0.0, round(profile[profile.len() - 1].1), 0.0));
    let at = |i: usize, k: u32| 1 + i as u32 * n + k % n;
    let mut triangles = Vec::new();
    for k in 0..n {
        triangles.push([0, at(0, k), at(0, k + 1)]);
        for i in 0..rings.len() - 1 {
            let (a, b, c, d) = (at(i, k), at(i, k + 1), at(i + 1, k + 1), at(i + 1, k));
            triangles.push([a, d, c]);
            triangles.push([a, c, b]);
        }
        triangles.push([top, at(rings.len() - 1, k + 1), at(rings.len() - 1, k)]);
    }
    Mesh::new(positions, triangles).expect("a lathe's indices are in range")
}

/// `profile` with points added along its long segments, so that no two
/// neighbouring rings are more than `step` apart.
fn refined(profile: &[(f64, f64)], step: f64) -> Vec<(f64, f64)> {
    let mut out = vec![profile[0]];
    for w in profile.windows(2) {
        let ((r0, y0), (r1, y1)) = (w[0], w[1]);
        let k = ((r1 - r0).hypot(y1 - y0) / step).ceil().max(1.0) as u32;
        out.extend((1..=k).map(|i| {
            let t = i as f64 / k as f64;
            (r0 + (r1 - r0) * t, y0 + (y1 - y0) * t)
        }));
    }
    out
}

/// Points of a circular arc about (0, `cy`) of radius `r` from `from` to
/// `to` degrees (0: outwards, 90: up), `steps` segments, ends included.
fn arc(cy: f64, r: f64, (from, to): (f64, f64), steps: u32) -> Vec<(f64, f64)> {
    (0..=steps)
        .map(|s| {
            let a = (from + (to - from) * s as f64 / steps as f64).to_radians();
            (r * a.cos(), cy + r * a.sin())
        })
        .collect()
}

/// The pieces' common foot: a disc of radius 0.36 with a rounded rim.
fn foot() -> Vec<(f64, f64)> {
    let mut p = vec![(0.0, 0.0), (0.36, 0.0)];
    p.extend(
        arc(0.07, 0.07, (-60.0, 90.0), 6)
            .into_iter()
            .map(|(r, y)| (0.31 + r, y)),
    );
    p.extend([(0.26, 0.16), (0.2, 0.2)]);
    p
}

/// A pawn, 1.0 high: foot, tapering stem, collar and ball.
pub fn pawn() -> Mesh {
    let mut p = foot();
    p.extend([
        (0.16, 0.3),
        (0.13, 0.46),
        (0.12, 0.54),
        (0.21, 0.57),
        (0.21, 0.61),
        (0.12, 0.65),
    ]);
    p.extend(arc(0.8, 0.18, (-56.0, 90.0), 14));
    p.last_mut().unwrap().0 = 0.0;
    lathe(&p, SEGMENTS)
}

/// A rook, 1.2 high: foot, thick waist, a turret hollowed at the top.
pub fn rook() -> Mesh {
    let mut p = foot();
    p.extend([(0.25, 0.3), (0.22, 0.55), (0.22, 0.8), (0.26, 0.86)]);
    p.extend([
        (0.3, 0.9),
        (0.31, 1.0),
        (0.31, 1.2),
        (0.22, 1.2),
        (0.2, 1.14),
        (0.1, 1.1),
        (0.0, 1.1),
    ]);
    lathe(&p, SEGMENTS)
}

/// A bishop, 1.6 high: foot, slender stem, collar, mitre and a small ball.
pub fn bishop() -> Mesh {
    let mut p = foot();
    p.extend([
        (0.15, 0.34),
        (0.11, 0.6),
        (0.1, 0.82),
        (0.2, 0.86),
        (0.2, 0.9),
        (0.11, 0.93),
    ]);
    p.extend(
        arc(1.15, 0.2, (-90.0, 70.0), 14)
            .into_iter()
            .skip(2)
            .map(|(r, y)| (r, 1.15 + (y - 1.15) * 1.4)),
    );
    p.extend(arc(1.53, 0.07, (-40.0, 90.0), 8));
    p.last_mut().unwrap().0 = 0.0;
    lathe(&p, SEGMENTS)
}

/// The board: a closed 8 x 0.25 x 8 slab, its top face (y = 0) a fine grid
/// of `BOARD_CELLS`² cells so that shadows land on vertices.
pub fn board() -> Mesh {
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    // Faces as (origin, u, v, cells along u and v): cross(u, v) points out.
    let (h, n) = (0.25f32, BOARD_CELLS);
    let faces = [
        (Vec3::new(-4.0, 0.0, -4.0), Vec3::Z * 8.0, Vec3::X * 8.0, n, n),
        (Vec3::new(-4.0, -h, -4.0), Vec3::X * 8.0, Vec3::Z * 8.0, 4, 4),
        (Vec3::new(-4.0, -h, -4.0), Vec3::Y * h, Vec3::X * 8.0, 2, n),
        (Vec3::new(-4.0, -h, 4.0), Vec3::X * 8.0, Vec3::Y * h, n, 2),
        (Vec3::new(-4.0, -h, -4.0), Vec3::Z * 8.0, Vec3::Y * h, n, 2),
        (Vec3::new(4.0, -h, -4.0), Vec3::Y * h, Vec3::Z * 8.0, 2, n),
    ];
    for (o, u, v, nu, nv) in faces {
        let first = positions.len() as u32;
        for j in 0..=nv {
            for i in 0..=nu {
                let p = o + u * (i as f32 / nu as f32) + v * (j as f32 / nv as f32);
                positions.push(p.map(|c| round(c as f64)));
            }
        }
        let at = |i: u32, j: u32| first + j * (nu + 1) + i;
        for j in 0..nv {
            for i in 0..nu {
                triangles.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
                triangles.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
            }
        }
    }
    Mesh::new(positions, triangles).expect("the board's indices are in range")
}

/// The scene file: where each piece stands and how it moves per frame.
const SCENE: &str = r#"{
  "meshes": {
    "board": "../chess/board.obj",
    "pawn": "../chess/pawn.obj",
    "rook": "../chess/rook.obj",
    "bishop": "../chess/bishop.obj"
  },
  "instances": [
    { "name": "board", "mesh": "board" },
    { "name": "pawn-sliding", "mesh": "pawn", "translate": [-1.5, 0, -2.5],
      "motion": { "axis": [0, 1, 0], "degrees_per_frame": 0, "translate_per_frame": [0, 0, 0.05] } },
    { "name": "pawn-spinning", "mesh": "pawn", "translate": [1.5, 0, -1.5],
      "motion": { "axis": [0, 1, 0], "degrees_per_frame": 6, "translate_per_frame": [-0.03, 0, 0.02] } },
    { "name": "rook-circling", "mesh": "rook", "translate": [2.5, 0, 1.5],
      "motion": { "axis": [0, 1, 0], "degrees_per_frame": 4, "pivot": [0, 0, 0] } },
    { "name": "bishop-gliding", "mesh": "bishop", "translate": [-2.0, 0.3, 1.0],
      "rotate": { "axis": [0, 0, 1], "degrees": -10 },
      "motion": { "axis": [0, 1, 0], "degrees_per_frame": 0, "translate_per_frame": [0.04, 0, 0] } }
  ],
  "camera": { "eye": [5.5, 6, 7.5], "target": [0, 0.3, 0], "fov": 42 }
}
"#;

/// The files of the chess-like scene, as `penumbra gen-assets` writes them
/// under its output folder: the meshes (`chess/<piece>.obj`) and the scene
/// (`scenes/chess.json`).
pub fn chess_files() -> Vec<(String, String)> {
    let mut files = Vec::new();
    for (name, mesh) in [
        ("board", board()),
        ("pawn", pawn()),
        ("rook", rook()),
        ("bishop", bishop()),
    ] {
        let header = format!(
            "{name}.obj: a piece of the chess-like scene, generated by `penumbra gen-assets` \
             (crates/penumbra-assets/src/chess.rs); do not hand-edit.\n{} vertices, {} triangles",
            mesh.positions.len(),
            mesh.triangles.len()
        );
        files.push((format!("chess/{name}.obj"), write_obj(&mesh, &header)));
    }
    files.push(("scenes/chess.json".to_string(), SCENE.to_string()));
    files
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Closed and outward: every edge is shared by two triangles in
    /// opposite directions, and the signed volume is positive.
    fn closed_outward(m: &Mesh) {
        let mut edges = std::collections::HashMap::new();
        let mut volume = 0.0f64;
        for t in &m.triangles {
            for k in 0..3 {
                *edges.entry((t[k], t[(k + 1) % 3])).or_insert(0) += 1;
            }
            let [a, b, c] = t.map(|i| m.positions[i as usize].as_dvec3());
            volume += a.dot(b.cross(c)) / 6.0;
        }
        assert!(volume > 0.0, "faces point inwards");
        for (&(a, b), &n) in &edges {
            assert_eq!(n, 1, "edge {a}-{b} repeated");
            assert!(edges.contains_key(&(b, a)), "edge {a}-{b} is a boundary");
        }
    }

    #[test]
    fn pieces_are_closed_and_face_outwards() {
        for m in [pawn(), rook(), bishop()] {
            closed_outward(&m);
            assert!((1500..4000).contains(&m.triangles.len()), "{}", m.triangles.len());
        }
    }
}
