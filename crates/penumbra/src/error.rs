//! One error type for the library and the command lines built on it.
//!
//! The command-line contract maps errors to exit codes: bad input and an
//! unavailable device exit with 2, anything else with 1. Every variant that
//! comes from user input names the file (or parameter), the field and the
//! problem, so a CI log says what to fix without a backtrace.
//!
//! The library names parameters in its own language: `Error::param`'s name
//! is the field of a settings struct (`rays_per_point`, `bands`), and a
//! problem that mentions another parameter quotes its name in backticks
//! ("`spp` 12 is not a multiple of `steps` 5"). A front end renames them
//! (`Error::with_names`): the command line maps them to its flags.

use std::fmt;
use std::path::Path;

/// What went wrong, classified by who has to fix it.
#[derive(Debug, Clone, PartialEq)]
pub enum Error {
    /// Malformed or out-of-range input: a file, a field in it, or an option.
    BadInput {
        /// The file or command-line option the problem is in.
        source: String,
        /// The field, line or record inside it (may be empty).
        field: String,
        /// What is wrong with it.
        problem: String,
    },
    /// The requested device does not exist or cannot do the work.
    Device(String),
    /// A bug or an environment failure (I/O on an output, GPU lost...).
    Internal(String),
    /// The caller's [`Progress`](crate::Progress) asked the work to stop.
    Cancelled,
}

/// The library's result.
pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    /// Bad input in a file.
    pub fn file(path: &Path, field: impl Into<String>, problem: impl Into<String>) -> Self {
        Error::BadInput {
            source: path.display().to_string(),
            field: field.into(),
            problem: problem.into(),
        }
    }

    /// Bad value of a parameter, named as the library names it (a settings
    /// field); other parameters in `problem` are quoted in backticks.
    pub fn param(name: impl Into<String>, problem: impl Into<String>) -> Self {
        Error::BadInput {
            source: name.into(),
            field: String::new(),
            problem: problem.into(),
        }
    }

    /// Bad input that is not tied to a file (e.g. a mesh built in code).
    pub fn input(what: impl Into<String>, problem: impl Into<String>) -> Self {
        Self::param(what, problem)
    }

    /// A bug or an environment failure, described.
    pub fn internal(message: impl Into<String>) -> Self {
        Error::Internal(message.into())
    }

    /// Exit code per the command-line contract.
    pub fn exit_code(&self) -> i32 {
        match self {
            Error::BadInput { .. } | Error::Device(_) => 2,
            Error::Internal(_) => 1,
            // As shells expect of an interrupted program.
            Error::Cancelled => 130,
        }
    }

    /// Re-attributes an input error to a file, keeping the field and problem.
    /// Used when a mesh built from a file fails validation.
    pub fn in_file(self, path: &Path) -> Self {
        match self {
            Error::BadInput { field, problem, source } => Error::BadInput {
                source: path.display().to_string(),
                field: if field.is_empty() { source } else { field },
                problem,
            },
            other => other,
        }
    }

    /// The error with parameter names spelled by `rename` (e.g. the command
    /// line's flags): the name of a parameter error, and names quoted in
    /// backticks in its problem or in a device message. Names `rename` does
    /// not know stay as they are.
    pub fn with_names<'a>(self, rename: impl Fn(&str) -> Option<&'a str>) -> Error {
        match self {
            Error::BadInput { source, field, problem } => Error::BadInput {
                source: rename(&source).map_or(source, str::to_string),
                field,
                problem: rename_quoted(&problem, &rename),
            },
            Error::Device(message) => Error::Device(rename_quoted(&message, &rename)),
            other => other,
        }
    }

    /// Wraps an I/O error on reading a file as bad input (the file is missing
    /// or unreadable: the user has to fix the path).
    pub fn read(path: &Path, err: std::io::Error) -> Self {
        Error::file(path, "", format!("cannot read: {err}"))
    }

    /// Wraps an I/O error on writing an output file.
    pub fn write(path: &Path, err: impl fmt::Display) -> Self {
        Error::file(path, "", format!("cannot write: {err}"))
    }
}

/// `text` with every name quoted in backticks that `rename` knows replaced
/// by its spelling (unknown names keep their backticks).
pub fn rename_quoted<'a>(text: &str, rename: impl Fn(&str) -> Option<&'a str>) -> String {
    let parts: Vec<&str> = text.split('`').collect();
    let mut out = String::from(parts[0]);
    for (i, part) in parts.iter().enumerate().skip(1) {
        // Odd parts follow an opening backtick; the last one has no closing
        // backtick when the count is odd.
        let quoted = i % 2 == 1 && i + 1 < parts.len();
        match rename(part) {
            Some(name) if quoted => out.push_str(name),
            _ if quoted => out.push_str(&format!("`{part}`")),
            _ if i % 2 == 1 => out.push_str(&format!("`{part}")),
            _ => out.push_str(part),
        }
    }
    out
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::BadInput { source, field, problem } if field.is_empty() => {
                write!(f, "{source}: {problem}")
            }
            Error::BadInput { source, field, problem } => write!(f, "{source}: {field}: {problem}"),
            Error::Device(message) => write!(f, "device: {message}"),
            Error::Internal(message) => write!(f, "internal error: {message}"),
            Error::Cancelled => f.write_str("cancelled"),
        }
    }
}

impl std::error::Error for Error {}

#[cfg(test)]
mod tests {
    use super::Error;

    #[test]
    fn names_are_renamed_in_the_source_and_between_backticks() {
        let flags = |name: &str| match name {
            "spp" => Some("--spp"),
            "steps" => Some("--steps"),
            _ => None,
        };
        let e = Error::param("steps", "`spp` 12 is not a multiple of `steps` 5 (`other`)").with_names(flags);
        assert_eq!(
            e.to_string(),
            "--steps: --spp 12 is not a multiple of --steps 5 (`other`)"
        );
        let e = Error::Device("use `spp` or not".into()).with_names(flags);
        assert_eq!(e.to_string(), "device: use --spp or not");
        let e = Error::param("x", "an odd ` stays").with_names(flags);
        assert_eq!(e.to_string(), "x: an odd ` stays");
        let e = Error::param("x", "`spp` and ` odd").with_names(flags);
        assert_eq!(e.to_string(), "x: --spp and ` odd");
    }
}
