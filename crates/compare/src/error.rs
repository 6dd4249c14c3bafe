//! What can fail in comparing, tuning or judging a twin.

/// Errors of compare, tune and judge.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A bad file, an I/O or JSON failure on a path, a diverged plant (the errors every stage
    /// shares).
    #[error(transparent)]
    Model(#[from] drive_sim_model::Error),
    /// An analysis that cannot be done.
    #[error(transparent)]
    Analysis(#[from] drive_sim_analysis::error::Error),
    /// A figure or report that cannot be drawn.
    #[error(transparent)]
    Report(#[from] drive_sim_report::Error),
    /// A run of the harness that failed.
    #[error(transparent)]
    Harness(#[from] drive_sim_harness::Error),
    /// A calibration or twin that failed.
    #[error(transparent)]
    Calibration(#[from] drive_sim_calibration::Error),
    /// Too few of the twin's own runs completed to compare it with the real run.
    #[error("analysis: judge: {completed} of {asked} runs of the twin completed: nothing to judge (see the runs' errors: {})", errors.join("; "))]
    TooFewTwinRuns {
        /// Runs that completed.
        completed: usize,
        /// Runs asked for.
        asked: u32,
        /// Why the others failed.
        errors: Vec<String>,
    },
    /// Too few reference runs completed for a Monte Carlo p-value.
    #[error("analysis: judge: {completed} of {asked} reference runs completed: too few for a p-value ({})", errors.join("; "))]
    TooFewReferences {
        /// Reference runs that completed.
        completed: usize,
        /// Reference runs asked for.
        asked: u32,
        /// Why the others failed.
        errors: Vec<String>,
    },
    /// A `tune.json` read back without its model: no twin can be written from it.
    #[error("analysis: a tuning read back from JSON has no model")]
    TuningWithoutModel,
}

drive_sim_model::shared_error_constructors!(Error);

impl Error {
    /// The shared error this one carries, however deep (an interrupt, a bad file, ...), if any.
    pub fn model(&self) -> Option<&drive_sim_model::Error> {
        match self {
            Error::Model(e) => Some(e),
            Error::Analysis(e) => e.model(),
            Error::Report(e) => e.model(),
            Error::Harness(e) => e.model(),
            Error::Calibration(e) => e.model(),
            _ => None,
        }
    }

    /// Whether the user's input is at fault (exit code 2) rather than the run (exit code 1).
    pub fn is_bad_input(&self) -> bool {
        match self {
            Error::Model(e) => e.is_bad_input(),
            Error::Analysis(e) => e.is_bad_input(),
            Error::Report(e) => e.is_bad_input(),
            Error::Harness(e) => e.is_bad_input(),
            Error::Calibration(e) => e.is_bad_input(),
            Error::TooFewTwinRuns { .. } | Error::TooFewReferences { .. } | Error::TuningWithoutModel => {
                false
            }
        }
    }
}

/// Result of the compare crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;
