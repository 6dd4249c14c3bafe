//! `drive_sim._native`: the extension module of the Python package `drive_sim` (the pure
//! Python side is `python/drive_sim/`). Each function is thin over the library crates, as the
//! command line is: `run` over [`drive_sim_harness::run`], `analyze` over
//! [`drive_sim_harness::analyze`], `compare` over [`drive_sim_compare`], `calibrate` over
//! [`drive_sim_calibration::calibrate_logs`], `twin` over [`drive_sim_twin::make_twin`]. Results cross as JSON text (the same serialisation as
//! the files the command line writes) and as columns (lists of floats) that the Python side
//! turns into dicts and DataFrames.
//!
//! The GIL is released while Rust works; a Ctrl-C reaches a run through a per-run
//! [`drive_sim_protocol::CancelToken`], set when the interpreter's signal check (re-acquiring
//! the GIL every 50 ms) raises.
#![warn(missing_docs, unreachable_pub)]

mod analyze;
mod catalog;
mod errors;
mod run;
mod sampler;

use pyo3::prelude::*;

/// The module `drive_sim._native`.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("STEP_COLUMNS", sampler::STEP_COLUMNS.to_vec())?;
    m.add_function(wrap_pyfunction!(run::run, m)?)?;
    m.add_function(wrap_pyfunction!(analyze::analyze, m)?)?;
    m.add_function(wrap_pyfunction!(analyze::compare, m)?)?;
    m.add_function(wrap_pyfunction!(analyze::calibrate, m)?)?;
    m.add_function(wrap_pyfunction!(analyze::twin, m)?)?;
    m.add_function(wrap_pyfunction!(catalog::robots, m)?)?;
    m.add_function(wrap_pyfunction!(catalog::terrains, m)?)?;
    m.add_function(wrap_pyfunction!(catalog::samplers, m)?)?;
    Ok(())
}
