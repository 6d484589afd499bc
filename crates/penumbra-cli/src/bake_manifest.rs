//! `penumbra bake --manifest FILE --out DIR`: many assets, one a line, each
//! baked as `penumbra bake --mesh ASSET` would bake it into DIR. With
//! `--shard I/N` a shard bakes its entries (contiguous lines) into DIR
//! under their final names and records each in `DIR.part-I-of-N`; `merge
//! DIR` checks that every entry's files exist and reports them all.
//!
//! A line: `ASSET [OPTIONS]`, `ASSET` relative to the manifest's folder,
//! `OPTIONS` those of `penumbra bake` (`--resolution 2048 --rays 512`);
//! `--out NAME` (default: the asset's stem, `.glb`) and `--texture NAME`
//! are relative to DIR. Blank lines and lines starting with `#` are
//! skipped; a token with spaces is written in double quotes.

use std::path::{Path, PathBuf};

use serde_json::{Value, json};

use penumbra::error::{Error, Result};

use crate::Command;
use crate::bake::BakeArgs;
use crate::shard::Mode;

/// One asset of the manifest, as the command line it stands for.
pub struct Entry {
    /// Its line, from 1.
    pub line: usize,
    /// The asset, resolved against the manifest's folder.
    pub asset: PathBuf,
    /// `penumbra bake --mesh ASSET --out DIR/NAME OPTIONS`.
    pub command: Command,
}

impl Entry {
    fn args(&self) -> &BakeArgs {
        match &self.command {
            Command::Bake(a) => a,
            _ => unreachable!("an entry is a bake"),
        }
    }
}

/// A line's tokens: whitespace-separated, `"..."` keeping spaces.
fn tokens(line: &str) -> std::result::Result<Vec<String>, String> {
    let mut out = Vec::new();
    let mut chars = line.chars().peekable();
    while let Some(&c) = chars.peek() {
        if c.is_whitespace() {
            chars.next();
            continue;
        }
        let mut t = String::new();
        if c == '"' {
            chars.next();
            loop {
                match chars.next() {
                    Some('"') => break,
                    Some(c) => t.push(c),
                    None => return Err("a quote is not closed".into()),
                }
            }
        } else {
            while let Some(&c) = chars.peek() {
                if c.is_whitespace() {
                    break;
                }
                t.push(c);
                chars.next();
            }
        }
        out.push(t);
    }
    Ok(out)
}

/// The assets a manifest names (for the files a run reads); none where it
/// cannot be read (the run says why).
pub fn asset_paths(manifest: &Path) -> Vec<PathBuf> {
    let Ok(text) = std::fs::read_to_string(manifest) else {
        return Vec::new();
    };
    let dir = manifest.parent().unwrap_or(Path::new(""));
    text.lines()
        .filter_map(|l| tokens(l.trim()).ok())
        .filter(|t| t.first().is_some_and(|a| !a.starts_with('#')))
        .map(|t| dir.join(&t[0]))
        .collect()
}

/// Options of the command line (as typed, program and subcommand first)
/// that every entry takes unless its line gives its own: each option with
/// its value, if it takes one.
fn inherited(typed: &[String]) -> Vec<Vec<String>> {
    const VALUED: [&str; 11] = [
        "--device",
        "--seed",
        "--threads",
        "--rays",
        "--resolution",
        "--padding",
        "--texel-samples",
        "--png-bits",
        "--radius",
        "--max-error",
        "--vertex",
    ];
    let mut out = Vec::new();
    let mut it = typed.iter().skip(2);
    while let Some(a) = it.next() {
        let (name, value) = match a.split_once('=') {
            Some((n, v)) => (n.to_string(), Some(v.to_string())),
            None => (a.clone(), None),
        };
        if VALUED.contains(&name.as_str()) {
            let v = value.or_else(|| it.next().cloned()).unwrap_or_default();
            out.push(vec![name, v]);
        } else if ["--vertex-colors", "--replace"].contains(&name.as_str()) {
            out.push(vec![name]);
        }
    }
    out
}

/// Every entry of `manifest`, parsed before any work: an error names the
/// manifest, the line and the problem.
pub fn entries(args: &BakeArgs, manifest: &Path, typed: &[String]) -> Result<Vec<Entry>> {
    let text = std::fs::read_to_string(manifest).map_err(|e| Error::file(manifest, "", format!("cannot read: {e}")))?;
    let dir = manifest.parent().unwrap_or(Path::new(""));
    let inherited = inherited(typed);
    let mut out: Vec<Entry> = Vec::new();
    for (n, raw) in text.lines().enumerate() {
        let line = n + 1;
        let at = |problem: String| Error::file(manifest, format!("line {line}"), problem);
        let t = tokens(raw.trim()).map_err(at)?;
        let Some(asset) = t.first().filter(|a| !a.starts_with('#')) else {
            continue;
        };
        let asset = dir.join(asset);
        let mut options: Vec<String> = t[1..].to_vec();
        for refused in ["--manifest", "--scene", "--mesh", "--shard", "--json"] {
            if options
                .iter()
                .any(|o| o == refused || o.starts_with(&format!("{refused}=")))
            {
                return Err(at(format!("{refused} belongs on the command line, not in an entry")));
            }
        }
        let named = |opt: &str, options: &mut Vec<String>| -> Option<String> {
            let k = options.iter().position(|o| o == opt)?;
            let v = options.get(k + 1).cloned();
            options.drain(k..(k + 2).min(options.len()));
            v
        };
        let stem = asset
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let out_name = named("--out", &mut options).unwrap_or(format!("{stem}.glb"));
        let texture = named("--texture", &mut options);
        let mut argv: Vec<String> = vec!["penumbra".into(), "bake".into(), "--mesh".into()];
        argv.push(asset.display().to_string());
        argv.extend(["--out".into(), args.out.join(&out_name).display().to_string()]);
        if let Some(t) = texture {
            argv.extend(["--texture".into(), args.out.join(t).display().to_string()]);
        }
        // The line's own options win over those of the command line.
        let given = |name: &str| options.iter().any(|o| o == name || o.starts_with(&format!("{name}=")));
        for group in inherited.iter().filter(|g| !given(&g[0])) {
            argv.extend(group.iter().cloned());
        }
        argv.extend(options);
        let command = crate::parse_command(&argv).map_err(|e| {
            let first = e
                .lines()
                .next()
                .unwrap_or_default()
                .trim_start_matches("error: ")
                .to_string();
            at(first)
        })?;
        let entry = Entry { line, asset, command };
        crate::bake::settings(entry.args()).map_err(|e| at(e.with_names(crate::args::flag).to_string()))?;
        if let Some(same) = out.iter().find(|e| e.args().out == entry.args().out) {
            return Err(at(format!(
                "writes {}, as line {} does",
                entry.args().out.display(),
                same.line
            )));
        }
        out.push(entry);
    }
    if out.is_empty() {
        return Err(Error::file(manifest, "", "names no asset"));
    }
    Ok(out)
}

/// `bake --manifest`: every entry (or a shard's), or the merge of the
/// shards' records.
pub fn run(args: &BakeArgs, manifest: &Path, typed: &[String]) -> Result<Value> {
    if !args.out.is_dir() {
        let problem = format!("{}: with --manifest, a folder that exists", args.out.display());
        return Err(Error::param("--out", problem));
    }
    let entries = entries(args, manifest, typed)?;
    let reports = match args.shard.mode()? {
        Mode::Whole => {
            let mut reports = Vec::new();
            for e in &entries {
                reports.push(bake_entry(e)?);
            }
            reports
        }
        Mode::Part(shard) => {
            let mut writer = crate::shard::open_part(&args.out, shard, entries.len())?;
            let mut reports = Vec::new();
            for piece in writer.todo(1) {
                let report = bake_entry(&entries[piece.start])?;
                let bytes = serde_json::to_vec(&report).map_err(|e| Error::internal(e.to_string()))?;
                writer.record(piece, &bytes)?;
                reports.push(report);
            }
            let report = json!({ "method": "bake", "manifest": manifest.display().to_string(), "assets": reports });
            return crate::shard::finish_part(writer, report);
        }
        Mode::Merge(parts) => {
            if parts.total_items() != entries.len() {
                let problem = format!(
                    "the parts hold {} entries, the manifest has {}",
                    parts.total_items(),
                    entries.len()
                );
                return Err(Error::file(&parts.output, "", problem));
            }
            let mut reports = Vec::new();
            for (items, bytes) in parts.records()? {
                let report: Value = serde_json::from_slice(&bytes)
                    .map_err(|e| Error::file(&parts.output, "", format!("the record of entry {}: {e}", items.start)))?;
                let entry = &entries[items.start];
                for f in report["files"]
                    .as_array()
                    .into_iter()
                    .flatten()
                    .filter_map(Value::as_str)
                {
                    if !Path::new(f).is_file() {
                        let problem = format!(
                            "{f} (manifest line {}) is missing: run shard {} again",
                            entry.line,
                            parts
                                .sidecars
                                .iter()
                                .find(|s| s.items.contains(&items.start))
                                .map_or(0, |s| s.shard.index)
                        );
                        return Err(Error::file(&parts.output, "", problem));
                    }
                }
                reports.push(report);
            }
            reports
        }
    };
    Ok(json!({ "method": "bake", "manifest": manifest.display().to_string(), "assets": reports }))
}

/// One entry baked: its files refused where they are inputs, then `bake`.
fn bake_entry(e: &Entry) -> Result<Value> {
    crate::files::of(&e.command).check()?;
    let mut report = crate::bake::run(e.args())?;
    report["line"] = json!(e.line);
    report["mesh"] = json!(e.asset.display().to_string());
    Ok(report)
}
