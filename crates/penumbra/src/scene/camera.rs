//! Pinhole camera, the command-line contract's default camera, and images
//! asked of a scene (`View`: a camera given in part, and a size).

use glam::{DVec3, Vec3};

use crate::error::{Error, Result};
use crate::geom::aabb::Aabb;
use crate::geom::ray::{Ray, flush_subnormal};

/// A pinhole camera looking from `eye` at `target`, in the scene's frame,
/// with +y up (+z for a vertical view, `basis`) and square pixels.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Camera {
    /// The centre of projection, where every primary ray starts.
    pub eye: Vec3,
    /// The point at the image's centre; any distance from `eye` but zero.
    pub target: Vec3,
    /// Vertical field of view in degrees.
    #[serde(rename = "fov")]
    pub fov_degrees: f32,
}

/// A camera given in part (the command line's `--eye/--target/--fov`):
/// what is missing comes from the scene's camera, else from the contract's
/// default camera for the scene's bounds. Points are in world coordinates,
/// in f64 (an eye 1e6 sizes off keeps its digits); `resolve` moves them
/// into the scene's frame (`scene::frame`).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct CameraSpec {
    /// `--eye`, in world coordinates.
    pub eye: Option<DVec3>,
    /// `--target`, in world coordinates.
    pub target: Option<DVec3>,
    /// `--fov`: the vertical field of view in degrees, in (0, 180).
    pub fov_degrees: Option<f32>,
}

impl CameraSpec {
    /// The whole camera in the frame whose origin is `origin` (the scene's):
    /// `base` (a scene's camera, in that frame) or the default for
    /// `bounds`, with each given part replacing its own. Validated.
    pub fn resolve(&self, base: Option<Camera>, bounds: &Aabb, origin: DVec3) -> Result<Camera> {
        let framed = base.is_none();
        let base = match base {
            Some(camera) => camera,
            None => Camera::framing(bounds)?,
        };
        let local = |p: DVec3| super::frame::to_local(origin, p);
        let camera = Camera {
            eye: self.eye.map_or(base.eye, local),
            target: self.target.map_or(base.target, local),
            fov_degrees: self.fov_degrees.unwrap_or(base.fov_degrees),
        };
        camera.validate()?;
        // The default camera frames the bounds by construction.
        let given = self.eye.is_some() || self.target.is_some();
        if given || !framed {
            let name = if given { "eye/target" } else { "the scene's \"camera\"" };
            camera.sees(bounds).map_err(|problem| Error::param(name, problem))?;
        }
        Ok(camera)
    }

    /// The whole of `c`, a camera in the frame whose origin is `origin`.
    pub fn world(c: Camera, origin: DVec3) -> CameraSpec {
        CameraSpec {
            eye: Some(super::frame::to_world(origin, c.eye)),
            target: Some(super::frame::to_world(origin, c.target)),
            fov_degrees: Some(c.fov_degrees),
        }
    }
}

/// `v` (finite, not zero) at unit length. Where its squared length
/// overflows (components beyond about 1.8e19) or underflows, `normalize`
/// gives zeros or NaN: `v` is then scaled by its largest component first.
fn unit(v: Vec3) -> Vec3 {
    if v.length_squared().is_normal() {
        v.normalize()
    } else {
        (v / v.abs().max_element()).normalize()
    }
}

/// Most pixels of one image.
pub const MAX_PIXELS: u64 = 1 << 28;

/// An image asked of a scene: its camera, resolved against the scene, and
/// its size in pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct View {
    /// The camera, in as far as it is given.
    pub camera: CameraSpec,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
}

/// 800 x 600 pixels through the scene's camera (or one framing it), as
/// the command line's `--width`/`--height` default.
impl Default for View {
    fn default() -> Self {
        View::sized(800, 600)
    }
}

impl View {
    /// `width` x `height` pixels through `camera`; an error for an empty
    /// image or one of more than `MAX_PIXELS` pixels.
    pub fn new(camera: CameraSpec, width: u32, height: u32) -> Result<View> {
        check_image_size(width, height)?;
        Ok(View { camera, width, height })
    }

    /// `width` x `height` pixels through the scene's camera, or one that
    /// frames the scene (the size is checked where the view is used).
    pub fn sized(width: u32, height: u32) -> View {
        View {
            camera: CameraSpec::default(),
            width,
            height,
        }
    }

    /// `width * height`.
    pub fn pixels(&self) -> usize {
        self.width as usize * self.height as usize
    }
}

/// An image size of at least one and at most `MAX_PIXELS` pixels.
pub fn check_image_size(width: u32, height: u32) -> Result<()> {
    if width == 0 || height == 0 {
        return Err(Error::param("width/height", "must be at least 1"));
    }
    if width as u64 * height as u64 > MAX_PIXELS {
        return Err(Error::param(
            "width/height",
            format!("{width}x{height} is more than 2^28 pixels"),
        ));
    }
    Ok(())
}

impl Camera {
    /// The contract's default: looks at the box centre c from c + 2.5 r u,
    /// r = half the box diagonal, u = normalize(0.3, 0.4, 1.0); fov 45 degrees.
    /// A box of zero size (a mesh collapsed to a point) gets r = 1, so the
    /// camera stays defined.
    pub fn default_for(bounds: &Aabb) -> Camera {
        let c = bounds.center();
        let r = 0.5 * bounds.diagonal();
        let r = if r > 0.0 && r.is_finite() { r } else { 1.0 };
        let u = Vec3::new(0.3, 0.4, 1.0).normalize();
        Camera {
            eye: c + 2.5 * r * u,
            target: c,
            fov_degrees: 45.0,
        }
    }

    /// `default_for`, or what makes framing `bounds` impossible: bounds that are not finite, an extent whose diagonal
    /// overflows f32, or a centre so far from the origin for the scene's
    /// size that an eye 2.5 radii away rounds to the centre itself (which
    /// `validate` could only call "the same point").
    pub fn framing(bounds: &Aabb) -> Result<Camera> {
        let show = |v: Vec3| format!("({:.3e}, {:.3e}, {:.3e})", v.x, v.y, v.z);
        let box_text = format!("{} to {}", show(bounds.min), show(bounds.max));
        if !(bounds.min.is_finite() && bounds.max.is_finite()) || bounds.min.cmpgt(bounds.max).any() {
            return Err(Error::input(
                "camera",
                format!("the scene's bounds ({box_text}) are not finite: nothing to frame"),
            ));
        }
        let diagonal = bounds.diagonal();
        if !diagonal.is_finite() || !bounds.center().is_finite() {
            return Err(Error::input(
                "camera",
                format!(
                    "the scene's extent (bounds {box_text}) overflows f32: its diagonal or centre is not finite,                      so no default camera can frame it; rescale the model or give --eye and --target"
                ),
            ));
        }
        let camera = Camera::default_for(bounds);
        let radius = if diagonal > 0.0 { 0.5 * diagonal } else { 1.0 };
        if camera.eye == camera.target {
            return Err(Error::input(
                "camera",
                format!(
                    "the scene (bounds {box_text}) is too far from the origin for its size: an eye {:.3e} away                      from its centre rounds to the centre itself in f32; move the model nearer the origin",
                    2.5 * radius
                ),
            ));
        }
        Ok(camera)
    }

    /// This camera (in the frame whose origin is `origin`) in world
    /// coordinates, rounded to f32: for reports.
    pub fn in_world(&self, origin: DVec3) -> Camera {
        let world = |p: Vec3| super::frame::to_world(origin, p).as_vec3();
        Camera {
            eye: world(self.eye),
            target: world(self.target),
            ..*self
        }
    }

    /// Checks that eye and target are finite and distinct and the field
    /// of view is in (0, 180) degrees.
    pub fn validate(&self) -> Result<()> {
        if !self.eye.is_finite() || !self.target.is_finite() {
            return Err(Error::param("eye/target", "must be finite"));
        }
        if self.eye == self.target {
            return Err(Error::param("eye/target", "eye and target are the same point"));
        }
        if !(self.target - self.eye).is_finite() {
            return Err(Error::param(
                "eye/target",
                "eye and target are too far apart: their difference overflows f32",
            ));
        }
        if !(self.fov_degrees > 0.0 && self.fov_degrees < 180.0) {
            return Err(Error::param(
                "fov_degrees",
                format!("must be in (0, 180) degrees, got {}", self.fov_degrees),
            ));
        }
        Ok(())
    }

    /// Checks the view against the scene's `bounds` (its bounding sphere):
    /// the problem where the scene lies wholly behind the eye, or spans
    /// less than a millionth of a radian from it (no image has a pixel
    /// that small: the eye is at the float limits, or the scene is a
    /// speck). An eye inside the sphere (a room's camera) always passes.
    pub fn sees(&self, bounds: &Aabb) -> std::result::Result<(), String> {
        if bounds.is_empty() || !bounds.min.is_finite() || !bounds.max.is_finite() {
            return Ok(());
        }
        let (centre, radius) = (bounds.center().as_dvec3(), 0.5 * bounds.diagonal() as f64);
        let to_centre = centre - self.eye.as_dvec3();
        let distance = to_centre.length();
        // A scene of no extent (a point) is the readers' to name.
        if distance <= radius || radius == 0.0 {
            return Ok(());
        }
        let forward = (self.target.as_dvec3() - self.eye.as_dvec3()).normalize();
        if to_centre.dot(forward) < -radius {
            return Err(format!(
                "the scene is wholly behind the camera: its bounds' centre is at {:?}, {distance:.4e} from the eye, \
                 and the camera looks the other way (towards {:?})",
                bounds.center().to_array(),
                self.target.to_array()
            ));
        }
        let span = 2.0 * (radius / distance).asin();
        if span < 1e-6 {
            return Err(format!(
                "the scene (radius {radius:.4e}) is {distance:.4e} from the eye: it spans {span:.2e} radians, \
                 less than a pixel of any image; bring the eye closer"
            ));
        }
        Ok(())
    }

    /// Right, up and forward unit vectors; up is +y unless the view is
    /// vertical, then +z.
    pub fn basis(&self) -> (Vec3, Vec3, Vec3) {
        let forward = unit(self.target - self.eye);
        let world_up = if forward.cross(Vec3::Y).length_squared() < 1e-12 {
            Vec3::Z
        } else {
            Vec3::Y
        };
        let right = forward.cross(world_up).normalize();
        let up = right.cross(forward);
        (right, up, forward)
    }

    /// Primary rays, row 0 at the top, pixel centres at half-integer offsets,
    /// unit-length directions (so t is a distance).
    pub fn primary_rays(&self, width: u32, height: u32) -> Vec<Ray> {
        self.primary_rays_at(width, height, 0.5, 0.5)
    }

    /// Primary rays through the point `(ox, oy)` of each pixel, offsets in
    /// [0, 1) from the pixel's top-left corner (0.5, 0.5 is its centre).
    pub fn primary_rays_at(&self, width: u32, height: u32, ox: f32, oy: f32) -> Vec<Ray> {
        self.pixel_directions_at(width, height, ox, oy).rays(self.eye)
    }

    /// The directions of `primary_rays` without the image of rays: a
    /// tracer that makes each pixel's direction as it needs it reads no
    /// ray buffer (24 MB at 1024^2).
    pub fn pixel_directions(&self, width: u32, height: u32) -> PixelDirections {
        self.pixel_directions_at(width, height, 0.5, 0.5)
    }

    fn pixel_directions_at(&self, width: u32, height: u32, ox: f32, oy: f32) -> PixelDirections {
        let (right, up, forward) = self.basis();
        let (tan_half, aspect) = self.projection_scales(width, height);
        PixelDirections {
            right,
            up,
            forward,
            px: (0..width)
                .map(|x| screen_x(x as f32 + ox, width, tan_half, aspect))
                .collect(),
            py: (0..height).map(|y| screen_y(y as f32 + oy, height, tan_half)).collect(),
        }
    }

    /// The unit direction through image point `(x, y)` of a `width x height`
    /// image, in pixels from its top-left corner.
    pub fn direction(&self, width: u32, height: u32, x: f32, y: f32) -> Vec3 {
        let (right, up, forward) = self.basis();
        let (tan_half, aspect) = self.projection_scales(width, height);
        let (px, py) = (screen_x(x, width, tan_half, aspect), screen_y(y, height, tan_half));
        pixel_direction(forward, right, up, px, py)
    }

    fn projection_scales(&self, width: u32, height: u32) -> (f32, f32) {
        let tan_half = (0.5 * self.fov_degrees.to_radians()).tan();
        (tan_half, width as f32 / height as f32)
    }
}

/// Image x (pixels from the left) on the image plane at distance 1.
fn screen_x(x: f32, width: u32, tan_half: f32, aspect: f32) -> f32 {
    (2.0 * x / width as f32 - 1.0) * tan_half * aspect
}

/// Image y (pixels from the top) on the image plane at distance 1.
fn screen_y(y: f32, height: u32, tan_half: f32) -> f32 {
    (1.0 - 2.0 * y / height as f32) * tan_half
}

/// The unit direction through the image plane's point `(px, py)`.
#[inline(always)]
fn pixel_direction(forward: Vec3, right: Vec3, up: Vec3, px: f32, py: f32) -> Vec3 {
    flush_subnormal((forward + px * right + py * up).normalize())
}

/// A pinhole camera's pixel directions for one image size: the image
/// plane's coordinates of each column and each row, so that a pixel's
/// direction is a few multiplications, a square root and a division
/// (`Camera::primary_rays` is made from these, so the two agree bit for
/// bit).
#[derive(Debug, Clone, PartialEq)]
pub struct PixelDirections {
    pub(crate) right: Vec3,
    pub(crate) up: Vec3,
    pub(crate) forward: Vec3,
    /// Image-plane x of each column.
    pub(crate) px: Vec<f32>,
    /// Image-plane y of each row.
    pub(crate) py: Vec<f32>,
}

impl PixelDirections {
    /// The image's width in pixels.
    pub fn width(&self) -> u32 {
        self.px.len() as u32
    }

    /// The image's height in pixels.
    pub fn height(&self) -> u32 {
        self.py.len() as u32
    }

    /// The unit direction of pixel `(x, y)`.
    #[inline(always)]
    pub fn at(&self, x: u32, y: u32) -> Vec3 {
        pixel_direction(
            self.forward,
            self.right,
            self.up,
            self.px[x as usize],
            self.py[y as usize],
        )
    }

    /// The image of rays from `eye`, row-major.
    pub fn rays(&self, eye: Vec3) -> Vec<Ray> {
        let mut rays = Vec::with_capacity(self.px.len() * self.py.len());
        for y in 0..self.height() {
            for x in 0..self.width() {
                rays.push(Ray::new(eye, self.at(x, y)));
            }
        }
        rays
    }
}

/// A camera's image of primary rays together with the pixel directions
/// they were made from, so that a tracer may remake any ray's direction
/// instead of reading it (`mlrta::trace_camera_into`); equal by
/// construction.
#[derive(Debug, Clone)]
pub struct CameraRays {
    eye: Vec3,
    directions: PixelDirections,
    rays: Vec<Ray>,
}

impl CameraRays {
    /// `camera.primary_rays(width, height)` with its directions.
    pub fn new(camera: &Camera, width: u32, height: u32) -> CameraRays {
        let directions = camera.pixel_directions(width, height);
        let rays = directions.rays(camera.eye);
        CameraRays {
            eye: camera.eye,
            directions,
            rays,
        }
    }

    /// The camera's eye, every ray's origin.
    pub fn eye(&self) -> Vec3 {
        self.eye
    }

    /// The pixel directions the rays were made from.
    pub fn directions(&self) -> &PixelDirections {
        &self.directions
    }

    /// The rays, row-major.
    pub fn rays(&self) -> &[Ray] {
        &self.rays
    }

    /// The rays, row-major, without the directions.
    pub fn into_rays(self) -> Vec<Ray> {
        self.rays
    }
}

/// A point or vector written "X,Y,Z" (finite numbers), read as
/// `frame::parse_point` reads it and rounded to f32 once.
pub fn parse_vec3(s: &str) -> std::result::Result<Vec3, String> {
    super::frame::parse_point(s).map(|p| p.as_vec3())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_view_that_cannot_show_the_scene_is_refused_naming_what_was_given() {
        let b = Aabb::new(Vec3::ZERO, Vec3::ONE);
        let at = |eye: [f64; 3], target: [f64; 3]| CameraSpec {
            eye: Some(DVec3::from_array(eye)),
            target: Some(DVec3::from_array(target)),
            fov_degrees: None,
        };
        let resolve = |spec: CameraSpec| spec.resolve(None, &b, DVec3::ZERO).map(drop).map_err(|e| e.to_string());
        // Behind, and a speck at the float limits: refused, naming eye/target.
        let behind = resolve(at([3.0, 3.0, 3.0], [9.0, 9.0, 9.0])).unwrap_err();
        assert!(
            behind.contains("eye/target") && behind.contains("wholly behind"),
            "{behind}"
        );
        let far = resolve(at([1e30, 1e30, 1e30], [0.5, 0.5, 0.5])).unwrap_err();
        assert!(far.contains("less than a pixel"), "{far}");
        // Looking past the scene from beside it, from inside it, or at it.
        resolve(at([3.0, 0.5, 0.5], [3.0, 0.5, 9.0])).unwrap();
        resolve(at([0.5, 0.5, 0.5], [9.0, 9.0, 9.0])).unwrap();
        resolve(at([1e6, 1e6, 1e6], [0.5, 0.5, 0.5])).unwrap();
        // A scene's own camera that looks away is named as the scene's.
        let away = Camera {
            eye: Vec3::splat(3.0),
            target: Vec3::splat(9.0),
            fov_degrees: 45.0,
        };
        let e = CameraSpec::default()
            .resolve(Some(away), &b, DVec3::ZERO)
            .unwrap_err()
            .to_string();
        assert!(e.contains("the scene's \"camera\""), "{e}");
    }

    #[test]
    fn default_camera_looks_at_the_centre() {
        let b = Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0));
        let cam = Camera::default_for(&b);
        let rays = cam.primary_rays(2, 2);
        // The four central rays are symmetric about the view axis.
        let mean: Vec3 = rays.iter().map(|r| r.d()).sum::<Vec3>() / 4.0;
        assert!(mean.normalize().dot((cam.target - cam.eye).normalize()) > 0.99999);
        // Row 0 is the top: its rays point more upward than row 1's.
        let (_, up, _) = cam.basis();
        assert!(rays[0].d().dot(up) > rays[2].d().dot(up));
        assert!((cam.eye - Vec3::new(0.3, 0.4, 1.0).normalize() * 2.5 * 3f32.sqrt()).length() < 1e-5);
    }

    #[test]
    fn framing_says_what_is_wrong_with_a_scene_beyond_f32() {
        let huge = Aabb::new(Vec3::splat(-3e38), Vec3::splat(3e38));
        let e = Camera::framing(&huge).unwrap_err().to_string();
        assert!(e.contains("extent") && e.contains("overflows f32"), "{e}");
        let centre_overflows = Aabb::new(Vec3::splat(2e38), Vec3::splat(3e38));
        let e = Camera::framing(&centre_overflows).unwrap_err().to_string();
        assert!(e.contains("overflows f32"), "{e}");
        let nan = Aabb::new(Vec3::new(f32::NAN, 0.0, 0.0), Vec3::ONE);
        assert!(Camera::framing(&nan).unwrap_err().to_string().contains("not finite"));
        assert!(
            Camera::framing(&Aabb::EMPTY)
                .unwrap_err()
                .to_string()
                .contains("not finite")
        );
        // 1e30 + 1 is 1e30 in f32: a point far off, framed 2.5 away.
        let far = Aabb::new(Vec3::splat(1e30), Vec3::splat(1e30));
        let e = Camera::framing(&far).unwrap_err().to_string();
        assert!(
            e.contains("too far from the origin") && !e.contains("same point"),
            "{e}"
        );
        let fine = Aabb::new(Vec3::ZERO, Vec3::ONE);
        assert_eq!(Camera::framing(&fine).unwrap(), Camera::default_for(&fine));
    }

    #[test]
    fn rejects_bad_cameras() {
        let mut c = Camera::default_for(&Aabb::new(Vec3::ZERO, Vec3::ONE));
        c.fov_degrees = 0.0;
        assert!(c.validate().is_err());
        c.fov_degrees = 45.0;
        c.target = c.eye;
        assert!(c.validate().is_err());
    }
}
