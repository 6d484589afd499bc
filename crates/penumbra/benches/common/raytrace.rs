//! The ray tracer's bench scenes: every shipped scene with its camera, and
//! the shared Cornell box where `PENUMBRA_DATA` is set.

use std::path::Path;

use glam::Vec3;
use penumbra::scene::{Camera, Scene, load_obj_file, load_scene_shaded};
use penumbra_assets::raytrace::shipped_scenes;

/// A scene to render and its camera.
pub struct BenchScene {
    pub name: String,
    pub scene: Scene,
    pub camera: Camera,
}

/// The shipped scenes, and the Cornell box of `PENUMBRA_DATA` if set.
pub fn load_scenes() -> Vec<BenchScene> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/raytrace");
    let mut scenes: Vec<BenchScene> = shipped_scenes()
        .iter()
        .map(|s| {
            let path = dir.join(s.scene_file());
            let scene = load_scene_shaded(&path).unwrap_or_else(|e| panic!("loading {}: {e}", path.display()));
            let camera = scene
                .camera
                .unwrap_or_else(|| panic!("{} has no camera", path.display()));
            BenchScene {
                name: s.name.to_string(),
                scene,
                camera,
            }
        })
        .collect();
    match super::data_root() {
        Some(data) => {
            let path = Path::new(&data).join("scenes/CornellBox-Original.obj");
            if path.is_file() {
                let obj = load_obj_file(&path).unwrap_or_else(|e| panic!("loading {}: {e}", path.display()));
                scenes.push(BenchScene {
                    name: "CornellBox-Original".to_string(),
                    scene: Scene::from_obj_file("CornellBox-Original", &path, obj),
                    camera: Camera {
                        eye: Vec3::new(0.0, 1.0, 3.5),
                        target: Vec3::new(0.0, 1.0, 0.0),
                        fov_degrees: 40.0,
                    },
                });
            } else {
                eprintln!("note: {} not found; skipping it", path.display());
            }
        }
        None => eprintln!("note: PENUMBRA_DATA is not set; the shipped scenes only (no CornellBox-Original)"),
    }
    scenes
}
