//! The quick integration tests, one module per concern, in one test binary: each binary of
//! `tests/` links the whole pipeline, and these run in seconds, so one link serves them all
//! (`cargo test --test quick`; one module: `cargo test --test quick cli_bad_input::`). The
//! tests that run long (calibrations, judgements, twins) keep their own binaries, which
//! `cargo test` runs one after the other.

mod analysis_measured;
mod analysis_synthetic;
mod cli_bad_input;
mod cli_calibrate;
mod cli_run;
mod cli_sweep;
mod foxglove_layout;
mod mcap_python;
mod mcap_roundtrip;
mod protocol_claims;
mod readers_fuzz;
mod report_analysis;
mod report_figures;
mod samplers_compare;
mod samplers_properties;
mod sim_effects;
mod sim_phenomena;
mod sim_stepping;
mod sweep_runner;
mod time_efficiency;
mod twin_roundtrip;
