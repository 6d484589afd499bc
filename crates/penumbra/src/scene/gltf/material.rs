//! Materials: glTF's metallic-roughness materials read as the Whitted
//! model's (`whitted::surface`).
//!
//! - `pbrMetallicRoughness.baseColorFactor` (rgb) is the diffuse colour
//!   (illum 1), `baseColorTexture` its map (`MaterialMaps::kd`, which the
//!   renderer multiplies by the factor, as glTF does), with the texture's
//!   sampler: `CLAMP_TO_EDGE` clamps, `REPEAT` and `MIRRORED_REPEAT` (with
//!   a warning) repeat; a sampler whose S and T differ is read by its S.
//!   `KHR_texture_transform` becomes the map's scale and offset (in
//!   penumbra's v-up convention); its rotation is not used (a warning).
//!   A texture read through another set than `TEXCOORD_0` is not used.
//! - `emissiveFactor` (times `KHR_materials_emissive_strength`) is the
//!   emission.
//! - `alphaMode` `MASK`: the base colour texture's alpha times the factor's
//!   alpha, against `alphaCutoff` (0.5 by default), cuts holes
//!   (`MaterialMaps::alpha`); without a texture a factor below the cutoff
//!   makes the whole surface a hole (dissolve 0). `BLEND` with a texture is
//!   the same cut-out at 0.5 (a warning says blending is approximated);
//!   without one, the factor's alpha is the dissolve (a uniformly
//!   see-through surface is what blending gives).
//! - `KHR_materials_transmission` (a factor above 0) makes glass (illum 7):
//!   transmission `Tf` = factor times the base colour, index of refraction
//!   `KHR_materials_ior` (1.5 by default), `Ks` the Fresnel reflectance at
//!   normal incidence of that index, ((n - 1) / (n + 1))^2 (0.04 for 1.5),
//!   a Phong exponent from the roughness (the Blinn-Phong exponent
//!   2 / a^2 - 2 of alpha a = roughness^2, within [1, 1000]), and the
//!   diffuse colour scaled by 1 - factor.
//! - Metalness, and the emissive, normal, occlusion and transmission
//!   textures, are not used (a warning names them).

use std::path::Path;
use std::sync::Arc;

use ::gltf::material::AlphaMode;
use ::gltf::texture::{Info, WrappingMode};
use glam::{Vec2, Vec3};

use super::{Reader, container};
use crate::error::{Error, Result};
use crate::scene::mtl::Material;
use crate::scene::texture::{AlphaMap, TextureMap, TextureSource};

/// glTF's default `alphaCutoff`, and the cut-out `BLEND` is read as.
const CUTOFF: f32 = 0.5;
/// The Phong exponents glass's roughness maps to.
const NS_RANGE: (f32, f32) = (1.0, 1000.0);

impl Reader<'_> {
    /// Our index of a primitive's material: 0 for glTF's default material.
    /// Colours must be finite and not negative (glTF says in [0, 1];
    /// `KHR_materials_emissive_strength` scales emission beyond).
    pub(super) fn material(&mut self, m: ::gltf::Material) -> Result<u32> {
        let Some(index) = m.index() else {
            return Ok(0);
        };
        if let Some(&ours) = self.out.material_index.get(&index) {
            return Ok(ours);
        }
        let name = m.name().map_or_else(|| format!("material {index}"), str::to_string);
        let field = |f: &str| format!("materials[{index}].{f}");
        let pbr = m.pbr_metallic_roughness();
        let [r, g, b, alpha] = pbr.base_color_factor();
        let strength = m.emissive_strength().unwrap_or(1.0);
        let kd = Vec3::new(r, g, b);
        let ke = Vec3::from(m.emissive_factor()) * strength;
        for (f, c) in [("pbrMetallicRoughness.baseColorFactor", kd), ("emissiveFactor", ke)] {
            if !c.is_finite() || c.min_element() < 0.0 {
                return Err(Error::file(
                    self.path,
                    field(f),
                    format!("{c} (with any emissive strength) is not a finite, non-negative colour"),
                ));
            }
        }
        if !(0.0..=1.0).contains(&alpha) {
            return Err(Error::file(
                self.path,
                field("pbrMetallicRoughness.baseColorFactor"),
                format!("alpha {alpha} is not in [0, 1]"),
            ));
        }
        let base = match pbr.base_color_texture() {
            Some(info) => self.texture_map(&name, &field("pbrMetallicRoughness.baseColorTexture"), &info)?,
            None => None,
        };
        let mut material = Material {
            ka: kd,
            kd,
            ke,
            illum: 1,
            ..Material::named(&name)
        };
        // glTF multiplies the factor by the texture; the renderer reads a
        // black Kd beside a map as the map alone, but here black is black.
        material.maps.kd = base.clone().filter(|_| kd != Vec3::ZERO).map(Box::new);
        match m.alpha_mode() {
            AlphaMode::Opaque => {}
            AlphaMode::Mask => {
                let cutoff = m.alpha_cutoff().unwrap_or(CUTOFF);
                if !(cutoff.is_finite() && cutoff >= 0.0) {
                    return Err(Error::file(
                        self.path,
                        field("alphaCutoff"),
                        format!("{cutoff} is not a finite, non-negative alpha"),
                    ));
                }
                self.alpha(&mut material, base, alpha, cutoff);
            }
            AlphaMode::Blend => {
                if base.is_some() {
                    self.out.warn(
                        "alphaMode BLEND with a base colour texture is approximated by a cut-out at alpha 0.5 \
                         (penumbra's surfaces are opaque, cut out or uniformly see-through)"
                            .into(),
                    );
                    self.alpha(&mut material, base, alpha, CUTOFF);
                } else {
                    material.dissolve = alpha;
                }
            }
        }
        let mut unused = Vec::new();
        if let Some(t) = m.transmission() {
            let factor = t.transmission_factor();
            if !(0.0..=1.0).contains(&factor) {
                return Err(Error::file(
                    self.path,
                    field("extensions.KHR_materials_transmission.transmissionFactor"),
                    format!("{factor} is not in [0, 1]"),
                ));
            }
            if t.transmission_texture().is_some() {
                unused.push("transmissionTexture");
            }
            if factor > 0.0 {
                let ior = m.ior().unwrap_or(1.5);
                if !(ior.is_finite() && ior >= 1.0) {
                    return Err(Error::file(
                        self.path,
                        field("extensions.KHR_materials_ior.ior"),
                        format!("{ior} is not an index of refraction (finite, at least 1)"),
                    ));
                }
                glass(&mut material, factor, ior, pbr.roughness_factor());
            }
        }
        if m.emissive_texture().is_some() {
            unused.push("emissiveTexture");
        }
        if m.normal_texture().is_some() {
            unused.push("normalTexture");
        }
        if m.occlusion_texture().is_some() {
            unused.push("occlusionTexture");
        }
        if pbr.metallic_factor() > 0.0 {
            unused.push("metalness");
        }
        if !unused.is_empty() {
            self.out
                .warn(format!("material '{name}': {} not used", unused.join(", ")));
        }
        self.out.materials.push(material);
        let ours = self.out.materials.len() as u32 - 1;
        self.out.material_index.insert(index, ours);
        Ok(ours)
    }

    /// A cut-out of the base colour texture `base` times `alpha` against
    /// `cutoff`; without a texture, a hole everywhere or nowhere.
    fn alpha(&mut self, material: &mut Material, base: Option<TextureMap>, alpha: f32, cutoff: f32) {
        match base {
            Some(map) => {
                material.maps.alpha = Some(Box::new(AlphaMap {
                    map,
                    factor: alpha,
                    cutoff,
                    luminance: false,
                }))
            }
            None if alpha < cutoff => {
                self.out.warn(format!(
                    "material '{}': its alpha {alpha} is below its alphaCutoff {cutoff} everywhere, so its \
                     surfaces are holes",
                    material.name
                ));
                material.dissolve = 0.0;
            }
            None => {}
        }
    }

    /// The map of a texture reference (`field` names it), or None (with a
    /// warning) where it cannot be used.
    fn texture_map(&mut self, material: &str, field: &str, info: &Info) -> Result<Option<TextureMap>> {
        let transform = info.texture_transform();
        let set = transform
            .as_ref()
            .and_then(|t| t.tex_coord())
            .unwrap_or(info.tex_coord());
        let what = field.rsplit('.').next().unwrap_or(field);
        if set != 0 {
            self.out.warn(format!(
                "material '{material}': {what} uses TEXCOORD_{set}; only TEXCOORD_0 is read, so it is not used"
            ));
            return Ok(None);
        }
        let texture = info.texture();
        let Some(image) = texture.source() else {
            self.out.warn(format!(
                "material '{material}': {what} (textures[{}]) has no image; not used",
                texture.index()
            ));
            return Ok(None);
        };
        let Some(source) = self.image(image.index())? else {
            return Ok(None);
        };
        let mut map = TextureMap::new(source);
        let sampler = texture.sampler();
        let (s, t) = (sampler.wrap_s(), sampler.wrap_t());
        if s != t {
            self.out.warn(format!(
                "material '{material}': {what}'s sampler wraps S and T differently ({s:?}, {t:?}); both are {s:?}"
            ));
        }
        if s == WrappingMode::MirroredRepeat {
            self.out.warn(format!(
                "material '{material}': {what}'s sampler is MIRRORED_REPEAT; it is read as REPEAT"
            ));
        }
        map.clamp = s == WrappingMode::ClampToEdge;
        if let Some(t) = transform {
            let (offset, scale, rotation) = (Vec2::from(t.offset()), Vec2::from(t.scale()), t.rotation());
            if !offset.is_finite() || !scale.is_finite() || !rotation.is_finite() {
                return Err(Error::file(
                    self.path,
                    format!("{field}.extensions.KHR_texture_transform"),
                    format!("offset {offset}, scale {scale} and rotation {rotation} must be finite"),
                ));
            }
            if rotation != 0.0 {
                self.out.warn(format!(
                    "material '{material}': {what}'s KHR_texture_transform rotation ({rotation} radians) is not \
                     used; its offset and scale are"
                ));
            }
            // glTF maps (u, v_down) to (u, v_down) * scale + offset; in
            // v_up = 1 - v_down that is v_up * scale.y + 1 - scale.y - offset.y.
            map.scale = scale;
            map.offset = Vec2::new(offset.x, 1.0 - scale.y - offset.y);
        }
        Ok(Some(map))
    }

    /// Image `i`'s source, read once: a file beside the asset (`uri`), or
    /// the bytes of a `data:` URI or of a buffer view, named
    /// `FILE#images[i]` (and the image's name). A URI with a scheme is a
    /// warning (None); a broken data URI or view is an error naming it.
    fn image(&mut self, i: usize) -> Result<Option<TextureSource>> {
        if let Some(source) = self.images.get(&i) {
            return Ok(source.clone());
        }
        let (path, document) = (self.path, self.document);
        let json = &document.as_json().images[i];
        let name = match &json.name {
            Some(n) => format!("{}#images[{i}] '{n}'", path.display()),
            None => format!("{}#images[{i}]", path.display()),
        };
        let fail = |f: &str, problem: String| Error::file(path, format!("images[{i}].{f}"), problem);
        let source = match (&json.uri, json.buffer_view) {
            (Some(uri), _) if uri.starts_with("data:") => {
                let bytes = container::data_uri(uri).map_err(|e| fail("uri", e))?;
                Some(TextureSource::Embedded {
                    name,
                    bytes: Arc::from(bytes),
                })
            }
            (Some(uri), _) => {
                let dir = path.parent().unwrap_or(Path::new("."));
                match container::relative_path(uri, dir) {
                    Ok(file) => Some(TextureSource::File(file)),
                    Err(e) => {
                        self.out.warn(format!("images[{i}]: {e}; the image is not used"));
                        None
                    }
                }
            }
            (None, Some(view)) => {
                let view = document
                    .views()
                    .nth(view.value())
                    .ok_or_else(|| fail("bufferView", "is out of range".into()))?;
                let (start, length) = (view.offset(), view.length());
                let v = view.index();
                let buffer = self.buffer(view.buffer()).map_err(|e| fail("bufferView", e))?;
                let bytes = start
                    .checked_add(length)
                    .and_then(|end| buffer.get(start..end))
                    .ok_or_else(|| {
                        fail(
                            "bufferView",
                            format!(
                                "bufferView {v} (bytes {start}..{}) runs past the end of its buffer ({} bytes)",
                                start as u128 + length as u128,
                                buffer.len()
                            ),
                        )
                    })?;
                Some(TextureSource::Embedded {
                    name,
                    bytes: Arc::from(bytes),
                })
            }
            (None, None) => return Err(fail("uri", "missing (an image has a uri or a bufferView)".into())),
        };
        self.images.insert(i, source.clone());
        Ok(source)
    }
}

/// `m` made glass: transmission `factor` of its base colour, index `ior`.
fn glass(m: &mut Material, factor: f32, ior: f32, roughness: f32) {
    let base = m.kd;
    m.illum = 7;
    m.tf = base * factor;
    m.has_tf = true;
    m.ni = ior;
    m.ks = Vec3::splat(((ior - 1.0) / (ior + 1.0)).powi(2));
    let a = (roughness * roughness).max(1e-3);
    m.ns = (2.0 / (a * a) - 2.0).clamp(NS_RANGE.0, NS_RANGE.1);
    m.kd = base * (1.0 - factor);
    m.ka = m.kd;
}
