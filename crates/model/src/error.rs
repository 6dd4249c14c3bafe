//! The errors every stage can meet: a bad configuration value or name, a log that cannot be
//! read, an I/O or JSON failure on a path, a diverged plant, an interrupt. Each stage above the
//! model has its own error enum for its own failures, wrapping this one
//! ([`shared_error_constructors`](crate::shared_error_constructors) gives it the same
//! constructors); every failure on user input says what and where.

use std::path::PathBuf;

/// Errors reported to the user. Each variant names the file, field, step or time involved.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A robot or terrain file (or any TOML input) is missing, malformed or has an impossible value.
    #[error("{file}: field `{field}`: {message}")]
    Config {
        /// The file that holds the bad value.
        file: PathBuf,
        /// Dotted path of the field, e.g. `body.mass_kg`.
        field: String,
        /// What is wrong with it.
        message: String,
    },
    /// A named robot or terrain that no file provides.
    #[error("unknown {kind} `{name}`; available: {available}")]
    Unknown {
        /// "robot" or "terrain".
        kind: &'static str,
        /// The name the user asked for.
        name: String,
        /// Comma-separated list of names that exist.
        available: String,
    },
    /// A log (MCAP or CSV) that cannot be read, with the location of the problem.
    #[error("{file}: {location}: {message}")]
    Log {
        /// The log file.
        file: PathBuf,
        /// Where in it: a row and column, a topic and message index, a step.
        location: String,
        /// What is wrong.
        message: String,
    },
    /// The simulation produced a non-physical state.
    #[error("simulation diverged at step {step}, t = {time_s:.3} s: {message}")]
    Diverged {
        /// Protocol step index (0 before the protocol starts).
        step: u32,
        /// Simulated time, s.
        time_s: f64,
        /// What diverged.
        message: String,
    },
    /// A sampler could not draw the command of a step: it failed, or drew a command that is
    /// not finite or lies outside the robot's command space U.
    #[error("sampler `{sampler}` failed at step {step}: {message}")]
    Sampler {
        /// The sampler's name.
        sampler: String,
        /// Protocol step index the command was for.
        step: u32,
        /// What went wrong.
        message: String,
    },
    /// The user stopped the command (SIGINT / SIGTERM); what was written is kept and named.
    #[error("interrupted at step {step}, t = {time_s:.3} s")]
    Interrupted {
        /// Steps completed when the signal came.
        step: u32,
        /// Simulated time, s.
        time_s: f64,
    },
    /// A value that cannot be written as JSON or a JSON file that cannot be read back.
    #[error("{path}: JSON: {source}")]
    Json {
        /// The file written or read.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: serde_json::Error,
    },
    /// Input/output failure on a path.
    #[error("{path}: {source}")]
    Io {
        /// The path that failed.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
}

impl Error {
    /// Builds a [`Error::Config`] error.
    pub fn config(file: impl Into<PathBuf>, field: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Config {
            file: file.into(),
            field: field.into(),
            message: message.into(),
        }
    }
    /// Builds a [`Error::Log`] error.
    pub fn log(file: impl Into<PathBuf>, location: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Log {
            file: file.into(),
            location: location.into(),
            message: message.into(),
        }
    }
    /// Whether the user's input is at fault (a bad file, value or name: exit code 2) rather
    /// than the run (a diverged simulation, a failed write: exit code 1). A missing input file
    /// is bad input; other I/O failures are not.
    pub fn is_bad_input(&self) -> bool {
        match self {
            Error::Config { .. } | Error::Unknown { .. } | Error::Log { .. } | Error::Sampler { .. } => true,
            Error::Io { source, .. } => source.kind() == std::io::ErrorKind::NotFound,
            Error::Diverged { .. } | Error::Interrupted { .. } | Error::Json { .. } => false,
        }
    }
    /// Builds an [`Error::Json`] error.
    pub fn json(path: impl Into<PathBuf>, source: serde_json::Error) -> Self {
        Error::Json {
            path: path.into(),
            source,
        }
    }
    /// Builds an [`Error::Io`] error.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            source,
        }
    }
}

/// Result alias used across the crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Gives a crate's own error enum, which wraps this crate's [`Error`] in a variant
/// `Model(#[from] drive_sim_model::Error)`, the constructors of the shared errors (`config`,
/// `log`, `io`, `json`), so that every stage names a bad file, log location or path the same way.
#[macro_export]
macro_rules! shared_error_constructors {
    ($t:ty) => {
        impl $t {
            /// A bad value in a configuration file or option ([`drive_sim_model::Error::Config`]).
            pub fn config(
                file: impl Into<std::path::PathBuf>,
                field: impl Into<String>,
                message: impl Into<String>,
            ) -> Self {
                Self::Model($crate::Error::config(file, field, message))
            }
            /// A log that cannot be read or used, and where ([`drive_sim_model::Error::Log`]).
            pub fn log(
                file: impl Into<std::path::PathBuf>,
                location: impl Into<String>,
                message: impl Into<String>,
            ) -> Self {
                Self::Model($crate::Error::log(file, location, message))
            }
            /// An I/O failure on a path ([`drive_sim_model::Error::Io`]).
            pub fn io(path: impl Into<std::path::PathBuf>, source: std::io::Error) -> Self {
                Self::Model($crate::Error::io(path, source))
            }
            /// A value that cannot be written as JSON, or a JSON file that cannot be read
            /// ([`drive_sim_model::Error::Json`]).
            pub fn json(path: impl Into<std::path::PathBuf>, source: serde_json::Error) -> Self {
                Self::Model($crate::Error::json(path, source))
            }
        }
    };
}
