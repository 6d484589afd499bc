//! Displacement fields on the GPU: the maps stacked into a 3D texture (the
//! paper's section 5 suggestion) — for 8-bit fields an RG8Unorm texture,
//! (distance if hit, hit), read through the texture unit's bilinear filter,
//! which returns the weighted distance and the coverage of the four texels
//! in one fetch (`field::lookup` explains the vote); for 32-bit fields an
//! R32Float texture whose four texels are loaded and weighed in the shader
//! (not filterable in core WebGPU) — or packed bits in a storage buffer for
//! 1-bit fields; and the `field_ao` (Algorithm 2) and `field_probe` (single
//! lookups, for the CPU twin's check) kernels.
//!
//! Portable WebGPU allows 2048 texels per 3D-texture side, fewer than the
//! paper's 4226 maps, so several maps share a layer as tiles
//! (`TextureLayout`); lookups clamp to texel centres inside the tile.
//!
//! Like the other passes, `FieldPasses` takes the host's device, caches its
//! layouts and pipelines, and records into the caller's encoder; the
//! blocking helpers (`visibility_field_gpu`, `probe_gpu`) are conveniences.

use std::ops::Range;
use std::sync::{Arc, OnceLock};

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use super::build::DisplacementField;
use super::lookup::Positional;
use super::storage::{FieldData, Storage};
use crate::error::{Error, Result};
use crate::gpu::batch::{BatchPass, BatchPlan, Batched, Pass, fit_items, run_batches};
use crate::gpu::buffers::{GrowingBuffer, read_buffer, storage_buffer, uniform_buffer};
use crate::gpu::kernels::{Kernels, PipelineLog, Pipelines, compute_pipelines, record_dispatch};
use crate::gpu::layout::{Io, bind_group, io_layout, layout, storage_entry, texture_entry, uniform_entry};
use crate::gpu::timer::PassTimer;
use crate::gpu::{GpuContext, dispatch_grid};
use crate::progress::Bar;
use crate::raycast::gpu::{AO_POINT_BYTES, AoRays};
use crate::raycast::{AoPoint, AoSettings, VisibilityMasks};
use crate::scene::Transform;

use super::ao::RayClasses;

/// `FieldLookupUniforms` in `wgsl/field_lookup.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub(crate) struct FieldLookupUniforms {
    pub center: [f32; 3],
    pub radius: f32,
    pub side: u32,
    pub res: u32,
    pub storage_bits: u32,
    pub directions: u32,
    pub tiles_x: u32,
    pub tiles_y: u32,
    pub positional: u32,
    pub words_per_map: u32,
}

/// `FieldAoUniforms` in `wgsl/field_ao.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub(crate) struct FieldAoUniforms {
    pub rays: AoRays,
    pub instance_count: u32,
    pub _pad: u32,
}

/// `FieldInstance` in `wgsl/field_ao.wgsl`: world to object space.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct GpuInstance {
    /// The inverse of the instance's rotation, a unit quaternion (x, y, z, w).
    pub inv_rotation: [f32; 4],
    /// The instance's translation, world space: a point's object-space position
    /// is inv_rotation (p - translation) / scale.
    pub translation: [f32; 3],
    /// The instance's uniform scale, > 0: an object-space hit distance times it
    /// is the world distance.
    pub scale: f32,
    /// The instance's index in the scene: points it owns skip it.
    pub instance: u32,
    /// Zero: pads the struct to the WGSL's 48 bytes.
    pub _pad: [u32; 3],
}

impl GpuInstance {
    /// Instance `instance`, placed by `transform` (object to world).
    pub fn new(transform: &Transform, instance: u32) -> GpuInstance {
        GpuInstance {
            inv_rotation: transform.rotation.inverse().to_array(),
            translation: transform.translation.to_array(),
            scale: transform.scale,
            instance,
            _pad: [0; 3],
        }
    }
}

/// `FieldProbeUniforms` in `wgsl/field_probe.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct FieldProbeUniforms {
    ray_count: u32,
    row_pitch: u32,
    _pad: [u32; 2],
}

const _: () = assert!(std::mem::size_of::<FieldLookupUniforms>() == 48 && std::mem::size_of::<GpuInstance>() == 48);

/// How the maps are read, from the storage.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MapAccess {
    /// 8-bit: RG8Unorm texture (distance if hit, hit), hardware bilinear filtering.
    Filtered,
    /// 32-bit: R32Float texture, four loads blended in the shader.
    Loaded,
    /// 1-bit: packed bits and per-map means in storage buffers.
    Bits,
}

impl MapAccess {
    /// How maps of `storage` are read.
    pub fn of(storage: Storage) -> MapAccess {
        match storage {
            Storage::U8 => MapAccess::Filtered,
            Storage::F32 => MapAccess::Loaded,
            Storage::Bit1 => MapAccess::Bits,
        }
    }
}

/// Maps per layer of the stacked 3D texture: `tiles_x * tiles_y` maps of
/// `res x res` texels side by side, layer after layer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct TextureLayout {
    /// Maps side by side along x in a layer.
    pub tiles_x: u32,
    /// Maps along y in a layer.
    pub tiles_y: u32,
    /// Layers (the texture's depth), enough for every map.
    pub layers: u32,
    /// Texels along a map's side.
    pub res: u32,
}

impl TextureLayout {
    /// The squarest tiling whose every side fits `max_side` (the device's
    /// `max_texture_dimension_3d`).
    pub fn for_maps(maps: u32, res: u32, max_side: u32) -> Result<TextureLayout> {
        let mut k = 1u32;
        loop {
            let layers = maps.div_ceil(k * k);
            if k * res > max_side {
                return Err(Error::Device(format!(
                    "{maps} maps of {res}x{res} texels do not fit a 3D texture of at most {max_side} texels per side"
                )));
            }
            if layers <= max_side {
                return Ok(TextureLayout {
                    tiles_x: k,
                    tiles_y: k,
                    layers,
                    res,
                });
            }
            k += 1;
        }
    }

    /// The texture's size: `tiles_x * res` by `tiles_y * res` texels, `layers`
    /// deep.
    pub fn size(&self) -> wgpu::Extent3d {
        wgpu::Extent3d {
            width: self.tiles_x * self.res,
            height: self.tiles_y * self.res,
            depth_or_array_layers: self.layers,
        }
    }

    /// Texel index (x, y, layer) in the texture of texel (a, b) of map m.
    pub fn texel(&self, m: u32, a: u32, b: u32) -> (u32, u32, u32) {
        let per_layer = self.tiles_x * self.tiles_y;
        let tile = m % per_layer;
        (
            (tile % self.tiles_x) * self.res + a,
            (tile / self.tiles_x) * self.res + b,
            m / per_layer,
        )
    }
}

/// Bind group 0 of the field kernels: the field's parameters and maps.
pub fn maps_layout(device: &wgpu::Device, access: MapAccess) -> wgpu::BindGroupLayout {
    let entries: Vec<wgpu::BindGroupLayoutEntry> = match access {
        MapAccess::Filtered => vec![
            uniform_entry(0),
            texture_entry(1, wgpu::TextureViewDimension::D3, true),
            wgpu::BindGroupLayoutEntry {
                binding: 2,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                count: None,
            },
        ],
        MapAccess::Loaded => vec![
            uniform_entry(0),
            texture_entry(1, wgpu::TextureViewDimension::D3, false),
        ],
        MapAccess::Bits => vec![uniform_entry(0), storage_entry(1, true), storage_entry(2, true)],
    };
    layout(device, "field maps", &entries)
}

/// A field on the device: its parameters and maps, as bind group 0.
pub struct GpuField {
    /// How the kernels read the maps (from the field's storage).
    pub access: MapAccess,
    /// The maps' tiling in the 3D texture; None for 1-bit maps, which live in
    /// storage buffers.
    pub layout: Option<TextureLayout>,
    /// Bind group 0 of the field kernels: the lookup parameters and the maps.
    pub bind_group: wgpu::BindGroup,
    /// Bytes of map data on the device.
    pub bytes: u64,
    params: wgpu::Buffer,
    gpu_params: FieldLookupUniforms,
    _resources: Vec<wgpu::Buffer>,
    _texture: Option<wgpu::Texture>,
}

impl GpuField {
    /// Uploads `field`, to be read with `positional` interpolation.
    pub fn upload(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        field: &DisplacementField,
        positional: Positional,
    ) -> Result<GpuField> {
        let p = &field.params;
        let access = MapAccess::of(p.storage);
        let max_side = device.limits().max_texture_dimension_3d;
        let layout = match access {
            MapAccess::Bits => None,
            _ => Some(TextureLayout::for_maps(p.grid.count(), p.res, max_side)?),
        };
        let gpu_params = FieldLookupUniforms {
            center: field.center.to_array(),
            radius: field.radius,
            side: p.grid.side,
            res: p.res,
            storage_bits: p.storage.bits(),
            directions: p.directions.code(),
            tiles_x: layout.map_or(1, |l| l.tiles_x),
            tiles_y: layout.map_or(1, |l| l.tiles_y),
            positional: positional_code(positional),
            words_per_map: p.words_per_map() as u32,
        };
        let params = uniform_buffer(device, "field params", &gpu_params);
        let group_layout = maps_layout(device, access);
        let mut resources = Vec::new();
        let mut texture = None;
        let (bind_group, bytes) = match (&field.data, layout) {
            (FieldData::Bits { words, mean }, _) => {
                let w = storage_buffer(device, "field bits", bytemuck::cast_slice(words))?;
                let m = storage_buffer(device, "field means", bytemuck::cast_slice(mean))?;
                let g = bind_group(device, "field maps", &group_layout, &[(0, &params), (1, &w), (2, &m)]);
                let bytes = (words.len() + mean.len()) as u64 * 4;
                resources.extend([w, m]);
                (g, bytes)
            }
            (data, Some(layout)) => {
                let (format, texel_bytes) = match access {
                    MapAccess::Filtered => (wgpu::TextureFormat::Rg8Unorm, 2),
                    _ => (wgpu::TextureFormat::R32Float, 4),
                };
                let tex = device.create_texture(&wgpu::TextureDescriptor {
                    label: Some("field maps"),
                    size: layout.size(),
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D3,
                    format,
                    usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                    view_formats: &[],
                });
                let texels = stack_maps(field, &layout, texel_bytes, data);
                let size = layout.size();
                queue.write_texture(
                    wgpu::TexelCopyTextureInfo {
                        texture: &tex,
                        mip_level: 0,
                        origin: wgpu::Origin3d::ZERO,
                        aspect: wgpu::TextureAspect::All,
                    },
                    &texels,
                    wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(size.width * texel_bytes),
                        rows_per_image: Some(size.height),
                    },
                    size,
                );
                let view = tex.create_view(&Default::default());
                let mut entries = vec![
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: params.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::TextureView(&view),
                    },
                ];
                let sampler;
                if access == MapAccess::Filtered {
                    sampler = device.create_sampler(&wgpu::SamplerDescriptor {
                        label: Some("field maps"),
                        mag_filter: wgpu::FilterMode::Linear,
                        min_filter: wgpu::FilterMode::Linear,
                        ..Default::default()
                    });
                    entries.push(wgpu::BindGroupEntry {
                        binding: 2,
                        resource: wgpu::BindingResource::Sampler(&sampler),
                    });
                }
                let g = device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("field maps"),
                    layout: &group_layout,
                    entries: &entries,
                });
                texture = Some(tex);
                (g, texels.len() as u64)
            }
            (_, None) => unreachable!("textures have a layout"),
        };
        Ok(GpuField {
            access,
            layout,
            bind_group,
            bytes,
            params,
            gpu_params,
            _resources: resources,
            _texture: texture,
        })
    }

    /// Switches the positional interpolation of later lookups.
    pub fn set_positional(&mut self, queue: &wgpu::Queue, positional: Positional) {
        self.gpu_params.positional = positional_code(positional);
        queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&self.gpu_params));
    }
}

fn positional_code(p: Positional) -> u32 {
    match p {
        Positional::Nearest => 0,
        Positional::Bilinear => 1,
    }
}

/// The maps laid out as the texture's texels (row-major x, then y, then layer).
fn stack_maps(field: &DisplacementField, layout: &TextureLayout, texel_bytes: u32, data: &FieldData) -> Vec<u8> {
    let size = layout.size();
    let (w, h) = (size.width as usize, size.height as usize);
    let mut out = vec![0u8; w * h * size.depth_or_array_layers as usize * texel_bytes as usize];
    let res = field.params.res;
    let texels = field.params.texels_per_map();
    for m in 0..field.params.grid.count() {
        for b in 0..res {
            let (x, y, z) = layout.texel(m, 0, b);
            let at = ((z as usize * h + y as usize) * w + x as usize) * texel_bytes as usize;
            let from = m as usize * texels + (b * res) as usize;
            let row = res as usize;
            match data {
                FieldData::U8(v) => {
                    // (distance if the direction hits else 0, hit): 255 is a miss.
                    for (k, &d) in v[from..from + row].iter().enumerate() {
                        let hit = d < 255;
                        out[at + 2 * k] = if hit { d } else { 0 };
                        out[at + 2 * k + 1] = if hit { 255 } else { 0 };
                    }
                }
                FieldData::F32(v) => {
                    out[at..at + 4 * row].copy_from_slice(bytemuck::cast_slice(&v[from..from + row]));
                }
                FieldData::Bits { .. } => unreachable!("bits are not stacked"),
            }
        }
    }
    out
}

/// `field_ao`'s io: params, points, owners, instances, ray classes.
const FIELD_AO_IO: &[Io] = &[
    Io::Uniform(0, "field ao params", std::mem::size_of::<FieldAoUniforms>() as u64),
    Io::In(1, "field ao points"),
    Io::In(2, "field ao owners"),
    Io::In(3, "field instances"),
    Io::Out(4, "field AO ray classes"),
];

/// `field_probe`'s io: params, rays, results.
const PROBE_IO: &[Io] = &[
    Io::Uniform(0, "probe params", std::mem::size_of::<FieldProbeUniforms>() as u64),
    Io::In(1, "probe rays"),
    Io::Out(2, "probe results"),
];

/// The layouts and pipelines of one map access.
pub struct FieldPipelines {
    /// Bind group 0: the field's lookup parameters and maps (`maps_layout`).
    pub maps_layout: wgpu::BindGroupLayout,
    /// Bind group 1 of `field_ao`: its parameters, the points, their owners,
    /// the instances and the ray classes.
    pub ao_layout: wgpu::BindGroupLayout,
    /// Bind group 1 of `field_probe`: its parameters, the rays and the results.
    pub probe_layout: wgpu::BindGroupLayout,
    /// The `field_ao` kernel (Algorithm 2).
    pub ao: Pipelines,
    /// The `field_probe` kernel (single lookups).
    pub probe: Pipelines,
}

/// The field kernels of one device, built on first use per map access.
pub struct FieldKernels {
    log: Arc<PipelineLog>,
    filtered: OnceLock<FieldPipelines>,
    loaded: OnceLock<FieldPipelines>,
    bits: OnceLock<FieldPipelines>,
}

impl Kernels for FieldKernels {
    /// Nothing yet: each map access's pipelines are built on first use.
    fn build(_device: &wgpu::Device, log: &Arc<PipelineLog>) -> FieldKernels {
        FieldKernels {
            log: Arc::clone(log),
            filtered: OnceLock::new(),
            loaded: OnceLock::new(),
            bits: OnceLock::new(),
        }
    }
}

impl FieldKernels {
    /// The layouts and pipelines of maps read by `access`, built on the first
    /// call.
    pub fn pipelines(&self, device: &wgpu::Device, access: MapAccess) -> &FieldPipelines {
        use crate::gpu::wgsl::*;
        let (cell, ao_module, probe_module) = match access {
            MapAccess::Filtered => (&self.filtered, FIELD_AO_FILTERED_MODULE, FIELD_PROBE_FILTERED_MODULE),
            MapAccess::Loaded => (&self.loaded, FIELD_AO_LOADED_MODULE, FIELD_PROBE_LOADED_MODULE),
            MapAccess::Bits => (&self.bits, FIELD_AO_BITS_MODULE, FIELD_PROBE_BITS_MODULE),
        };
        cell.get_or_init(|| {
            let maps = maps_layout(device, access);
            let ao_layout = io_layout(device, "field ao io", FIELD_AO_IO);
            let probe_layout = io_layout(device, "field probe io", PROBE_IO);
            let log = &self.log;
            let ao = compute_pipelines(device, &ao_module, &[&maps, &ao_layout], &["field_ao"], log);
            let probe = compute_pipelines(device, &probe_module, &[&maps, &probe_layout], &["field_probe"], log);
            FieldPipelines {
                maps_layout: maps,
                ao_layout,
                probe_layout,
                ao,
                probe,
            }
        })
    }
}

/// One field with the instances that use it.
pub struct FieldGroup<'f> {
    /// The field on the device, which every instance of its mesh shares.
    pub field: &'f GpuField,
    /// The instances that use it, placed at the frame traced.
    pub instances: Vec<GpuInstance>,
}

/// A field group's own inputs: its instances and parameters.
struct GroupIo {
    instances: GrowingBuffer,
    params: wgpu::Buffer,
    io: Option<wgpu::BindGroup>,
}

/// Algorithm 2 on the GPU: the `field_ao` kernel for every field of a
/// scene over one batch of points, with the buffers it keeps between calls.
pub struct FieldAoPass {
    kernels: Arc<FieldKernels>,
    points: GrowingBuffer,
    owners: GrowingBuffer,
    classes: GrowingBuffer,
    groups: Vec<GroupIo>,
    words: u64,
    grid: (u32, u32),
}

const STORAGE_IN: wgpu::BufferUsages = wgpu::BufferUsages::STORAGE.union(wgpu::BufferUsages::COPY_DST);

impl Pass for FieldAoPass {
    type Kernels = FieldKernels;

    fn with_kernels(_device: &wgpu::Device, kernels: Arc<FieldKernels>) -> FieldAoPass {
        FieldAoPass {
            kernels,
            points: GrowingBuffer::new("field ao points", STORAGE_IN),
            owners: GrowingBuffer::new("field ao owners", STORAGE_IN),
            classes: GrowingBuffer::new(
                "field AO ray classes",
                wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
            ),
            groups: Vec::new(),
            words: 0,
            grid: (0, 0),
        }
    }
}

impl FieldAoPass {
    /// Uploads a batch of points with their owners (`NO_OWNER` for none)
    /// and every group's instances; `groups` must be the ones `record` gets.
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        groups: &[FieldGroup],
        points: &[AoPoint],
        owners: &[u32],
        settings: &AoSettings,
    ) -> Result<()> {
        settings.validate()?;
        assert_eq!(points.len(), owners.len());
        let words = (points.len() * settings.words_per_point() as usize) as u64;
        let mut grown = self.points.write(device, queue, bytemuck::cast_slice(points))?;
        grown |= self.owners.write(device, queue, bytemuck::cast_slice(owners))?;
        grown |= self.classes.reserve(device, 3 * words * 4)?;
        // One invocation per mask word (`field_ao`), so the row pitch is in
        // words.
        let (gx, gy, pitch) = dispatch_grid(words as u32, device.limits().max_compute_workgroups_per_dimension);
        while self.groups.len() < groups.len() {
            self.groups.push(GroupIo {
                instances: GrowingBuffer::new("field instances", STORAGE_IN),
                params: uniform_buffer(device, "field ao params", &FieldAoUniforms::zeroed()),
                io: None,
            });
        }
        for (g, io) in groups.iter().zip(&mut self.groups) {
            let instances_grown = io.instances.write(device, queue, bytemuck::cast_slice(&g.instances))?;
            if grown || instances_grown || io.io.is_none() {
                io.io = Some(bind_group(
                    device,
                    "field ao io",
                    &self.kernels.pipelines(device, g.field.access).ao_layout,
                    &[
                        (0, &io.params),
                        (1, self.points.get()),
                        (2, self.owners.get()),
                        (3, io.instances.get()),
                        (4, self.classes.get()),
                    ],
                ));
            }
            let params = FieldAoUniforms {
                rays: AoRays::new(points.len(), settings, pitch),
                instance_count: g.instances.len() as u32,
                _pad: 0,
            };
            queue.write_buffer(&io.params, 0, bytemuck::bytes_of(&params));
        }
        self.words = words;
        self.grid = (gx, gy);
        Ok(())
    }

    /// Records the prepared batch: clears the ray classes, then one
    /// `field_ao` dispatch per group (each timed by `timer` if given).
    pub fn record(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        mut timer: Option<&mut PassTimer>,
        groups: &[FieldGroup],
    ) {
        encoder.clear_buffer(self.classes.get(), 0, None);
        for (g, io) in groups.iter().zip(&self.groups) {
            let p = self.kernels.pipelines(device, g.field.access);
            let io = io.io.as_ref().expect("FieldAoPass::record before prepare");
            let writes = timer.as_mut().and_then(|t| t.next_pass());
            record_dispatch(
                encoder,
                "field ao",
                writes,
                p.ao.get(0),
                &[&g.field.bind_group, io],
                self.grid,
            );
        }
    }

    /// The batch's three masks one after another, each `words_per_point`
    /// words per point: occluded rays, rays starting inside a sphere, rays
    /// whose surface a field put behind the origin.
    pub fn classes(&self) -> &wgpu::Buffer {
        self.classes.get()
    }

    /// Bytes of each of the prepared batch's three masks in `classes`: the
    /// occluded rays' come first, so a host copies out this many bytes
    /// from offset 0 and reads them with `VisibilityMasks::from_occluded`.
    pub fn mask_bytes(&self) -> u64 {
        self.words * 4
    }
}

/// Result of `FieldAoBatches::visibility`.
pub struct GpuFieldAo {
    /// Visibility per ray: bit set = open (no field hit within the AO radius).
    pub masks: VisibilityMasks,
    /// The rays that started inside a sphere, and those whose surface a field
    /// put behind the origin.
    pub classes: RayClasses,
    /// Milliseconds of the `field_ao` dispatches, summed over the batches, from
    /// GPU timestamps; None where the device has no timestamp queries.
    pub gpu_ms: Option<f64>,
}

/// Rays per batch of points.
const RAYS_PER_BATCH: u64 = 1 << 22;

/// The pass with its read-back buffer, as a runner keeps it on a device.
pub type FieldAoBatches = Batched<FieldAoPass>;

impl Batched<FieldAoPass> {
    /// `field::field_ao` on the GPU (blocking): the same rays, one
    /// dispatch per field per batch of points.
    pub fn visibility(
        &mut self,
        ctx: &GpuContext,
        groups: &[FieldGroup],
        points: &[AoPoint],
        owners: &[u32],
        settings: &AoSettings,
        progress: &Bar,
    ) -> Result<GpuFieldAo> {
        settings.validate()?;
        assert_eq!(points.len(), owners.len());
        let words = settings.words_per_point() as usize;
        let groups: Vec<FieldGroup> = groups
            .iter()
            .filter(|g| !g.instances.is_empty())
            .map(|g| FieldGroup {
                field: g.field,
                instances: g.instances.clone(),
            })
            .collect();
        let mut occluded = Vec::with_capacity(points.len() * words);
        let mut inside = Vec::with_capacity(points.len() * words);
        let mut hidden = Vec::with_capacity(points.len() * words);
        // Per point: the point, its owner, and three masks (in one binding,
        // read back).
        let classes_bytes = 3 * 4 * words as u64;
        let fit = fit_items(&ctx.device, &[AO_POINT_BYTES, 4, classes_bytes], classes_bytes);
        let per_batch = ((RAYS_PER_BATCH / settings.rays_per_point as u64).max(1) as usize).min(fit);
        let plan = BatchPlan::new(points.len(), per_batch, groups.len().max(1) as u32);
        let mut batch = FieldBatch {
            pass: &mut self.pass,
            device: &ctx.device,
            groups: &groups,
            points,
            owners,
            settings,
        };
        let gpu_ms = run_batches(
            ctx,
            &mut batch,
            &mut self.readback,
            plan,
            progress,
            |items, w: &[u32]| {
                let len = items.len() * words;
                occluded.extend_from_slice(&w[..len]);
                inside.extend_from_slice(&w[len..2 * len]);
                hidden.extend_from_slice(&w[2 * len..3 * len]);
                Ok(())
            },
        )?;
        Ok(GpuFieldAo {
            masks: VisibilityMasks::from_occluded(&occluded, settings),
            classes: RayClasses { inside, hidden },
            gpu_ms,
        })
    }
}

struct FieldBatch<'a> {
    pass: &'a mut FieldAoPass,
    device: &'a wgpu::Device,
    groups: &'a [FieldGroup<'a>],
    points: &'a [AoPoint],
    owners: &'a [u32],
    settings: &'a AoSettings,
}

impl BatchPass for FieldBatch<'_> {
    fn prepare(&mut self, ctx: &GpuContext, items: Range<usize>) -> Result<()> {
        let (points, owners) = (&self.points[items.clone()], &self.owners[items]);
        self.pass
            .prepare(&ctx.device, &ctx.queue, self.groups, points, owners, self.settings)
    }

    fn record(&self, encoder: &mut wgpu::CommandEncoder, timer: &mut Option<PassTimer>) {
        self.pass.record(self.device, encoder, timer.as_mut(), self.groups);
    }

    fn results(&self) -> Vec<(&wgpu::Buffer, u64)> {
        vec![(self.pass.classes(), 3 * self.pass.mask_bytes())]
    }
}

/// Single lookups on the GPU: per object-space ray (origin, unit
/// direction), `[kind, t, distance, flags]` (kind 0 outside, 1 miss, 2 hit;
/// flags 1 inside + 2 hidden), as `wgsl/field_probe.wgsl` returns them.
pub fn probe_gpu(ctx: &GpuContext, field: &GpuField, rays: &[(Vec3, Vec3)]) -> Result<Vec<[f32; 4]>> {
    let device = &ctx.device;
    let kernels = FieldKernels::cached(ctx);
    let p = kernels.pipelines(device, field.access);
    let data: Vec<[f32; 4]> = rays
        .iter()
        .flat_map(|(o, d)| [o.extend(0.0).to_array(), d.extend(0.0).to_array()])
        .collect();
    let n = rays.len().max(1);
    let ray_buf = storage_buffer(device, "probe rays", bytemuck::cast_slice(&data))?;
    let mut results = GrowingBuffer::new(
        "probe results",
        wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
    );
    results.reserve(device, n as u64 * 16)?;
    let (gx, gy, pitch) = dispatch_grid(n as u32, device.limits().max_compute_workgroups_per_dimension);
    let params = uniform_buffer(
        device,
        "probe params",
        &FieldProbeUniforms {
            ray_count: rays.len() as u32,
            row_pitch: pitch,
            _pad: [0; 2],
        },
    );
    let io = bind_group(
        device,
        "field probe io",
        &p.probe_layout,
        &[(0, &params), (1, &ray_buf), (2, results.get())],
    );
    let mut encoder = device.create_command_encoder(&Default::default());
    record_dispatch(
        &mut encoder,
        "field probe",
        None,
        p.probe.get(0),
        &[&field.bind_group, &io],
        (gx, gy),
    );
    ctx.queue.submit([encoder.finish()]);
    read_buffer(ctx, results.get(), rays.len())
}
