//! The WGSL sources in `wgsl/`, compiled into the library with `include_str!`,
//! and how kernels are composed from them.
//!
//! WGSL has no `#include`: a kernel module is the concatenation of the
//! self-contained library files it needs and its own file. Validation maps an
//! error's line in the composed text back to the file and line it came from.

/// One file of `wgsl/`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WgslFile {
    /// Path relative to the crate root, for messages.
    pub path: &'static str,
    /// The file's WGSL source.
    pub text: &'static str,
}

macro_rules! wgsl_file {
    ($name:literal) => {
        WgslFile {
            path: concat!("wgsl/", $name),
            text: include_str!(concat!("../../wgsl/", $name)),
        }
    };
}

/// Owen-scrambled Sobol points, the concentric disk map and Malley's cosine
/// hemisphere: the twin of `geom::sampling`, bit for bit.
pub const SAMPLING: WgslFile = wgsl_file!("sampling.wgsl");
/// The orthonormal basis about a unit normal (Duff et al. 2017), the twin
/// of `Frame::from_normal`.
pub const FRAME: WgslFile = wgsl_file!("frame.wgsl");
/// The G-buffer's albedo packed into one float (`r + 256 g + 65536 b`),
/// shared by the G-buffer pass and SSAO's indirect light.
pub const ALBEDO: WgslFile = wgsl_file!("albedo.wgsl");
/// Single-ray kd-tree traversal with the watertight triangle test over the
/// tree's buffers (bind group 0): the twin of `kdtree::traverse` and
/// `kdtree::watertight`.
pub const KDTREE_TRAVERSE: WgslFile = wgsl_file!("kdtree_traverse.wgsl");
/// Texture maps packed as `scene::texture_table` packs them: bilinear
/// lookups and cut-out tests, the twin of `TextureTable::sample`.
pub const TEXTURE_MAPS: WgslFile = wgsl_file!("texture_maps.wgsl");
/// Kernel: closest or any hit of a batch of rays (`kdtree::gpu`).
pub const TRACE_RAYS: WgslFile = wgsl_file!("trace_rays.wgsl");
/// Kernel: ambient-occlusion rays, one invocation per ray, each setting a
/// bit of its point's visibility mask (`raycast`).
pub const AO_RAYS: WgslFile = wgsl_file!("ao_rays.wgsl");
/// Kernel: MLRTA packets, sixteen invocations per packet walking the tree
/// from the packet's entry point (Reshetov, Soupikov and Hurley, section
/// 4.3).
pub const PACKET_TRAVERSE: WgslFile = wgsl_file!("packet_traverse.wgsl");
/// Displacement-field geometry: the field's parameters, its octahedral grid
/// of positional samples and the hemisphere mappings.
pub const FIELD_LOOKUP: WgslFile = wgsl_file!("field_lookup.wgsl");
/// Map access for 8-bit fields: an RG8Unorm 3D texture read through the
/// texture unit's bilinear filter.
pub const FIELD_MAPS_FILTERED: WgslFile = wgsl_file!("field_maps_filtered.wgsl");
/// Map access for 32-bit fields: an R32Float 3D texture, its four texels
/// loaded and weighed in f32 as the CPU twin does.
pub const FIELD_MAPS_LOADED: WgslFile = wgsl_file!("field_maps_loaded.wgsl");
/// Map access for 1-bit fields: hit bits packed 32 to a word in a storage
/// buffer, with each map's mean hit distance.
pub const FIELD_MAPS_BITS: WgslFile = wgsl_file!("field_maps_bits.wgsl");
/// The displacement-field query (a map's sample in world terms, a sample, a
/// trace), over a map-access file.
pub const FIELD_TRACE: WgslFile = wgsl_file!("field_trace.wgsl");
/// Kernel: ambient occlusion through displacement fields (Gaitatzes,
/// Chrysanthou and Papaioannou, Algorithm 2), one invocation per 32-ray
/// word of a point's mask.
pub const FIELD_AO: WgslFile = wgsl_file!("field_ao.wgsl");
/// Kernel: single field lookups along object-space rays, the twin of the
/// CPU's `field_probe`.
pub const FIELD_PROBE: WgslFile = wgsl_file!("field_probe.wgsl");
/// Render pipeline: the SSAO G-buffer (camera-space normal and z, direct
/// light and packed albedo), reversed-Z with an infinite far plane.
pub const GBUFFER: WgslFile = wgsl_file!("gbuffer.wgsl");
/// Render pipeline: `GBUFFER` for scenes with colour maps or alpha
/// cut-outs (albedo read at each pixel's point, holes discarded); composed
/// after `TEXTURE_MAPS` and `GBUFFER`.
pub const GBUFFER_TEXTURED: WgslFile = wgsl_file!("gbuffer_textured.wgsl");
/// What the SSAO kernels share: parameters, bindings, camera-space
/// reconstruction and projection, the depth-buffer visibility test and the
/// pixel's sample set.
pub const SSAO_COMMON: WgslFile = wgsl_file!("ssao_common.wgsl");
/// Kernels: Szirmay-Kalos et al.'s screen-space AO estimators (point
/// samples, ray marching, pipes through the base disk), one invocation per
/// estimation cell.
pub const SSAO_ESTIMATE: WgslFile = wgsl_file!("ssao_estimate.wgsl");
/// Kernels: SSAO's depth-aware 4x4 low-pass filter (Szirmay-Kalos et al.,
/// section 5) and the half-resolution upsampling.
pub const SSAO_FILTER: WgslFile = wgsl_file!("ssao_filter.wgsl");
/// Kernels: SSAO's indirect light (Szirmay-Kalos et al., section 3.1) and
/// the composed image.
pub const SSAO_INDIRECT: WgslFile = wgsl_file!("ssao_indirect.wgsl");
/// Kernel: PRT's SH transfer vectors from per-vertex visibility masks
/// (Kautz et al. 2004, equation 3 and section 3.2), rotated to world space
/// and dotted with the lighting; composed after one of the two
/// workgroup-array files.
pub const SH_TRANSFER: WgslFile = wgsl_file!("sh_transfer.wgsl");
/// `SH_TRANSFER`'s workgroup arrays for 8 vertices a workgroup (14,848
/// bytes), within WebGPU's portable 16 KiB.
pub const SH_TRANSFER_PORTABLE: WgslFile = wgsl_file!("sh_transfer_portable.wgsl");
/// `SH_TRANSFER`'s workgroup arrays for 16 vertices a workgroup (29,696
/// bytes), for devices with 32 KiB of workgroup memory.
pub const SH_TRANSFER_WIDE: WgslFile = wgsl_file!("sh_transfer_wide.wgsl");
/// `WHITTED`'s pixel entries, with ray-tree recording compiled out: its
/// mere presence makes them 18 times slower on lavapipe.
pub const WHITTED_PIXELS: WgslFile = wgsl_file!("whitted_pixels.wgsl");
/// `WHITTED`'s `whitted_trees` entry: each ray's tree written into its slot.
pub const WHITTED_TREES: WgslFile = wgsl_file!("whitted_trees.wgsl");
/// Kernel: Whitted ray tracing, one invocation per pixel, each sample's ray
/// tree walked depth first with an explicit stack; composed after
/// `WHITTED_PIXELS` or `WHITTED_TREES`.
pub const WHITTED: WgslFile = wgsl_file!("whitted.wgsl");
/// The kernel writing the Whitted pass's pixels into a host's texture.
pub const WHITTED_IMAGE: WgslFile = wgsl_file!("whitted_image.wgsl");
/// Kernel: bounded-error ray tracing's fast path (Bala, Dorsey and Teller,
/// sections 4.2 and 6): each pixel's radiance interpolated quadrilinearly
/// from its linetree cell's 16 extremal rays.
pub const INTERPOLATE: WgslFile = wgsl_file!("interpolate.wgsl");

/// Every file compiled in (the validation test checks this against `wgsl/`).
pub const FILES: &[WgslFile] = &[
    SAMPLING,
    FRAME,
    ALBEDO,
    KDTREE_TRAVERSE,
    TEXTURE_MAPS,
    TRACE_RAYS,
    AO_RAYS,
    PACKET_TRAVERSE,
    FIELD_LOOKUP,
    FIELD_MAPS_FILTERED,
    FIELD_MAPS_LOADED,
    FIELD_MAPS_BITS,
    FIELD_TRACE,
    FIELD_AO,
    FIELD_PROBE,
    GBUFFER,
    GBUFFER_TEXTURED,
    SSAO_COMMON,
    SSAO_ESTIMATE,
    SSAO_FILTER,
    SSAO_INDIRECT,
    SH_TRANSFER,
    SH_TRANSFER_PORTABLE,
    SH_TRANSFER_WIDE,
    WHITTED_PIXELS,
    WHITTED_TREES,
    WHITTED,
    WHITTED_IMAGE,
    INTERPOLATE,
];

/// A shader module made of several files, in order, and what it asks of a
/// device.
#[derive(Debug, Clone, Copy)]
pub struct Composition {
    /// The module's name: shader module and pipeline labels, `module` in
    /// pipeline names (`module.entry_point`) and messages.
    pub name: &'static str,
    /// The files concatenated, libraries first, the kernel's own file last.
    pub parts: &'static [WgslFile],
    /// Written out, not read from the WGSL when a device is checked:
    /// parsing every module costs about 50 ms, more than a small command's
    /// GPU work. The validation test proves each equal to what naga reads
    /// (`resources`).
    pub demands: Demands,
}

/// What a module's entry points ask of a device at most, in the terms of
/// `wgpu::Limits`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Demands {
    /// Storage buffers its declarations bind: the pipeline layout its entry
    /// points share, which wgpu counts per shader stage.
    pub storage_buffers: u32,
    /// Storage textures its declarations bind, counted as storage buffers are.
    pub storage_textures: u32,
    /// The most workgroup memory one entry point uses (each variable
    /// rounded up to 16 bytes, as WebGPU counts it).
    pub workgroup_bytes: u32,
    /// The largest workgroup along each axis (zero: no compute entry point).
    pub workgroup_size: [u32; 3],
}

impl Demands {
    /// A compute module over `storage_buffers` storage buffers with 1D
    /// workgroups of `WORKGROUP_SIZE` and no workgroup memory.
    const fn compute(storage_buffers: u32) -> Demands {
        Demands {
            storage_buffers,
            storage_textures: 0,
            workgroup_bytes: 0,
            workgroup_size: [crate::gpu::WORKGROUP_SIZE, 1, 1],
        }
    }

    /// As `compute`, with 8 x 8 workgroups (the per-pixel kernels).
    const fn per_pixel(storage_buffers: u32) -> Demands {
        Demands {
            workgroup_size: [8, 8, 1],
            ..Demands::compute(storage_buffers)
        }
    }

    /// Each limit of `limits` these demands exceed, for module `module`.
    pub fn exceeded(&self, module: &str, limits: &wgpu::Limits) -> Vec<Exceeded> {
        let size = self.workgroup_size;
        let checks = [
            (
                "max_storage_buffers_per_shader_stage",
                "storage buffers per shader stage",
                self.storage_buffers,
                limits.max_storage_buffers_per_shader_stage,
            ),
            (
                "max_storage_textures_per_shader_stage",
                "storage textures per shader stage",
                self.storage_textures,
                limits.max_storage_textures_per_shader_stage,
            ),
            (
                "max_compute_workgroup_storage_size",
                "bytes of workgroup memory",
                self.workgroup_bytes,
                limits.max_compute_workgroup_storage_size,
            ),
            (
                "max_compute_invocations_per_workgroup",
                "invocations per workgroup",
                size.iter().product(),
                limits.max_compute_invocations_per_workgroup,
            ),
            (
                "max_compute_workgroup_size_x",
                "invocations along x",
                size[0],
                limits.max_compute_workgroup_size_x,
            ),
            (
                "max_compute_workgroup_size_y",
                "invocations along y",
                size[1],
                limits.max_compute_workgroup_size_y,
            ),
            (
                "max_compute_workgroup_size_z",
                "invocations along z",
                size[2],
                limits.max_compute_workgroup_size_z,
            ),
        ];
        checks
            .into_iter()
            .filter(|&(_, _, needs, allows)| needs > allows)
            .map(|(limit, counts, needs, allows)| Exceeded {
                limit,
                counts,
                needs,
                module: module.to_string(),
                allows,
            })
            .collect()
    }
}

/// `TRACE_RAYS` over the kd-tree traversal.
pub const TRACE_RAYS_MODULE: Composition = Composition {
    name: "trace_rays",
    parts: &[KDTREE_TRAVERSE, TRACE_RAYS],
    demands: Demands::compute(6),
};

/// `AO_RAYS` over sampling, the tangent frame and the kd-tree traversal.
pub const AO_RAYS_MODULE: Composition = Composition {
    name: "ao_rays",
    parts: &[SAMPLING, FRAME, KDTREE_TRAVERSE, TEXTURE_MAPS, AO_RAYS],
    demands: Demands::compute(7),
};

/// `WHITTED` with its pixel entries (no ray-tree recording).
pub const WHITTED_MODULE: Composition = Composition {
    name: "whitted",
    parts: &[SAMPLING, KDTREE_TRAVERSE, TEXTURE_MAPS, WHITTED_PIXELS, WHITTED],
    demands: Demands::compute(8),
};

/// `whitted.wgsl` with its ray-tree recording compiled in, for its
/// `whitted_trees` entry.
pub const WHITTED_TREES_MODULE: Composition = Composition {
    name: "whitted_trees",
    parts: &[SAMPLING, KDTREE_TRAVERSE, TEXTURE_MAPS, WHITTED_TREES, WHITTED],
    demands: Demands::compute(8),
};

/// The Whitted pass's pixels into a host's `rgba32float` storage texture.
pub const WHITTED_IMAGE_MODULE: Composition = Composition {
    name: "whitted_image",
    parts: &[WHITTED_IMAGE],
    demands: Demands {
        storage_textures: 1,
        ..Demands::compute(1)
    },
};

/// `INTERPOLATE` on its own.
pub const INTERPOLATE_MODULE: Composition = Composition {
    name: "interpolate",
    parts: &[INTERPOLATE],
    demands: Demands::compute(3),
};

/// `PACKET_TRAVERSE` over the kd-tree traversal.
pub const PACKET_TRAVERSE_MODULE: Composition = Composition {
    name: "packet_traverse",
    parts: &[KDTREE_TRAVERSE, PACKET_TRAVERSE],
    demands: Demands::compute(7),
};

/// Displacement-field kernels: one module per kernel and map storage (8-bit
/// texture sampled with filtering, 32-bit texture loaded, 1-bit buffer).
macro_rules! field_module {
    ($name:literal, $maps:ident, $kernel:ident, $storage_buffers:literal) => {
        Composition {
            name: $name,
            parts: &[SAMPLING, FRAME, FIELD_LOOKUP, $maps, FIELD_TRACE, $kernel],
            demands: Demands::compute($storage_buffers),
        }
    };
}

/// `FIELD_AO` over 8-bit maps (filtered texture).
pub const FIELD_AO_FILTERED_MODULE: Composition = field_module!("field_ao_filtered", FIELD_MAPS_FILTERED, FIELD_AO, 4);
/// `FIELD_AO` over 32-bit maps (loaded texture).
pub const FIELD_AO_LOADED_MODULE: Composition = field_module!("field_ao_loaded", FIELD_MAPS_LOADED, FIELD_AO, 4);
/// `FIELD_AO` over 1-bit maps (storage buffers).
pub const FIELD_AO_BITS_MODULE: Composition = field_module!("field_ao_bits", FIELD_MAPS_BITS, FIELD_AO, 6);
/// `FIELD_PROBE` over 8-bit maps (filtered texture).
pub const FIELD_PROBE_FILTERED_MODULE: Composition =
    field_module!("field_probe_filtered", FIELD_MAPS_FILTERED, FIELD_PROBE, 2);
/// `FIELD_PROBE` over 32-bit maps (loaded texture).
pub const FIELD_PROBE_LOADED_MODULE: Composition =
    field_module!("field_probe_loaded", FIELD_MAPS_LOADED, FIELD_PROBE, 2);
/// `FIELD_PROBE` over 1-bit maps (storage buffers).
pub const FIELD_PROBE_BITS_MODULE: Composition = field_module!("field_probe_bits", FIELD_MAPS_BITS, FIELD_PROBE, 4);

/// The G-buffer render pipeline (vertex and fragment stages).
pub const GBUFFER_MODULE: Composition = Composition {
    name: "gbuffer",
    parts: &[ALBEDO, GBUFFER],
    demands: Demands {
        workgroup_size: [0; 3],
        ..Demands::compute(0)
    },
};

/// The G-buffer render pipeline of scenes with colour maps or cut-outs
/// (vertex and fragment stages; one storage buffer: the surfaces' words).
pub const GBUFFER_TEXTURED_MODULE: Composition = Composition {
    name: "gbuffer_textured",
    parts: &[ALBEDO, TEXTURE_MAPS, GBUFFER, GBUFFER_TEXTURED],
    demands: Demands {
        workgroup_size: [0; 3],
        ..Demands::compute(1)
    },
};

/// `SSAO_ESTIMATE` over the tangent frame and `SSAO_COMMON`.
pub const SSAO_ESTIMATE_MODULE: Composition = Composition {
    name: "ssao_estimate",
    parts: &[FRAME, SSAO_COMMON, SSAO_ESTIMATE],
    demands: Demands::per_pixel(8),
};

/// `SSAO_FILTER` over the tangent frame and `SSAO_COMMON`.
pub const SSAO_FILTER_MODULE: Composition = Composition {
    name: "ssao_filter",
    parts: &[FRAME, SSAO_COMMON, SSAO_FILTER],
    demands: Demands::per_pixel(8),
};

/// `SSAO_INDIRECT` over the tangent frame, the packed albedo and
/// `SSAO_COMMON`.
pub const SSAO_INDIRECT_MODULE: Composition = Composition {
    name: "ssao_indirect",
    parts: &[FRAME, ALBEDO, SSAO_COMMON, SSAO_INDIRECT],
    demands: Demands::per_pixel(8),
};

/// SH transfer with 16 vertices a workgroup, for devices with 32 KiB of
/// workgroup memory (`prt::gpu` picks the form per device).
pub const SH_TRANSFER_MODULE: Composition = Composition {
    name: "sh_transfer",
    parts: &[SH_TRANSFER_WIDE, SH_TRANSFER],
    demands: Demands {
        workgroup_bytes: 29_696,
        ..Demands::compute(7)
    },
};

/// SH transfer with 8 vertices a workgroup, within WebGPU's portable
/// limits.
pub const SH_TRANSFER_PORTABLE_MODULE: Composition = Composition {
    name: "sh_transfer_portable",
    parts: &[SH_TRANSFER_PORTABLE, SH_TRANSFER],
    demands: Demands {
        workgroup_bytes: 14_848,
        ..Demands::compute(7)
    },
};

/// Every kernel module the library builds pipelines from, in the form that
/// fits WebGPU's portable limits (what a device must allow for penumbra's
/// compute kernels: `device::Needs`).
pub const MODULES: &[Composition] = &[
    TRACE_RAYS_MODULE,
    AO_RAYS_MODULE,
    PACKET_TRAVERSE_MODULE,
    FIELD_AO_FILTERED_MODULE,
    FIELD_AO_LOADED_MODULE,
    FIELD_AO_BITS_MODULE,
    FIELD_PROBE_FILTERED_MODULE,
    FIELD_PROBE_LOADED_MODULE,
    FIELD_PROBE_BITS_MODULE,
    GBUFFER_MODULE,
    GBUFFER_TEXTURED_MODULE,
    SSAO_ESTIMATE_MODULE,
    SSAO_FILTER_MODULE,
    SSAO_INDIRECT_MODULE,
    SH_TRANSFER_PORTABLE_MODULE,
    WHITTED_MODULE,
    WHITTED_TREES_MODULE,
    WHITTED_IMAGE_MODULE,
    INTERPOLATE_MODULE,
];

/// Modules compiled instead of one of `MODULES` on devices with larger
/// limits than WebGPU's portable ones.
pub const VARIANTS: &[Composition] = &[SH_TRANSFER_MODULE];

/// What one entry point of a composed module asks of a device, in the terms
/// of `wgpu::Limits`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EntryNeeds {
    /// `module.entry_point`.
    pub name: String,
    /// The entry point's stage (compute, or the G-buffer's vertex and
    /// fragment).
    pub stage: naga::ShaderStage,
    /// Storage buffers the entry point itself uses (its pipeline layout,
    /// shared by the module's entry points, binds `Resources::storage_buffers`).
    pub storage_buffers: u32,
    /// Storage textures the entry point itself uses.
    pub storage_textures: u32,
    /// Sampled (non-storage) textures the entry point itself uses.
    pub sampled_textures: u32,
    /// Bytes of the `var<workgroup>` variables it uses, each rounded up to
    /// 16 as WebGPU counts them against `max_compute_workgroup_storage_size`.
    pub workgroup_bytes: u32,
    /// The entry point's `@workgroup_size` (zero for a render stage).
    pub workgroup_size: [u32; 3],
}

/// What a composed module asks of a device, as naga reads it: what its
/// declarations bind (the pipeline layout every entry point shares, which
/// wgpu counts per shader stage) and what each entry point uses.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Resources {
    /// The module's name (`Composition::name`).
    pub module: &'static str,
    /// Storage buffers the module declares, used or not.
    pub storage_buffers: u32,
    /// Storage textures the module declares, used or not.
    pub storage_textures: u32,
    /// Each entry point's own needs, in the module's order.
    pub entries: Vec<EntryNeeds>,
}

impl Resources {
    /// The module's demands as `Composition::demands` writes them out.
    pub fn demands(&self) -> Demands {
        let compute = self.entries.iter().filter(|e| e.stage == naga::ShaderStage::Compute);
        let mut size = [0; 3];
        for entry in compute.clone() {
            for (s, &e) in size.iter_mut().zip(&entry.workgroup_size) {
                *s = (*s).max(e);
            }
        }
        Demands {
            storage_buffers: self.storage_buffers,
            storage_textures: self.storage_textures,
            workgroup_bytes: compute.map(|e| e.workgroup_bytes).max().unwrap_or(0),
            workgroup_size: size,
        }
    }
}

/// A limit a module exceeds (`Demands::exceeded`); displayed as a device
/// error lists it: what it needs, for which module, and what the device
/// allows.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Exceeded {
    /// The limit's name in `wgpu::Limits`.
    pub limit: &'static str,
    /// What it counts ("bytes of workgroup memory").
    pub counts: &'static str,
    /// How many the module needs.
    pub needs: u32,
    /// The module's name.
    pub module: String,
    /// How many the device allows.
    pub allows: u32,
}

impl std::fmt::Display for Exceeded {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} {} for {} (`{}` is {})",
            self.needs, self.counts, self.module, self.limit, self.allows
        )
    }
}

impl Composition {
    /// Each limit of `limits` the module exceeds.
    pub fn exceeded(&self, limits: &wgpu::Limits) -> Vec<Exceeded> {
        self.demands.exceeded(self.name, limits)
    }

    /// Whether the module fits `limits`.
    pub fn fits(&self, limits: &wgpu::Limits) -> bool {
        self.exceeded(limits).is_empty()
    }

    /// The composed WGSL: the parts concatenated, each ending in a newline.
    pub fn source(&self) -> String {
        let mut s = String::new();
        for part in self.parts {
            s.push_str(part.text);
            if !part.text.ends_with('\n') {
                s.push('\n');
            }
        }
        s
    }

    /// The file and 1-based line that line `line` of `source()` came from.
    pub fn locate(&self, line: u32) -> (&'static str, u32) {
        let mut first = 1u32;
        for part in self.parts {
            let lines = part.text.lines().count() as u32;
            if line < first + lines {
                return (part.path, line - first + 1);
            }
            first += lines;
        }
        (self.parts.last().map_or("?", |p| p.path), line)
    }

    /// Parses and validates the composed module with naga. An error names the
    /// original file and line.
    pub fn validate(&self) -> Result<naga::Module, String> {
        let source = self.source();
        validate_source(&source, |line| self.locate(line)).map(|(module, _)| module)
    }

    /// What the module asks of a device, read from its validated IR (for
    /// an invalid module, `validate`'s error).
    pub fn resources(&self) -> Result<Resources, String> {
        let source = self.source();
        let (module, info) = validate_source(&source, |line| self.locate(line))?;
        let mut layouter = naga::proc::Layouter::default();
        layouter
            .update(module.to_ctx())
            .map_err(|e| format!("{}: {e}", self.name))?;
        let storage_texture = |ty: naga::Handle<naga::Type>| {
            matches!(
                module.types[ty].inner,
                naga::TypeInner::Image {
                    class: naga::ImageClass::Storage { .. },
                    ..
                }
            )
        };
        let sampled_texture = |ty: naga::Handle<naga::Type>| {
            matches!(module.types[ty].inner, naga::TypeInner::Image { .. }) && !storage_texture(ty)
        };
        let count = |used: &dyn Fn(naga::Handle<naga::GlobalVariable>) -> bool,
                     kind: &dyn Fn(&naga::GlobalVariable) -> bool| {
            module
                .global_variables
                .iter()
                .filter(|&(h, g)| used(h) && kind(g))
                .count() as u32
        };
        let storage_buffer = |g: &naga::GlobalVariable| matches!(g.space, naga::AddressSpace::Storage { .. });
        let declared = |_| true;
        let entries = module
            .entry_points
            .iter()
            .enumerate()
            .map(|(i, ep)| {
                let function = info.get_entry_point(i);
                let used = |h: naga::Handle<naga::GlobalVariable>| !function[h].is_empty();
                let workgroup_bytes = module
                    .global_variables
                    .iter()
                    .filter(|&(h, g)| used(h) && g.space == naga::AddressSpace::WorkGroup)
                    .map(|(_, g)| layouter[g.ty].size.next_multiple_of(16))
                    .sum();
                EntryNeeds {
                    name: format!("{}.{}", self.name, ep.name),
                    stage: ep.stage,
                    storage_buffers: count(&used, &storage_buffer),
                    storage_textures: count(&used, &|g| storage_texture(g.ty)),
                    sampled_textures: count(&used, &|g| sampled_texture(g.ty)),
                    workgroup_bytes,
                    workgroup_size: ep.workgroup_size,
                }
            })
            .collect();
        Ok(Resources {
            module: self.name,
            storage_buffers: count(&declared, &storage_buffer),
            storage_textures: count(&declared, &|g| storage_texture(g.ty)),
            entries,
        })
    }
}

impl WgslFile {
    /// Parses and validates the file on its own.
    pub fn validate(&self) -> Result<naga::Module, String> {
        validate_source(self.text, |line| (self.path, line)).map(|(module, _)| module)
    }
}

/// Marker path given to naga's diagnostic renderer, so the line it reports
/// can be found and mapped back.
const MARK: &str = "@composed@";

/// The first `@composed@:LINE:COL` in a rendered naga diagnostic. (naga's
/// `location()` uses the first label, which can have an undefined span and
/// then points at line 1; the rendered text skips undefined spans.)
fn rendered_line(rendered: &str) -> Option<u32> {
    let at = rendered.find(&format!("{MARK}:"))? + MARK.len() + 1;
    rendered[at..].split(':').next()?.parse().ok()
}

fn validate_source(
    source: &str,
    locate: impl Fn(u32) -> (&'static str, u32),
) -> Result<(naga::Module, naga::valid::ModuleInfo), String> {
    let describe = |rendered: String, kind: &str, message: String| {
        let at = rendered_line(&rendered)
            .map(&locate)
            .map_or("?".to_string(), |(f, l)| format!("{f}:{l}"));
        format!("{at}: {kind}: {message}\n{rendered}")
    };
    let module = naga::front::wgsl::parse_str(source).map_err(|e| {
        describe(
            e.emit_to_string_with_path(source, MARK),
            "parse error",
            e.message().to_string(),
        )
    })?;
    let info = naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::default(),
    )
    .validate(&module)
    .map_err(|e| {
        describe(
            e.emit_to_string_with_path(source, MARK),
            "validation error",
            e.as_inner().to_string(),
        )
    })?;
    Ok((module, info))
}
