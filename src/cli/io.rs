//! The command line's JSON reports and notes on stderr (images and
//! per-vertex files: `crate::image_out`, `crate::vertex_out`).

use serde_json::Value;

use crate::error::{Error, Result};

/// Says on stderr what `--max-error` chose, and warns when no setting met it.
pub fn note_choice(c: &crate::sweep::budget::Choice) {
    c.notes().iter().for_each(|n| note(n));
}

/// Each warning on stderr.
pub fn warn(warnings: &[String]) {
    warnings.iter().for_each(|w| note(&format!("warning: {w}")));
}

/// A runner's note on stderr, parameters named by their flags.
pub fn note(text: &str) {
    eprintln!("penumbra: {}", crate::error::rename_quoted(text, super::args::flag));
}

/// Each of a runner's notes on stderr.
pub fn notes(texts: &[String]) {
    texts.iter().for_each(|n| note(n));
}

/// `report` with every field of `more` (a JSON object) added.
pub fn merged(mut report: Value, more: impl serde::Serialize) -> Result<Value> {
    let more = serde_json::to_value(more).map_err(|e| Error::internal(format!("report: {e}")))?;
    if let (Value::Object(a), Value::Object(b)) = (&mut report, more) {
        a.extend(b);
    }
    Ok(report)
}
