//! Baking AO into an asset: the texture covers the UV layout and agrees
//! with per-vertex AO where a corner's UV meets its vertex, the GLB reads
//! back (by penumbra and by the `gltf` crate) with the same triangles, the
//! occlusion texture and `_AO`, a rerun gives the same bytes, a glTF input
//! keeps what it had, a mesh without UVs is refused, and the GPU bakes as
//! the CPU does.

mod common;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use penumbra::bake::{BakeSettings, bake};
use penumbra::gpu::device::Device;
use penumbra::progress::Reporter;
use penumbra::raycast::AoSettings;
use penumbra::scene::load_mesh_file;

fn folder(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("penumbra-bake-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A floor of 4x4 quads over [-1, 1]^2 (UVs over the whole square) with a
/// box standing on it (its faces in a strip of charts on the right): a UV
/// layout with seams, concave corners and open floor.
fn scene_obj(dir: &Path, with_uv: bool) -> PathBuf {
    let mut obj = String::new();
    let n = 5;
    for j in 0..n {
        for i in 0..n {
            let (x, y) = (-1.0 + 0.5 * i as f32, -1.0 + 0.5 * j as f32);
            writeln!(obj, "v {x} 0 {y}").unwrap();
            writeln!(obj, "vt {} {}", 0.5 * i as f32 / 4.0, j as f32 / 4.0).unwrap();
        }
    }
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let a = j * n + i + 1;
            let q = [a, a + n, a + n + 1, a + 1];
            let f: Vec<String> = q
                .iter()
                .map(|&v| if with_uv { format!("{v}/{v}") } else { format!("{v}") })
                .collect();
            writeln!(obj, "f {}", f.join(" ")).unwrap();
        }
    }
    // A box 0.6 wide and tall, just off the floor (a vertex on another
    // surface has no well-defined AO): four sides, each its own chart.
    let base = n * n;
    let (lo, hi, h) = (-0.3f32, 0.3f32, 0.6f32);
    let corners = [(lo, lo), (hi, lo), (hi, hi), (lo, hi)];
    for &(x, z) in &corners {
        writeln!(obj, "v {x} 0.02 {z}\nv {x} {h} {z}").unwrap();
    }
    for k in 0..4 {
        let u0 = 0.55 + 0.1 * k as f32;
        writeln!(
            obj,
            "vt {u0} 0.1\nvt {} 0.1\nvt {} 0.9\nvt {u0} 0.9",
            u0 + 0.08,
            u0 + 0.08
        )
        .unwrap();
    }
    for k in 0..4 {
        let (a, b) = (base + 2 * k + 1, base + 2 * ((k + 1) % 4) + 1);
        let t = base + 4 * k + 1;
        // Outward: bottom a, bottom b, top b, top a.
        let f = [(a, t), (a + 1, t + 3), (b + 1, t + 2), (b, t + 1)];
        let f: Vec<String> = f
            .iter()
            .map(|&(v, vt)| if with_uv { format!("{v}/{vt}") } else { format!("{v}") })
            .collect();
        writeln!(obj, "f {}", f.join(" ")).unwrap();
    }
    let path = dir.join(if with_uv { "scene.obj" } else { "bare.obj" });
    std::fs::write(&path, obj).unwrap();
    path
}

fn settings(resolution: u32, rays: u32) -> BakeSettings {
    BakeSettings {
        resolution,
        ao: AoSettings {
            rays_per_point: rays,
            ..Default::default()
        },
        ..Default::default()
    }
}

/// Bilinear lookup of `texture` (rows from the top) at (u, v), v up.
fn lookup(texture: &[Option<f32>], n: u32, u: f32, v: f32) -> f32 {
    let (x, y) = (u * n as f32 - 0.5, (1.0 - v) * n as f32 - 0.5);
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let at = |i: f32, j: f32| {
        let (i, j) = ((i as i64).clamp(0, n as i64 - 1), (j as i64).clamp(0, n as i64 - 1));
        texture[(j * n as i64 + i) as usize].unwrap_or(1.0)
    };
    (at(x0, y0) * (1.0 - fx) + at(x0 + 1.0, y0) * fx) * (1.0 - fy)
        + (at(x0, y0 + 1.0) * (1.0 - fx) + at(x0 + 1.0, y0 + 1.0) * fx) * fy
}

#[test]
fn the_texture_at_each_corner_agrees_with_that_vertex_ao() {
    let dir = folder("corners");
    let path = scene_obj(&dir, true);
    let baked = bake(&Device::cpu(), &path, &settings(256, 512), &Reporter::silent()).unwrap();
    let texture = baked.texture.as_ref().unwrap();
    let vertex = baked.vertex_ao.as_ref().unwrap();
    let file = load_mesh_file(&path).unwrap();
    let mut diffs = Vec::new();
    for (t, tri) in file.mesh.triangles.iter().enumerate() {
        for k in 0..3 {
            let uv = file.texcoords[file.corner_texcoords[t][k] as usize];
            diffs.push((lookup(texture, 256, uv.x, uv.y) - vertex[tri[k] as usize]).abs());
        }
    }
    diffs.sort_by(f32::total_cmp);
    let mean = diffs.iter().sum::<f32>() / diffs.len() as f32;
    let p95 = diffs[diffs.len() * 95 / 100];
    println!(
        "texture vs vertex AO at {} corners: mean |d| {mean}, p95 {p95}",
        diffs.len()
    );
    // 512 rays: one standard deviation is at most 0.022. At a chart's
    // corner the bilinear lookup takes three quarters of its weight from
    // texels off the corner (padding or the chart's inside), where AO
    // changes fast (the box's foot): the tail is wider than the noise.
    assert!(mean < 0.03 && p95 < 0.2, "mean {mean}, p95 {p95}");
    let r = &baked.report;
    assert!(r.texels_covered > 256 * 256 / 2, "{r:?}");
    assert_eq!(r.overlapping_samples, 0);
    assert!(r.texels_padded > 0);
    // The floor is open far from the box and shaded at its foot.
    let far = lookup(texture, 256, 0.02, 0.02);
    let foot = lookup(texture, 256, 0.5 * 0.35, 0.5);
    println!("floor AO far {far}, at the box's foot {foot}");
    assert!(far > 0.9 && foot < far - 0.1);
}

#[test]
fn the_glb_reads_back_with_its_triangles_occlusion_texture_and_ao_and_a_rerun_is_identical() {
    let dir = folder("glb");
    let path = scene_obj(&dir, true);
    let s = settings(64, 32);
    let baked = bake(&Device::cpu(), &path, &s, &Reporter::silent()).unwrap();
    let again = bake(&Device::cpu(), &path, &s, &Reporter::silent()).unwrap();
    assert_eq!(baked.glb, again.glb, "a rerun writes the same bytes");
    let out = dir.join("baked.glb");
    std::fs::write(&out, &baked.glb).unwrap();
    let ours = load_mesh_file(&out).unwrap();
    let input = load_mesh_file(&path).unwrap();
    assert_eq!(ours.mesh.triangles.len(), input.mesh.triangles.len());
    let doc = gltf::Gltf::from_slice(&baked.glb).expect("the gltf crate reads the GLB");
    let material = doc.materials().next().unwrap();
    let occlusion = material.occlusion_texture().expect("an occlusion texture");
    assert_eq!(occlusion.texture().source().map(|i| i.index()), Some(0));
    let primitive = doc.meshes().next().unwrap().primitives().next().unwrap();
    let ao = doc.as_json().meshes[0].primitives[0]
        .attributes
        .iter()
        .find(|(s, _)| s.to_string() == "_AO")
        .map(|(_, a)| a.value())
        .expect("_AO");
    let count = |i: usize| doc.accessors().nth(i).unwrap().count();
    assert_eq!(count(ao), primitive.get(&gltf::Semantic::Positions).unwrap().count());

    // Baked again from the GLB: what it had is kept, its occlusion texture
    // replaced only on request.
    let kept = bake(&Device::cpu(), &out, &s, &Reporter::silent()).unwrap();
    assert!(
        kept.warnings.iter().any(|w| w.contains("own occlusionTexture")),
        "{:?}",
        kept.warnings
    );
    assert_eq!(kept.report.materials_with_ao, 0);
    let replaced = bake(
        &Device::cpu(),
        &out,
        &BakeSettings { replace: true, ..s },
        &Reporter::silent(),
    )
    .unwrap();
    assert_eq!(replaced.report.materials_with_ao, 1);
    let doc2 = gltf::Gltf::from_slice(&replaced.glb).unwrap();
    assert_eq!(doc2.images().count(), 2, "the first AO image stays, unreferenced");
    let t = doc2.materials().next().unwrap().occlusion_texture().unwrap().texture();
    assert_eq!(t.source().map(|i| i.index()), Some(1), "the new one is the material's");
    let p2 = doc2.meshes().next().unwrap().primitives().next().unwrap();
    for semantic in [gltf::Semantic::Normals, gltf::Semantic::TexCoords(0)] {
        assert!(p2.get(&semantic).is_some(), "{semantic:?} kept");
    }
    let back = {
        let f = dir.join("twice.glb");
        std::fs::write(&f, &replaced.glb).unwrap();
        load_mesh_file(&f).unwrap()
    };
    assert_eq!(
        back.mesh.positions, ours.mesh.positions,
        "the geometry travels unchanged"
    );
}

#[test]
fn a_mesh_without_uvs_is_refused_for_a_texture_and_bakes_vertices_alone() {
    let dir = folder("bare");
    let path = scene_obj(&dir, false);
    let e = bake(&Device::cpu(), &path, &settings(64, 16), &Reporter::silent()).unwrap_err();
    let text = e.to_string();
    assert!(
        text.contains("bare.obj") && text.contains("texture coordinates"),
        "{text}"
    );
    let vertices = bake(&Device::cpu(), &path, &settings(0, 16), &Reporter::silent()).unwrap();
    assert!(vertices.png.is_none() && vertices.vertex_ao.is_some());
}

#[test]
fn the_gpu_bakes_the_texture_as_the_cpu() {
    let Some(ctx) = common::gpu() else {
        return;
    };
    let dir = folder("gpu");
    let path = scene_obj(&dir, true);
    let s = settings(64, 128);
    let cpu = bake(&Device::cpu(), &path, &s, &Reporter::silent()).unwrap();
    let gpu = bake(&Device::gpu(ctx), &path, &s, &Reporter::silent()).unwrap();
    let (a, b) = (cpu.texture.unwrap(), gpu.texture.unwrap());
    let diffs: Vec<f32> = a
        .iter()
        .zip(&b)
        .filter_map(|(x, y)| Some((x.as_ref()? - y.as_ref()?).abs()))
        .collect();
    let worst = diffs.iter().copied().fold(0.0, f32::max);
    let off = diffs.iter().filter(|&&d| d > 0.0).count();
    // The trees differ (the GPU's leaves are smaller): a ray grazing an
    // edge may count on one side only; 2 rays of 128 at most.
    println!(
        "CPU vs GPU texels: {off} of {} differ, worst {worst} (tolerance 2/128)",
        diffs.len()
    );
    assert!(worst <= 2.0 / 128.0);
}

/// A floor and a box of their own files, placed by a scene file: each
/// baked with the other occluding it.
#[test]
fn a_scene_bakes_each_mesh_with_the_others_as_occluders() {
    let dir = folder("scene");
    std::fs::write(
        dir.join("floor.obj"),
        "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 4/4 3/3 2/2\n",
    )
    .unwrap();
    // A unit cube (outward faces), its own UVs per face.
    let mut cube = String::new();
    for z in [-0.5f32, 0.5] {
        for y in [-0.5f32, 0.5] {
            for x in [-0.5f32, 0.5] {
                writeln!(cube, "v {x} {y} {z}").unwrap();
            }
        }
    }
    cube.push_str("vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n");
    for f in [
        [1, 3, 4, 2],
        [5, 6, 8, 7],
        [1, 2, 6, 5],
        [3, 7, 8, 4],
        [1, 5, 7, 3],
        [2, 4, 8, 6],
    ] {
        writeln!(cube, "f {}/1 {}/2 {}/3 {}/4", f[0], f[1], f[2], f[3]).unwrap();
    }
    std::fs::write(dir.join("box.obj"), cube).unwrap();
    let scene_file = dir.join("scene.json");
    std::fs::write(
        &scene_file,
        r#"{"meshes": {"floor": "floor.obj", "box": "box.obj"},
            "instances": [{"mesh": "floor"}, {"mesh": "box", "translate": [0, 0.27, 0], "scale": 0.5}]}"#,
    )
    .unwrap();
    let scene = penumbra::scene::load_scene_shaded(&scene_file).unwrap();
    let baked = penumbra::bake::bake_scene(&Device::cpu(), &scene, &settings(64, 128), &Reporter::silent()).unwrap();
    assert_eq!(baked.len(), 2);
    let floor = baked.iter().find(|b| b.name == "floor").unwrap();
    let texture = floor.baked.texture.as_ref().unwrap();
    let (centre, edge) = (lookup(texture, 64, 0.5, 0.5), lookup(texture, 64, 0.02, 0.02));
    println!("floor AO under the box {centre}, at the edge {edge}");
    assert!(centre < 0.2 && edge > 0.9, "the box shades the floor under it");
    // Baked alone, the floor is open everywhere.
    let alone = bake(
        &Device::cpu(),
        &dir.join("floor.obj"),
        &settings(64, 128),
        &Reporter::silent(),
    )
    .unwrap();
    assert!(alone.texture.unwrap().iter().flatten().all(|&a| a == 1.0));
}

#[test]
fn max_error_picks_fewer_rays_for_a_looser_budget() {
    let dir = folder("budget");
    let path = scene_obj(&dir, true);
    let with = |e: f64| {
        let s = BakeSettings {
            max_error: Some(e),
            ..settings(64, 256)
        };
        bake(&Device::cpu(), &path, &s, &Reporter::silent()).unwrap().report
    };
    let (tight, loose) = (with(0.02), with(0.05));
    let (t, l) = (tight.budget.unwrap(), loose.budget.unwrap());
    println!(
        "budget 0.02: {} rays (estimate {}), 0.05: {} rays (estimate {})",
        t.rays, t.estimated_error, l.rays, l.estimated_error
    );
    assert!(t.rays > l.rays);
    assert!(t.estimated_error <= 0.02 && l.estimated_error <= 0.05);
    assert_eq!(tight.rays_per_point, t.rays);
    assert!(t.probe_points > 100);
}
