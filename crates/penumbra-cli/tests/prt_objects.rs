//! Several objects (Kautz, Lehtinen and Aila 2004, section
//! 4.1): each object self-shadowed, the others' coarse levels in its masks
//! (`prt::blockers`, `prt::objects`), checked against ray tracing of the
//! whole scene; `prt --scene` on the shipped chess-like scene; bad input.
//!
//! Bounds:
//! * Far apart (beyond 32 bounding radii at a 32-pixel mask, where an
//!   object covers at most one mask pixel and is culled): the transfer is
//!   bit for bit the object's alone.
//! * The shipped scene, 4096 rays, frames 0 and 7 of 8: measured 2.04%
//!   (coarse), 2.21% (fine), 99.9% (off); bounds 3.5% for the coarse
//!   error, 1 point for coarse - fine, off at least ten times coarse, and
//!   6% for each object (the hovering bishop's 4.8% is the largest).
//! * GPU vs CPU: the masks are the CPU's; the kernel integrates them as
//!   its twin does, so the radiance agrees within 1e-4 relative (+1e-5).

mod common;

use common::cli::{GROUND, SKY, TempDir, asset_s, gpu_available, pen, write_probe};
use glam::{Quat, Vec3};
use penumbra::gpu::device::Device;
use penumbra::prt::blockers::InterObject;
use penumbra::prt::objects::{ObjectSpec, ObjectsRunner};
use penumbra::prt::pipeline::{FrameOutput, PrtSettings};
use penumbra::prt::runner::{PrtRunner, RayTraced, Shadows};
use penumbra::scene::Role;
use penumbra::sh::coefficient_count;
use penumbra_assets::chess::{board, pawn};

const RAYS: RayTraced = RayTraced { rays: 256, seed: 7 };

fn placed(mesh: &penumbra::scene::Mesh, at: Vec3, turn: f32) -> Vec<Vec3> {
    let q = Quat::from_rotation_y(turn);
    mesh.positions.iter().map(|&p| q * p + at).collect()
}

fn spec(name: &str, mesh: &penumbra::scene::Mesh, pose: Vec<Vec3>) -> ObjectSpec {
    ObjectSpec {
        name: name.into(),
        triangles: mesh.triangles.clone(),
        poses: vec![pose],
        role: Role::Both,
    }
}

/// Constant white lighting: radiance is the transfer's first coefficient times a constant.
fn white(bands: usize) -> Vec<f32> {
    let n = coefficient_count(bands);
    let mut l = vec![0.0; 3 * n];
    for c in 0..3 {
        l[c * n] = 1.0;
    }
    l
}

#[test]
fn objects_far_apart_get_exactly_their_own_transfer() {
    let settings = PrtSettings::default();
    let p = pawn();
    let (a, b) = (placed(&p, Vec3::ZERO, 0.0), placed(&p, Vec3::new(60.0, 0.0, 10.0), 0.5));
    let lighting = white(settings.bands);
    let eye = Some(Vec3::new(3.0, 2.0, 4.0));
    let mut alone = PrtRunner::new(&Device::cpu(), &a, &p.triangles, &settings, Shadows::On, RAYS).unwrap();
    let mut own = FrameOutput::default();
    alone.frame(&a, eye, &lighting, false, &mut own).unwrap();
    let specs = vec![spec("a", &p, a.clone()), spec("b", &p, b.clone())];
    let mut scene = ObjectsRunner::new(
        &Device::cpu(),
        specs,
        &settings,
        (Shadows::On, RAYS),
        InterObject::Coarse,
    )
    .unwrap();
    let mut outs = Vec::new();
    scene.frame(&[a, b], eye, &lighting, false, &mut outs).unwrap();
    assert_eq!(outs[0].transfer, own.transfer, "a far object changes nothing");
    let o = &outs[0].stats.others;
    assert!(o.candidates > 0);
    assert_eq!(o.object_culled, o.candidates, "culled whole, under a pixel");
    assert_eq!(o.gathered, 0);
}

/// A pawn hovering over the board shadows the squares below it: the board's
/// vertices under it lose light with inter-object shadows on, those far
/// away keep theirs; and the shadow agrees with the whole scene ray traced.
#[test]
fn an_object_above_another_darkens_the_vertices_below_it() {
    let settings = PrtSettings::default();
    let (bd, p) = (board(), pawn());
    let (floor, piece) = (bd.positions.clone(), placed(&p, Vec3::new(0.0, 0.5, 0.0), 0.0));
    let specs = vec![spec("board", &bd, floor.clone()), spec("pawn", &p, piece.clone())];
    let mut r = ObjectsRunner::new(
        &Device::cpu(),
        specs,
        &settings,
        (Shadows::On, RAYS),
        InterObject::Coarse,
    )
    .unwrap();
    let poses = vec![floor.clone(), piece];
    let lighting = white(settings.bands);
    let run = |r: &mut ObjectsRunner, mode| {
        let mut outs = Vec::new();
        let blockers = r.blockers(&poses, mode);
        r.frame_with(&poses, None, &lighting, false, &blockers, &mut outs)
            .unwrap();
        outs
    };
    let (off, on) = (run(&mut r, InterObject::Off), run(&mut r, InterObject::Coarse));
    // Top vertices (y = 0) within 0.15 of the axis, and beyond 3 from it.
    let top = |keep: &dyn Fn(f32) -> bool| -> Vec<usize> {
        (0..floor.len())
            .filter(|&v| floor[v].y == 0.0 && keep(floor[v].x.hypot(floor[v].z)))
            .collect()
    };
    let (under, far) = (top(&|d| d < 0.15), top(&|d| d > 3.0));
    assert!(!under.is_empty() && !far.is_empty());
    let radiance = |outs: &[FrameOutput], v: usize| outs[0].radiance[v][0];
    for &v in &under {
        let (a, b) = (radiance(&off, v), radiance(&on, v));
        assert!(b < 0.8 * a, "vertex {v} under the pawn: {b} not below 0.8 x {a}");
    }
    for &v in &far {
        let (a, b) = (radiance(&off, v), radiance(&on, v));
        assert!((a - b).abs() <= 0.02 * a, "vertex {v} far away: {b} vs {a}");
    }
    // Against the whole scene ray traced (256 rays: ~6% noise per vertex).
    let normals: Vec<Vec<Vec3>> = on.iter().map(|o| o.normals.clone()).collect();
    let reference = r.reference_transfer(&poses, &normals, None).unwrap();
    let n = coefficient_count(settings.bands);
    for &v in &under {
        let (mine, truth) = (on[0].transfer[v * n], reference[0][v * n]);
        assert!(
            (mine - truth).abs() < 0.1 * off[0].transfer[v * n],
            "vertex {v}: {mine} vs {truth}"
        );
    }
}

#[test]
fn the_chess_scene_is_within_its_bound_of_whole_scene_ray_tracing() {
    let dir = TempDir::new("prt-chess");
    let env = write_probe(&dir, SKY, GROUND);
    let scene = asset_s("scenes/chess.json");
    let r = pen(
        "prt --scene {scene} --env {env} --frames 8 --reference --reference-frames 2 --device cpu --json",
        &[("scene", &scene), ("env", &env)],
    );
    let j = r.ok().json();
    assert_eq!(j["objects"].as_array().unwrap().len(), 5);
    assert_eq!(j["triangles"], 14496);
    let err = j["transfer_l2_error"].as_f64().unwrap();
    let m = &j["errors_by_inter_object"];
    let (off, coarse, fine) = (
        m["off"].as_f64().unwrap(),
        m["coarse"].as_f64().unwrap(),
        m["fine"].as_f64().unwrap(),
    );
    println!("chess: coarse {coarse:.4}, fine {fine:.4}, off {off:.4}");
    assert_eq!(err, coarse);
    assert!(coarse < 0.035, "{coarse}");
    assert!(coarse - fine < 0.01, "the approximation costs {}", coarse - fine);
    assert!(off > 10.0 * coarse, "inter-object shadows matter: {off} vs {coarse}");
    for o in j["objects"].as_array().unwrap() {
        let e = o["transfer_l2_error"].as_f64().unwrap();
        assert!(e < 0.06, "{}: {e}", o["name"]);
        let b = &o["blockers_per_vertex"]["others"];
        assert!(b["gathered"].as_f64().unwrap() > 0.0, "{}", o["name"]);
    }
    assert!(j["fps"].as_f64().unwrap() > 0.0);
}

#[test]
fn gpu_and_cpu_shade_the_scene_alike() {
    if !gpu_available() {
        println!("no GPU adapter: GPU half skipped");
        return;
    }
    let dir = TempDir::new("prt-chess-devices");
    let env = write_probe(&dir, SKY, GROUND);
    let scene = asset_s("scenes/chess.json");
    let mut rows = Vec::new();
    for device in ["cpu", "gpu"] {
        let csv = dir.p(&format!("{device}.csv"));
        let r = pen(
            &format!("prt --scene {{scene}} --env {{env}} --frames 2 --device {device} --per-vertex {{csv}} --json"),
            &[("scene", &scene), ("env", &env), ("csv", &csv)],
        );
        assert_eq!(r.ok().json()["device"], device);
        rows.push(std::fs::read_to_string(&csv).unwrap());
    }
    let values = |s: &str| -> Vec<f64> {
        s.lines()
            .skip(1)
            .flat_map(|l| {
                l.split(',')
                    .skip(2)
                    .map(|x| x.parse::<f64>().unwrap())
                    .collect::<Vec<_>>()
            })
            .collect()
    };
    let (cpu, gpu) = (values(&rows[0]), values(&rows[1]));
    assert_eq!(cpu.len(), gpu.len());
    assert_eq!(cpu.len(), 2 * 7518 * 3);
    for (a, b) in cpu.iter().zip(&gpu) {
        assert!((a - b).abs() <= 1e-4 * a.abs() + 1e-5, "{a} vs {b}");
    }
}

#[test]
fn bad_scene_input_exits_2_naming_the_problem() {
    let dir = TempDir::new("prt-chess-bad");
    let env = write_probe(&dir, SKY, GROUND);
    let scene = asset_s("scenes/chess.json");
    let chess = asset_s("chess/");
    let text = std::fs::read_to_string(&scene).unwrap().replace("../chess/", &chess);
    let missing = dir.write(
        "missing.json",
        text.replace("\"mesh\": \"rook\"", "\"mesh\": \"queen\""),
    );
    pen("prt --scene {s} --env {env}", &[("s", &missing), ("env", &env)]).bad_input(&[
        "missing.json",
        "instances[3].mesh",
        "queen",
    ]);
    let broken = dir.write("broken.json", &text[..text.len() / 2]);
    pen("prt --scene {s} --env {env}", &[("s", &broken), ("env", &env)]).bad_input(&["broken.json", "line"]);
    let scale = dir.write(
        "scale.json",
        text.replace("\"mesh\": \"pawn\",", "\"mesh\": \"pawn\", \"scale\": -1,"),
    );
    pen("prt --scene {s} --env {env}", &[("s", &scale), ("env", &env)]).bad_input(&["instances[1].scale", "positive"]);
    let cases = [
        ("prt --scene {s} --mesh {s} --env {env}", "--mesh"),
        ("prt --scene {s} --env {env} --pvs on", "--pvs"),
        ("prt --scene {s} --env {env} --start 1", "--start"),
        ("prt --scene {s} --env {env} --max-error 0.05", "--max-error"),
        ("prt --animated cloth --env {env} --inter-object fine", "--inter-object"),
        ("prt --scene {s} --env {env} --inter-object some", "--inter-object"),
        ("prt --scene {d}/none.json --env {env}", "none.json"),
    ];
    for (template, phrase) in cases {
        pen(template, &[("s", &scene), ("env", &env), ("d", &dir.p(""))]).bad_input(&[phrase]);
    }
}

#[test]
fn gen_assets_writes_the_committed_chess_scene() {
    let dir = TempDir::new("prt-chess-assets");
    pen("gen-assets --out {d} --json", &[("d", &dir.p("out"))]).ok();
    for name in [
        "chess/board.obj",
        "chess/pawn.obj",
        "chess/rook.obj",
        "chess/bishop.obj",
        "scenes/chess.json",
    ] {
        let made = std::fs::read(dir.p(&format!("out/{name}"))).unwrap();
        let committed = std::fs::read(asset_s(name)).unwrap();
        assert!(
            made == committed,
            "{name} differs from the committed assets (run `penumbra gen-assets --out assets`)"
        );
    }
}

/// Roles as the scene format has them: a caster shadows the others but is
/// not shaded; a receiver is shaded but casts nothing, not even on itself.
#[test]
fn casters_cast_and_receivers_receive() {
    let settings = PrtSettings::default();
    let (bd, p) = (board(), pawn());
    let poses = vec![bd.positions.clone(), placed(&p, Vec3::new(0.0, 0.5, 0.0), 0.0)];
    let lighting = white(settings.bands);
    let run = |roles: [Role; 2]| {
        let specs = vec![
            ObjectSpec {
                role: roles[0],
                ..spec("board", &bd, poses[0].clone())
            },
            ObjectSpec {
                role: roles[1],
                ..spec("pawn", &p, poses[1].clone())
            },
        ];
        let mut r = ObjectsRunner::new(
            &Device::cpu(),
            specs,
            &settings,
            (Shadows::On, RAYS),
            InterObject::Coarse,
        )
        .unwrap();
        let mut outs = Vec::new();
        r.frame(&poses, None, &lighting, false, &mut outs).unwrap();
        outs
    };
    let both = run([Role::Both, Role::Both]);
    let caster = run([Role::Both, Role::Caster]);
    assert_eq!(caster[0].transfer, both[0].transfer, "a caster shadows as both does");
    assert!(caster[1].transfer.is_empty(), "a caster is not shaded");
    let receiver = run([Role::Receiver, Role::Both]);
    let n = coefficient_count(settings.bands);
    // The pawn's foot faces the board: shadowed by it unless the board casts nothing.
    let foot: Vec<usize> = (0..poses[1].len()).filter(|&v| p.positions[v].y == 0.0).collect();
    assert!(!foot.is_empty());
    for &v in &foot {
        assert!(
            receiver[1].transfer[v * n] > both[1].transfer[v * n] + 0.1,
            "vertex {v}"
        );
    }
    // The board as a receiver does not shadow itself: only the pawn darkens it.
    let alone = run([Role::Receiver, Role::Receiver]);
    assert!(alone[0].stats.drawn == 0, "nothing casts");
}
