//! The harness: DRIVE runs composed from the pipeline's stages. Runs in memory
//! ([`mod@simulate`]) or logged to MCAP ([`run`]), the simulator's ground truth
//! ([`ground_truth`]), the analysis of logs written as a report ([`analyze`]), the
//! demonstration ([`demo`]), the sampler comparison ([`samplers`]) and sweeps over robots,
//! terrains, samplers and seeds on batch engines ([`sweep`], each run by [`sweep_run`]).
//!
//! They sit above the stages they compose (simulator, protocol, log, analysis, report) and
//! below the command line, which only parses arguments, calls these and prints; tests and
//! sweeps call them directly.

//!
//! ```no_run
//! use drive_sim_harness::simulate;
//! use drive_sim_model::{robot::Robot, terrain::Terrain};
//! use drive_sim_sim::SensorNoise;
//!
//! let robot = Robot::resolve("warthog")?.0;
//! let terrain = Terrain::resolve("gravel")?.0;
//! // A 20-step DRIVE in memory with typical field sensors, analysed like a measured log.
//! let run = simulate(&robot, &terrain, "uniform-wheel", 20, 7, SensorNoise::typical())?;
//! let analysis = drive_sim_analysis::analyze(&run.log, &Default::default())?;
//! println!("{} steps, time efficiency {:.2}", run.summary.steps_completed, run.summary.time_efficiency);
//! # let _ = analysis;
//! # Ok::<(), drive_sim_harness::Error>(())
//! ```
#![warn(missing_docs, unreachable_pub)]

pub mod error;
pub use error::{Error, Result};

pub mod analyze;
pub mod demo;
pub mod ground_truth;
pub mod run;
pub mod samplers;
pub mod simulate;
pub mod sweep;
pub mod sweep_run;

pub use simulate::{simulate, simulate_matched, simulate_with, unknown_sampler, SimulatedRun};
