//! Experiments composed from the library's stages: DRIVE runs in memory ([`mod@simulate`]) or logged
//! to MCAP ([`run`]), the analysis of logs ([`analyze`]), the demonstration ([`demo`]), the
//! sampler comparison ([`samplers`]), what one sweep run does ([`sweep`]), closed-loop tuning
//! ([`tune`]) and judging a twin against a real run ([`judge`]).
//!
//! They sit above the stages they compose (simulator, protocol, log, analysis, report) and
//! below the command line, which only parses arguments, calls these and prints; tests and
//! sweeps call them directly.

pub mod analyze;
pub mod demo;
pub mod judge;
pub mod real_steps;
pub mod run;
pub mod samplers;
pub mod simulate;
pub mod sweep;
pub mod tune;

pub use simulate::{simulate, simulate_with, unknown_sampler, SimulatedRun};
