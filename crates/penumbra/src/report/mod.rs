//! What runs report besides their answers: timed repeats of a run, and
//! what a run left out because the scene did not need it.

pub mod repeats;
pub mod skipped;
