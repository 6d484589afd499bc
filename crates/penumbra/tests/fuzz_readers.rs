//! Fuzzing every file reader, on stable Rust with `proptest`.
//!
//! Readers: OBJ (`parse_obj`, `parse_obj_file`, `load_obj`, `load_obj_file`,
//! and the `ObjFile::shading_normals` a shaded scene computes), MTL
//! (`parse_mtl`, `load_mtl`), scene JSON (`load_scene`, `load_scene_shaded`),
//! `.dfield` (`field::file::from_bytes`, `read`), HDR probes
//! (`EnvironmentMap::load`), ray files (`read_rays`), camera paths
//! (`CameraPath::parse`, `load`), PLY (`parse_ply`, `load_ply`, and
//! `load_mesh`, `load_mesh_file` of a `.ply`) and GLB (`load_gltf`, and
//! `load_mesh`, `load_mesh_file` of a `.glb`).
//!
//! Inputs come from two kinds of strategy per reader. Mutations of seeds:
//! the shipped assets (`assets/`, `tests/data/mtl/`), small files built here
//! (fields from `DisplacementField::build`, probes from image's `HdrEncoder`
//! and by hand in old-style RLE, ray records, PLY and GLB files from
//! `tests/mesh_formats/write.rs`) and "heavy" files, each at the
//! worst cost in memory per input byte of one statement (a 30,000-corner
//! polygon, thousands of unknown keywords, materials, warnings, instances,
//! the densest RLE the HDR reader admits); edits are byte flips, insertions
//! (random bytes and format tokens), deletions, truncation, duplicated,
//! swapped and deleted lines, 32-bit words overwritten (binary formats) and
//! number tokens replaced by extremes (1e39, -0, nan, inf, 4294967297,
//! -99999999999, hundreds of digits...); a GLB's JSON chunk is also edited
//! as text and rewrapped with its chunk lengths right. And structured generators of
//! statements, headers and records, each file with a "wildness" (0, 1%, 5%
//! or 30% of its values malformed or extreme) so that both the Ok paths and
//! every check get exercised. Case counts are fixed and each test has its
//! own fixed seed (ChaCha), so CI runs the same cases every time;
//! `PENUMBRA_FUZZ_CASES=N` runs N cases per test instead, for a deeper run.
//!
//! Properties, for every input:
//!
//! 1. No panic and no hang: each case runs on a thread of its own under
//!    `catch_unwind`, and must answer within 5 s.
//! 2. Ok results are finite and consistent. Meshes: positions finite,
//!    indices in range, objects covering the triangles; per-face arrays as
//!    long as the triangles, their indices in range; shading normals finite
//!    and unit. Materials: colours finite and not negative, Ns not negative,
//!    Ni positive, d in [0, 1], illum at most 10. Scenes: transforms,
//!    motions, cameras (valid), lights, spheres, ambient and background
//!    finite. Fields: sphere and bounds finite, radius positive, maps of the
//!    declared size with distances in [0, 1]. Probes: a 2:1 grid of finite,
//!    non-negative texels. Rays: one per 24 bytes, finite, directions not
//!    zero. Camera paths: keyframes valid (finite, eye != target, fov in
//!    (0, 180)), interpolated frames finite.
//! 3. Errors are bad input with a non-empty source and problem. The file
//!    forms name the file: the path read (`load_obj`, `load_mtl`,
//!    `field::file::read`, `read_rays`, `EnvironmentMap::load`,
//!    `CameraPath::load`, `load_ply`, `load_gltf`, `load_mesh`), or the file at fault by its absolute path
//!    (`load_obj_file`: the OBJ or an MTL file; scenes: the scene, or an OBJ,
//!    MTL or probe it names). File and text forms agree (`load_obj` =
//!    `parse_obj`, `load_mtl` = `parse_mtl`, `read` = `from_bytes`,
//!    `load_ply` = `load_mesh(_file)` of a `.ply` = `parse_ply`,
//!    `load_mesh(_file)` of a `.glb` = `load_gltf`).
//! 4. Allocation is bounded: a counting global allocator keeps, per thread,
//!    the bytes allocated and their peak (a `realloc` counts old and new
//!    block), and the peak while one reader runs must stay below
//!    `factor x input bytes + constant`. Input bytes: the file or text read;
//!    for scenes, plus each mesh and probe file it names, once per mention
//!    (the OBJ, MTL and probe files cases refer to are tiny and fixed).
//!
//!    | reader | factor | constant | worst measured | why |
//!    |---|---:|---:|---:|---|
//!    | OBJ | 64 | 1 MiB | 53.0 | `f 1 2 3 ...`: 2 bytes a corner (8) and a triangle (12 + 32 per face), Vecs double |
//!    | MTL | 64 | 256 KiB | 41.8 | `newmtl ab`: 10 bytes a material (104 bytes), its name hashed, Vecs doubling |
//!    | scene | 64 | 1 MiB | 34.4 | JSON values, each `meshes` entry an OBJ read (and shaded) |
//!    | .dfield | 3 | 64 KiB | 2.0 | the file read, and maps decoded to their own size |
//!    | HDR | 1536 | 1 MiB | 1549 | the reader admits 64 pixels a byte, 12 bytes a pixel, twice (image, texels) |
//!    | rays | 3 | 64 KiB | 2.0 | the file read, and 24 bytes a ray |
//!    | camera path | 16 | 64 KiB | 6.6 | 28 bytes a key for a 14-byte line, Vecs doubling |
//!    | PLY | 64 | 1 MiB | 44.6 | a binary polygon of uchar indices: a triangle (12 bytes) and its face (4) per index byte, Vecs doubling |
//!    | GLB | 128 | 1 MiB | 71.6 | a strip of u8 indices: a triangle a byte, with its corner normals, smoothing, material and face (36 bytes), Vecs doubling |
//!
//!    ("Worst measured": peak bytes per input byte over inputs of 4 KiB or
//!    more, printed by each test; HDR's includes its constant.) A single
//!    allocation above 1 GiB on a fuzzing thread is refused, which aborts
//!    with a message rather than exhausting memory.
//!
//! A failing case is shrunk, saved to
//! `target/tmp/fuzz-failures/<reader>/<hash>`, and reported with a preview.
//! Once the reader is fixed, the file goes to `tests/regressions/<reader>/`
//! (reader: `obj`, `mtl`, `scene`, `dfield`, `hdr`, `rays`, `camera_path`,
//! `ply`, `glb`):
//! `regressions_replay` runs every file there through the same checks.
//!
//! The harness is in `fuzz_readers/`: `allocation.rs` (the counting
//! allocator), `harness.rs` (budgets, isolation, the driver, the checks of
//! errors, seeds and regressions replayed), `inputs.rs` (edits and value
//! generators), and a file per reader with its seeds, check and generators.

mod common;

#[path = "fuzz_readers/allocation.rs"]
mod allocation;
#[path = "fuzz_readers/camera_path.rs"]
mod camera_path;
#[path = "fuzz_readers/dfield.rs"]
mod dfield;
#[path = "fuzz_readers/glb.rs"]
mod glb;
#[path = "fuzz_readers/harness.rs"]
mod harness;
#[path = "fuzz_readers/hdr.rs"]
mod hdr;
#[path = "fuzz_readers/inputs.rs"]
mod inputs;
#[path = "fuzz_readers/mtl.rs"]
mod mtl;
#[path = "fuzz_readers/obj.rs"]
mod obj;
#[path = "fuzz_readers/ply.rs"]
mod ply;
#[path = "fuzz_readers/rays.rs"]
mod rays;
#[path = "fuzz_readers/scene.rs"]
mod scene;
#[path = "mesh_formats/write.rs"]
mod write;

use penumbra::field::file;
use penumbra::io::rays::read_rays;
use penumbra::scene::{CameraPath, EnvironmentMap, load_gltf, load_scene_shaded, parse_mtl, parse_obj_file, parse_ply};

use camera_path::CAMERA_PATH;
use dfield::DFIELD;
use glb::GLB;
use harness::{assert_seeds_accepted, fuzz, replay_regressions};
use hdr::HDR;
use inputs::{binary_edit, mutated, text_edit};
use mtl::MTL;
use obj::OBJ;
use ply::PLY;
use rays::RAYS;
use scene::SCENE;

#[test]
fn obj_mutated_seeds() {
    fuzz("obj_mutated_seeds", &OBJ, 768, mutated(obj::seeds(), text_edit(), 6));
}

#[test]
fn obj_structured() {
    fuzz("obj_structured", &OBJ, 768, obj::text());
}

#[test]
fn mtl_mutated_seeds() {
    fuzz("mtl_mutated_seeds", &MTL, 768, mutated(mtl::seeds(), text_edit(), 6));
}

#[test]
fn mtl_structured() {
    fuzz("mtl_structured", &MTL, 768, mtl::text());
}

#[test]
fn scene_mutated_seeds() {
    fuzz(
        "scene_mutated_seeds",
        &SCENE,
        512,
        mutated(scene::seeds(), text_edit(), 6),
    );
}

#[test]
fn scene_structured() {
    fuzz("scene_structured", &SCENE, 512, scene::text());
}

#[test]
fn dfield_mutated_seeds() {
    fuzz("dfield_mutated_seeds", &DFIELD, 768, dfield::mutations());
}

#[test]
fn dfield_structured_headers() {
    fuzz("dfield_structured_headers", &DFIELD, 768, dfield::structured());
}

#[test]
fn hdr_mutated_seeds() {
    fuzz("hdr_mutated_seeds", &HDR, 512, mutated(hdr::seeds(), binary_edit(), 4));
}

#[test]
fn hdr_structured_headers() {
    fuzz("hdr_structured_headers", &HDR, 768, hdr::structured());
}

#[test]
fn rays_mutated_seeds() {
    fuzz(
        "rays_mutated_seeds",
        &RAYS,
        512,
        mutated(rays::seeds(), binary_edit(), 4),
    );
}

#[test]
fn rays_structured_records() {
    fuzz("rays_structured_records", &RAYS, 768, rays::structured());
}

#[test]
fn camera_path_mutated_seeds() {
    fuzz(
        "camera_path_mutated_seeds",
        &CAMERA_PATH,
        768,
        mutated(camera_path::seeds(), text_edit(), 6),
    );
}

#[test]
fn camera_path_structured() {
    fuzz("camera_path_structured", &CAMERA_PATH, 768, camera_path::text());
}

#[test]
fn ply_mutated_text() {
    fuzz("ply_mutated_text", &PLY, 512, mutated(ply::seeds(true), text_edit(), 6));
}

#[test]
fn ply_mutated_binary() {
    fuzz(
        "ply_mutated_binary",
        &PLY,
        512,
        mutated(ply::seeds(false), binary_edit(), 4),
    );
}

#[test]
fn ply_structured() {
    fuzz("ply_structured", &PLY, 768, ply::structured());
}

#[test]
fn glb_mutated_bytes() {
    fuzz("glb_mutated_bytes", &GLB, 512, glb::mutated_bytes());
}

#[test]
fn glb_mutated_json() {
    fuzz("glb_mutated_json", &GLB, 768, glb::mutated_json());
}

/// The seeds are inputs the readers accept (so mutations start from valid
/// files), and they pass every check unmutated.
#[test]
fn seeds_are_accepted() {
    let lossy = |b: &[u8]| String::from_utf8_lossy(b).into_owned();
    assert_seeds_accepted(&OBJ, obj::seeds(), |dir, b| {
        parse_obj_file(&lossy(b), Some(dir)).is_ok()
    });
    assert_seeds_accepted(&MTL, mtl::seeds(), |_, b| parse_mtl(&lossy(b), &mut Vec::new()).is_ok());
    assert_seeds_accepted(&CAMERA_PATH, camera_path::seeds(), |_, b| {
        CameraPath::parse(&lossy(b)).is_ok()
    });
    assert_seeds_accepted(&DFIELD, dfield::seeds(), |_, b| file::from_bytes(b).is_ok());
    let ply_seeds = [ply::seeds(true), ply::seeds(false)].concat();
    assert_seeds_accepted(&PLY, ply_seeds, |_, b| parse_ply(b).is_ok());
    assert_seeds_accepted(&GLB, glb::seeds(), |dir, b| {
        std::fs::write(dir.join("seed.glb"), b).is_ok() && load_gltf(&dir.join("seed.glb")).is_ok()
    });
    assert_seeds_accepted(&RAYS, rays::seeds().split_off(1), |dir, b| {
        std::fs::write(dir.join("seed.f32"), b).is_ok() && read_rays(&dir.join("seed.f32")).is_ok()
    });
    // All but the square probe, the bare header and the +Y one.
    let probes = hdr::seeds()
        .into_iter()
        .enumerate()
        .filter(|(i, _)| ![4, 8, 9].contains(i))
        .map(|(_, p)| p)
        .collect();
    assert_seeds_accepted(&HDR, probes, |dir, b| {
        std::fs::write(dir.join("seed.hdr"), b).is_ok() && EnvironmentMap::load(&dir.join("seed.hdr")).is_ok()
    });
    // The scenes of the shared data set name meshes that are missing here.
    let scenes: Vec<Vec<u8>> = scene::seeds()
        .into_iter()
        .filter(|s| !s.windows(7).any(|w| w == b"../data"))
        .collect();
    assert!(scenes.len() >= 12, "{} scene seeds load", scenes.len());
    assert_seeds_accepted(&SCENE, scenes, |dir, b| {
        let path = dir.join("s").join("seed.json");
        std::fs::write(&path, b).is_ok() && load_scene_shaded(&path).is_ok()
    });
}

/// Every input under `tests/regressions/<reader>/` passes its reader's
/// checks; the folders are named after readers.
#[test]
fn regressions_replay() {
    replay_regressions(&[&OBJ, &MTL, &SCENE, &DFIELD, &HDR, &RAYS, &CAMERA_PATH, &PLY, &GLB]);
}
