//! `penumbra gen-assets`: writes the library's procedural scenes, the ray
//! tracer's scenes, the example animations and the chess-like scene as the
//! files under `assets/` (the committed ones are these, byte for byte).

use std::path::{Path, PathBuf};

use penumbra::error::{Error, Result};
use penumbra::io::output::write_bytes;
use penumbra::scene::procedural;
use penumbra_assets::raytrace::shipped_scenes;
use penumbra_assets::{animations, chess};

/// Writes `files` (paths relative to `dir`) under `dir`, creating the
/// folders they need; returns the paths written, in order.
fn write_files<B: AsRef<[u8]>>(dir: &Path, files: Vec<(String, B)>) -> Result<Vec<PathBuf>> {
    let mut written = Vec::with_capacity(files.len());
    for (name, bytes) in files {
        let path = dir.join(name);
        if let Some(folder) = path.parent() {
            std::fs::create_dir_all(folder).map_err(|e| Error::write(folder, e))?;
        }
        write_bytes(&path, bytes.as_ref())?;
        written.push(path);
    }
    Ok(written)
}

/// Every asset under `out`: the procedural scenes (OBJ), the ray tracer's
/// scenes (`raytrace/`), the example animations (`animations/`) and the
/// chess-like scene (`chess/`, `scenes/chess.json`).
pub fn write_every_asset(out: &Path) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(out).map_err(|e| Error::write(out, e))?;
    let mut written = write_files(out, procedural::asset_files())?;
    let scenes = shipped_scenes();
    let raytrace: Vec<(String, Vec<u8>)> = scenes
        .into_iter()
        .flat_map(|s| s.files.into_iter().map(|(n, t)| (n, t.into_bytes())).chain(s.images))
        .collect();
    written.extend(write_files(&out.join("raytrace"), raytrace)?);
    written.extend(write_files(&out.join("animations"), animations::animation_files())?);
    written.extend(write_files(out, chess::chess_files())?);
    Ok(written)
}
