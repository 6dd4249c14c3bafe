//! What can fail in the analysis of a log.

/// Errors of the analysis.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A bad file, an I/O or JSON failure on a path (the errors every stage shares).
    #[error(transparent)]
    Model(#[from] drive_sim_model::Error),
    /// A log none of whose steps can be analysed.
    #[error("analysis: {dataset}: no complete step to analyse ({excluded} excluded; {})", first_reasons.join("; "))]
    NoCompleteStep {
        /// The log's dataset name.
        dataset: String,
        /// Steps excluded.
        excluded: usize,
        /// Why the first few were, `step N: reason`.
        first_reasons: Vec<String>,
    },
}

drive_sim_model::shared_error_constructors!(Error);

impl Error {
    /// The shared error this one carries, however deep (an interrupt, a bad file, ...), if any.
    pub fn model(&self) -> Option<&drive_sim_model::Error> {
        match self {
            Error::Model(e) => Some(e),
            _ => None,
        }
    }

    /// Whether the user's input is at fault (exit code 2) rather than the run (exit code 1).
    pub fn is_bad_input(&self) -> bool {
        match self {
            Error::Model(e) => e.is_bad_input(),
            Error::NoCompleteStep { .. } => false,
        }
    }
}

/// Result of the analysis crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;
