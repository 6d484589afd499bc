//! Output formats, read back: linear `.exr`/`.pfm` beside PNG (the same
//! values), 16-bit AO PNG, the AO image's background, image formats
//! refused before any work, per-vertex AO as PLY vertex colours, the
//! near-zero AO warning, and prt's `--sh-out`, `--per-vertex` and
//! per-frame `--out`.

mod common;

use common::cli::{TempDir, asset_s, cmd, pen, run, write_probe};
use glam::{DVec3, Vec3};
use penumbra::geom::color::srgb8;
use penumbra::io::image::read_pfm;
use penumbra::scene::{load_mesh, load_ply};
use penumbra::sh::ShBasis;
use serde_json::Value;

const AO: &str = "ao --mesh {mesh} --method raycast --rays 16 --width 40 --height 30 --device cpu --json";

/// An image as RGBA f32 (EXR) or its grey values and alpha (PNG, any depth).
fn exr(path: &str) -> Vec<[f32; 4]> {
    image::open(path)
        .unwrap()
        .into_rgba32f()
        .pixels()
        .map(|p| p.0)
        .collect()
}

fn png16(path: &str) -> Vec<[u16; 2]> {
    image::open(path)
        .unwrap()
        .into_luma_alpha16()
        .pixels()
        .map(|p| p.0)
        .collect()
}

/// The same AO image as 8-bit PNG, 16-bit PNG, EXR and PFM: PNG values are
/// the float values rounded to 255 or 65535 steps, PFM holds the EXR's;
/// the background is opaque black by default, transparent when asked.
#[test]
fn ao_image_in_every_format_holds_the_same_values() {
    let d = TempDir::new("out-ao-formats");
    let mesh = asset_s("sphere-on-plane.obj");
    let run = |name: &str, extra: &str| -> Value {
        let path = d.p(name);
        pen(
            &format!("{AO} --image {{img}} {extra}"),
            &[("mesh", &mesh), ("img", &path)],
        )
        .ok()
        .json()
    };
    let j = run("a.exr", "");
    let hit = j["image"]["pixels_hit"].as_u64().unwrap() as usize;
    assert!(
        hit > 100 && hit < 40 * 30,
        "the view shows surface and background: {hit}"
    );
    run("a.png", "");
    run("a16.png", "--png-bits 16");
    run("a.pfm", "");
    run("t.png", "--background transparent");
    run("t.exr", "--background transparent");
    let float = exr(&d.p("a.exr"));
    assert!(float.iter().all(|p| p[3] == 1.0 && p[0] == p[1] && p[1] == p[2]));
    let img8 = image::open(d.p("a.png")).unwrap();
    assert_eq!(img8.color(), image::ColorType::L8, "opaque grey by default");
    let img16 = image::open(d.p("a16.png")).unwrap();
    assert_eq!(img16.color(), image::ColorType::L16);
    for ((f, p8), p16) in float.iter().zip(img8.to_luma8().pixels()).zip(png16(&d.p("a16.png"))) {
        assert_eq!(p8.0[0], (f[0].clamp(0.0, 1.0) * 255.0).round() as u8);
        assert_eq!(p16[0], (f[0].clamp(0.0, 1.0) * 65535.0).round() as u16);
    }
    let (w, h, pfm) = read_pfm(std::path::Path::new(&d.p("a.pfm"))).unwrap();
    assert_eq!((w, h), (40, 30));
    for (f, p) in float.iter().zip(&pfm) {
        assert_eq!(*p, Vec3::splat(f[0]));
    }
    // Transparent: alpha 0 exactly where no surface is, in PNG and EXR.
    let covered = |alpha: Vec<bool>| alpha.iter().filter(|a| **a).count();
    let t8 = png16(&d.p("t.png"));
    assert_eq!(covered(t8.iter().map(|p| p[1] == 65535).collect()), hit);
    assert!(t8.iter().all(|p| p[1] == 65535 || p[1] == 0));
    let t32 = exr(&d.p("t.exr"));
    assert_eq!(covered(t32.iter().map(|p| p[3] == 1.0).collect()), hit);
    let opaque_black = float
        .iter()
        .zip(&t32)
        .filter(|(_, t)| t[3] == 0.0)
        .all(|(f, _)| f[0] == 0.0);
    assert!(opaque_black, "the opaque background is 0");
}

/// An unknown or unsuitable image name: exit 2 naming the option, the file
/// and the formats accepted, before any work (the mesh is not even read:
/// it does not exist), and no file left behind.
#[test]
fn image_formats_are_checked_before_any_work() {
    let d = TempDir::new("out-format-first");
    let mesh = d.p("missing.obj");
    let env = d.p("missing.hdr");
    let bad = d.p("x.jpg");
    for (line, option) in [
        ("ao --mesh {mesh} --method raycast --rays 4 --image {bad}", "--image"),
        (
            "ao --mesh {mesh} --method field --receiver {mesh} --rays 4 --image {bad}",
            "--image",
        ),
        (
            "ssao --mesh {mesh} --estimator sphere --spp 4 --radius 1 --out {bad}",
            "--out",
        ),
        (
            "ssao --mesh {mesh} --estimator sphere --spp 4 --radius 1 --image {bad}",
            "--image",
        ),
        ("trace --mesh {mesh} --width 8 --height 8 --out {bad}", "--out"),
        (
            "trace --mesh {mesh} --width 8 --height 8 --aa uniform --aa-image {bad}",
            "--aa-image",
        ),
        ("prt --mesh {mesh} --env {env} --out {bad}", "--out"),
        (
            "raytrace --method whitted --mesh {mesh} --width 8 --height 8 --out {bad}",
            "--out",
        ),
    ] {
        pen(line, &[("mesh", &mesh), ("env", &env), ("bad", &bad)]).bad_input(&[
            option,
            "x.jpg",
            "unknown image format",
            ".png",
            ".exr",
            ".pfm",
        ]);
    }
    let exr = d.p("t.exr");
    for (line, option) in [
        (
            "trace --mesh {mesh} --width 8 --height 8 --tiles-image {exr}",
            "--tiles-image",
        ),
        (
            "raytrace --method bounded --mesh {mesh} --width 8 --height 8 --error-image {exr}",
            "--error-image",
        ),
    ] {
        pen(line, &[("mesh", &mesh), ("exr", &exr)]).bad_input(&[option, "t.exr", "only .png"]);
    }
    let pfm = d.p("t.pfm");
    pen(
        "ao --mesh {mesh} --method raycast --rays 4 --image {pfm} --background transparent",
        &[("mesh", &mesh), ("pfm", &pfm)],
    )
    .bad_input(&["--image", "t.pfm", "no alpha channel"]);
    let left: Vec<_> = std::fs::read_dir(&d.0).unwrap().collect();
    assert!(left.is_empty(), "no output was written: {left:?}");
}

/// The new options refuse to be given where they do nothing.
#[test]
fn output_options_apply_only_with_their_output() {
    let d = TempDir::new("out-applies");
    let mesh = asset_s("corner.obj");
    let (csv, exr) = (d.p("v.csv"), d.p("a.exr"));
    let vars = [("mesh", mesh.as_str()), ("csv", csv.as_str()), ("exr", exr.as_str())];
    for (line, option, needs) in [
        (
            "ao {m} --per-vertex {csv} --png-bits 16",
            "--png-bits",
            "--image FILE.png",
        ),
        ("ao {m} --image {exr} --png-bits 16", "--png-bits", "--image FILE.png"),
        (
            "ao {m} --per-vertex {csv} --background transparent",
            "--background",
            "--image",
        ),
        ("ssao {s} --image {exr} --png-bits 16", "--png-bits", "--out FILE.png"),
        ("ssao {s} --image {exr} --background black", "--background", "--out"),
        (
            "prt --mesh {mesh} --env {mesh} --per-vertex-transfer",
            "--per-vertex-transfer",
            "--per-vertex",
        ),
    ] {
        let line = line
            .replace("{m}", "--mesh {mesh} --method raycast --rays 4")
            .replace("{s}", "--mesh {mesh} --estimator sphere --spp 4 --radius 1");
        pen(&line, &vars).bad_input(&[option, "does not apply", needs]);
    }
}

/// `--per-vertex out.ply`: the mesh with AO as vertex colours, which
/// penumbra's own PLY reader reads back as the same mesh, colours = the
/// CSV's AO in 255 steps.
#[test]
fn per_vertex_ao_as_ply_vertex_colours() {
    let d = TempDir::new("out-ply");
    let mesh = asset_s("sphere-on-plane.obj");
    let (csv, ply) = (d.p("ao.csv"), d.p("ao.ply"));
    for out in [&csv, &ply] {
        let j = pen(
            "ao --mesh {mesh} --method raycast --rays 16 --per-vertex {out} --device cpu --json",
            &[("mesh", &mesh), ("out", out)],
        )
        .ok()
        .json();
        assert_eq!(j["per_vertex"]["file"], out.as_str());
    }
    let ao: Vec<f32> = std::fs::read_to_string(&csv)
        .unwrap()
        .lines()
        .map(|l| l.split(',').nth(1).unwrap().parse().unwrap())
        .collect();
    let obj = load_mesh(std::path::Path::new(&mesh)).unwrap();
    let back = load_ply(std::path::Path::new(&ply)).unwrap();
    assert_eq!(back.mesh.positions, obj.positions);
    assert_eq!(back.mesh.triangles, obj.triangles);
    let colours = back.vertex_colors.expect("the PLY has vertex colours");
    assert_eq!(colours.len(), ao.len());
    let mut levels = std::collections::BTreeSet::new();
    for (c, a) in colours.iter().zip(&ao) {
        assert_eq!(*c, Vec3::splat((a * 255.0).round() / 255.0));
        levels.insert((c.x * 255.0) as u32);
    }
    assert!(levels.len() > 5, "AO varies over the mesh: {levels:?}");
    // The PLY gives the same AO as the OBJ it was written from.
    let again = d.p("again.csv");
    pen(
        "ao --mesh {ply} --method raycast --rays 16 --per-vertex {out} --device cpu",
        &[("ply", &ply), ("out", &again)],
    )
    .ok();
    assert_eq!(std::fs::read(&again).unwrap(), std::fs::read(&csv).unwrap());
}

/// A closed scene with the default infinite radius: AO is 0 everywhere and
/// stderr says so, with a radius to try; a finite radius silences it.
#[test]
fn near_zero_ao_everywhere_is_warned_about() {
    let d = TempDir::new("out-closed");
    let mesh = asset_s("closed-box.obj");
    let csv = d.p("ao.csv");
    let r = pen(
        "ao --mesh {mesh} --method raycast --rays 16 --per-vertex {csv} --device cpu",
        &[("mesh", &mesh), ("csv", &csv)],
    );
    r.ok();
    assert!(
        r.stderr.contains("warning: AO is at most 0.000 everywhere"),
        "{}",
        r.describe()
    );
    assert!(r.stderr.contains("give a finite --radius"), "{}", r.describe());
    let r = pen(
        "ao --mesh {mesh} --method raycast --rays 16 --radius 0.2 --per-vertex {csv} --device cpu",
        &[("mesh", &mesh), ("csv", &csv)],
    );
    assert!(!r.ok().stderr.contains("warning"), "{}", r.describe());
    let r = pen(
        "ao --mesh {mesh} --method raycast --rays 16 --per-vertex {csv} --device cpu",
        &[("mesh", &asset_s("corner.obj")), ("csv", &csv)],
    );
    assert!(!r.ok().stderr.contains("warning"), "an open scene: {}", r.describe());
}

/// ssao's AO and shaded images, trace's image: EXR and PNG of one run
/// hold the same values (linear grey; sRGB of the linear radiance).
#[test]
fn ssao_and_trace_float_images_match_their_pngs() {
    let d = TempDir::new("out-ssao-trace");
    let mesh = asset_s("sphere-on-plane.obj");
    let ssao = "ssao --mesh {mesh} --estimator sphere --spp 8 --radius 0.5 --width 40 --height 30 \
                --truth-rays 0 --reference-spp 0 --device cpu --out {ao} --image {img}";
    for (ao, img) in [("ao.png", "img.png"), ("ao.exr", "img.exr")] {
        pen(ssao, &[("mesh", &mesh), ("ao", &d.p(ao)), ("img", &d.p(img))]).ok();
    }
    let ao = exr(&d.p("ao.exr"));
    let ao8: Vec<u8> = image::open(d.p("ao.png")).unwrap().to_luma8().into_raw();
    assert!(
        ao.iter()
            .zip(&ao8)
            .all(|(f, p)| *p == (f[0].clamp(0.0, 1.0) * 255.0).round() as u8)
    );
    assert!(ao.iter().any(|f| f[0] > 0.0 && f[0] < 1.0));
    let (ao16, img2) = (d.p("ao16.png"), d.p("img2.png"));
    pen(
        &format!("{ssao} --png-bits 16"),
        &[("mesh", &mesh), ("ao", &ao16), ("img", &img2)],
    )
    .ok();
    let levels = png16(&ao16);
    assert_eq!(levels.len(), ao.len());
    let exact16 = ao
        .iter()
        .zip(&levels)
        .all(|(f, p)| p[0] == (f[0].clamp(0.0, 1.0) * 65535.0).round() as u16);
    assert!(exact16, "the 16-bit PNG holds the float values in 65535 steps");
    let radiance = exr(&d.p("img.exr"));
    let srgb = image::open(d.p("img.png")).unwrap().to_rgb8();
    for (f, p) in radiance.iter().zip(srgb.pixels()) {
        assert_eq!(p.0, [srgb8(f[0]), srgb8(f[1]), srgb8(f[2])]);
    }
    let trace = "trace --mesh {mesh} --width 40 --height 30 --device cpu --out {out}";
    for out in ["t.png", "t.pfm"] {
        pen(trace, &[("mesh", &mesh), ("out", &d.p(out))]).ok();
    }
    let (_, _, pfm) = read_pfm(std::path::Path::new(&d.p("t.pfm"))).unwrap();
    let png = image::open(d.p("t.png")).unwrap().to_luma_alpha8();
    for (f, p) in pfm.iter().zip(png.pixels()) {
        assert_eq!(p.0[0], (f.x.clamp(0.0, 1.0) * 255.0).round() as u8);
        if p.0[1] == 0 {
            assert_eq!(f.x, 0.0, "no surface: 0 in the PFM");
        }
    }
}

/// The SH coefficients of a probe that is `sky` for y > 0 and `ground`
/// below, by brute-force quadrature over the sphere (independent of the
/// projection code): midpoint rule in (theta from +y, phi), the horizon
/// on a cell boundary.
fn projected_by_quadrature(sky: [f32; 3], ground: [f32; 3], bands: usize) -> Vec<[f64; 3]> {
    let basis = ShBasis::new(bands);
    let (nt, np) = (400, 400);
    let mut c = vec![[0.0f64; 3]; bands * bands];
    let (dt, dp) = (std::f64::consts::PI / nt as f64, 2.0 * std::f64::consts::PI / np as f64);
    for i in 0..nt {
        let theta = (i as f64 + 0.5) * dt;
        for j in 0..np {
            let phi = (j as f64 + 0.5) * dp;
            let d = DVec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin());
            let l = if d.y > 0.0 { sky } else { ground };
            let w = theta.sin() * dt * dp;
            for (ci, y) in c.iter_mut().zip(basis.at(d)) {
                for k in 0..3 {
                    ci[k] += l[k] as f64 * y * w;
                }
            }
        }
    }
    c
}

fn triples(v: &Value) -> Vec<[f64; 3]> {
    let rows = v.as_array().unwrap();
    rows.iter()
        .map(|t| {
            let t = t.as_array().unwrap();
            [0, 1, 2].map(|k| t[k].as_f64().unwrap())
        })
        .collect()
}

/// `prt --sh-out`: 25 RGB triples in the order l(l+1)+m, matching an
/// independent projection; band 1 says where the bright sky is (+y:
/// Y_1,-1 = sqrt(3/4pi) y). `--per-vertex`: a row per frame and vertex,
/// and r = albedo x transfer . lighting. `--out` with `{}`: every frame,
/// EXR = the linear radiance whose sRGB the PNG holds.
#[test]
fn prt_numbers_out() {
    let d = TempDir::new("out-prt");
    let (sky, ground) = ([2.0, 1.5, 1.0], [0.2, 0.25, 0.3]);
    let env = write_probe(&d, sky, ground);
    let frames = 3;
    let mut args = cmd(
        &format!(
            "prt --animated cloth --env {{env}} --frames {frames} --width 48 --height 36 --albedo 0.8,0.6,0.4 \
             --sh-out {{sh}} --per-vertex {{csv}} --per-vertex-transfer --device cpu --json --out"
        ),
        &[("env", &env), ("sh", &d.p("sh.json")), ("csv", &d.p("v.csv"))],
    );
    args.push(d.p("f{:02}.exr"));
    let j = run(&args).ok().json();
    assert_eq!(j["images"], frames);
    let sh: Value = serde_json::from_str(&std::fs::read_to_string(d.p("sh.json")).unwrap()).unwrap();
    assert_eq!(sh["count"], 25);
    assert_eq!(sh["lm"][3], serde_json::json!([1, 1]));
    let coefficients = triples(&sh["coefficients"]);
    // The values the .hdr file holds (RGBE rounds 0.2 and 0.3).
    let probe = penumbra::scene::EnvironmentMap::load(std::path::Path::new(&env)).unwrap();
    let (sky, ground) = (probe.texels[0], *probe.texels.last().unwrap());
    assert_eq!(coefficients.len(), 25);
    let independent = projected_by_quadrature(sky, ground, 5);
    let scale = independent.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    for (i, (a, b)) in coefficients.iter().zip(&independent).enumerate() {
        for k in 0..3 {
            assert!(
                (a[k] - b[k]).abs() <= 1e-4 * scale,
                "coefficient {i}[{k}]: {} vs {}",
                a[k],
                b[k]
            );
        }
    }
    // Band 0 and 1 in closed form: the mean, and the sky's direction +y.
    let pi = std::f64::consts::PI;
    for k in 0..3 {
        let (s, g) = (sky[k] as f64, ground[k] as f64);
        assert!((coefficients[0][k] - (s + g) * pi.sqrt()).abs() < 1e-6 * scale);
        assert!((coefficients[1][k] - (3.0 / (4.0 * pi)).sqrt() * pi * (s - g)).abs() < 1e-6 * scale);
        assert!(coefficients[2][k].abs() < 1e-9 * scale && coefficients[3][k].abs() < 1e-9 * scale);
    }
    // Per-vertex rows: frames x vertices, radiance = albedo x T . L.
    let (header, rows) = penumbra::io::vertex::read_prt_csv(std::path::Path::new(&d.p("v.csv"))).unwrap();
    assert_eq!(&header[..5], ["frame", "vertex", "r", "g", "b"]);
    assert_eq!(header.len(), 5 + 25);
    let vertices = j["vertices"].as_u64().unwrap() as usize;
    assert_eq!(rows.len(), frames * vertices);
    let lighting = triples(&sh["lighting"]["coefficients"]);
    let albedo = [0.8, 0.6, 0.4];
    let mut lit = 0;
    for (n, row) in rows.iter().enumerate() {
        assert_eq!((row[0] as usize, row[1] as usize), (n / vertices, n % vertices));
        for k in 0..3 {
            let dot: f64 = (0..25).map(|i| row[5 + i] * lighting[i][k]).sum::<f64>() * albedo[k];
            assert!(
                (row[2 + k] - dot).abs() <= 1e-4 * dot.abs().max(1e-3),
                "row {n}: {} vs {dot}",
                row[2 + k]
            );
        }
        lit += (row[2] > 0.0) as usize;
    }
    assert!(lit > rows.len() / 2, "most vertices are lit");
    // Every frame's image, EXR; the last again as PNG and PFM.
    let exposure = j["exposure"].as_f64().unwrap() as f32;
    for f in 0..frames {
        assert_eq!(image::image_dimensions(d.p(&format!("f{f:02}.exr"))).unwrap(), (48, 36));
    }
    for out in ["last.png", "last.pfm"] {
        pen(
            &format!(
                "prt --animated cloth --env {{env}} --frames {frames} --width 48 --height 36 --albedo 0.8,0.6,0.4 \
                 --exposure {exposure} --out {{out}} --device cpu"
            ),
            &[("env", &env), ("out", &d.p(out))],
        )
        .ok();
    }
    let last = exr(&d.p("f02.exr"));
    let (_, _, pfm) = read_pfm(std::path::Path::new(&d.p("last.pfm"))).unwrap();
    let png = image::open(d.p("last.png")).unwrap().to_rgb8();
    for ((e, p), q) in last.iter().zip(&pfm).zip(png.pixels()) {
        assert_eq!(*p, Vec3::new(e[0], e[1], e[2]));
        assert_eq!(q.0, [0, 1, 2].map(|k| srgb8(e[k] * exposure)));
    }
}

/// `ssao --image` shades with the OBJ's MTL materials: a red (`Kd 1 0 0`)
/// half of a floor is red in the linear image (green and blue exactly 0,
/// every term is multiplied by the albedo), the half without `usemtl`
/// keeps the palette's grey-beige; without the MTL no pixel is pure red.
#[test]
fn ssao_image_albedo_comes_from_obj_materials() {
    let d = TempDir::new("out-ssao-mtl");
    d.write("m.mtl", "newmtl red\nKd 1 0 0\n");
    let geometry = "v -1 0 -1\nv 0 0 -1\nv 0 0 1\nv -1 0 1\nv 1 0 -1\nv 1 0 1\nf 2 3 6 5\n";
    let with = d.write("with.obj", format!("mtllib m.mtl\n{geometry}usemtl red\nf 1 4 3 2\n"));
    let without = d.write("without.obj", format!("{geometry}f 1 4 3 2\n"));
    let pure_red = |mesh: &str, img: &str| -> (usize, usize) {
        let img = d.p(img);
        pen(
            "ssao --mesh {mesh} --estimator sphere --spp 4 --radius 0.5 --width 40 --height 30 \
             --truth-rays 0 --reference-spp 0 --device cpu --image {img}",
            &[("mesh", mesh), ("img", &img)],
        )
        .ok();
        let px = exr(&img);
        let red = px.iter().filter(|p| p[0] > 0.0 && p[1] == 0.0 && p[2] == 0.0).count();
        let other = px.iter().filter(|p| p[1] > 0.0).count();
        (red, other)
    };
    let (red, other) = pure_red(&with, "with.exr");
    assert!(red > 30 && other > 30, "red {red}, other {other}");
    let (red, other) = pure_red(&without, "without.exr");
    assert!(red == 0 && other > 100, "red {red}, other {other}");
}

/// Every shared probe's `--sh-out` coefficients against an independent
/// texel-exact projection: each texel's constant radiance times the
/// integral of Y_i over the texel, by a 16 x 16 midpoint rule in the map's
/// own (u, v) with the exact area element (`EnvironmentMap::direction_f64`
/// is the map's parameterisation); within 1e-4 of the largest coefficient,
/// and 1e-4 relative for every coefficient above 1% of it.
#[test]
fn sh_out_of_every_shared_probe_matches_a_texel_exact_projection() {
    let Some(root) = common::data_root() else {
        println!("PENUMBRA_DATA not set: skipping the shared probes");
        return;
    };
    let d = TempDir::new("out-sh-probes");
    let mesh = d.write("tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    let probes = std::path::Path::new(&root).join("probes");
    let mut names: Vec<_> = std::fs::read_dir(&probes)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .collect();
    names.retain(|p| p.extension().is_some_and(|e| e == "hdr"));
    names.sort();
    assert!(!names.is_empty(), "no probes in {}", probes.display());
    let basis = ShBasis::new(5);
    for probe in names {
        let env = probe.to_str().unwrap();
        let sh = d.p("sh.json");
        pen(
            "prt --mesh {mesh} --env {env} --sh-out {sh} --self-check off --device cpu",
            &[("mesh", &mesh), ("env", env), ("sh", &sh)],
        )
        .ok();
        let json: Value = serde_json::from_str(&std::fs::read_to_string(&sh).unwrap()).unwrap();
        let got = triples(&json["coefficients"]);
        let map = penumbra::scene::EnvironmentMap::load(&probe).unwrap();
        let (w, h, k) = (map.width as usize, map.height as usize, 16usize);
        let mut want = vec![[0.0f64; 3]; 25];
        let (du, dv) = (1.0 / (w * k) as f64, 1.0 / (h * k) as f64);
        let area = 2.0 * std::f64::consts::PI * du * std::f64::consts::PI * dv;
        for r in 0..h {
            for c in 0..w {
                let t = map.texels[r * w + c];
                let mut integral = [0.0f64; 25];
                for i in 0..k {
                    let v = (r * k + i) as f64 * dv + 0.5 * dv;
                    let weight = area * (std::f64::consts::PI * v).sin();
                    for j in 0..k {
                        let u = (c * k + j) as f64 * du + 0.5 * du;
                        let y = basis.at(penumbra::scene::EnvironmentMap::direction_f64(u, v));
                        for (s, yi) in integral.iter_mut().zip(y) {
                            *s += yi * weight;
                        }
                    }
                }
                for (wi, s) in want.iter_mut().zip(integral) {
                    for ch in 0..3 {
                        wi[ch] += t[ch] as f64 * s;
                    }
                }
            }
        }
        let largest = want.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
        let (mut worst_abs, mut worst_rel) = (0.0f64, 0.0f64);
        for (a, b) in got.iter().zip(&want) {
            for ch in 0..3 {
                let e = (a[ch] - b[ch]).abs();
                worst_abs = worst_abs.max(e / largest);
                if b[ch].abs() > 0.01 * largest {
                    worst_rel = worst_rel.max(e / b[ch].abs());
                }
            }
        }
        println!(
            "{}: worst difference {worst_abs:.1e} of the largest, {worst_rel:.1e} relative",
            probe.display()
        );
        assert!(worst_abs < 1e-4 && worst_rel < 1e-4, "{}", probe.display());
    }
}

/// Ctrl-C (SIGINT) in the middle of a run that streams an output (prt's
/// per-vertex CSV, written frame by frame into a hidden temporary) leaves
/// neither the output nor its temporary, and exits with 130.
#[test]
fn an_interrupted_run_leaves_no_output_and_no_temporary() {
    let d = TempDir::new("out-interrupt");
    let env = write_probe(&d, [0.9, 0.8, 0.7], [0.2, 0.2, 0.2]);
    let csv = d.p("radiance.csv");
    let args = cmd(
        "prt --animated cloth --env {env} --frames 100000 --self-check off --per-vertex {csv} --device cpu",
        &[("env", &env), ("csv", &csv)],
    );
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_penumbra"))
        .args(&args)
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let temporaries = || -> Vec<String> {
        std::fs::read_dir(&d.0)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.ends_with(".tmp"))
            .collect()
    };
    let start = std::time::Instant::now();
    while temporaries().is_empty() {
        assert!(start.elapsed().as_secs() < 60, "the run never started its output");
        assert!(
            child.try_wait().unwrap().is_none(),
            "the run ended before it was interrupted"
        );
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    // Frames are being written now.
    std::thread::sleep(std::time::Duration::from_millis(300));
    let pid = child.id().to_string();
    let sent = std::process::Command::new("kill")
        .args(["-INT", &pid])
        .status()
        .unwrap();
    assert!(sent.success());
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(130), "{stderr}");
    assert!(stderr.contains("interrupted"), "{stderr}");
    assert!(temporaries().is_empty(), "temporaries left: {:?}", temporaries());
    assert!(!std::path::Path::new(&csv).exists(), "a partial output was left");
}

/// `asset`'s OBJ with every vertex scaled by `scale` and `extra` lines
/// appended, written to `dir/name`.
fn scaled_obj(dir: &TempDir, asset: &str, scale: f32, extra: &str, name: &str) -> String {
    let text = std::fs::read_to_string(asset_s(asset)).unwrap();
    let mut out = String::new();
    for line in text.lines() {
        match line.strip_prefix("v ") {
            Some(rest) => {
                let v: Vec<String> = rest
                    .split_whitespace()
                    .map(|x| (x.parse::<f32>().unwrap() * scale).to_string())
                    .collect();
                out += &format!("v {}\n", v.join(" "));
            }
            None => out += &format!("{line}\n"),
        }
    }
    out += extra;
    let path = dir.p(name);
    std::fs::write(&path, out).unwrap();
    path
}

/// Vertices no face uses are written (ao = 1) but left out of the mean:
/// the JSON's mean_ao is the mean of the used vertices' CSV values and
/// says so (`mean_over`, `used_vertices`).
#[test]
fn mean_ao_is_over_the_vertices_faces_use() {
    let d = TempDir::new("out-unused");
    let mesh = scaled_obj(
        &d,
        "corner.obj",
        1.0,
        "v 9 9 9\nv 9 9 8\nv 9 8 9\nv 8 9 9\n",
        "corner.obj",
    );
    let csv = d.p("ao.csv");
    let r = pen(
        "ao --mesh {mesh} --method raycast --rays 16 --per-vertex {csv} --device cpu --json",
        &[("mesh", &mesh), ("csv", &csv)],
    );
    let j = r.ok().json();
    let ao: Vec<f64> = std::fs::read_to_string(&csv)
        .unwrap()
        .lines()
        .map(|l| l.split(',').nth(1).unwrap().parse().unwrap())
        .collect();
    let used = ao.len() - 4;
    assert!(ao[used..].iter().all(|&a| a == 1.0), "unused vertices read 1");
    let v = &j["per_vertex"];
    assert_eq!(v["vertices"], ao.len());
    assert_eq!(v["without_normal"], 4);
    assert_eq!(v["used_vertices"], used);
    assert_eq!(v["mean_over"], "used_vertices");
    let mean_used = ao[..used].iter().sum::<f64>() / used as f64;
    let mean_all = ao.iter().sum::<f64>() / ao.len() as f64;
    let mean = v["mean_ao"].as_f64().unwrap();
    assert!((mean - mean_used).abs() < 1e-6, "{mean} vs {mean_used}");
    assert!(
        (mean - mean_all).abs() > 1e-5,
        "the unused vertices would move the mean"
    );
    assert!(r.stderr.contains("left out of mean_ao"), "{}", r.describe());
}

/// A scanned-size model (the sphere on its plane, 300 times larger) with
/// a radius meant for a unit scene: AO reads 1 everywhere, and stderr says
/// so naming --radius with one to try; a radius at the scene's scale is
/// not warned about.
#[test]
fn ao_of_one_everywhere_from_a_small_radius_is_warned_about() {
    let d = TempDir::new("out-near-one");
    let mesh = scaled_obj(&d, "sphere-on-plane.obj", 300.0, "", "big.obj");
    let (csv, png) = (d.p("ao.csv"), d.p("ao.png"));
    let r = pen(
        "ao --mesh {mesh} --method raycast --rays 16 --radius 0.2 --per-vertex {csv} --device cpu --json",
        &[("mesh", &mesh), ("csv", &csv)],
    );
    let j = r.ok().json();
    assert!(j["per_vertex"]["mean_ao"].as_f64().unwrap() > 0.995, "{}", r.describe());
    assert!(r.stderr.contains("AO is at least"), "{}", r.describe());
    assert!(r.stderr.contains("--radius 0.2 is"), "{}", r.describe());
    let r = pen(
        "ao --mesh {mesh} --method raycast --rays 16 --radius 0.2 --width 40 --height 30 --image {png} --device cpu",
        &[("mesh", &mesh), ("png", &png)],
    );
    assert!(
        r.ok().stderr.contains("AO is at least"),
        "the image too: {}",
        r.describe()
    );
    let r = pen(
        "ao --mesh {mesh} --method raycast --rays 16 --radius 60 --per-vertex {csv} --device cpu",
        &[("mesh", &mesh), ("csv", &csv)],
    );
    assert!(!r.ok().stderr.contains("AO is at least"), "{}", r.describe());
}

/// ssao without --radius takes 5% of the scene's diagonal, so a model's
/// scale does not decide what occludes: the sphere on its plane at 300
/// times its size gives the same mean AO as at unit size; --radius 0.2 on
/// the large one reads 1 everywhere, with a warning naming --radius.
#[test]
fn ssao_radius_defaults_to_the_scene_scale() {
    let d = TempDir::new("out-ssao-scale");
    let small = asset_s("sphere-on-plane.obj");
    let big = scaled_obj(&d, "sphere-on-plane.obj", 300.0, "", "big.obj");
    let out = d.p("ao.png");
    let ssao = |mesh: &str, extra: &str| {
        pen(
            &format!(
                "ssao --mesh {{mesh}} --estimator importance --spp 16 --width 48 --height 36 --reference-rays 0 \
                 --screen-reference-spp 0 --out {{out}} --device cpu --json {extra}"
            ),
            &[("mesh", mesh), ("out", &out)],
        )
    };
    let (s, b) = (ssao(&small, ""), ssao(&big, ""));
    let (js, jb) = (s.ok().json(), b.ok().json());
    let (rs, rb) = (js["radius"].as_f64().unwrap(), jb["radius"].as_f64().unwrap());
    assert!((rb / rs - 300.0).abs() < 0.01, "{rs} {rb}");
    let (ms, mb) = (js["mean_ao"].as_f64().unwrap(), jb["mean_ao"].as_f64().unwrap());
    assert!(ms < 0.995 && (ms - mb).abs() < 1e-3, "{ms} {mb}");
    assert!(!b.stderr.contains("AO is at least"), "{}", b.describe());
    let r = ssao(&big, "--radius 0.2");
    let j = r.ok().json();
    assert!(j["mean_ao"].as_f64().unwrap() > 0.995, "{}", r.describe());
    assert!(r.stderr.contains("--radius 0.2 is"), "{}", r.describe());
}

/// trace's images keep the convention of every grey image: opaque black
/// where no surface is by default, alpha 0 there with `--background
/// transparent`, which a PFM (no alpha) refuses.
#[test]
fn trace_images_have_the_ao_images_background() {
    let d = TempDir::new("out-trace-background");
    let mesh = asset_s("sphere-on-plane.obj");
    let png = d.p("t.png");
    let trace = |extra: &str| {
        pen(
            &format!("trace --mesh {{mesh}} --width 40 --height 30 --out {{png}} --device cpu {extra}"),
            &[("mesh", &mesh), ("png", &png)],
        )
    };
    trace("").ok();
    let opaque = image::open(&png).unwrap().into_luma_alpha8();
    let corner = opaque.get_pixel(0, 0).0;
    assert_eq!(corner, [0, 255], "the sky corner is opaque black");
    assert!(opaque.pixels().all(|p| p.0[1] == 255));
    trace("--background transparent").ok();
    let keyed = image::open(&png).unwrap().into_luma_alpha8();
    assert_eq!(keyed.get_pixel(0, 0).0[1], 0, "alpha 0 where no surface is");
    let pfm = d.p("t.pfm");
    pen(
        "trace --mesh {mesh} --width 40 --height 30 --out {pfm} --background transparent --device cpu",
        &[("mesh", &mesh), ("pfm", &pfm)],
    )
    .bad_input(&["--out"]);
}
