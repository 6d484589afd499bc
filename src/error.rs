//! One error type for the library and the CLI.
//!
//! The command-line contract maps errors to exit codes: bad input and an
//! unavailable device exit with 2, anything else with 1. Every variant that
//! comes from user input names the file (or option), the field and the problem,
//! so a CI log says what to fix without a backtrace.

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
}

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

    /// Bad value of a command-line option or API parameter.
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

    pub fn internal(message: impl Into<String>) -> Self {
        Error::Internal(message.into())
    }

    /// Exit code per the command-line contract.
    pub fn exit_code(&self) -> i32 {
        match self {
            Error::BadInput { .. } | Error::Device(_) => 2,
            Error::Internal(_) => 1,
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

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::BadInput { source, field, problem } if field.is_empty() => {
                write!(f, "{source}: {problem}")
            }
            Error::BadInput { source, field, problem } => write!(f, "{source}: {field}: {problem}"),
            Error::Device(message) => write!(f, "device: {message}"),
            Error::Internal(message) => write!(f, "internal error: {message}"),
        }
    }
}

impl std::error::Error for Error {}
