//! drive-sim: a simulation-backed test harness for the DRIVE protocol.
//!
//! Data flows one way: robot, terrain and effect models ([`robot`], [`terrain`], [`effects`]) →
//! simulator ([`sim`])
//! driven by the protocol ([`protocol`]) → logs ([`log`]) → analysis ([`analysis`]) and
//! calibration ([`calibration`]) → figures and reports ([`report`]). The [`cli`] wires them.

pub mod analysis;
pub mod calibration;
pub mod cli;
pub mod config;
pub mod effects;
pub mod error;
pub mod geometry;
pub mod kinematics;
pub mod log;
pub mod protocol;
pub mod report;
pub mod robot;
pub mod sim;
pub mod sweep;
pub mod terrain;

pub use error::{Error, Result};
