//! Progress on stderr for long work (indicatif): the command line's
//! implementation of the library's `Progress`. Bars only appear after a
//! second, so quick runs and CI logs stay clean. When stderr is not a terminal they are
//! silent, unless `log_when_not_a_terminal` (the CLI's `--progress`) asks for
//! them: then each bar writes a plain line about once a second.

use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle, TermLike};
use penumbra::progress::{Progress, Reporter, Task};

static LOG_LINES: AtomicBool = AtomicBool::new(false);

/// Bars write plain progress lines to stderr when it is not a terminal
/// (a CI log, a file); by default they are silent there.
pub fn log_when_not_a_terminal(on: bool) {
    LOG_LINES.store(on, Ordering::Relaxed);
}

/// How long work runs before its bar appears: a second, or
/// `PENUMBRA_PROGRESS_DELAY_MS` (tests set 0).
fn delay() -> Duration {
    let ms = std::env::var("PENUMBRA_PROGRESS_DELAY_MS")
        .ok()
        .and_then(|v| v.parse().ok());
    Duration::from_millis(ms.unwrap_or(1000))
}

/// Where a bar draws: the terminal, lines in a log, or nowhere.
fn stderr_target() -> ProgressDrawTarget {
    if std::io::stderr().is_terminal() {
        ProgressDrawTarget::stderr()
    } else if LOG_LINES.load(Ordering::Relaxed) {
        ProgressDrawTarget::term_like(Box::new(LogLines::default()))
    } else {
        ProgressDrawTarget::hidden()
    }
}

/// A "terminal" that cannot move its cursor: a redraw is a new line, at
/// most one a second (the first at once), so a CI log stays readable.
#[derive(Debug, Default)]
struct LogLines {
    last: std::sync::Mutex<Option<std::time::Instant>>,
}

impl TermLike for LogLines {
    fn width(&self) -> u16 {
        100
    }
    fn move_cursor_up(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }
    fn move_cursor_down(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }
    fn move_cursor_right(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }
    fn move_cursor_left(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }
    fn write_line(&self, s: &str) -> std::io::Result<()> {
        let mut last = self.last.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        let due = last.is_none_or(|t| t.elapsed() >= Duration::from_secs(1));
        if due && !s.trim().is_empty() {
            eprintln!("penumbra: progress: {}", s.trim());
            *last = Some(std::time::Instant::now());
        }
        Ok(())
    }
    fn write_str(&self, s: &str) -> std::io::Result<()> {
        self.write_line(s)
    }
    fn clear_line(&self) -> std::io::Result<()> {
        Ok(())
    }
    fn flush(&self) -> std::io::Result<()> {
        Ok(())
    }
}

/// The command line's progress: indicatif bars on stderr, shown once a
/// phase has run a second, and the library's notes as `penumbra:` lines.
pub struct StderrBars;

impl Progress for StderrBars {
    fn task(&self, what: &str, steps: Option<u64>) -> Box<dyn Task> {
        Box::new(match steps {
            Some(len) => IndicatifTask::bar(len, what),
            None => IndicatifTask::spinner(what),
        })
    }

    fn note(&self, message: &str) {
        crate::io::note(message);
    }
}

/// The reporter every subcommand hands the library.
pub fn stderr() -> Reporter {
    Reporter::new(StderrBars)
}

/// One phase's bar.
struct IndicatifTask {
    bar: ProgressBar,
}

impl IndicatifTask {
    /// A bar of `len` steps labelled `message` on stderr (hidden when stderr
    /// is not a terminal, as indicatif does).
    fn bar(len: u64, message: &str) -> IndicatifTask {
        let bar = ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::hidden());
        bar.set_style(
            ProgressStyle::with_template("{msg:>12} [{bar:40}] {pos}/{len} ({eta} left)")
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> "),
        );
        bar.set_message(message.to_string());
        // Drawing starts only once the work has taken a second.
        let shown = bar.clone();
        std::thread::spawn(move || {
            std::thread::sleep(delay());
            if !shown.is_finished() {
                shown.set_draw_target(stderr_target());
                shown.enable_steady_tick(Duration::from_millis(200));
                // Drawn at once, however long the work still runs.
                shown.tick();
            }
        });
        IndicatifTask { bar }
    }

    /// A spinner for work of unknown length.
    fn spinner(message: &str) -> IndicatifTask {
        let t = IndicatifTask::bar(0, message);
        t.bar.set_length(0);
        t.bar.set_style(
            ProgressStyle::with_template("{spinner} {msg} ({elapsed})")
                .unwrap_or_else(|_| ProgressStyle::default_spinner()),
        );
        t
    }
}

impl Task for IndicatifTask {
    fn advance(&self, steps: u64) {
        self.bar.inc(steps);
    }

    fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

impl Drop for IndicatifTask {
    fn drop(&mut self) {
        self.bar.finish_and_clear();
    }
}
