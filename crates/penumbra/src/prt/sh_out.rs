//! `prt --sh-out FILE.json`: the light probe's spherical-harmonic
//! coefficients per colour channel, with their convention stated in the
//! file itself (see `crate::sh` for the conventions penumbra uses
//! everywhere).
//!
//! `coefficients` is the probe's projection (each texel constant radiance
//! over its exact solid angle) at max(5, --order) bands, so at least the 25
//! RGB triples the command-line contract promises; `lighting` is what the
//! shading used at `--order` bands: the projection windowed as little as
//! keeps its reconstruction non-negative (`crate::sh::window`), identical
//! to `coefficients` when no window was needed.

use std::path::Path;

use serde_json::{Value, json};

use crate::error::Result;
use crate::scene::EnvironmentMap;
use crate::sh::window::nonnegative;
use crate::sh::{ShRgb, project_environment};

/// Bands of `coefficients` at least: the contract's 25 triples.
pub const MIN_BANDS: usize = 5;

/// The convention, as written into the file.
pub const CONVENTION: &str = "real spherical harmonics, orthonormal on the unit sphere (integral of Y_i Y_j = delta_ij), \
     no Condon-Shortley phase: Y_1,-1 = sqrt(3/(4 pi)) y, Y_1,0 = sqrt(3/(4 pi)) z, Y_1,1 = sqrt(3/(4 pi)) x; \
     (x, y, z) is the unit direction towards the environment in world coordinates (+y up); \
     radiance L(d) = sum_i coefficients[i] Y_i(d), per channel (r, g, b), linear";

/// The JSON of the probe `env` (read from `probe`), shaded at `bands`.
pub fn sh_json(env: &EnvironmentMap, probe: &Path, bands: usize, env_spin: f32) -> Value {
    let projected = project_environment(env, bands.max(MIN_BANDS));
    let (lighting, deringing) = nonnegative(&projected.truncated(bands));
    let lm: Vec<[i64; 2]> = (0..projected.bands as i64)
        .flat_map(|l| (-l..=l).map(move |m| [l, m]))
        .collect();
    json!({
        "probe": probe.display().to_string(),
        "width": env.width,
        "height": env.height,
        "convention": CONVENTION,
        "order": "index i = l (l + 1) + m, m = -l..l: band l holds indices l^2..(l+1)^2 - 1",
        "bands": projected.bands,
        "count": projected.rgb.len(),
        "lm": lm,
        "coefficients": triples(&projected),
        "lighting": {
            "bands": bands,
            "coefficients": triples(&lighting),
            "window": deringing,
        },
        "env_spin_degrees_per_frame": env_spin,
    })
}

fn triples(sh: &ShRgb) -> &[[f64; 3]] {
    &sh.rgb
}

/// Writes `sh_json` to `path`.
pub fn write_sh_json(path: &Path, env: &EnvironmentMap, probe: &Path, bands: usize, env_spin: f32) -> Result<()> {
    let text = serde_json::to_string_pretty(&sh_json(env, probe, bands, env_spin))
        .map_err(|e| crate::error::Error::internal(format!("SH JSON: {e}")))?;
    crate::io::output::write_bytes(path, format!("{text}\n").as_bytes())
}
