//! The long integration tests, one module per concern, in one test binary: calibrations,
//! discovery, `compare`, `judge`, `tune` and `twin` on generated and measured runs, and the
//! README's examples, each taking from seconds to a minute. Each binary of `tests/` links the whole pipeline; in one binary
//! they share that link and the test harness keeps both cores busy until the last test, where
//! binaries run one after the other each leave a core idle at their end
//! (`cargo test --test long`; one module: `cargo test --test long judge::`).
//!
//! The README's examples (`readme_examples`) run one command after another on one core: here
//! the other tests fill the second. The measured-data calibrations
//! (`tests/calibration_sim.rs`, `tests/calibration_measured.rs`) and the measurements of the
//! methods' statistical properties (`tests/statistics/`) are tiers of their own outside `cargo
//! test`.

#[path = "../common/mod.rs"]
mod common;

#[allow(dead_code)] // the benchmark's cases and scores the family tests do not use
#[path = "../bench_cases/mod.rs"]
mod bench_cases;

mod calibration_synthetic;
mod calibration_uncertainty;
mod compare;
mod discovery;
mod discovery_families;
mod judge;
mod readme_examples;
mod tune;
mod twin;
mod twin_joint;
