//! Whitted's brightness in absolute terms: scenes whose centre pixel has a
//! closed form under the shading model (README, "Shading model"), checked
//! from above and below on the CPU and on the GPU.
//!
//! * A diffuse plane under a point light: `L = Kd I cos(theta) / d^2`, the
//!   light at two distances and angles.
//! * A perfect mirror (`Ks` = `kr`) in front of a lit diffuse wall: `kr`
//!   times the wall's radiance where the reflected ray meets it.
//! * A glass slab of constant coefficients (no Fresnel) before a lit wall,
//!   seen at normal incidence: the ray passes two faces, `Tf^2` times the
//!   wall's radiance.

mod common;

use glam::Vec3;
use penumbra::gpu::device::Device;
use penumbra::progress::{Bar, Reporter};
use penumbra::scene::{Camera, Light, Scene, load_obj_file};
use penumbra::whitted::{LightingSettings, RenderScene, WhittedRenderer, WhittedSettings};

/// Relative tolerance of every check, from above and below: the point a
/// light is shaded from is lifted off the surface along its normal by an
/// offset that grows with the scene's extent (measured: 1.5e-4 of the
/// radiance for these 20-unit planes), and float32 shading. A light pi
/// times too bright, a missing cosine or a falloff of d instead of d^2 are
/// all far outside it.
const TOLERANCE: f32 = 1e-3;

const INTENSITY: f32 = 10.0;

/// A scene of an OBJ and its MTL, lit by one point light of `INTENSITY`
/// at `light`, no ambient light.
fn scene(name: &str, obj: &str, mtl: &str, light: Vec3) -> Scene {
    let dir = std::env::temp_dir().join(format!("penumbra-radiometry-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("m.mtl"), mtl).unwrap();
    let path = dir.join("s.obj");
    std::fs::write(&path, format!("mtllib m.mtl\n{obj}")).unwrap();
    let obj = load_obj_file(&path).unwrap();
    assert!(obj.warnings.is_empty(), "{:?}", obj.warnings);
    let mut scene = Scene::from_obj_file(name, &path, obj);
    std::fs::remove_dir_all(&dir).unwrap();
    scene.lights = vec![Light::Point {
        position: light,
        intensity: Vec3::splat(INTENSITY),
    }];
    scene.ambient = Some(Vec3::ZERO);
    scene
}

/// The centre pixel of a 3 x 3 image from `eye` towards the origin (its
/// ray is the view direction) on `device`.
fn centre(device: &Device, scene: &Scene, eye: Vec3) -> Vec3 {
    let rs = RenderScene::new(scene, 0, &LightingSettings::default()).unwrap();
    let mut renderer = WhittedRenderer::new(device, rs, &Reporter::silent()).unwrap();
    let camera = Camera {
        eye,
        target: Vec3::ZERO,
        fov_degrees: 30.0,
    };
    let frame = renderer
        .render(&camera, 3, 3, &WhittedSettings::default(), &Bar::hidden())
        .unwrap();
    frame.radiance()[4]
}

fn assert_close(what: &str, device: &Device, got: Vec3, expected: Vec3) {
    let rel = ((got - expected).abs() / expected).max_element();
    println!(
        "{what} on {}: {got} against {expected} (relative {rel:.1e})",
        device.kind()
    );
    assert!(
        got.cmple(expected * (1.0 + TOLERANCE)).all() && got.cmpge(expected * (1.0 - TOLERANCE)).all(),
        "{what} on {}: {got}, the closed form gives {expected} (relative error {rel:.1e} > {TOLERANCE:.0e})",
        device.kind()
    );
}

const KD: Vec3 = Vec3::new(0.5, 0.25, 0.8);

fn matte() -> String {
    format!(
        "newmtl matte\nKa 0 0 0\nKd {} {} {}\nKs 0 0 0\nillum 1\n",
        KD.x, KD.y, KD.z
    )
}

/// `Kd I cos / d^2` at the origin of a plane of normal `n`, the light at `light`.
fn diffuse(n: Vec3, at: Vec3, light: Vec3) -> Vec3 {
    let to = light - at;
    let d2 = to.length_squared();
    KD * INTENSITY * n.dot(to / d2.sqrt()) / d2
}

#[test]
fn a_diffuse_plane_under_a_point_light_has_the_closed_form_radiance() {
    let plane = "v -10 0 -10\nv -10 0 10\nv 10 0 10\nv 10 0 -10\nusemtl matte\nf 1 2 3 4\n";
    for device in common::devices() {
        // Straight above at distance 2 (cos 1), then at 45 degrees at
        // distance sqrt(18): 1.25 and 0.1964 times Kd's weight.
        for light in [Vec3::new(0.0, 2.0, 0.0), Vec3::new(3.0, 3.0, 0.0)] {
            let s = scene("plane", plane, &matte(), light);
            let got = centre(&device, &s, Vec3::new(0.0, 4.0, 3.0));
            let expected = diffuse(Vec3::Y, Vec3::ZERO, light);
            assert_close(&format!("plane, light at {light}"), &device, got, expected);
        }
    }
}

#[test]
fn a_perfect_mirror_shows_kr_times_the_lit_wall() {
    // The mirror at z = 0 (x, y within 1) facing +z; the wall at z = 4
    // facing -z, behind the eye at (0, 0, 2). The light is behind the
    // mirror's plane (no highlight of its own) and above its edge, so the
    // wall's shadow ray passes beside it.
    let obj = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nusemtl mirror\nf 1 2 3 4\n\
v -10 -10 4\nv -10 10 4\nv 10 10 4\nv 10 -10 4\nusemtl matte\nf 5 6 7 8\n";
    let mtl = format!(
        "{}newmtl mirror\nKa 0 0 0\nKd 0 0 0\nKs 0.8 0.8 0.8\nillum 3\n",
        matte()
    );
    let light = Vec3::new(0.0, 5.0, -1.0);
    let s = scene("mirror", obj, &mtl, light);
    let expected = 0.8 * diffuse(-Vec3::Z, Vec3::new(0.0, 0.0, 4.0), light);
    for device in common::devices() {
        let got = centre(&device, &s, Vec3::new(0.0, 0.0, 2.0));
        assert_close("mirror", &device, got, expected);
    }
}

#[test]
fn a_glass_slab_of_constant_coefficients_passes_tf_squared_of_the_wall() {
    // The slab between z = -0.25 and 0.25 (x, y within 1), index 1.5,
    // Tf constant (Fresnel off, no Ks: no reflected rays); the wall at
    // z = -2 facing +z, lit from beside the slab.
    let obj = "v -1 -1 0.25\nv 1 -1 0.25\nv 1 1 0.25\nv -1 1 0.25\n\
v -1 -1 -0.25\nv -1 1 -0.25\nv 1 1 -0.25\nv 1 -1 -0.25\nusemtl glass\nf 1 2 3 4\nf 5 6 7 8\n\
v -10 -10 -2\nv 10 -10 -2\nv 10 10 -2\nv -10 10 -2\nusemtl matte\nf 9 10 11 12\n";
    let tf = Vec3::new(0.6, 0.5, 0.4);
    let mtl = format!(
        "{}newmtl glass\nKa 0 0 0\nKd 0 0 0\nKs 0 0 0\nTf {} {} {}\nNi 1.5\nillum 7\n",
        matte(),
        tf.x,
        tf.y,
        tf.z
    );
    let light = Vec3::new(3.0, 0.0, -1.0);
    let s = scene("slab", obj, &mtl, light);
    let expected = tf * tf * diffuse(Vec3::Z, Vec3::new(0.0, 0.0, -2.0), light);
    for device in common::devices() {
        let got = centre(&device, &s, Vec3::new(0.0, 0.0, 3.0));
        assert_close("glass slab", &device, got, expected);
    }
}
