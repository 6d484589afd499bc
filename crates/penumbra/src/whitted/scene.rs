//! A scene made ready for Whitted ray tracing: every instance's triangles
//! in world space with their surfaces, shading normals and ray-tree ids,
//! the analytic spheres, the surfaces (materials as coefficients) and the
//! lights, laid out as the GPU reads them.

use std::collections::HashMap;

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use crate::error::{Error, Result};
use crate::scene::mtl_rules::{RuleApplied, SceneMaterials};
use crate::scene::texture_table::{DEFAULT_TEXTURE_BYTES, MapUse, NO_MAP, TextureTable, TextureTableBuilder};
use crate::scene::{Light, Material, Mesh, MeshObject, MtlRules, Scene};
use crate::whitted::lights::{Emitter, LightSample, check_light_count};
use crate::whitted::sphere::Sphere;
use crate::whitted::surface::Surface;

/// `TriangleShading::normals` of a flat triangle (shaded with its face normal).
pub const NO_NORMAL: u32 = u32::MAX;
/// `TriangleShading::face` of a smoothly shaded triangle: its surface is
/// one patch in ray trees (crossing its triangles is no discontinuity).
pub const SMOOTH_FACE: u32 = u32::MAX - 1;
/// A ray tree's object and face ids of a miss.
pub const MISS: u32 = u32::MAX;
/// `TriangleShading::texcoords` of a triangle without texture coordinates.
pub const NO_TEXCOORDS: u32 = u32::MAX;

/// The ambient light where neither the scene nor the caller gives one.
pub const DEFAULT_AMBIENT: f32 = 0.05;

/// What the renderer needs of each triangle, as the GPU reads it (32 bytes;
/// two words4 of the kernel's `triangle_shading`).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct TriangleShading {
    /// Index into `RenderScene::surfaces`.
    pub surface: u32,
    /// Its corners' shading normals (indices into `RenderScene::normals`),
    /// or `NO_NORMAL` for a flat triangle.
    pub normals: [u32; 3],
    /// Ray-tree object id: an instance's OBJ object (an index into
    /// `RenderScene::objects`).
    pub object: u32,
    /// Ray-tree face id: the OBJ polygon the triangle was fanned from,
    /// numbered across the scene's instances, or `SMOOTH_FACE`.
    pub face: u32,
    /// Its corners' texture coordinates: two entries of
    /// `RenderScene::normals` from this index, (u0, v0, u1, v1) and
    /// (u2, v2, -, -); or `NO_TEXCOORDS`.
    pub texcoords: u32,
    /// Padding to 32 bytes.
    pub _pad: u32,
}

/// An emissive polygon's surface and world-space triangles.
type EmissivePolygon = (u32, Vec<[Vec3; 3]>);

/// Scene-level choices of the lighting.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightingSettings {
    /// Point lights per emissive polygon (1: at its centroid).
    pub light_samples: u32,
    /// Ambient light, over the scene's (else `DEFAULT_AMBIENT` grey).
    pub ambient: Option<Vec3>,
    /// Radiance of rays that leave the scene, over the scene's (else black).
    pub background: Option<Vec3>,
    /// Bytes of texels the scene's texture maps may take: larger images
    /// are halved, largest first, with a warning each.
    pub texture_bytes: u64,
    /// How MTL files' materials are read: as their exporters meant where
    /// the file shows it, or by the letter of the spec (`scene::mtl_rules`).
    pub mtl_rules: MtlRules,
}

impl Default for LightingSettings {
    fn default() -> Self {
        LightingSettings {
            light_samples: 1,
            ambient: None,
            background: None,
            texture_bytes: DEFAULT_TEXTURE_BYTES,
            mtl_rules: MtlRules::default(),
        }
    }
}

/// A scene ready to render (see the module's description).
#[derive(Debug, Clone)]
pub struct RenderScene {
    /// World-space triangles, one mesh object per ray-tree object.
    pub mesh: Mesh,
    /// Per triangle of `mesh`, its surface, shading normals and ray-tree ids.
    pub triangles: Vec<TriangleShading>,
    /// Unit shading normals (w unused), then the triangles' texture
    /// coordinates (`TriangleShading::texcoords`).
    pub normals: Vec<[f32; 4]>,
    /// The surfaces (materials as shading coefficients), each material
    /// made once.
    pub surfaces: Vec<Surface>,
    /// The material each surface came from.
    pub surface_names: Vec<String>,
    /// The surfaces' texture maps and their images.
    pub textures: TextureTable,
    /// The analytic spheres, primitives `triangles.len()` onwards.
    pub spheres: Vec<Sphere>,
    /// The scene's point and directional lights, then the emissive
    /// polygons' samples; the default light where there is none.
    pub lights: Vec<LightSample>,
    /// Ambient light: the caller's, else the scene's, else
    /// `DEFAULT_AMBIENT` grey.
    pub ambient: Vec3,
    /// Radiance of rays that leave the scene: the caller's, else the
    /// scene's, else black.
    pub background: Vec3,
    /// Ray-tree object names: the mesh's objects, then the spheres.
    pub objects: Vec<String>,
    /// Whether any surface lets light through (glass, dissolved or cut out:
    /// shadow rays then pass it, filtered, instead of stopping at the first
    /// occluder).
    pub transmissive: bool,
    /// Emissive polygons turned into lights, and their sample points.
    pub emitters: usize,
    /// The rules that read MTL materials as their exporters meant, and the
    /// materials each changed (`LightingSettings::mtl_rules`).
    pub material_rules: Vec<RuleApplied>,
    /// Problems that do not stop rendering (MTL rules applied, clamped
    /// weights, emissive spheres...).
    pub warnings: Vec<String>,
}

/// Surfaces by the material they come from, each made once.
struct SurfaceTable<'a> {
    surfaces: Vec<Surface>,
    names: Vec<String>,
    index: HashMap<(usize, u32), u32>,
    scene_materials: &'a [Material],
    textures: TextureTableBuilder,
    warnings: Vec<String>,
}

/// Where a surface's material comes from: a mesh's own (mesh, index) or
/// the scene's (usize::MAX, index); `u32::MAX` is the default material.
impl<'a> SurfaceTable<'a> {
    fn get(&mut self, key: (usize, u32), material: impl FnOnce() -> Material) -> u32 {
        if let Some(&s) = self.index.get(&key) {
            return s;
        }
        let mut m = material();
        let maps = &m.maps;
        let mut add = |map: Option<&crate::scene::TextureMap>, usage| {
            map.and_then(|map| self.textures.add(map, usage, &m.name, &mut self.warnings))
                .unwrap_or(NO_MAP)
        };
        let ids = [
            add(maps.kd.as_deref(), MapUse::Colour),
            add(maps.ka.as_deref(), MapUse::Colour),
            add(maps.ks.as_deref(), MapUse::Colour),
            match &maps.alpha {
                Some(a) => add(Some(&a.map), MapUse::Alpha { luminance: a.luminance }),
                None => NO_MAP,
            },
        ];
        if let (Some(a), true) = (&maps.alpha, ids[3] != NO_MAP) {
            self.textures.cut_out(ids[3], a.factor, a.cutoff);
        }
        // A black colour beside its map: the map alone is the colour.
        if ids[0] != NO_MAP && m.kd == Vec3::ZERO {
            m.kd = Vec3::ONE;
        }
        if ids[1] != NO_MAP && m.ka == Vec3::ZERO {
            m.ka = Vec3::ONE;
        }
        let mut surface = Surface::from_material(&m, &mut self.warnings);
        if ids[2] != NO_MAP && m.ks == Vec3::ZERO && !matches!(m.illum, 0 | 1) {
            // The highlight's colour only: the mirror weight stays Ks's.
            let dissolved = !surface.refracts() && m.dissolve < 1.0;
            surface.ks = [if dissolved { m.dissolve } else { 1.0 }; 3];
        }
        [surface.map_kd, surface.map_ka, surface.map_ks, surface.map_alpha] = ids;
        self.surfaces.push(surface);
        self.names.push(m.name.clone());
        let id = self.surfaces.len() as u32 - 1;
        self.index.insert(key, id);
        id
    }

    fn default_surface(&mut self) -> u32 {
        self.get((usize::MAX, u32::MAX), Material::default_surface)
    }

    fn scene_material(&mut self, name: &str, what: &str) -> Result<u32> {
        let Some(i) = self.scene_materials.iter().position(|m| m.name == name) else {
            return Err(Error::input(
                what,
                format!("material '{name}' is not defined in the scene's \"materials\""),
            ));
        };
        let m = self.scene_materials[i].clone();
        Ok(self.get((usize::MAX, i as u32), || m))
    }
}

impl RenderScene {
    /// The scene at animation frame `frame` (instances' rigid motions).
    pub fn new(scene: &Scene, frame: u32, options: &LightingSettings) -> Result<RenderScene> {
        if options.light_samples == 0 {
            return Err(Error::param("light_samples", "must be at least 1"));
        }
        let materials = SceneMaterials::new(&scene.meshes, options.mtl_rules);
        let mut table = SurfaceTable {
            surfaces: Vec::new(),
            names: Vec::new(),
            index: HashMap::new(),
            scene_materials: &scene.materials,
            textures: TextureTableBuilder::default(),
            warnings: materials.warnings.clone(),
        };
        // Texture coordinates, two entries per triangle that has them
        // (appended to the normals at the end).
        let mut texcoords: Vec<[f32; 4]> = Vec::new();
        let mut mesh = Mesh::default();
        let mut triangles = Vec::new();
        let mut normals = Vec::new();
        let mut emitters = Vec::new();
        let mut face_base = 0u32;
        for inst in &scene.instances {
            let source = &scene.meshes[inst.mesh];
            let transform = inst.transform_at(frame);
            let mut world = source.mesh.map_positions(|p| transform.apply_point(p));
            // Placed: in the scene's frame now (as `Scene::world_mesh_at`).
            world.origin = scene.origin;
            let shading = source.shading.as_ref();
            let normal_base = normals.len() as u32;
            if let Some(s) = shading {
                normals.extend(s.normals.iter().map(|&n| {
                    let n = transform.apply_vector(n).normalize_or_zero();
                    [n.x, n.y, n.z, 0.0]
                }));
            }
            let object_base = mesh.objects.len() as u32;
            let override_surface = match &inst.material {
                Some(name) => Some(table.scene_material(name, &format!("instance '{}'", inst.name))?),
                None => None,
            };
            // Emissive polygons: their surface and triangles.
            let mut polygons: HashMap<u32, EmissivePolygon> = HashMap::new();
            let mut faces_used = 0u32;
            for (object_index, object) in world.objects.iter().enumerate() {
                for t in object.triangles.clone() {
                    let t = t as usize;
                    let surface = match (override_surface, shading) {
                        (Some(s), _) => s,
                        (None, Some(s)) => {
                            let m = s.triangle_materials[t];
                            table.get((inst.mesh, m), || materials.material(inst.mesh, m).clone())
                        }
                        (None, None) => table.default_surface(),
                    };
                    let polygon = shading.map_or(t as u32, |s| s.triangle_faces[t]);
                    faces_used = faces_used.max(polygon + 1);
                    let corner = shading.and_then(|s| s.corner_normals[t]);
                    let uv = shading.and_then(|s| {
                        let c = s.corner_texcoords.get(t).copied().flatten()?;
                        Some(c.map(|i| s.texcoords[i as usize]))
                    });
                    let uv_at = match uv {
                        Some([a, b, c]) => {
                            texcoords.push([a.x, a.y, b.x, b.y]);
                            texcoords.push([c.x, c.y, 0.0, 0.0]);
                            texcoords.len() as u32 - 2
                        }
                        None => NO_TEXCOORDS,
                    };
                    triangles.push(TriangleShading {
                        surface,
                        normals: corner.map_or([NO_NORMAL; 3], |c| c.map(|i| normal_base + i)),
                        object: object_base + object_index as u32,
                        face: if corner.is_some() {
                            SMOOTH_FACE
                        } else {
                            face_base + polygon
                        },
                        texcoords: uv_at,
                        _pad: 0,
                    });
                    if table.surfaces[surface as usize].emits() {
                        let entry = polygons.entry(polygon).or_insert((surface, Vec::new()));
                        entry.1.push(world.triangle(t));
                    }
                }
            }
            let mut polygons: Vec<(u32, EmissivePolygon)> = polygons.into_iter().collect();
            polygons.sort_unstable_by_key(|p| p.0);
            for (k, (surface, tris)) in polygons {
                emitters.push((face_base + k, tris, surface));
            }
            let mut placed = world;
            for o in &mut placed.objects {
                o.name = if source.mesh.objects.len() > 1 {
                    format!("{}/{}", inst.name, o.name)
                } else {
                    inst.name.clone()
                };
            }
            mesh.append(&placed);
            face_base += faces_used;
        }
        let mut objects: Vec<String> = mesh.objects.iter().map(|o| o.name.clone()).collect();
        let mut spheres = Vec::new();
        for (i, s) in scene.spheres.iter().enumerate() {
            let surface = match &s.material {
                Some(name) => table.scene_material(name, &format!("spheres[{i}]"))?,
                None => table.default_surface(),
            };
            if table.surfaces[surface as usize].emits() {
                table.warnings.push(format!(
                    "sphere '{}' is emissive: it glows where seen but does not light the scene (emissive faces of meshes do)",
                    s.name
                ));
            }
            spheres.push(Sphere {
                center: s.center.to_array(),
                radius: s.radius,
                surface,
                object: objects.len() as u32,
                _pad: [0; 2],
            });
            objects.push(s.name.clone());
        }
        if mesh.triangles.is_empty() {
            if spheres.is_empty() {
                return Err(Error::input(
                    "scene",
                    "has no triangles and no spheres: nothing to render",
                ));
            }
            placeholder_triangle(&mut mesh, &mut triangles, &spheres, table.default_surface());
        }
        mesh.validate()?;
        let uv_base = normals.len() as u32;
        for t in &mut triangles {
            if t.texcoords != NO_TEXCOORDS {
                t.texcoords += uv_base;
            }
        }
        normals.extend_from_slice(&texcoords);
        unmapped_warnings(&table.surfaces, &table.names, &triangles, &mut table.warnings);
        let textures = table.textures.finish(options.texture_bytes, &mut table.warnings);
        let mut lights = scene_lights(&scene.lights);
        for (index, tris, surface) in &emitters {
            let emitter = Emitter {
                triangles: tris.clone(),
                radiance: Vec3::from_array(table.surfaces[*surface as usize].ke),
                index: *index,
            };
            lights.extend(emitter.samples(options.light_samples));
            check_light_count(lights.len())?;
        }
        if lights.is_empty() {
            lights = scene_lights(&[Light::default_light()]);
        }
        let transmissive = table.surfaces.iter().any(|s| s.transmits() || s.map_alpha != NO_MAP);
        Ok(RenderScene {
            mesh,
            triangles,
            normals,
            surfaces: table.surfaces,
            surface_names: table.names,
            textures,
            spheres,
            lights,
            ambient: options
                .ambient
                .or(scene.ambient)
                .unwrap_or(Vec3::splat(DEFAULT_AMBIENT)),
            background: options.background.or(scene.background).unwrap_or(Vec3::ZERO),
            objects,
            transmissive,
            emitters: emitters.len(),
            material_rules: materials.applied,
            warnings: table.warnings,
        })
    }

    /// Surface `id` (an index into `surfaces`, as `primitive_surface`
    /// gives it).
    pub fn surface(&self, id: u32) -> &Surface {
        &self.surfaces[id as usize]
    }

    /// The surface id of primitive `p` (a triangle, or `triangles + s` for
    /// sphere `s`).
    pub fn primitive_surface(&self, p: u32) -> u32 {
        match p.checked_sub(self.triangles.len() as u32) {
            Some(s) => self.spheres[s as usize].surface,
            None => self.triangles[p as usize].surface,
        }
    }

    /// The stack of glass a point is inside, outermost first: the spheres
    /// and closed glass objects around it (by the parity of crossings of a
    /// ray from it), larger ones outside smaller ones. Where a camera
    /// inside glass starts.
    pub fn media_at(&self, p: Vec3) -> Vec<u32> {
        let mut inside: Vec<(f32, u32)> = Vec::new();
        for s in &self.spheres {
            if self.surface(s.surface).refracts() && s.contains(p) {
                inside.push((s.radius, s.surface));
            }
        }
        // Odd crossings of an arbitrary ray with an object's glass triangles.
        let dir = Vec3::new(0.5773, 0.5774, 0.5775).normalize();
        let ray = crate::accel::kdtree::watertight::ShearedRay::new(p, dir);
        for object in &self.mesh.objects {
            let mut crossings = 0u32;
            let mut surface = None;
            for t in object.triangles.clone() {
                let s = self.triangles[t as usize].surface;
                if !self.surface(s).refracts() {
                    continue;
                }
                let [a, b, c] = self.mesh.triangle(t as usize);
                if ray.intersect(a, b, c, f32::INFINITY).is_some() {
                    crossings += 1;
                    surface = Some(s);
                }
            }
            if let (true, Some(s)) = (crossings % 2 == 1, surface) {
                inside.push((object_extent(&self.mesh, object), s));
            }
        }
        inside.sort_by(|a, b| b.0.total_cmp(&a.0));
        inside.into_iter().map(|(_, s)| s).collect()
    }
}

/// One warning per mapped surface some of whose triangles have no texture
/// coordinates (its maps are not used there), and per mapped surface on a
/// sphere (spheres have none).
fn unmapped_warnings(
    surfaces: &[Surface],
    names: &[String],
    triangles: &[TriangleShading],
    warnings: &mut Vec<String>,
) {
    let mut missing = vec![0usize; surfaces.len()];
    for t in triangles {
        if t.texcoords == NO_TEXCOORDS && surfaces[t.surface as usize].mapped() {
            missing[t.surface as usize] += 1;
        }
    }
    for (s, &n) in missing.iter().enumerate() {
        if n > 0 {
            warnings.push(format!(
                "material '{}' has texture maps, but {n} of its triangles have no texture coordinates (vt / TEXCOORD_0): the maps are not used there",
                names[s]
            ));
        }
    }
}

/// Diagonal of an object's bounds, to order nested media.
fn object_extent(mesh: &Mesh, object: &MeshObject) -> f32 {
    let triangles = &mesh.triangles[object.triangles.start as usize..object.triangles.end as usize];
    crate::scene::used_bounds(&mesh.positions, triangles).diagonal()
}

/// A scene of spheres alone still needs a tree: one triangle of zero area
/// (never hit: the watertight test rejects it) inside the first sphere.
fn placeholder_triangle(mesh: &mut Mesh, triangles: &mut Vec<TriangleShading>, spheres: &[Sphere], surface: u32) {
    let c = spheres[0].center();
    let origin = mesh.origin;
    *mesh = Mesh {
        positions: vec![c, c, c],
        triangles: vec![[0, 1, 2]],
        objects: vec![MeshObject {
            name: "(none)".into(),
            triangles: 0..1,
        }],
        origin,
    };
    triangles.push(TriangleShading {
        surface,
        normals: [NO_NORMAL; 3],
        object: MISS,
        face: MISS,
        texcoords: NO_TEXCOORDS,
        _pad: 0,
    });
}

fn scene_lights(lights: &[Light]) -> Vec<LightSample> {
    lights
        .iter()
        .map(|l| match *l {
            Light::Point { position, intensity } => LightSample::point(position, intensity),
            Light::Directional { direction, radiance } => LightSample::directional(direction, radiance),
        })
        .collect()
}
