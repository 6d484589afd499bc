//! The command line's JSON reports and notes on stderr (images and
//! per-vertex files: `penumbra::io::image`, `penumbra::io::vertex`).

use std::io::Write;

use serde_json::Value;

use penumbra::error::{Error, Result};

/// Says on stderr what `--max-error` chose, and warns when no setting met it.
pub fn note_choice(c: &penumbra::tune::Pick) {
    c.notes().iter().for_each(|n| note(n));
}

/// Each warning on stderr.
pub fn warn(warnings: &[String]) {
    warnings.iter().for_each(|w| note(&format!("warning: {w}")));
}

/// A runner's note on stderr, parameters named by their flags.
pub fn note(text: &str) {
    eprintln!("penumbra: {}", penumbra::error::rename_quoted(text, crate::args::flag));
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

/// Prints a command's report on stdout: the JSON object alone (`json`), else
/// the person's `summary` of it (`crate::summary`).
/// A closed stdout (`penumbra ... | head -c 10`) ends the run quietly.
pub fn print_report(json: bool, value: &serde_json::Value, summary: impl FnOnce() -> String) -> Result<()> {
    let text = match json {
        true => format!("{value}\n"),
        false => summary(),
    };
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
            Err(Error::internal(format!("cannot write to stdout: {e}")))
        }
        _ => Ok(()),
    }
}
