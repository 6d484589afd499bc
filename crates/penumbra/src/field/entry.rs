//! [`FieldSettings`] and [`FieldAo::build`]: displacement-field AO
//! (Gaitatzes et al.) as one entry.

use super::directions::DirectionMapping;
use super::lookup::Positional;
use super::reach::Reach;
use super::runner::FieldAo;
use super::storage::FieldSampling;
use crate::error::Result;
use crate::gpu::device::Device;
use crate::progress::Reporter;
use crate::scene::Scene;

/// The knobs of displacement-field AO. `Default` is the command line's:
/// 4226 positional samples (a 65 x 65 octahedral grid), maps of 32 x 32
/// directions at 8 bits, the concentric direction mapping, bilinear
/// positional lookups.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FieldSettings {
    /// How fields are sampled and stored (built for casters the scene
    /// names no `.dfield` file for).
    pub sampling: FieldSampling,
    /// How a lookup combines the positional samples around a ray's entry
    /// point.
    pub positional: Positional,
}

impl Default for FieldSettings {
    fn default() -> Self {
        FieldSettings {
            sampling: FieldSampling::new(4226, 32, 8, DirectionMapping::Concentric)
                .expect("the default parameters are valid"),
            positional: Positional::Bilinear,
        }
    }
}

impl<'s> FieldAo<'s> {
    /// The fields of `scene`'s casters (read where the scene names a file,
    /// built with `settings` otherwise), on `device`: a GPU holds them as
    /// 3D textures and runs the lookups in the WGSL kernel `field_ao`, the
    /// CPU runs its twin. Every caster may occlude every receiver (one
    /// frame); `new` narrows that to a radius and a number of frames.
    ///
    /// ```
    /// use penumbra::{AoRequest, AoSettings, Device, FieldAo, FieldSettings, Scene};
    /// use penumbra::field::{DirectionMapping, FieldSampling};
    /// use penumbra::scene::SceneMesh;
    /// use penumbra::scene::procedural::{corner, uv_sphere};
    ///
    /// // A ball over a corner: the ball casts, the corner receives.
    /// let ball = uv_sphere("ball", glam::Vec3::new(0.5, 0.5, 0.5), 0.3, 16, 8);
    /// let scene = Scene::from_mesh("ball", "ball.obj".as_ref(), ball)
    ///     .with_receiver(SceneMesh::new("corner", "corner.obj".as_ref(), corner()));
    /// let settings = FieldSettings {
    ///     sampling: FieldSampling::new(66, 8, 8, DirectionMapping::Concentric)?,
    ///     ..Default::default()
    /// };
    /// let mut fields = FieldAo::build(&Device::cpu(), &scene, &settings)?;
    /// let request = AoRequest { settings: AoSettings { rays_per_point: 32, ..Default::default() }, vertices: true, image: None };
    /// let run = fields.run(&request, 1, false)?;
    /// assert!(run.vertices.is_some());
    /// # Ok::<(), penumbra::Error>(())
    /// ```
    pub fn build(device: &Device, scene: &'s Scene, settings: &FieldSettings) -> Result<FieldAo<'s>> {
        FieldAo::build_with(device, scene, settings, Reach::EVERYTHING, &Reporter::silent())
    }

    /// `build` for AO within `reach` (a radius over a number of frames:
    /// casters that cannot occlude any receiver there get no field),
    /// following the fields' builds and every later run with `progress`.
    pub fn build_with(
        device: &Device,
        scene: &'s Scene,
        settings: &FieldSettings,
        reach: Reach,
        progress: &Reporter,
    ) -> Result<FieldAo<'s>> {
        let mut fields = FieldAo::new(scene, &settings.sampling, settings.positional, reach, progress)?;
        fields.upload(device)?;
        Ok(fields)
    }
}
