//! Progress reporting on stderr for long work (indicatif). Library functions
//! take a `&Progress`; `Progress::hidden()` reports nothing. Runners, which
//! make their own bars phase by phase, take `Bars`: the command line asks
//! for bars on stderr, a host for none. Bars only appear after a second, so
//! quick runs and CI logs stay clean.

use std::time::Duration;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// Whether a runner shows its phases' progress on stderr.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Bars {
    /// No output (a host engine).
    #[default]
    Hidden,
    /// Bars on stderr (the command line).
    Stderr,
}

impl Bars {
    /// A bar of `len` steps, or a hidden one.
    pub fn bar(self, len: u64, message: &str) -> Progress {
        match self {
            Bars::Hidden => Progress::hidden(),
            Bars::Stderr => Progress::bar(len, message),
        }
    }

    /// A spinner for work of unknown length, or a hidden one.
    pub fn spinner(self, message: &str) -> Progress {
        match self {
            Bars::Hidden => Progress::hidden(),
            Bars::Stderr => Progress::spinner(message),
        }
    }
}

pub struct Progress {
    bar: Option<ProgressBar>,
}

impl Progress {
    pub fn hidden() -> Progress {
        Progress { bar: None }
    }

    /// A bar of `len` steps labelled `message` on stderr (hidden when stderr
    /// is not a terminal, as indicatif does).
    pub fn bar(len: u64, message: &str) -> Progress {
        let bar = ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::stderr());
        bar.set_style(
            ProgressStyle::with_template("{msg:>12} [{bar:40}] {pos}/{len} ({eta} left)")
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> "),
        );
        bar.set_message(message.to_string());
        // Drawing starts only once the work has taken a second.
        bar.set_draw_target(ProgressDrawTarget::hidden());
        let shown = bar.clone();
        std::thread::spawn(move || {
            std::thread::sleep(Duration::from_secs(1));
            if !shown.is_finished() {
                shown.set_draw_target(ProgressDrawTarget::stderr());
                shown.enable_steady_tick(Duration::from_millis(200));
            }
        });
        Progress { bar: Some(bar) }
    }

    /// A spinner for work of unknown length.
    pub fn spinner(message: &str) -> Progress {
        let p = Progress::bar(0, message);
        if let Some(bar) = &p.bar {
            bar.set_length(0);
            bar.set_style(
                ProgressStyle::with_template("{spinner} {msg} ({elapsed})")
                    .unwrap_or_else(|_| ProgressStyle::default_spinner()),
            );
        }
        p
    }

    pub fn inc(&self, n: u64) {
        if let Some(b) = &self.bar {
            b.inc(n);
        }
    }

    pub fn finish(&self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.finish();
    }
}
