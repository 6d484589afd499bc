//! Cameras: the perspective cameras the scenes' nodes place, in traversal
//! order, as penumbra's pinhole cameras in the mesh's frame.
//!
//! A glTF camera looks down its node's -z with +y up. Its `yfov` (radians)
//! is penumbra's vertical field of view; `aspectRatio` is not used (the
//! image size the user asks for sets it), nor are `znear` and `zfar`.
//! penumbra's cameras keep the scene's +y up, so a camera rolled about its
//! view direction is read unrolled, with a warning. Orthographic cameras
//! are skipped with a warning (penumbra's are perspective).

use std::path::Path;

use ::gltf::Document;
use ::gltf::json::camera::Type;
use ::gltf::json::validation::Checked;
use glam::DVec3;

use super::nodes::CameraNode;
use super::out::Out;
use crate::error::{Error, Result};
use crate::scene::camera::Camera;
use crate::scene::frame::to_local;

/// Rolls below this many degrees are not worth a warning.
const ROLL_WARNING_DEGREES: f64 = 0.5;

/// A camera in world space, before the mesh's frame is known.
pub struct WorldCamera {
    pub eye: DVec3,
    /// Unit view direction.
    pub forward: DVec3,
    pub fov_degrees: f32,
}

/// The perspective cameras `nodes` place (in their order). A `yfov` out of
/// (0, pi) or a transform without a view direction is an error naming the
/// camera or node; orthographic cameras and rolls are warnings.
pub fn world_cameras(
    path: &Path,
    document: &Document,
    nodes: &[CameraNode],
    out: &mut Out,
) -> Result<Vec<WorldCamera>> {
    let json = document.as_json();
    let mut cameras = Vec::new();
    for placed in nodes {
        let c = placed.camera;
        let camera = &json.cameras[c];
        let node = &json.nodes[placed.node];
        let named = match &node.name {
            Some(name) => format!("camera {c} (node '{name}')"),
            None => format!("camera {c} (nodes[{}])", placed.node),
        };
        let perspective = match (&camera.type_, &camera.perspective) {
            (Checked::Valid(Type::Perspective), Some(p)) => p,
            (Checked::Valid(Type::Orthographic), _) => {
                out.warn(format!(
                    "{named} is orthographic and is not used (penumbra's cameras are perspective)"
                ));
                continue;
            }
            _ => {
                return Err(Error::file(
                    path,
                    format!("cameras[{c}].perspective"),
                    "missing (the camera's type is perspective)",
                ));
            }
        };
        let yfov = perspective.yfov;
        if !(yfov > 0.0 && yfov < std::f32::consts::PI) {
            return Err(Error::file(
                path,
                format!("cameras[{c}].perspective.yfov"),
                format!("{yfov} is not an angle in (0, pi) radians"),
            ));
        }
        let world = placed.world;
        let eye = world.transform_point3(DVec3::ZERO);
        let forward = world.transform_vector3(DVec3::NEG_Z).normalize_or_zero();
        if forward == DVec3::ZERO || !eye.is_finite() {
            return Err(Error::file(
                path,
                format!("nodes[{}]", placed.node),
                format!("places camera {c} with a transform that leaves it no view direction"),
            ));
        }
        let roll = roll_degrees(forward, world.transform_vector3(DVec3::Y));
        if roll > ROLL_WARNING_DEGREES {
            out.warn(format!(
                "{named} is rolled {roll:.1} degrees about its view direction; penumbra's cameras keep +y up, \
                 so it is read unrolled"
            ));
        }
        cameras.push(WorldCamera {
            eye,
            forward,
            fov_degrees: yfov.to_degrees(),
        });
    }
    Ok(cameras)
}

/// The angle between a camera's own up (`up`, made perpendicular to the
/// unit `forward`) and the up penumbra's camera takes for `forward`
/// (`Camera::basis`); 0 where `up` has no such part.
fn roll_degrees(forward: DVec3, up: DVec3) -> f64 {
    let own = (up - forward * up.dot(forward)).normalize_or_zero();
    let world_up = if forward.cross(DVec3::Y).length_squared() < 1e-12 {
        DVec3::Z
    } else {
        DVec3::Y
    };
    let ours = forward.cross(world_up).normalize().cross(forward);
    if own == DVec3::ZERO {
        return 0.0;
    }
    own.dot(ours).clamp(-1.0, 1.0).acos().to_degrees()
}

/// The cameras in the frame whose origin is `origin`, each looking at the
/// point of its view line as far from its eye as the centre of the mesh's
/// bounds (`positions`, world space) is, so that `--eye` alone moves a
/// camera that still looks towards the scene's part it looked at.
pub fn in_frame(cameras: &[WorldCamera], positions: &[DVec3], origin: DVec3) -> Vec<Camera> {
    let (lo, hi) = positions
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &p| {
            (lo.min(p), hi.max(p))
        });
    let centre = 0.5 * (lo + hi);
    let size = (hi - lo).length();
    cameras
        .iter()
        .map(|c| {
            let d = (centre - c.eye).length();
            // An eye at the centre (or an empty mesh) still needs a target
            // apart from it.
            let d = if d > 1e-6 * size && d.is_finite() {
                d
            } else {
                size.max(1.0)
            };
            Camera {
                eye: to_local(origin, c.eye),
                target: to_local(origin, c.eye + c.forward * d),
                fov_degrees: c.fov_degrees,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn roll_is_the_angle_to_penumbras_up() {
        assert_eq!(roll_degrees(DVec3::NEG_Z, DVec3::Y), 0.0);
        let r = roll_degrees(DVec3::NEG_Z, DVec3::new(1.0, 1.0, 0.0));
        assert!((r - 45.0).abs() < 1e-9, "{r}");
        // Looking straight down, penumbra's camera takes its up from +z:
        // a camera whose up is that one is not rolled, the opposite one is
        // by half a turn.
        let ours = Camera {
            eye: Vec3::ZERO,
            target: Vec3::NEG_Y,
            fov_degrees: 45.0,
        }
        .basis()
        .1
        .as_dvec3();
        assert!(roll_degrees(DVec3::NEG_Y, ours) < 1e-6);
        assert!((roll_degrees(DVec3::NEG_Y, -ours) - 180.0).abs() < 1e-6);
    }
}
