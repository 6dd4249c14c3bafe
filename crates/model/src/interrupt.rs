//! SIGINT / SIGTERM as a request to stop cleanly: long loops (the protocol's, a sweep's) poll
//! [`requested`] and wind down, so that a log is closed with a valid summary (as
//! `NAME.interrupted.mcap`) instead of being cut mid-record. A second signal while winding
//! down ends the process at once (the default behaviour the user expects from a second Ctrl-C).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};

/// The exit code of an interrupted command (128 + SIGINT, as shells report it).
pub const EXIT_CODE: i32 = 130;

fn flag() -> &'static Arc<AtomicBool> {
    static FLAG: OnceLock<Arc<AtomicBool>> = OnceLock::new();
    FLAG.get_or_init(|| Arc::new(AtomicBool::new(false)))
}

/// Installs the SIGINT and SIGTERM handlers (once; later calls do nothing). Without them (the
/// library used from tests or other programs) a signal keeps its default action.
pub fn install() {
    static INSTALLED: OnceLock<()> = OnceLock::new();
    INSTALLED.get_or_init(|| {
        #[cfg(unix)]
        for sig in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
            // A second signal, once the first has set the flag, exits at once.
            let _ = signal_hook::flag::register_conditional_shutdown(sig, EXIT_CODE, Arc::clone(flag()));
            let _ = signal_hook::flag::register(sig, Arc::clone(flag()));
        }
    });
}

/// True once SIGINT or SIGTERM has been received (or [`request`] called).
pub fn requested() -> bool {
    flag().load(Ordering::Relaxed)
}

/// Asks the running loops to stop, as a signal would.
pub fn request() {
    flag().store(true, Ordering::Relaxed);
}
