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

pub const SAMPLING: WgslFile = wgsl_file!("sampling.wgsl");
pub const FRAME: WgslFile = wgsl_file!("frame.wgsl");
pub const ALBEDO: WgslFile = wgsl_file!("albedo.wgsl");
pub const KDTREE_TRAVERSE: WgslFile = wgsl_file!("kdtree_traverse.wgsl");
pub const TRACE_RAYS: WgslFile = wgsl_file!("trace_rays.wgsl");
pub const AO_RAYS: WgslFile = wgsl_file!("ao_rays.wgsl");
pub const PACKET_TRAVERSE: WgslFile = wgsl_file!("packet_traverse.wgsl");
pub const FIELD_LOOKUP: WgslFile = wgsl_file!("field_lookup.wgsl");
pub const FIELD_MAPS_FILTERED: WgslFile = wgsl_file!("field_maps_filtered.wgsl");
pub const FIELD_MAPS_LOADED: WgslFile = wgsl_file!("field_maps_loaded.wgsl");
pub const FIELD_MAPS_BITS: WgslFile = wgsl_file!("field_maps_bits.wgsl");
pub const FIELD_TRACE: WgslFile = wgsl_file!("field_trace.wgsl");
pub const FIELD_AO: WgslFile = wgsl_file!("field_ao.wgsl");
pub const FIELD_PROBE: WgslFile = wgsl_file!("field_probe.wgsl");
pub const GBUFFER: WgslFile = wgsl_file!("gbuffer.wgsl");
pub const SSAO_COMMON: WgslFile = wgsl_file!("ssao_common.wgsl");
pub const SSAO_ESTIMATE: WgslFile = wgsl_file!("ssao_estimate.wgsl");
pub const SSAO_FILTER: WgslFile = wgsl_file!("ssao_filter.wgsl");
pub const SSAO_INDIRECT: WgslFile = wgsl_file!("ssao_indirect.wgsl");
pub const SH_TRANSFER: WgslFile = wgsl_file!("sh_transfer.wgsl");
pub const WHITTED_PIXELS: WgslFile = wgsl_file!("whitted_pixels.wgsl");
pub const WHITTED_TREES: WgslFile = wgsl_file!("whitted_trees.wgsl");
pub const WHITTED: WgslFile = wgsl_file!("whitted.wgsl");
pub const INTERPOLATE: WgslFile = wgsl_file!("interpolate.wgsl");

/// Every file compiled in (the validation test checks this against `wgsl/`).
pub const FILES: &[WgslFile] = &[
    SAMPLING,
    FRAME,
    ALBEDO,
    KDTREE_TRAVERSE,
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
    SSAO_COMMON,
    SSAO_ESTIMATE,
    SSAO_FILTER,
    SSAO_INDIRECT,
    SH_TRANSFER,
    WHITTED_PIXELS,
    WHITTED_TREES,
    WHITTED,
    INTERPOLATE,
];

/// A shader module made of several files, in order.
#[derive(Debug, Clone, Copy)]
pub struct Composition {
    pub name: &'static str,
    pub parts: &'static [WgslFile],
}

pub const TRACE_RAYS_MODULE: Composition = Composition {
    name: "trace_rays",
    parts: &[KDTREE_TRAVERSE, TRACE_RAYS],
};

pub const AO_RAYS_MODULE: Composition = Composition {
    name: "ao_rays",
    parts: &[SAMPLING, FRAME, KDTREE_TRAVERSE, AO_RAYS],
};

pub const WHITTED_MODULE: Composition = Composition {
    name: "whitted",
    parts: &[SAMPLING, KDTREE_TRAVERSE, WHITTED_PIXELS, WHITTED],
};

/// `whitted.wgsl` with its ray-tree recording compiled in, for its
/// `whitted_trees` entry.
pub const WHITTED_TREES_MODULE: Composition = Composition {
    name: "whitted_trees",
    parts: &[SAMPLING, KDTREE_TRAVERSE, WHITTED_TREES, WHITTED],
};

pub const INTERPOLATE_MODULE: Composition = Composition {
    name: "interpolate",
    parts: &[INTERPOLATE],
};

pub const PACKET_TRAVERSE_MODULE: Composition = Composition {
    name: "packet_traverse",
    parts: &[KDTREE_TRAVERSE, PACKET_TRAVERSE],
};

/// Displacement-field kernels: one module per kernel and map storage (8-bit
/// texture sampled with filtering, 32-bit texture loaded, 1-bit buffer).
macro_rules! field_module {
    ($name:literal, $maps:ident, $kernel:ident) => {
        Composition {
            name: $name,
            parts: &[SAMPLING, FRAME, FIELD_LOOKUP, $maps, FIELD_TRACE, $kernel],
        }
    };
}

pub const FIELD_AO_FILTERED_MODULE: Composition = field_module!("field_ao_filtered", FIELD_MAPS_FILTERED, FIELD_AO);
pub const FIELD_AO_LOADED_MODULE: Composition = field_module!("field_ao_loaded", FIELD_MAPS_LOADED, FIELD_AO);
pub const FIELD_AO_BITS_MODULE: Composition = field_module!("field_ao_bits", FIELD_MAPS_BITS, FIELD_AO);
pub const FIELD_PROBE_FILTERED_MODULE: Composition =
    field_module!("field_probe_filtered", FIELD_MAPS_FILTERED, FIELD_PROBE);
pub const FIELD_PROBE_LOADED_MODULE: Composition = field_module!("field_probe_loaded", FIELD_MAPS_LOADED, FIELD_PROBE);
pub const FIELD_PROBE_BITS_MODULE: Composition = field_module!("field_probe_bits", FIELD_MAPS_BITS, FIELD_PROBE);

/// The G-buffer render pipeline (vertex and fragment stages).
pub const GBUFFER_MODULE: Composition = Composition {
    name: "gbuffer",
    parts: &[ALBEDO, GBUFFER],
};

pub const SSAO_ESTIMATE_MODULE: Composition = Composition {
    name: "ssao_estimate",
    parts: &[FRAME, SSAO_COMMON, SSAO_ESTIMATE],
};

pub const SSAO_FILTER_MODULE: Composition = Composition {
    name: "ssao_filter",
    parts: &[FRAME, SSAO_COMMON, SSAO_FILTER],
};

pub const SSAO_INDIRECT_MODULE: Composition = Composition {
    name: "ssao_indirect",
    parts: &[FRAME, ALBEDO, SSAO_COMMON, SSAO_INDIRECT],
};

pub const SH_TRANSFER_MODULE: Composition = Composition {
    name: "sh_transfer",
    parts: &[SH_TRANSFER],
};

/// Every kernel module the library builds pipelines from.
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
    SSAO_ESTIMATE_MODULE,
    SSAO_FILTER_MODULE,
    SSAO_INDIRECT_MODULE,
    SH_TRANSFER_MODULE,
    WHITTED_MODULE,
    WHITTED_TREES_MODULE,
    INTERPOLATE_MODULE,
];

impl Composition {
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
        validate_source(&source, |line| self.locate(line))
    }
}

impl WgslFile {
    /// Parses and validates the file on its own.
    pub fn validate(&self) -> Result<naga::Module, String> {
        validate_source(self.text, |line| (self.path, line))
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

fn validate_source(source: &str, locate: impl Fn(u32) -> (&'static str, u32)) -> Result<naga::Module, String> {
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
    naga::valid::Validator::new(
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
    Ok(module)
}
