//! Extremal rays' samples: the radiance leaving a linetree's root surface
//! along a line and its ray tree, traced by the Whitted twin or (as
//! `TreeRay`s) by the kernel's `whitted_trees`; and a sample's radiance
//! split around its root's texture.

use glam::{DVec3, Vec3};

use crate::bounded::geometry::SceneGeometry;
use crate::bounded::linetree::Sample;
use crate::bounded::predicate::RootFace;
use crate::whitted::RenderScene;
use crate::whitted::scene::MISS;
use crate::whitted::surface::Surface as Shading;
use crate::whitted::tree_records::TreeRay;
use crate::whitted::whitted::Whitted;

/// An extremal ray as the Whitted kernel's `whitted_trees` takes it: its
/// root hit found here as `trace_sample` finds it.
pub(crate) fn tree_ray(geometry: &SceneGeometry, root: RootFace, o: DVec3, d: DVec3) -> TreeRay {
    let (t, primitive) = geometry
        .root_hit(root, o, d)
        .map_or((0.0, MISS), |(t, p)| (t as f32, p));
    TreeRay {
        origin: o.as_vec3().to_array(),
        root_t: t,
        dir: d.as_vec3().to_array(),
        root_primitive: primitive,
    }
}

/// An extremal ray's sample: from the front face, in air.
/// The radiance leaving a linetree's root surface along the line `o + t d`
/// and its ray tree: the line's first hit is put on the root (what lies
/// between the front face and the root is no part of the interpolant:
/// pixel assignment is exact, and reprojection culls the eye's own shaft).
pub(crate) fn trace_sample(twin: &Whitted, geometry: &SceneGeometry, root: RootFace, o: DVec3, d: DVec3) -> Sample {
    twin_sample(twin, &tree_ray(geometry, root, o, d))
}

/// The sample of a ray whose root hit is found (`tree_ray`), by the twin.
pub(crate) fn twin_sample(twin: &Whitted, ray: &TreeRay) -> Sample {
    let (out, tree) = twin.trace_tree(ray);
    Sample::new(out.radiance, out.diffuse, tree)
}

/// The surface a sample's line hits first.
pub(crate) fn first_surface<'a>(scene: &'a RenderScene, s: &Sample) -> Option<&'a Shading> {
    let hit = s.tree.nodes.first()?.hit?;
    Some(scene.surface(hit.surface))
}

/// A sample's radiance as `(base, diffuse)` with `radiance = base + T
/// diffuse`, `T` the texture at its first hit (`(radiance, 0)` where that
/// surface has no texture).
pub(crate) fn textured_split(scene: &RenderScene, s: &Sample) -> (Vec3, Vec3) {
    match s.tree.nodes.first().and_then(|n| n.hit) {
        Some(hit) if scene.surface(hit.surface).textured() => {
            let t = scene.surface(hit.surface).texture(hit.point);
            (s.radiance - t * s.diffuse, s.diffuse)
        }
        _ => (s.radiance, Vec3::ZERO),
    }
}
