//! What can fail in a run, an analysis command, a sampler comparison or a sweep.

/// Errors of the harness.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A bad file or name, an I/O or JSON failure on a path, a diverged plant, an interrupt (the
    /// errors every stage shares).
    #[error(transparent)]
    Model(#[from] drive_sim_model::Error),
    /// An analysis that cannot be done.
    #[error(transparent)]
    Analysis(#[from] drive_sim_analysis::error::Error),
    /// A figure or report that cannot be drawn.
    #[error(transparent)]
    Report(#[from] drive_sim_report::Error),
    /// Sweep directories given to one merge that hold runs of different sweeps.
    #[error("analysis: the directories hold runs of different sweeps: {}", sweeps.join(", "))]
    MixedSweeps {
        /// The sweeps' names.
        sweeps: Vec<String>,
    },
    /// The merged table could not be written as CSV.
    #[error("analysis: writing CSV: {0}")]
    Csv(#[from] csv::Error),
    /// The merged table's CSV writer could not be flushed into its buffer.
    #[error("analysis: writing CSV: {0}")]
    CsvFlush(#[source] std::io::Error),
    /// The merged table's CSV is not UTF-8 (a cell that is not).
    #[error("analysis: writing CSV: {0}")]
    CsvText(#[from] std::string::FromUtf8Error),
}

drive_sim_model::shared_error_constructors!(Error);

impl Error {
    /// The shared error this one carries, however deep (an interrupt, a bad file, ...), if any.
    pub fn model(&self) -> Option<&drive_sim_model::Error> {
        match self {
            Error::Model(e) => Some(e),
            Error::Analysis(e) => e.model(),
            Error::Report(e) => e.model(),
            _ => None,
        }
    }

    /// Whether the user's input is at fault (exit code 2) rather than the run (exit code 1).
    pub fn is_bad_input(&self) -> bool {
        match self {
            Error::Model(e) => e.is_bad_input(),
            Error::Analysis(e) => e.is_bad_input(),
            Error::Report(e) => e.is_bad_input(),
            Error::MixedSweeps { .. } | Error::Csv(_) | Error::CsvFlush(_) | Error::CsvText(_) => false,
        }
    }
}

/// Result of the harness crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;
