//! drive-sim: a simulation-backed test harness for the DRIVE protocol.
//!
//! Data flows one way: robot, terrain and effect models ([`robot`], [`terrain`], [`effects`]) →
//! simulator ([`sim`])
//! driven by the protocol ([`protocol`]) → logs ([`log`]) → analysis ([`analysis`]) and
//! calibration ([`calibration`]) → figures and reports ([`report`]) → experiments composed from
//! them ([`experiments`]: runs, analysis, demo, sampler comparison, sweep runs). The [`cli`]
//! parses arguments, calls those and prints. The data model of a run (measurements, frames,
//! the log of completed steps) sits below all of them in [`measurement`].

pub mod analysis;
pub mod calibration;
pub mod cli;
pub mod compare;
pub mod config;
pub mod discovery;
pub mod effects;
pub mod effects_table;
pub mod error;
pub mod experiments;
pub mod geometry;
pub mod interrupt;
pub mod kinematics;
pub mod log;
pub mod measurement;
pub mod output;
pub mod protocol;
pub mod provenance;
pub mod report;
pub mod robot;
pub mod sim;
pub mod sweep;
pub mod terrain;

pub use error::{Error, Result};
