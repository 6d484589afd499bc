//! `--shard I/N|auto` and `penumbra merge` (`penumbra::io::shard` holds the
//! part files): a shard computes its items into `P.part-I-of-N`; `merge`
//! runs the parts' command again with the items read from the parts, so the
//! command's own writer writes `P` and its report as one process does.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use serde_json::{Value, json};

use penumbra::error::{Error, Result};
use penumbra::io::shard::{InputFile, Job, PartWriter, Parts, Shard};

/// `--shard`, flattened into every command whose work splits into items.
#[derive(clap::Args, Default, Clone)]
pub struct ShardArgs {
    /// Compute only shard I of N (0-based: 0/4 .. 3/4) of this job's items into OUTPUT.part-I-of-N, then `penumbra merge OUTPUT`; 'auto' takes I and N from Slurm (SLURM_ARRAY_TASK_ID, SLURM_ARRAY_TASK_COUNT), 'auto/N' takes I from Kubernetes (JOB_COMPLETION_INDEX) or Slurm.
    #[arg(long, value_name = "I/N|auto|auto/N")]
    pub shard: Option<String>,
    /// Set by `penumbra merge`: the items come from these parts.
    #[arg(skip)]
    pub merging: Option<Arc<Parts>>,
}

/// How a command runs its items.
pub enum Mode {
    /// All of them, as one process.
    Whole,
    /// One shard's, into a part.
    Part(Shard),
    /// None: they are read from the parts, and the outputs written whole.
    Merge(Arc<Parts>),
}

impl ShardArgs {
    pub fn mode(&self) -> Result<Mode> {
        if let Some(parts) = &self.merging {
            return Ok(Mode::Merge(parts.clone()));
        }
        match self.shard.as_deref() {
            None => Ok(Mode::Whole),
            Some(text) => Ok(Mode::Part(parse(text, &|name| std::env::var(name).ok())?)),
        }
    }
}

/// Kubernetes' index of an Indexed Job's pod.
const K8S_INDEX: &str = "JOB_COMPLETION_INDEX";
/// Slurm's array task id, its lowest and the task count.
const SLURM_ID: &str = "SLURM_ARRAY_TASK_ID";
const SLURM_MIN: &str = "SLURM_ARRAY_TASK_MIN";
const SLURM_COUNT: &str = "SLURM_ARRAY_TASK_COUNT";

/// `I/N`, `auto` or `auto/N`, the environment read through `var`.
pub fn parse(text: &str, var: &dyn Fn(&str) -> Option<String>) -> Result<Shard> {
    let option = "--shard";
    let Some(rest) = text.strip_prefix("auto") else {
        return Shard::parse(text, option);
    };
    let count: Option<u32> = match rest.strip_prefix('/') {
        Some(n) => Some(
            n.trim()
                .parse()
                .map_err(|_| Error::param(option, format!("expected auto/N with N a shard count, got '{text}'")))?,
        ),
        None if rest.is_empty() => None,
        None => {
            return Err(Error::param(
                option,
                format!("expected I/N, auto or auto/N, got '{text}'"),
            ));
        }
    };
    let number = |name: &str| -> Result<Option<u32>> {
        match var(name) {
            None => Ok(None),
            Some(v) => v
                .trim()
                .parse()
                .map(Some)
                .map_err(|_| Error::param(option, format!("{name}={v} is not a whole number"))),
        }
    };
    if let Some(id) = number(SLURM_ID)? {
        let min = number(SLURM_MIN)?.unwrap_or(0);
        let slurm_count = number(SLURM_COUNT)?;
        let n = count.or(slurm_count).ok_or_else(|| {
            Error::param(
                option,
                format!("{SLURM_ID} is set but {SLURM_COUNT} is not: give --shard auto/N"),
            )
        })?;
        let index = id
            .checked_sub(min)
            .ok_or_else(|| Error::param(option, format!("{SLURM_ID}={id} is below {SLURM_MIN}={min}")))?;
        return Shard::new(index, n, option);
    }
    if let Some(index) = number(K8S_INDEX)? {
        let n = count.ok_or_else(|| {
            Error::param(
                option,
                format!("{K8S_INDEX} gives the index but Kubernetes does not give the count: write --shard auto/N, N the Job's completions"),
            )
        })?;
        return Shard::new(index, n, option);
    }
    Err(Error::param(
        option,
        format!(
            "auto needs {K8S_INDEX} (a Kubernetes Indexed Job) or {SLURM_ID} and {SLURM_COUNT} (a Slurm job array); neither is set"
        ),
    ))
}

/// The command line and inputs of this run, which identify its job.
#[derive(Default)]
struct Invocation {
    args: Vec<String>,
    inputs: Vec<PathBuf>,
}

static INVOCATION: Mutex<Option<Invocation>> = Mutex::new(None);

/// Records the command line (program name first) and the files it reads.
pub fn record_invocation(args: &[String], inputs: Vec<PathBuf>) {
    *INVOCATION.lock().expect("not poisoned") = Some(Invocation {
        args: args.to_vec(),
        inputs,
    });
}

/// The command line of this run, program name first.
pub fn invocation_args() -> Vec<String> {
    let guard = INVOCATION.lock().expect("not poisoned");
    guard.as_ref().map(|i| i.args.clone()).unwrap_or_default()
}

/// The arguments that make the job: the subcommand and its options, without
/// those that change how it runs but not what it computes.
fn job_command(args: &[String]) -> Vec<String> {
    let mut out = Vec::new();
    let mut skip_value = false;
    for a in args.iter().skip(1) {
        if skip_value {
            skip_value = false;
            continue;
        }
        if ["--shard", "--threads"].contains(&a.as_str()) {
            skip_value = true;
            continue;
        }
        if a.starts_with("--shard=") || a.starts_with("--threads=") || a == "--json" || a == "--progress" {
            continue;
        }
        out.push(a.clone());
    }
    out
}

/// The program and its version.
fn program() -> String {
    format!("penumbra {}", env!("CARGO_PKG_VERSION"))
}

/// Opens `shard`'s part of `output`, a job of `total` items.
pub fn open_part(output: &Path, shard: Shard, total: usize) -> Result<PartWriter> {
    let (command, paths) = {
        let guard = INVOCATION.lock().expect("not poisoned");
        let inv = guard.as_ref().expect("recorded before any command runs");
        (job_command(&inv.args), inv.inputs.clone())
    };
    let mut inputs = Vec::new();
    for p in &paths {
        if p.is_file() {
            inputs.push(InputFile::of(p)?);
        }
    }
    let job = Job {
        program: program(),
        command,
        total_items: total,
        inputs,
    };
    let writer = PartWriter::open(output, shard, job)?;
    let kept = writer.kept();
    if kept > 0 {
        crate::io::note(&format!(
            "shard {shard}: {kept} of its {} items kept from a run cut short",
            writer.items().len()
        ));
    }
    Ok(writer)
}

/// Finishes a part: the sidecar gets `report`; the command prints what the
/// shard did.
pub fn finish_part(writer: PartWriter, report: Value) -> Result<Value> {
    let kept = writer.kept();
    let shard = writer.shard();
    let items = writer.items();
    let seconds = writer.seconds();
    let part = writer.finish(report.clone())?;
    let mut out = report;
    out["shard"] = json!({
        "index": shard.index,
        "count": shard.count,
        "items": [items.start, items.end],
        "items_kept": kept,
        "items_computed": items.len() - kept,
        "part": part.display().to_string(),
        "seconds": seconds,
    });
    Ok(out)
}

/// The records of a job whose items are `frames` frames, each written by
/// its shard under its own name (`path(f)`): an error where the parts
/// hold another frame count or a recorded frame's file is missing.
pub fn frame_records(
    parts: &Parts,
    out: &Path,
    frames: usize,
    path: impl Fn(usize) -> PathBuf,
) -> Result<Vec<(std::ops::Range<usize>, Vec<u8>)>> {
    if parts.total_items() != frames {
        let problem = format!("the parts hold {} frames, the command {frames}", parts.total_items());
        return Err(Error::file(out, "", problem));
    }
    let records = parts.records()?;
    for f in 0..frames {
        let file = path(f);
        if !file.is_file() {
            return Err(missing_frame(parts, out, &file, f));
        }
    }
    Ok(records)
}

/// Frame `f`'s file `path` is missing though a part of `out` records it:
/// the error names the frame, the file and the shard to run again.
fn missing_frame(parts: &Parts, out: &Path, path: &Path, f: usize) -> Error {
    let side = parts.sidecars.iter().find(|s| s.items.contains(&f));
    let shard = side.map_or_else(|| "?".into(), |s| s.shard.to_string());
    let problem = format!(
        "frame {f} is missing, though shard {shard}'s part records it: remove that shard's part \
         ({}.part-{}) and its .json, run the shard again, then merge",
        out.display(),
        shard.replace('/', "-of-")
    );
    Error::file(path, "", problem)
}

/// What `merge` adds to the command's report: each shard's items and time.
pub fn merge_report(parts: &Parts) -> Value {
    let shards: Vec<Value> = parts
        .sidecars
        .iter()
        .map(|s| json!({ "index": s.shard.index, "items": [s.items.start, s.items.end], "seconds": s.seconds }))
        .collect();
    json!({ "parts": parts.sidecars.len(), "items": parts.total_items(), "shards": shards })
}

/// Checks that the parts were written by this program.
pub fn check_program(parts: &Parts) -> Result<()> {
    let first = &parts.sidecars[0];
    if first.program != program() {
        let problem = format!("its parts were written by {}, this is {}", first.program, program());
        return Err(Error::file(&parts.output, "", problem));
    }
    Ok(())
}

/// Refuses `--shard` with more than one output, naming them.
pub fn one_output(outputs: &[(&str, bool)]) -> Result<()> {
    let given: Vec<&str> = outputs.iter().filter(|(_, g)| *g).map(|(o, _)| *o).collect();
    if given.len() > 1 {
        let problem = format!("splits one output at a time; give only one of {}", given.join(", "));
        return Err(Error::param("--shard", problem));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env(pairs: &[(&str, &str)]) -> impl Fn(&str) -> Option<String> {
        let pairs: Vec<(String, String)> = pairs.iter().map(|(a, b)| (a.to_string(), b.to_string())).collect();
        move |name| pairs.iter().find(|(k, _)| k == name).map(|(_, v)| v.clone())
    }

    #[test]
    fn auto_reads_slurm_and_kubernetes() {
        let s = parse("auto", &env(&[(SLURM_ID, "5"), (SLURM_MIN, "4"), (SLURM_COUNT, "3")])).unwrap();
        assert_eq!((s.index, s.count), (1, 3));
        let s = parse("auto/4", &env(&[(K8S_INDEX, "3")])).unwrap();
        assert_eq!((s.index, s.count), (3, 4));
        let e = parse("auto", &env(&[(K8S_INDEX, "3")])).unwrap_err().to_string();
        assert!(e.contains("auto/N"), "{e}");
        let e = parse("auto", &env(&[])).unwrap_err().to_string();
        assert!(e.contains(K8S_INDEX) && e.contains(SLURM_ID), "{e}");
        let e = parse("auto/4", &env(&[(K8S_INDEX, "4")])).unwrap_err().to_string();
        assert!(e.contains("4 of 4"), "{e}");
    }

    #[test]
    fn the_job_leaves_out_how_it_runs() {
        let args: Vec<String> = "penumbra ao --mesh m.obj --shard 1/4 --threads 2 --json --per-vertex o.csv"
            .split(' ')
            .map(String::from)
            .collect();
        assert_eq!(job_command(&args), ["ao", "--mesh", "m.obj", "--per-vertex", "o.csv"]);
    }
}
