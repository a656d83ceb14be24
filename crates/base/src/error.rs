//! One error type for every crate of coapt.
//!
//! Every variant says which file (or config key) is at fault and what to do
//! about it. The exit code follows from the variant: 2 for bad input or usage,
//! 1 for a computation that failed on valid input.

use std::path::{Path, PathBuf};

pub type Result<T, E = Error> = std::result::Result<T, E>;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// An input file exists but its content is unusable.
    #[error("{}: {problem}", path.display())]
    BadInput { path: PathBuf, problem: String },

    /// An input file could not be opened or read.
    #[error("{}: cannot read: {source}", path.display())]
    Read {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },

    /// A config value (file and key) is missing, malformed or out of range.
    #[error("{}: {key}: {problem}", path.display())]
    Config {
        path: PathBuf,
        key: String,
        problem: String,
    },

    /// A command line that cannot be carried out as written.
    #[error("{0}")]
    Usage(String),

    /// A value (from the CLI or a config) is malformed; the caller adds where it came from.
    #[error("{0}")]
    Value(String),

    /// An output could not be written.
    #[error("{}: cannot write: {source}", path.display())]
    Write {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },

    /// A computation on valid input did not succeed (e.g. a solver that did
    /// not converge, a structure that was looked for and not found).
    #[error("{stage}: {problem}")]
    Failed { stage: String, problem: String },
}

impl Error {
    pub fn bad_input(path: impl AsRef<Path>, problem: impl Into<String>) -> Self {
        Error::BadInput {
            path: path.as_ref().to_path_buf(),
            problem: problem.into(),
        }
    }

    pub fn read(path: impl AsRef<Path>, source: std::io::Error) -> Self {
        Error::Read {
            path: path.as_ref().to_path_buf(),
            source,
        }
    }

    pub fn write(path: impl AsRef<Path>, source: std::io::Error) -> Self {
        Error::Write {
            path: path.as_ref().to_path_buf(),
            source,
        }
    }

    pub fn config(
        path: impl AsRef<Path>,
        key: impl Into<String>,
        problem: impl Into<String>,
    ) -> Self {
        Error::Config {
            path: path.as_ref().to_path_buf(),
            key: key.into(),
            problem: problem.into(),
        }
    }

    pub fn usage(msg: impl Into<String>) -> Self {
        Error::Usage(msg.into())
    }

    pub fn value(msg: impl Into<String>) -> Self {
        Error::Value(msg.into())
    }

    pub fn failed(stage: impl Into<String>, problem: impl Into<String>) -> Self {
        Error::Failed {
            stage: stage.into(),
            problem: problem.into(),
        }
    }

    /// Exit code of the `coapt` binary for this error: 2 for bad input or
    /// usage, 1 for a computation (or an output write) that failed.
    pub fn exit_code(&self) -> i32 {
        match self {
            Error::BadInput { .. }
            | Error::Read { .. }
            | Error::Config { .. }
            | Error::Usage(_)
            | Error::Value(_) => 2,
            Error::Write { .. } | Error::Failed { .. } => 1,
        }
    }

    /// Attach a file to a context-free [`Error::Value`]; other variants pass through.
    pub fn in_file(self, path: impl AsRef<Path>) -> Self {
        match self {
            Error::Value(problem) => Error::bad_input(path, problem),
            other => other,
        }
    }
}
