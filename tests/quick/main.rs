//! The quick integration tests, one module per concern, in one test binary: each binary of
//! `tests/` links the whole pipeline, and these run in seconds, so one link serves them all
//! (`cargo test --test quick`; one module: `cargo test --test quick cli_bad_input::`). The
//! tests that run long (calibrations, judgements, twins) are the `long` binary's
//! (`tests/long/main.rs`).

mod analysis_measured;
mod analysis_synthetic;
mod bag_read;
mod cli_bad_input;
mod cli_calibrate;
mod cli_run;
mod cli_sweep;
mod command_space_measured;
mod foxglove_layout;
mod mcap_python;
mod mcap_roundtrip;
mod protocol_claims;
mod readers_fuzz;
mod report_analysis;
mod report_figures;
mod report_render;
mod samplers_compare;
mod samplers_properties;
mod sim_effects;
mod sim_phenomena;
mod sim_stepping;
mod sweep_runner;
mod time_efficiency;
mod twin_roundtrip;
