//! One long job split into `N` shards run anywhere (a Kubernetes Indexed
//! Job, a Slurm array, a CI matrix, GNU parallel), then merged into what a
//! single process writes.
//!
//! A job is a list of independent items (vertices, texel rows, frames,
//! settings of a sweep). Shard `I` of `N` takes the contiguous range
//! `[⌊n I / N⌋, ⌊n (I + 1) / N⌋)` of the `n` items ([`Shard::range`]), a
//! rule that depends on `n`, `I` and `N` only. Every item's random numbers
//! depend on the item alone (its sample stream is its index), so an item
//! gives the same bits whichever shard computes it.
//!
//! A shard writes the results of its items into a part file,
//! `P.part-I-of-N` beside the output `P` ([`part_path`]), through a
//! [`PartWriter`]:
//! - results are appended to `P.part-I-of-N.partial` in records, one per
//!   finished piece of work, each synced to disk before the next begins;
//! - a shard run again after it was killed reads the records that are
//!   whole, and computes only the items they lack;
//! - [`PartWriter::finish`] renames the partial file to the part, then
//!   writes the sidecar `P.part-I-of-N.json` ([`Sidecar`]: the items, the
//!   command, the inputs' sizes and CRC-32s, the program's version, the
//!   shard's report). A part without its sidecar is unfinished.
//!
//! [`Parts::find`] reads the sidecars of every shard of `P` and refuses a
//! missing shard, shards of another `N`, another command or other inputs;
//! [`Parts::records`] gives every item's result once, in item order, for
//! the command's own writer to write `P` as one process would.

use std::io::{Read, Write};
use std::ops::Range;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// Shard `index` of `count` (0-based: `0/4` to `3/4`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    /// Which shard, `0..count`.
    pub index: u32,
    /// How many shards the job is split into, at least 1.
    pub count: u32,
}

impl Shard {
    /// Shard `index` of `count`; an error naming `option` unless
    /// `index < count`.
    pub fn new(index: u32, count: u32, option: &str) -> Result<Shard> {
        if count == 0 || index >= count {
            let problem = format!("shard {index} of {count}: the index must be in 0..{count} and the count at least 1");
            return Err(Error::param(option, problem));
        }
        Ok(Shard { index, count })
    }

    /// `I/N` as typed, e.g. `2/4`; an error naming `option`.
    pub fn parse(text: &str, option: &str) -> Result<Shard> {
        let bad = || Error::param(option, format!("expected I/N with 0 <= I < N (e.g. 0/4), got '{text}'"));
        let (i, n) = text.split_once('/').ok_or_else(bad)?;
        let i: u32 = i.trim().parse().map_err(|_| bad())?;
        let n: u32 = n.trim().parse().map_err(|_| bad())?;
        Shard::new(i, n, option)
    }

    /// This shard's items of `n`: a contiguous range, the ranges of the
    /// `count` shards in order covering `0..n` once.
    pub fn range(&self, n: usize) -> Range<usize> {
        let at = |i: u32| ((n as u128 * i as u128) / self.count as u128) as usize;
        at(self.index)..at(self.index + 1)
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// `P.part-I-of-N`, the part of `output` that `shard` writes.
pub fn part_path(output: &Path, shard: Shard) -> PathBuf {
    suffixed(output, &format!(".part-{}-of-{}", shard.index, shard.count))
}

/// `P.part-I-of-N.json`, the part's sidecar.
pub fn sidecar_path(output: &Path, shard: Shard) -> PathBuf {
    suffixed(&part_path(output, shard), ".json")
}

/// `P.part-I-of-N.partial`, the part being written.
fn partial_path(output: &Path, shard: Shard) -> PathBuf {
    suffixed(&part_path(output, shard), ".partial")
}

fn suffixed(path: &Path, suffix: &str) -> PathBuf {
    let mut name = path.as_os_str().to_owned();
    name.push(suffix);
    PathBuf::from(name)
}

/// An input file as a shard read it: merging parts that read different
/// files is refused.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct InputFile {
    /// The path as the command named it.
    pub path: String,
    /// Its size in bytes.
    pub bytes: u64,
    /// CRC-32 (IEEE) of its bytes, in hex: a check that the file did not
    /// change between shards, not a cryptographic hash.
    pub crc32: String,
}

impl InputFile {
    /// Reads `path` whole for its size and checksum.
    pub fn of(path: &Path) -> Result<InputFile> {
        let mut file = std::fs::File::open(path).map_err(|e| Error::file(path, "", format!("cannot open: {e}")))?;
        let mut hasher = crc32fast::Hasher::new();
        let mut buf = vec![0u8; 1 << 20];
        let mut bytes = 0u64;
        loop {
            let n = file
                .read(&mut buf)
                .map_err(|e| Error::file(path, "", format!("cannot read: {e}")))?;
            if n == 0 {
                break;
            }
            hasher.update(&buf[..n]);
            bytes += n as u64;
        }
        Ok(InputFile {
            path: path.display().to_string(),
            bytes,
            crc32: format!("{:08x}", hasher.finalize()),
        })
    }
}

/// What a part is: written beside it as `P.part-I-of-N.json` once the part
/// is complete.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Sidecar {
    /// The program and its version, e.g. `penumbra 0.1.0`.
    pub program: String,
    /// The command's arguments, `--shard` left out: the same for every
    /// shard of one job.
    pub command: Vec<String>,
    /// Which shard this is.
    pub shard: Shard,
    /// How many items the whole job has.
    pub total_items: usize,
    /// This shard's items, `[first, end)`.
    pub items: Range<usize>,
    /// Every file the command read.
    pub inputs: Vec<InputFile>,
    /// Seconds the shard ran (this run and the runs before it that were
    /// cut short, whose records it kept).
    pub seconds: f64,
    /// The shard's own report (the command's JSON for its items).
    pub report: serde_json::Value,
}

/// What identifies a job: shards of one job agree on all of it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Job {
    /// See [`Sidecar::program`].
    pub program: String,
    /// See [`Sidecar::command`].
    pub command: Vec<String>,
    /// See [`Sidecar::total_items`].
    pub total_items: usize,
    /// See [`Sidecar::inputs`].
    pub inputs: Vec<InputFile>,
}

/// Records read back: each one's items and payload.
type Records = Vec<(Range<usize>, Vec<u8>)>;

/// Magic line of a partial file; the job's JSON follows on the next line.
const PARTIAL_MAGIC: &[u8] = b"penumbra part 1\n";

/// A shard's part being written: the records of a run cut short are kept
/// and their items not computed again.
pub struct PartWriter {
    output: PathBuf,
    shard: Shard,
    job: Job,
    file: std::fs::File,
    done: Vec<(Range<usize>, Vec<u8>)>,
    kept: usize,
    seconds_before: f64,
    started: std::time::Instant,
}

impl PartWriter {
    /// Opens shard `shard`'s part of `output` for `job`. A part already
    /// complete for the same job is opened with every item done; a partial
    /// part of the same job keeps its whole records; one of another job
    /// (other options or inputs) is started afresh.
    pub fn open(output: &Path, shard: Shard, job: Job) -> Result<PartWriter> {
        let partial = partial_path(output, shard);
        let part = part_path(output, shard);
        let sidecar = sidecar_path(output, shard);
        // A finished part of this job: reopen it as a partial with all its
        // records, so `finish` writes the same part and sidecar again.
        if let Ok(side) = read_sidecar(&sidecar)
            && job_of(&side) == job
            && part.is_file()
        {
            std::fs::rename(&part, &partial).map_err(|e| Error::write(&partial, e))?;
            let _ = std::fs::remove_file(&sidecar);
        }
        let (done, seconds_before) = match std::fs::read(&partial) {
            Ok(bytes) => read_partial(&bytes, &job).unwrap_or_default(),
            Err(_) => Default::default(),
        };
        // Rewrite the partial with only its whole records: a record cut
        // short by a kill is dropped here, once.
        let mut file = std::fs::File::create(&partial).map_err(|e| Error::write(&partial, e))?;
        let head = header(&job)?;
        file.write_all(&head).map_err(|e| Error::write(&partial, e))?;
        for (items, payload) in &done {
            file.write_all(&record(items, payload, 0.0))
                .map_err(|e| Error::write(&partial, e))?;
        }
        if seconds_before > 0.0 {
            file.write_all(&record(&(0..0), &[], seconds_before))
                .map_err(|e| Error::write(&partial, e))?;
        }
        file.sync_data().map_err(|e| Error::write(&partial, e))?;
        Ok(PartWriter {
            output: output.to_path_buf(),
            shard,
            job,
            file,
            kept: done.iter().map(|(r, _)| r.len()).sum(),
            done,
            seconds_before,
            started: std::time::Instant::now(),
        })
    }

    /// The shard.
    pub fn shard(&self) -> Shard {
        self.shard
    }

    /// This shard's items.
    pub fn items(&self) -> Range<usize> {
        self.shard.range(self.job.total_items)
    }

    /// Items whose records were kept from runs before this one.
    pub fn kept(&self) -> usize {
        self.kept
    }

    /// The records kept from runs before this one.
    pub fn done(&self) -> &[(Range<usize>, Vec<u8>)] {
        &self.done
    }

    /// This shard's items in pieces of at most `piece` items, without the
    /// pieces a record already holds.
    pub fn todo(&self, piece: usize) -> Vec<Range<usize>> {
        let range = self.items();
        let piece = piece.max(1);
        self.left(
            (range.start..range.end)
                .step_by(piece)
                .map(|s| s..(s + piece).min(range.end)),
        )
    }

    /// `pieces` (the command's own partition of the job's items) cut to
    /// this shard's items, without the pieces a record already holds.
    pub fn left(&self, pieces: impl IntoIterator<Item = Range<usize>>) -> Vec<Range<usize>> {
        let range = self.items();
        pieces
            .into_iter()
            .map(|p| p.start.max(range.start)..p.end.min(range.end))
            .filter(|p| !p.is_empty() && !self.done.iter().any(|(r, _)| r == p))
            .collect()
    }

    /// Appends the result of `items` and syncs it to disk.
    pub fn record(&mut self, items: Range<usize>, payload: &[u8]) -> Result<()> {
        let partial = partial_path(&self.output, self.shard);
        let elapsed = self.seconds_before + self.started.elapsed().as_secs_f64();
        self.file
            .write_all(&record(&items, payload, elapsed))
            .and_then(|()| self.file.sync_data())
            .map_err(|e| Error::write(&partial, e))?;
        self.done.push((items, payload.to_vec()));
        Ok(())
    }

    /// Every record, this run's and the kept ones, in item order.
    pub fn records(&self) -> Vec<(Range<usize>, &[u8])> {
        let mut all: Vec<_> = self.done.iter().map(|(r, p)| (r.clone(), p.as_slice())).collect();
        all.sort_by_key(|(r, _)| r.start);
        all
    }

    /// Seconds this shard has run, runs cut short included.
    pub fn seconds(&self) -> f64 {
        self.seconds_before + self.started.elapsed().as_secs_f64()
    }

    /// Checks that every item of the shard has its record, renames the
    /// partial to `P.part-I-of-N` and writes the sidecar with `report`.
    /// Returns the part's path.
    pub fn finish(self, report: serde_json::Value) -> Result<PathBuf> {
        let covered = coverage(self.records().iter().map(|(r, _)| r.clone()), self.items());
        if let Err(problem) = covered {
            return Err(Error::internal(format!("shard {}: {problem}", self.shard)));
        }
        let partial = partial_path(&self.output, self.shard);
        let part = part_path(&self.output, self.shard);
        let seconds = self.seconds();
        drop(self.file);
        std::fs::rename(&partial, &part).map_err(|e| Error::write(&part, e))?;
        let sidecar = Sidecar {
            program: self.job.program.clone(),
            command: self.job.command.clone(),
            shard: self.shard,
            total_items: self.job.total_items,
            items: self.shard.range(self.job.total_items),
            inputs: self.job.inputs.clone(),
            seconds,
            report,
        };
        let text = serde_json::to_string_pretty(&sidecar).map_err(|e| Error::internal(e.to_string()))?;
        crate::io::output::write_bytes(&sidecar_path(&self.output, self.shard), text.as_bytes())?;
        Ok(part)
    }
}

fn job_of(s: &Sidecar) -> Job {
    Job {
        program: s.program.clone(),
        command: s.command.clone(),
        total_items: s.total_items,
        inputs: s.inputs.clone(),
    }
}

fn header(job: &Job) -> Result<Vec<u8>> {
    let mut head = PARTIAL_MAGIC.to_vec();
    let json = serde_json::to_string(job).map_err(|e| Error::internal(e.to_string()))?;
    head.extend_from_slice(json.as_bytes());
    head.push(b'\n');
    Ok(head)
}

/// A record: first item, item count, seconds so far, payload length (u64,
/// u64, f64, u64 little-endian), the payload, and the CRC-32 of all that.
fn record(items: &Range<usize>, payload: &[u8], seconds: f64) -> Vec<u8> {
    let mut r = Vec::with_capacity(36 + payload.len());
    r.extend_from_slice(&(items.start as u64).to_le_bytes());
    r.extend_from_slice(&(items.len() as u64).to_le_bytes());
    r.extend_from_slice(&seconds.to_le_bytes());
    r.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    r.extend_from_slice(payload);
    let crc = crc32fast::hash(&r);
    r.extend_from_slice(&crc.to_le_bytes());
    r
}

/// The whole records of a partial or part file written for `job` (none if
/// it was written for another), and the seconds its runs took.
fn read_partial(bytes: &[u8], job: &Job) -> Option<(Records, f64)> {
    let rest = bytes.strip_prefix(PARTIAL_MAGIC)?;
    let line = rest.iter().position(|&b| b == b'\n')?;
    let written: Job = serde_json::from_slice(&rest[..line]).ok()?;
    if written != *job {
        return None;
    }
    let (records, seconds) = read_records(&rest[line + 1..]);
    Some((records.into_iter().filter(|(r, _)| !r.is_empty()).collect(), seconds))
}

/// Records up to the first that is cut short or corrupt.
fn read_records(mut bytes: &[u8]) -> (Records, f64) {
    let mut records = Vec::new();
    let mut seconds = 0.0f64;
    let u64_at = |b: &[u8], at: usize| u64::from_le_bytes(b[at..at + 8].try_into().expect("8 bytes"));
    while bytes.len() >= 36 {
        let start = u64_at(bytes, 0) as usize;
        let count = u64_at(bytes, 8) as usize;
        let secs = f64::from_le_bytes(bytes[16..24].try_into().expect("8 bytes"));
        let len = u64_at(bytes, 24) as usize;
        let Some(end) = 32usize.checked_add(len).filter(|&e| e + 4 <= bytes.len()) else {
            break;
        };
        let crc = u32::from_le_bytes(bytes[end..end + 4].try_into().expect("4 bytes"));
        if crc32fast::hash(&bytes[..end]) != crc {
            break;
        }
        records.push((start..start + count, bytes[32..end].to_vec()));
        seconds = seconds.max(secs);
        bytes = &bytes[end + 4..];
    }
    (records, seconds)
}

/// Whether `ranges` cover `want` exactly once.
fn coverage(ranges: impl Iterator<Item = Range<usize>>, want: Range<usize>) -> std::result::Result<(), String> {
    let mut ranges: Vec<_> = ranges.collect();
    ranges.sort_by_key(|r| r.start);
    let mut next = want.start;
    for r in ranges {
        if r.start > next {
            return Err(format!("items {next}..{} are missing", r.start));
        }
        if r.start < next {
            return Err(format!("items {}..{} appear twice", r.start, next.min(r.end)));
        }
        next = r.end;
    }
    if next != want.end {
        return Err(format!("items {next}..{} are missing", want.end));
    }
    Ok(())
}

/// The complete parts of one output, checked to be one job's.
#[derive(Debug, Clone)]
pub struct Parts {
    /// The output they are parts of.
    pub output: PathBuf,
    /// Every shard's sidecar, in shard order.
    pub sidecars: Vec<Sidecar>,
}

impl Parts {
    /// The sidecars of `output`'s parts (`P.part-*-of-N.json`): an error
    /// naming the problem where none is found, where shards of different
    /// `N` are present, a shard is missing, or two shards differ in
    /// program, command, item count or inputs.
    pub fn find(output: &Path) -> Result<Parts> {
        let dir = match output.parent().filter(|p| !p.as_os_str().is_empty()) {
            Some(d) => d.to_path_buf(),
            None => PathBuf::from("."),
        };
        let name = output
            .file_name()
            .ok_or_else(|| Error::file(output, "", "is not a file name"))?
            .to_string_lossy()
            .into_owned();
        let entries = std::fs::read_dir(&dir).map_err(|e| Error::file(&dir, "", format!("cannot list: {e}")))?;
        let prefix = format!("{name}.part-");
        let mut found: Vec<(Shard, PathBuf)> = Vec::new();
        let mut unfinished = Vec::new();
        for entry in entries.flatten() {
            let file = entry.file_name().to_string_lossy().into_owned();
            let Some(rest) = file.strip_prefix(&prefix) else {
                continue;
            };
            let (shard, tail) = match parse_part_name(rest) {
                Some(p) => p,
                None => continue,
            };
            match tail {
                ".json" => found.push((shard, dir.join(&file))),
                ".partial" => unfinished.push(shard),
                _ => {}
            }
        }
        if found.is_empty() {
            let problem = match unfinished.is_empty() {
                true => format!("no parts found ({name}.part-I-of-N.json in {})", dir.display()),
                false => format!("no finished parts; shard {} is still being written", unfinished[0]),
            };
            return Err(Error::file(output, "", problem));
        }
        let mut counts: Vec<u32> = found.iter().map(|(s, _)| s.count).collect();
        counts.sort_unstable();
        counts.dedup();
        if counts.len() > 1 {
            let counts: Vec<String> = counts.iter().map(u32::to_string).collect();
            let problem = format!(
                "parts of different shard counts are present (N = {}); remove those of the other runs",
                counts.join(", ")
            );
            return Err(Error::file(output, "", problem));
        }
        let count = counts[0];
        found.sort_by_key(|(s, _)| s.index);
        let missing: Vec<String> = (0..count)
            .filter(|i| !found.iter().any(|(s, _)| s.index == *i))
            .map(|i| match unfinished.iter().any(|s| s.index == i && s.count == count) {
                true => format!("{i} (unfinished)"),
                false => i.to_string(),
            })
            .collect();
        if !missing.is_empty() {
            let problem = format!(
                "shard(s) {} of {count} missing: run them, then merge",
                missing.join(", ")
            );
            return Err(Error::file(output, "", problem));
        }
        let mut sidecars = Vec::new();
        for (shard, path) in &found {
            let side = read_sidecar(path)?;
            if side.shard != *shard {
                return Err(Error::file(
                    path,
                    "shard",
                    format!("says {}, its name {shard}", side.shard),
                ));
            }
            if !part_path(output, *shard).is_file() {
                return Err(Error::file(
                    path,
                    "",
                    format!("its part {} is missing", part_path(output, *shard).display()),
                ));
            }
            sidecars.push(side);
        }
        let first = &sidecars[0];
        for s in &sidecars[1..] {
            let differs = |what: &str, a: &dyn std::fmt::Debug, b: &dyn std::fmt::Debug| {
                let problem = format!(
                    "shards 0 and {} are of different jobs: {what} {:?} against {:?}",
                    s.shard.index, a, b
                );
                Err(Error::file(output, "", problem))
            };
            if s.program != first.program {
                return differs("program", &first.program, &s.program);
            }
            if s.command != first.command {
                return differs("command", &first.command.join(" "), &s.command.join(" "));
            }
            if s.total_items != first.total_items {
                return differs("item count", &first.total_items, &s.total_items);
            }
            if s.inputs != first.inputs {
                let changed = first
                    .inputs
                    .iter()
                    .zip(&s.inputs)
                    .find(|(a, b)| a != b)
                    .map(|(a, b)| {
                        format!(
                            "{} ({} bytes, crc {} against {} bytes, crc {})",
                            a.path, a.bytes, a.crc32, b.bytes, b.crc32
                        )
                    })
                    .unwrap_or_else(|| "the list of files".into());
                return differs("input", &changed, &"");
            }
        }
        Ok(Parts {
            output: output.to_path_buf(),
            sidecars,
        })
    }

    /// The job's command (`--shard` left out).
    pub fn command(&self) -> &[String] {
        &self.sidecars[0].command
    }

    /// How many items the job has.
    pub fn total_items(&self) -> usize {
        self.sidecars[0].total_items
    }

    /// Every item's record from every part, in item order, each item once;
    /// an error naming the part that is corrupt or short.
    pub fn records(&self) -> Result<Vec<(Range<usize>, Vec<u8>)>> {
        let mut all = Vec::new();
        for side in &self.sidecars {
            let part = part_path(&self.output, side.shard);
            let bytes = std::fs::read(&part).map_err(|e| Error::file(&part, "", format!("cannot read: {e}")))?;
            let job = job_of(side);
            let (records, _) = read_partial(&bytes, &job)
                .ok_or_else(|| Error::file(&part, "", "is not a part of the job its sidecar names"))?;
            coverage(records.iter().map(|(r, _)| r.clone()), side.items.clone())
                .map_err(|problem| Error::file(&part, "", problem))?;
            all.extend(records);
        }
        all.sort_by_key(|(r, _)| r.start);
        coverage(all.iter().map(|(r, _)| r.clone()), 0..self.total_items())
            .map_err(|problem| Error::file(&self.output, "", problem))?;
        Ok(all)
    }

    /// Every shard's seconds, in shard order.
    pub fn seconds(&self) -> Vec<f64> {
        self.sidecars.iter().map(|s| s.seconds).collect()
    }
}

/// `I-of-N` and what follows it in a part's file name.
fn parse_part_name(rest: &str) -> Option<(Shard, &str)> {
    let (i, rest) = rest.split_once("-of-")?;
    let digits = rest.find(|c: char| !c.is_ascii_digit()).unwrap_or(rest.len());
    let (n, tail) = rest.split_at(digits);
    let shard = Shard {
        index: i.parse().ok()?,
        count: n.parse().ok()?,
    };
    (shard.index < shard.count).then_some((shard, tail))
}

fn read_sidecar(path: &Path) -> Result<Sidecar> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::file(path, "", format!("cannot read: {e}")))?;
    serde_json::from_str(&text).map_err(|e| Error::file(path, "", format!("not a part's sidecar: {e}")))
}

/// `values` as little-endian bytes, for a record.
pub fn f32_bytes(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

/// The values of `f32_bytes`; an error naming `what` for a length that is
/// not a whole number of values.
pub fn f32s(bytes: &[u8], what: &Path) -> Result<Vec<f32>> {
    if !bytes.len().is_multiple_of(4) {
        return Err(Error::file(what, "", "a record is not a whole number of values"));
    }
    Ok(bytes
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes(b.try_into().expect("4 bytes")))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn job(command: &str) -> Job {
        Job {
            program: "penumbra test".into(),
            command: command.split(' ').map(String::from).collect(),
            total_items: 10,
            inputs: vec![],
        }
    }

    #[test]
    fn ranges_cover_the_items_once_in_order() {
        for n in [0usize, 1, 5, 10, 1001] {
            for count in 1..=7 {
                let mut next = 0;
                for index in 0..count {
                    let r = Shard { index, count }.range(n);
                    assert_eq!(r.start, next);
                    next = r.end;
                }
                assert_eq!(next, n);
            }
        }
    }

    #[test]
    fn parses_and_refuses() {
        assert_eq!(Shard::parse("2/4", "--shard").unwrap(), Shard { index: 2, count: 4 });
        for bad in ["4/4", "0/0", "-1/4", "1", "a/b", "1/4/2"] {
            assert!(Shard::parse(bad, "--shard").is_err(), "{bad}");
        }
    }

    #[test]
    fn a_killed_part_keeps_its_whole_records_and_merges() {
        let dir = std::env::temp_dir().join(format!("penumbra-shard-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let out = dir.join("ao.csv");
        for index in 0..2 {
            let shard = Shard { index, count: 2 };
            let mut w = PartWriter::open(&out, shard, job("ao x")).unwrap();
            for piece in w.todo(2) {
                let values: Vec<f32> = piece.clone().map(|i| i as f32).collect();
                w.record(piece, &f32_bytes(&values)).unwrap();
            }
            if index == 1 {
                // Cut the last record short, as a kill mid-write would.
                drop(w);
                let partial = partial_path(&out, shard);
                let bytes = std::fs::read(&partial).unwrap();
                std::fs::write(&partial, &bytes[..bytes.len() - 3]).unwrap();
                let w = PartWriter::open(&out, shard, job("ao x")).unwrap();
                assert_eq!(w.done().len(), 2, "two whole records kept");
                assert_eq!(w.todo(2), vec![9..10]);
                let mut w = w;
                w.record(9..10, &f32_bytes(&[9.0])).unwrap();
                w.finish(serde_json::json!({})).unwrap();
            } else {
                w.finish(serde_json::json!({})).unwrap();
            }
        }
        let parts = Parts::find(&out).unwrap();
        let values: Vec<f32> = parts
            .records()
            .unwrap()
            .iter()
            .flat_map(|(_, b)| f32s(b, &out).unwrap())
            .collect();
        assert_eq!(values, (0..10).map(|i| i as f32).collect::<Vec<_>>());
        // Another job's shard beside them is refused.
        let other = Shard { index: 1, count: 2 };
        std::fs::remove_file(sidecar_path(&out, other)).unwrap();
        let mut w = PartWriter::open(&out, other, job("ao y")).unwrap();
        assert!(w.done().is_empty(), "another job's records are not kept");
        for piece in w.todo(5) {
            w.record(piece.clone(), &f32_bytes(&vec![0.0; piece.len()])).unwrap();
        }
        w.finish(serde_json::json!({})).unwrap();
        let e = Parts::find(&out).unwrap_err().to_string();
        assert!(e.contains("different jobs") && e.contains("command"), "{e}");
        std::fs::remove_file(sidecar_path(&out, other)).unwrap();
        let e = Parts::find(&out).unwrap_err().to_string();
        assert!(e.contains("shard(s) 1 of 2 missing"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
