//! What can fail in making a twin.

/// Errors of the twin command.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A bad file, option or name, an I/O or JSON failure on a path, an interrupt (the errors
    /// every stage shares).
    #[error(transparent)]
    Model(#[from] drive_sim_model::Error),
    /// An analysis that cannot be done.
    #[error(transparent)]
    Analysis(#[from] drive_sim_analysis::error::Error),
    /// A calibration that failed.
    #[error(transparent)]
    Calibration(#[from] drive_sim_calibration::Error),
    /// A comparison, tuning or judgement that failed.
    #[error(transparent)]
    Compare(#[from] drive_sim_compare::Error),
    /// Neither the tuned twin nor the calibrated one runs its own DRIVE.
    #[error("no runnable twin: {why}")]
    NoRunnableTwin {
        /// What each candidate twin's check said.
        why: String,
    },
}

drive_sim_model::shared_error_constructors!(Error);

impl Error {
    /// The shared error this one carries, however deep (an interrupt, a bad file, ...), if any.
    pub fn model(&self) -> Option<&drive_sim_model::Error> {
        match self {
            Error::Model(e) => Some(e),
            Error::Analysis(e) => e.model(),
            Error::Calibration(e) => e.model(),
            Error::Compare(e) => e.model(),
            Error::NoRunnableTwin { .. } => None,
        }
    }

    /// Whether the user's input is at fault (exit code 2) rather than the run (exit code 1).
    pub fn is_bad_input(&self) -> bool {
        match self {
            Error::Model(e) => e.is_bad_input(),
            Error::Analysis(e) => e.is_bad_input(),
            Error::Calibration(e) => e.is_bad_input(),
            Error::Compare(e) => e.is_bad_input(),
            Error::NoRunnableTwin { .. } => false,
        }
    }
}

/// Result of the twin crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;
