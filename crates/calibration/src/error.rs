//! What can fail in a calibration, a replay or a twin.

/// Errors of calibration. Texts keep the `analysis:` prefix the command line has always shown
/// for a calibration that cannot be done.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A bad file or name, an unreadable log, an I/O or JSON failure on a path, a diverged
    /// plant (the errors every stage shares).
    #[error(transparent)]
    Model(#[from] drive_sim_model::Error),
    /// An analysis that cannot be done.
    #[error(transparent)]
    Analysis(#[from] drive_sim_analysis::error::Error),
    /// A figure or report that cannot be drawn.
    #[error(transparent)]
    Report(#[from] drive_sim_report::Error),
    /// A twin asked of a calibration of the kinematic model, whose values are effective.
    #[error(
        "analysis: a twin comes from a simulator calibration; this one fitted the {model_kind} model{why}"
    )]
    TwinOfKinematicModel {
        /// The model the calibration fitted.
        model_kind: String,
        /// Why that model's values do not make a twin, when said.
        why: &'static str,
    },
    /// A joint calibration of fewer than two logs.
    #[error("analysis: a joint calibration needs at least two logs (one log: `calibrate LOG`)")]
    TooFewLogs,
    /// A joint model that cannot be evaluated at its start.
    #[error(
        "analysis: the joint model could not be evaluated at its start (every log's own calibrated model)"
    )]
    JointStartFailed,
    /// A step asked for that the log does not hold.
    #[error("analysis: step {step} is not in the log")]
    StepNotInLog {
        /// The step's number.
        step: u32,
    },
    /// A step asked for in a replay that the log does not hold.
    #[error("analysis: replay: step {step} is not in log `{log}`")]
    ReplayStepNotInLog {
        /// The step's number.
        step: u32,
        /// The log's dataset name.
        log: String,
    },
    /// Split fractions that do not leave three sets.
    #[error("analysis: `{dataset}`: the split fractions must be positive and sum below 1 (train {train}, validation {validation}, test the rest)")]
    SplitFractions {
        /// The log's dataset name.
        dataset: String,
        /// Training fraction.
        train: f64,
        /// Validation fraction.
        validation: f64,
    },
    /// A log with too few completed steps for its split.
    #[error("analysis: `{dataset}` has {steps} completed steps: too few for a train / validation / test split of {:.0} / {:.0} / {:.0} % with at least {min_per_set} steps in each (needs {need})", 100.0 * train, 100.0 * validation, 100.0 * (1.0 - train - validation))]
    TooFewSteps {
        /// The log's dataset name.
        dataset: String,
        /// Completed steps.
        steps: usize,
        /// Steps the split needs.
        need: usize,
        /// Steps each set needs at least.
        min_per_set: usize,
        /// Training fraction.
        train: f64,
        /// Validation fraction.
        validation: f64,
    },
    /// Training steps that give no noise floor.
    #[error("analysis: `{dataset}`: no noise floor from its training steps: {source}")]
    NoNoiseFloor {
        /// The log's dataset name.
        dataset: String,
        /// Why.
        #[source]
        source: Box<Error>,
    },
    /// No steady window with at least two samples, so no scatter to estimate a floor from.
    #[error("analysis: noise floor: no steady window with at least two samples")]
    NoSteadyScatter,
    /// No training step with two steady windows.
    #[error("analysis: `{dataset}`: no training step has two steady windows, so the steady channels have no noise floor estimate (the floor compares the two steady windows of each step)")]
    NoTwoWindowStep {
        /// The log's dataset name.
        dataset: String,
    },
    /// A fit none of whose models could be evaluated.
    #[error("analysis: no model could be evaluated on the {steps} steps fitted ({} parameters: {})", params.len(), params.join(", "))]
    NothingEvaluable {
        /// Steps fitted.
        steps: usize,
        /// The parameters fitted.
        params: Vec<String>,
    },
    /// The kinematic model asked to represent a tyre-contact effect.
    #[error("analysis: the kinematic model has no tyre model and cannot represent the effect `{effect}`")]
    ContactEffectInKinematicModel {
        /// The effect's name.
        effect: String,
    },
    /// A step without samples.
    #[error("analysis: step {step} has no sample")]
    StepWithoutSamples {
        /// The step's number.
        step: u32,
    },
    /// A step whose first sample is missing.
    #[error("analysis: empty step")]
    EmptyStep,
    /// A replayed step that does not line up with its recording.
    #[error(
        "analysis: step {step}: replay has {replay} samples, recording {recording} (step {recording_step})"
    )]
    ReplayMismatch {
        /// The replayed step.
        step: u32,
        /// Samples of the replay.
        replay: usize,
        /// Samples of the recording.
        recording: usize,
        /// The recorded step.
        recording_step: u32,
    },
    /// Steps and start states of a replay that do not pair up.
    #[error("analysis: replay: {steps} steps but {starts} start states")]
    StartStates {
        /// Steps.
        steps: usize,
        /// Start states.
        starts: usize,
    },
    /// A model parameter set to a non-finite value.
    #[error("analysis: parameter `{name}`: non-finite value {value}")]
    NonFiniteParameter {
        /// The parameter's name.
        name: String,
        /// Its value.
        value: f64,
    },
    /// A parameter that names no registered effect parameter.
    #[error("analysis: unknown effect parameter")]
    UnknownEffectParameter,
    /// A fitted robot or terrain that fails its own validation.
    #[error("analysis: {model} parameter `{field}`: {message}")]
    InvalidModel {
        /// "robot" or "terrain".
        model: &'static str,
        /// The field.
        field: String,
        /// What is wrong with its value.
        message: String,
    },
    /// A twin's closed-loop run that needs a sampler the registry lacks.
    #[error("analysis: the {0} sampler is not registered")]
    SamplerMissing(&'static str),
    /// A robot, terrain or twin file that cannot be written as TOML.
    #[error("analysis: cannot write {what}: {source}")]
    Toml {
        /// What was being written.
        what: &'static str,
        /// The serializer's error.
        #[source]
        source: toml::ser::Error,
    },
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
            _ => false,
        }
    }
}

/// Result of the calibration crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;
