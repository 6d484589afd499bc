//! Tuning a method's knobs, the one mechanism under both `penumbra sweep`
//! (every setting of a grid, timed and compared with the method's truth)
//! and `--max-error` (the fastest candidate whose sampled error is within a
//! budget).
//!
//! A method declares its knobs with the types its settings take
//! ([`Knob`]); settings hold typed values ([`Setting`]), read from text
//! once, where a grid spec or a cached pick is read. A method takes part
//! by implementing [`Tunable`] (its name and knobs) and then [`Sweep`]
//! (its truth, one timed run of a setting) and/or [`Budgeted`] (its
//! candidates, each run on a sample). Each method's implementations live
//! in the method's own module (`field::tune`, `ssao::tune`, ...); this
//! module imports no method.

pub(crate) mod budget;
pub(crate) mod grid;
pub(crate) mod knob;
pub(crate) mod sweep;

pub use budget::{
    Budgeted, Candidate, ChoiceCache, ErrorBudget, Order, Pick, SampleError, cache_key, choose, choose_cached,
};
pub use grid::{Grid, MAX_SETTINGS};
pub use knob::{Given, Knob, KnobKind, KnobType, KnobValue, Setting};
pub use sweep::{
    Row, Run, Sweep, SweepPart, SweepReport, SweepTotals, csv_text, output_files, pareto_front, sweep, sweep_report,
    sweep_settings,
};

/// A method with knobs to tune: its name and the knobs it declares.
pub trait Tunable {
    /// The method's name (`sweep field`, and the key of its cached picks).
    fn name(&self) -> &'static str;
    /// The knobs a grid may vary and a budget choose among.
    fn knobs(&self) -> &'static [Knob];
}
