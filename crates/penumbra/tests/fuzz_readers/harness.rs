//! The driver: budgets and their accounting, each case isolated on a thread
//! of its own with a timeout, the fixed configuration, failures saved and
//! previewed, the checks every reader's errors pass, and the replay of seeds
//! and regressions.

use std::collections::BTreeMap;
use std::fmt::Debug;
use std::panic::{self, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use glam::Vec3;
use penumbra::Error;
use proptest::strategy::Strategy;
use proptest::test_runner::{Config, RngAlgorithm, RngSeed, TestCaseError, TestError, TestRunner};

use crate::allocation::{guard_this_thread, measured};

/// Allocation allowed to a reader: `factor` bytes per input byte plus
/// `constant`.
#[derive(Clone, Copy)]
pub struct Budget {
    factor: usize,
    constant: usize,
}

impl Budget {
    pub const fn new(factor: usize, constant: usize) -> Budget {
        Budget { factor, constant }
    }

    fn limit(self, len: usize) -> usize {
        self.factor * len + self.constant
    }
}

pub const KIB: usize = 1024;
pub const MIB: usize = 1024 * KIB;

/// What the runs measured, per reader call (printed after each test).
#[derive(Default)]
struct CallStats {
    calls: usize,
    ok: usize,
    worst_peak: usize,
    worst_peak_len: usize,
    /// Largest share of its budget a call used.
    worst_share: f64,
    /// Largest peak per input byte over inputs of 4 KiB or more.
    worst_per_byte: f64,
}

static STATS: Mutex<BTreeMap<&'static str, CallStats>> = Mutex::new(BTreeMap::new());

/// Reader calls and those that succeeded, by the name of the thread that
/// made them (`fuzz-<test>` for a fuzz test's cases): tests run at once
/// share `STATS`, so a generator's own share of valid inputs is kept here.
static BY_THREAD: Mutex<BTreeMap<String, (usize, usize)>> = Mutex::new(BTreeMap::new());

/// The least share of a generator's reader calls that must succeed: a
/// generator whose inputs nearly all fail at the first check exercises the
/// readers' error paths only, however many cases it runs. Measured
/// 2026-11-29: 15% (scene_mutated_seeds) to 65% (dfield_structured_headers).
pub const MIN_VALID_SHARE: f64 = 0.10;

/// Runs one reader call measured, records it, and checks its budget.
pub fn call<T>(
    name: &'static str,
    budget: Budget,
    len: usize,
    f: impl FnOnce() -> penumbra::Result<T>,
) -> Result<penumbra::Result<T>, String> {
    let (result, peak) = measured(f);
    let limit = budget.limit(len);
    if let (Some(thread), Ok(mut counts)) = (std::thread::current().name(), BY_THREAD.lock()) {
        let c = counts.entry(thread.to_string()).or_default();
        c.0 += 1;
        c.1 += usize::from(result.is_ok());
    }
    if let Ok(mut stats) = STATS.lock() {
        let s = stats.entry(name).or_default();
        s.calls += 1;
        s.ok += usize::from(result.is_ok());
        if peak > s.worst_peak {
            (s.worst_peak, s.worst_peak_len) = (peak, len);
        }
        s.worst_share = s.worst_share.max(peak as f64 / limit as f64);
        if len >= 4 * KIB {
            s.worst_per_byte = s.worst_per_byte.max(peak as f64 / len as f64);
        }
    }
    if peak > limit {
        return Err(format!(
            "{name} allocated {peak} bytes at its peak reading {len} bytes; the bound is {} x {len} + {} = {limit}",
            budget.factor, budget.constant
        ));
    }
    Ok(result)
}

fn print_stats(names: &[&str]) {
    let Ok(stats) = STATS.lock() else { return };
    for name in names {
        if let Some(s) = stats.get(name) {
            println!(
                "{name}: {} calls, {} ok; peak {} bytes (input {} bytes), at most {:.1}% of the budget, \
                 at most {:.1} bytes per input byte (inputs >= 4 KiB)",
                s.calls,
                s.ok,
                s.worst_peak,
                s.worst_peak_len,
                100.0 * s.worst_share,
                s.worst_per_byte
            );
        }
    }
}

const CASE_TIMEOUT: Duration = Duration::from_secs(5);

fn panic_text(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "a non-string panic payload".into())
}

/// Runs `body` on a thread of its own: a panic or no answer within
/// `CASE_TIMEOUT` is a failure.
fn isolated(name: &str, body: impl FnOnce() -> Result<(), String> + Send + 'static) -> Result<(), String> {
    let (tx, rx) = mpsc::channel();
    let spawned = std::thread::Builder::new()
        .name(format!("fuzz-{name}"))
        .spawn(move || {
            guard_this_thread();
            let outcome = panic::catch_unwind(AssertUnwindSafe(body))
                .unwrap_or_else(|payload| Err(format!("panicked: {}", panic_text(&*payload))));
            let _ = tx.send(outcome);
        })
        .map_err(|e| format!("cannot start a thread: {e}"))?;
    match rx.recv_timeout(CASE_TIMEOUT) {
        Ok(outcome) => {
            let _ = spawned.join();
            outcome
        }
        // The thread is left running; the test fails.
        Err(RecvTimeoutError::Timeout) => Err(format!("no answer within {} s: a hang", CASE_TIMEOUT.as_secs())),
        Err(RecvTimeoutError::Disconnected) => Err("the case's thread ended without an answer".into()),
    }
}

/// A reader under test: its name (the folder of its regressions), the
/// support files its cases refer to, and the check of one input.
pub struct Reader {
    name: &'static str,
    calls: &'static [&'static str],
    setup: fn(&Path) -> std::io::Result<()>,
    check: fn(&Path, &[u8]) -> Result<(), String>,
}

impl Reader {
    /// A reader called `name` (its calls named `calls` in the statistics)
    /// whose cases need no support files.
    pub const fn new(
        name: &'static str,
        calls: &'static [&'static str],
        check: fn(&Path, &[u8]) -> Result<(), String>,
    ) -> Reader {
        Reader {
            name,
            calls,
            setup: |_| Ok(()),
            check,
        }
    }

    /// The same reader, its support files written by `setup`.
    pub const fn with_setup(self, setup: fn(&Path) -> std::io::Result<()>) -> Reader {
        Reader { setup, ..self }
    }
}

/// A folder of its own under the temporary folder, with a reader's support
/// files; removed on drop.
struct FuzzDir(PathBuf);

impl FuzzDir {
    fn new(reader: &Reader) -> FuzzDir {
        static COUNT: AtomicUsize = AtomicUsize::new(0);
        let n = COUNT.fetch_add(1, Ordering::Relaxed);
        let dir = std::env::temp_dir().join(format!("penumbra-fuzz-{}-{}-{n}", std::process::id(), reader.name));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("cannot create {}: {e}", dir.display()));
        (reader.setup)(&dir).unwrap_or_else(|e| panic!("cannot write support files in {}: {e}", dir.display()));
        FuzzDir(dir)
    }
}

impl Drop for FuzzDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Writes the case's input where its file form reads it.
pub fn write_case(path: PathBuf, input: &[u8]) -> Result<PathBuf, String> {
    std::fs::write(&path, input).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    Ok(path)
}

/// The fixed configuration: `cases` cases (or `PENUMBRA_FUZZ_CASES`), a
/// seed of its own per test, nothing persisted.
fn config(test: &str, cases: u32) -> Config {
    let cases = crate::common::fuzz_cases(cases);
    Config {
        cases,
        failure_persistence: None,
        rng_algorithm: RngAlgorithm::ChaCha,
        rng_seed: RngSeed::Fixed(fnv1a(test.as_bytes())),
        max_shrink_iters: 2048,
        max_shrink_time: 120_000,
        ..Config::default()
    }
}

fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x100_0000_01b3)
    })
}

/// Saves a failing input under `target/tmp/fuzz-failures/<reader>/`.
fn save_failure(reader: &str, input: &[u8]) -> String {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("fuzz-failures")
        .join(reader);
    let path = dir.join(format!("{:016x}", fnv1a(input)));
    match std::fs::create_dir_all(&dir).and_then(|()| std::fs::write(&path, input)) {
        Ok(()) => path.display().to_string(),
        Err(e) => format!("(not saved: {e})"),
    }
}

fn preview(input: &[u8]) -> String {
    const SHOWN: usize = 800;
    let head = String::from_utf8_lossy(&input[..input.len().min(SHOWN)])
        .escape_debug()
        .to_string();
    if input.len() > SHOWN {
        format!("\"{head}\"... ({} bytes)", input.len())
    } else {
        format!("\"{head}\" ({} bytes)", input.len())
    }
}

/// Checks one input of `reader` with support files in `dir`, isolated.
fn check_isolated(reader: &'static Reader, dir: &Path, input: Arc<Vec<u8>>) -> Result<(), String> {
    check_isolated_as(reader.name, reader, dir, input)
}

/// `check_isolated` on a thread named after `label`.
fn check_isolated_as(label: &str, reader: &'static Reader, dir: &Path, input: Arc<Vec<u8>>) -> Result<(), String> {
    let dir = dir.to_path_buf();
    isolated(label, move || (reader.check)(&dir, &input))
}

/// Runs `cases` inputs of `strategy` through `reader`'s checks.
pub fn fuzz(test: &str, reader: &'static Reader, cases: u32, strategy: impl Strategy<Value = Vec<u8>>) {
    let dir = FuzzDir::new(reader);
    let mut runner = TestRunner::new(config(test, cases));
    let start = Instant::now();
    let result = runner.run(&strategy, |input| {
        check_isolated_as(test, reader, &dir.0, Arc::new(input)).map_err(TestCaseError::fail)
    });
    println!("{test}: {:.2} s", start.elapsed().as_secs_f64());
    print_stats(reader.calls);
    let (calls, ok) = BY_THREAD
        .lock()
        .map(|c| c.get(&format!("fuzz-{test}")).copied().unwrap_or_default())
        .unwrap_or_default();
    let share = ok as f64 / calls.max(1) as f64;
    println!("{test}: {ok} of {calls} reader calls succeeded ({:.1}%)", 100.0 * share);
    match result {
        Ok(()) => {}
        Err(TestError::Fail(reason, input)) => panic!(
            "{test}: {reason}\ninput (shrunk): {}\nsaved to {}; once the reader is fixed, copy it to \
             tests/regressions/{}/",
            preview(&input),
            save_failure(reader.name, &input),
            reader.name
        ),
        Err(TestError::Abort(reason)) => panic!("{test}: aborted: {reason}"),
    }
    assert!(calls > 0, "{test}: no reader was called");
    assert!(
        share >= MIN_VALID_SHARE,
        "{test}: only {ok} of {calls} reader calls succeeded ({:.1}%, at least {:.0}% expected): the generator \
         no longer makes inputs the reader accepts",
        100.0 * share,
        100.0 * MIN_VALID_SHARE
    );
}

/// The error of a reader: bad input, naming what and why. Returns its source.
pub fn error_ok(e: &Error) -> Result<&str, String> {
    match e {
        Error::BadInput { source, problem, .. } if !source.trim().is_empty() && !problem.trim().is_empty() => {
            Ok(source.as_str())
        }
        _ => Err(format!("not a bad-input error naming what and why: {e:?}")),
    }
}

/// `e` names `path` (its source, shown in its message).
pub fn names(e: &Error, path: &Path) -> Result<(), String> {
    let shown = path.display().to_string();
    if error_ok(e)? == shown && e.to_string().starts_with(&shown) {
        Ok(())
    } else {
        Err(format!("the error does not name {shown}: {e}"))
    }
}

/// `e` names a file by its absolute path (the file read or one it names).
pub fn names_a_file(e: &Error) -> Result<(), String> {
    let source = error_ok(e)?;
    if Path::new(source).is_absolute() && e.to_string().starts_with(source) {
        Ok(())
    } else {
        Err(format!("the error names no file: {e}"))
    }
}

pub fn finite(what: &str, v: Vec3) -> Result<(), String> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(format!("{what} {v} is not finite"))
    }
}

pub fn fail<T>(problem: String) -> Result<T, String> {
    Err(problem)
}

/// A text form's result: Ok and passing `ok`, or a bad-input error.
pub fn ok_or_bad_input<T>(
    result: &penumbra::Result<T>,
    ok: impl FnOnce(&T) -> Result<(), String>,
) -> Result<(), String> {
    match result {
        Ok(value) => ok(value),
        Err(e) => error_ok(e).map(|_| ()),
    }
}

/// The file form of a reader agrees with its text form: both Ok and `same`,
/// or both errors, the file form's naming `path`.
pub fn agree<T: Debug>(
    text_form: &str,
    parsed: &penumbra::Result<T>,
    file_form: &str,
    loaded: penumbra::Result<T>,
    path: &Path,
    same: impl Fn(&T, &T) -> bool,
) -> Result<(), String> {
    match (parsed, loaded) {
        (Ok(a), Ok(b)) if same(a, &b) => Ok(()),
        (Err(_), Err(e)) => names(&e, path),
        (a, b) => fail(format!("{text_form} gave {a:?} but {file_form} {b:?}")),
    }
}

/// Each of `seeds` is accepted by `load` (given the folder of `reader`'s
/// support files) and passes `reader`'s checks.
pub fn assert_seeds_accepted(reader: &'static Reader, seeds: Vec<Vec<u8>>, load: impl Fn(&Path, &[u8]) -> bool) {
    let dir = FuzzDir::new(reader);
    for (i, seed) in seeds.into_iter().enumerate() {
        assert!(
            load(&dir.0, &seed),
            "{} seed {i} is refused: {}",
            reader.name,
            preview(&seed)
        );
        let seed = Arc::new(seed);
        if let Err(problem) = check_isolated(reader, &dir.0, Arc::clone(&seed)) {
            panic!("{} seed {i}: {problem}", reader.name);
        }
    }
}

/// Runs every input under `tests/regressions/<reader>/` through its
/// reader's checks (one of `readers`, by name).
pub fn replay_regressions(readers: &[&'static Reader]) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests").join("regressions");
    let Ok(folders) = std::fs::read_dir(&root) else {
        println!("no {}", root.display());
        return;
    };
    let mut replayed = 0;
    let mut failures = Vec::new();
    for folder in folders.flatten().map(|e| e.path()).filter(|p| p.is_dir()) {
        let name = folder
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let Some(&reader) = readers.iter().find(|r| r.name == name) else {
            panic!("{}: no reader is called '{name}'", folder.display());
        };
        let dir = FuzzDir::new(reader);
        let mut files: Vec<PathBuf> = std::fs::read_dir(&folder)
            .unwrap_or_else(|e| panic!("{}: {e}", folder.display()))
            .flatten()
            .map(|e| e.path())
            .filter(|p| p.is_file())
            .collect();
        files.sort();
        for file in files {
            let input = std::fs::read(&file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
            if let Err(problem) = check_isolated(reader, &dir.0, Arc::new(input)) {
                failures.push(format!("{}: {problem}", file.display()));
            }
            replayed += 1;
        }
    }
    println!("replayed {replayed} regression inputs");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
