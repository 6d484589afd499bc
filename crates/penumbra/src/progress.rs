//! Following long work, and stopping it: a host implements [`Progress`]
//! (a bar in its own UI, a log line, a cancel button) and hands it to an
//! entry as a [`Reporter`]; without one the library says nothing.
//!
//! The library names its phases in its own words ("building kd-tree",
//! "AO vertices", ...) and counts their steps; it never draws, prints or
//! reads the terminal. Cancellation is checked between units of work (a
//! batch of rays, a frame, a setting of a sweep), so a cancelled call
//! returns [`Error::Cancelled`] soon, with nothing
//! half-written.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use crate::error::{Error, Result};

/// What a host implements to follow the library's work. Every method has a
/// default that does nothing, so `impl Progress for MyUi {}` compiles.
pub trait Progress: Send + Sync {
    /// A phase of work named `what` begins, of `steps` steps (`None`: its
    /// length is not known in advance). The returned task is advanced from
    /// any thread and finished once, when the phase ends.
    fn task(&self, what: &str, steps: Option<u64>) -> Box<dyn Task> {
        let _ = (what, steps);
        Box::new(Silent)
    }

    /// Something worth telling the user that is not an error (an estimate
    /// of how long work will take, a cache that could not be written).
    fn note(&self, message: &str) {
        let _ = message;
    }

    /// Whether the caller wants the work stopped. Checked between units of
    /// work; a `true` makes the running call return `Error::Cancelled`.
    fn cancelled(&self) -> bool {
        false
    }
}

/// One phase of work, as the [`Progress`] that began it follows it.
pub trait Task: Send + Sync {
    /// `steps` more steps are done.
    fn advance(&self, steps: u64) {
        let _ = steps;
    }

    /// The phase has ended (called once, also when it ends early).
    fn finish(&self) {}
}

/// Follows nothing: the default.
#[derive(Debug, Clone, Copy, Default)]
pub struct Silent;

impl Progress for Silent {}
impl Task for Silent {}

/// A caller's [`Progress`], shared by every phase of a call: cheap to
/// clone, silent by default.
#[derive(Clone, Default)]
pub struct Reporter(Option<Arc<dyn Progress>>);

impl std::fmt::Debug for Reporter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(if self.0.is_some() {
            "Reporter(..)"
        } else {
            "Reporter(silent)"
        })
    }
}

/// Two reporters are equal when they report to the same progress (or both
/// to none).
impl PartialEq for Reporter {
    fn eq(&self, other: &Reporter) -> bool {
        match (&self.0, &other.0) {
            (Some(a), Some(b)) => Arc::ptr_eq(a, b),
            (None, None) => true,
            _ => false,
        }
    }
}

impl Reporter {
    /// Reports to `progress`.
    pub fn new(progress: impl Progress + 'static) -> Reporter {
        Reporter(Some(Arc::new(progress)))
    }

    /// Reports to a progress the caller keeps a handle on.
    pub fn shared(progress: Arc<dyn Progress>) -> Reporter {
        Reporter(Some(progress))
    }

    /// Reports nothing.
    pub fn silent() -> Reporter {
        Reporter(None)
    }

    /// Whether anything follows the work.
    pub fn is_silent(&self) -> bool {
        self.0.is_none()
    }

    /// A phase of `len` steps.
    pub fn bar(&self, len: u64, what: &str) -> Bar {
        Bar::of(self.0.as_ref().map(|p| p.task(what, Some(len))))
    }

    /// A phase of unknown length.
    pub fn spinner(&self, what: &str) -> Bar {
        Bar::of(self.0.as_ref().map(|p| p.task(what, None)))
    }

    /// Tells the caller `message`.
    pub fn note(&self, message: &str) {
        if let Some(p) = &self.0 {
            p.note(message);
        }
    }

    /// `Err(Error::Cancelled)` once the caller asked to stop.
    pub fn check(&self) -> Result<()> {
        match &self.0 {
            Some(p) if p.cancelled() => Err(Error::Cancelled),
            _ => Ok(()),
        }
    }
}

/// A running phase: advanced by the work, finished when dropped. It also
/// counts its steps, so tests can check who advanced it.
pub struct Bar {
    task: Option<Box<dyn Task>>,
    done: AtomicU64,
    finished: std::sync::atomic::AtomicBool,
}

impl Bar {
    fn of(task: Option<Box<dyn Task>>) -> Bar {
        Bar {
            task,
            done: AtomicU64::new(0),
            finished: std::sync::atomic::AtomicBool::new(false),
        }
    }

    /// A phase nobody follows.
    pub fn hidden() -> Bar {
        Bar::of(None)
    }

    /// Steps done so far.
    pub fn position(&self) -> u64 {
        self.done.load(Ordering::Relaxed)
    }

    /// `n` more steps done.
    pub fn inc(&self, n: u64) {
        self.done.fetch_add(n, Ordering::Relaxed);
        if let Some(t) = &self.task {
            t.advance(n);
        }
    }

    /// The phase has ended.
    pub fn finish(&self) {
        if !self.finished.swap(true, Ordering::Relaxed)
            && let Some(t) = &self.task
        {
            t.finish();
        }
    }
}

impl Drop for Bar {
    fn drop(&mut self) {
        self.finish();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Mutex;

    #[derive(Default)]
    struct Log(Arc<Mutex<Vec<String>>>);

    struct LogTask(Arc<Mutex<Vec<String>>>, String);

    impl Progress for Log {
        fn task(&self, what: &str, steps: Option<u64>) -> Box<dyn Task> {
            self.0.lock().unwrap().push(format!("begin {what} {steps:?}"));
            Box::new(LogTask(self.0.clone(), what.to_string()))
        }
        fn cancelled(&self) -> bool {
            self.0.lock().unwrap().len() > 3
        }
    }

    impl Task for LogTask {
        fn advance(&self, steps: u64) {
            self.0.lock().unwrap().push(format!("{} +{steps}", self.1));
        }
        fn finish(&self) {
            self.0.lock().unwrap().push(format!("end {}", self.1));
        }
    }

    #[test]
    fn a_bar_tells_its_task_each_step_and_finishes_once() {
        let log = Log::default();
        let lines = log.0.clone();
        let reporter = Reporter::new(log);
        {
            let bar = reporter.bar(3, "rays");
            bar.inc(2);
            bar.finish();
            assert_eq!(bar.position(), 2);
        }
        assert_eq!(*lines.lock().unwrap(), ["begin rays Some(3)", "rays +2", "end rays"]);
        assert!(reporter.check().is_ok());
        let _spin = reporter.spinner("more");
        assert!(matches!(reporter.check(), Err(Error::Cancelled)));
    }

    #[test]
    fn silent_reports_nothing_and_never_cancels() {
        let r = Reporter::silent();
        let bar = r.bar(10, "x");
        bar.inc(4);
        assert_eq!(bar.position(), 4);
        assert!(r.check().is_ok() && r.is_silent());
    }
}
