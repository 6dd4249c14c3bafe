//! A per-run request to stop: [`CancelToken`]. The process-wide flag of
//! [`drive_sim_model::interrupt`] stops every loop of a command-line process on SIGINT; a
//! library caller running several runs (a Python session, a server) stops one run with its
//! own token, polled by the protocol loop beside that flag.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// Asks one run to stop between two frames, as a signal would the whole process; clones
/// share the request. The run ends with [`drive_sim_model::Error::Interrupted`] and its log is
/// closed as the interrupted log the command line keeps.
#[derive(Debug, Clone, Default)]
pub struct CancelToken(Arc<AtomicBool>);

impl CancelToken {
    /// A token not cancelled yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Asks the run (or runs) holding this token to stop.
    pub fn cancel(&self) {
        self.0.store(true, Ordering::Relaxed);
    }

    /// True once [`CancelToken::cancel`] has been called on this token or a clone.
    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }
}
