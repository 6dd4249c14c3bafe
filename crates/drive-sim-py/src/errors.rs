//! Errors as Python exceptions, by the command line's classes (`stage_error` in
//! `src/cli/mod.rs`): bad input (a bad file, value or name) is `ValueError` with the command
//! line's message, an I/O failure `OSError` (`FileNotFoundError` for a missing file), an
//! interrupt `KeyboardInterrupt`, anything else (a diverged simulation) `RuntimeError`; and the
//! interpreter's signal check during a run.

use drive_sim_model::Error as ModelError;
use drive_sim_protocol::CancelToken;
use pyo3::exceptions::{PyFileNotFoundError, PyKeyboardInterrupt, PyOSError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use std::time::{Duration, Instant};

/// The errors of every stage: the shared one they may carry, and whether the user's input is
/// at fault.
pub(crate) trait StageError: std::fmt::Display {
    /// The shared error carried, if any.
    fn shared(&self) -> Option<&ModelError>;
    /// Bad input (the command line's exit code 2).
    fn bad_input(&self) -> bool;
}

impl StageError for ModelError {
    fn shared(&self) -> Option<&ModelError> {
        Some(self)
    }
    fn bad_input(&self) -> bool {
        self.is_bad_input()
    }
}

macro_rules! stage_errors {
    ($($t:ty),*) => {$(
        impl StageError for $t {
            fn shared(&self) -> Option<&ModelError> {
                self.model()
            }
            fn bad_input(&self) -> bool {
                self.is_bad_input()
            }
        }
    )*};
}

stage_errors!(
    drive_sim_harness::Error,
    drive_sim_analysis::Error,
    drive_sim_calibration::Error,
    drive_sim_compare::Error,
    drive_sim_twin::Error
);

/// The Python exception of a stage's error, with its message.
pub(crate) fn to_py(e: &dyn StageError) -> PyErr {
    let message = e.to_string();
    match e.shared() {
        Some(ModelError::Io { source, .. }) if source.kind() == std::io::ErrorKind::NotFound => {
            PyFileNotFoundError::new_err(message)
        }
        Some(ModelError::Io { .. } | ModelError::Json { .. }) => PyOSError::new_err(message),
        Some(ModelError::Interrupted { .. }) => PyKeyboardInterrupt::new_err(message),
        _ if e.bad_input() => PyValueError::new_err(message),
        _ => PyRuntimeError::new_err(message),
    }
}

/// How often a run re-acquires the GIL to run the interpreter's signal handlers (Ctrl-C).
pub(crate) const SIGNAL_CHECK_EVERY: Duration = Duration::from_millis(50);

/// The interpreter's signal check, polled from a run that released the GIL: once a handler
/// raises (`KeyboardInterrupt`), the run's cancel token is set and the exception kept to be
/// raised when the run has stopped.
pub(crate) struct SignalWatch {
    cancel: CancelToken,
    last: Instant,
    /// The exception a signal handler raised.
    pub(crate) raised: Option<PyErr>,
}

impl SignalWatch {
    /// A watch that cancels `cancel`.
    pub(crate) fn new(cancel: CancelToken) -> Self {
        Self {
            cancel,
            last: Instant::now(),
            raised: None,
        }
    }

    /// Runs the signal handlers if [`SIGNAL_CHECK_EVERY`] has passed since the last check.
    pub(crate) fn poll(&mut self) {
        if self.raised.is_some() || self.last.elapsed() < SIGNAL_CHECK_EVERY {
            return;
        }
        self.last = Instant::now();
        if let Err(e) = Python::with_gil(|py| py.check_signals()) {
            self.raised = Some(e);
            self.cancel.cancel();
        }
    }
}
