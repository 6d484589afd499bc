//! Camera paths for animations (`raytrace --frames N --path FILE`): one
//! keyframe a line, `EX,EY,EZ TX,TY,TZ FOV` (eye, target, vertical field of
//! view in degrees), `#` comments and blank lines ignored. Frame `f` of `N`
//! lies at `f / (N - 1)` of the way along the keys, interpolated linearly
//! between neighbouring keys. Without a file, the frames take the
//! built-in walk from the scene's camera: over the animation the eye steps
//! sideways by 12% and forward by 6% of its distance to the target, which
//! follows a sixth of the way sideways, so each frame sees most of what
//! the last one saw (the paper's walkthroughs cross a room in 400 frames).

use std::path::Path;

#[cfg(test)]
use glam::Vec3;

use super::Camera;
use crate::error::{Error, Result};

/// How the camera moves over an animation's frames (see the module's
/// description).
#[derive(Debug, Clone, PartialEq)]
pub enum CameraPath {
    /// Keyframes of a path file, at least one, in the scene's frame: the
    /// frames spread evenly over them, interpolated linearly.
    Keys(Vec<Camera>),
    /// The built-in walk from a camera.
    Walk(Camera),
}

impl CameraPath {
    /// Reads a path file whose points are taken as they are (a scene at
    /// the world's origin); errors name the file and line.
    pub fn load(path: &Path) -> Result<CameraPath> {
        Self::load_in(path, glam::DVec3::ZERO)
    }

    /// `load`, the keyframes' points (world coordinates, read in f64) moved
    /// into the frame whose origin is `origin` (the scene's: `scene::frame`).
    pub fn load_in(path: &Path, origin: glam::DVec3) -> Result<CameraPath> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::read(path, e))?;
        Self::parse_in(&text, origin).map_err(|e| e.in_file(path))
    }

    /// Parses keyframes; errors name the line.
    pub fn parse(text: &str) -> Result<CameraPath> {
        Self::parse_in(text, glam::DVec3::ZERO)
    }

    fn parse_in(text: &str, origin: glam::DVec3) -> Result<CameraPath> {
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let mut keys = Vec::new();
        for (i, raw) in text.lines().enumerate() {
            let line = raw.split('#').next().unwrap_or("").trim();
            if line.is_empty() {
                continue;
            }
            let at = || format!("line {}", i + 1);
            let parts: Vec<&str> = line.split_ascii_whitespace().collect();
            let [eye, target, fov] = parts[..] else {
                return Err(Error::input(
                    at(),
                    format!("expected 'EX,EY,EZ TX,TY,TZ FOV', got {} fields", parts.len()),
                ));
            };
            let vec3 = |what: &str, s: &str| {
                super::frame::parse_point(s)
                    .map(|p| super::frame::to_local(origin, p))
                    .map_err(|e| Error::input(at(), format!("{what}: {e}")))
            };
            let fov_degrees: f32 = fov
                .parse()
                .map_err(|_| Error::input(at(), format!("field of view '{fov}' is not a number")))?;
            let camera = Camera {
                eye: vec3("eye", eye)?,
                target: vec3("target", target)?,
                fov_degrees,
            };
            camera.validate().map_err(|e| Error::input(at(), e.to_string()))?;
            keys.push(camera);
        }
        if keys.is_empty() {
            return Err(Error::input("path", "has no keyframes"));
        }
        Ok(CameraPath::Keys(keys))
    }

    /// The camera of frame `frame` of `frames`.
    pub fn at(&self, frame: u32, frames: u32) -> Camera {
        let u = if frames > 1 {
            frame as f32 / (frames - 1) as f32
        } else {
            0.0
        };
        match self {
            CameraPath::Keys(keys) => {
                let x = u * (keys.len() - 1) as f32;
                let k = (x.floor() as usize).min(keys.len() - 1);
                let (a, b) = (keys[k], keys[(k + 1).min(keys.len() - 1)]);
                let s = x - k as f32;
                Camera {
                    eye: a.eye.lerp(b.eye, s),
                    target: a.target.lerp(b.target, s),
                    fov_degrees: a.fov_degrees + (b.fov_degrees - a.fov_degrees) * s,
                }
            }
            CameraPath::Walk(c) => {
                let (right, _, forward) = c.basis();
                let dist = (c.target - c.eye).length();
                Camera {
                    eye: c.eye + u * dist * (0.12 * right + 0.06 * forward),
                    target: c.target + u * dist * 0.02 * right,
                    fov_degrees: c.fov_degrees,
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_interpolate_and_errors_name_the_line() {
        let p = CameraPath::parse("# a path\n0,0,5 0,0,0 40\n\n10,0,5 10,0,0 60\n").unwrap();
        assert_eq!(p.at(0, 3).eye, Vec3::new(0.0, 0.0, 5.0));
        assert_eq!(p.at(1, 3).eye, Vec3::new(5.0, 0.0, 5.0));
        assert_eq!(p.at(1, 3).fov_degrees, 50.0);
        assert_eq!(p.at(2, 3).target, Vec3::new(10.0, 0.0, 0.0));
        for (text, problem) in [
            ("0,0,5 0,0,0\n", "got 2 fields"),
            ("0,0,5 0,0,0 x\n", "not a number"),
            ("0,0,5 0,0,5 40\n", "same point"),
            ("0,0 0,0,0 40\n", "eye"),
            ("# nothing\n", "no keyframes"),
        ] {
            let e = CameraPath::parse(text).unwrap_err().to_string();
            assert!(e.contains(problem), "{text:?}: {e}");
        }
        assert!(
            CameraPath::parse("\n0,0,5 0,0,0 x\n")
                .unwrap_err()
                .to_string()
                .contains("line 2")
        );
    }

    #[test]
    fn the_walk_starts_at_the_camera_and_steps_sideways_and_forward() {
        let c = Camera {
            eye: Vec3::new(0.0, 1.0, 4.0),
            target: Vec3::new(0.0, 1.0, 0.0),
            fov_degrees: 45.0,
        };
        let p = CameraPath::Walk(c);
        assert_eq!(p.at(0, 30), c);
        let last = p.at(29, 30);
        assert!((last.eye - Vec3::new(0.48, 1.0, 3.76)).length() < 1e-5, "{}", last.eye);
    }
}
