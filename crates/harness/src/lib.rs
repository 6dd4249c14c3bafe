//! The harness: DRIVE runs composed from the pipeline's stages. Runs in memory
//! ([`mod@simulate`]) or logged to MCAP ([`run`]), the simulator's ground truth
//! ([`ground_truth`]), the analysis of logs written as a report ([`analyze`]), the
//! demonstration ([`demo`]), the sampler comparison ([`samplers`]) and sweeps over robots,
//! terrains, samplers and seeds on batch engines ([`sweep`], each run by [`sweep_run`]).
//!
//! They sit above the stages they compose (simulator, protocol, log, analysis, report) and
//! below the command line, which only parses arguments, calls these and prints; tests and
//! sweeps call them directly.

pub mod analyze;
pub mod demo;
pub mod ground_truth;
pub mod run;
pub mod samplers;
pub mod simulate;
pub mod sweep;
pub mod sweep_run;

pub use simulate::{simulate, simulate_with, unknown_sampler, SimulatedRun};
