//! drive-sim: a simulation-backed test harness for the DRIVE protocol.
//!
//! The work is split into crates along the pipeline, so that Cargo enforces the direction in
//! which data flows (a crate can only use those before it); this crate re-exports them under
//! one name and holds the `drive-sim` binary, which parses arguments, calls them and prints.
//!
//! | crate | re-exported as | what it is |
//! |---|---|---|
//! | [`drive_sim_model`] | [`robot`], [`terrain`], [`effects`], [`kinematics`], [`measurement`], ... | robots, terrains and effects as data; units, kinematics, measurement types |
//! | [`drive_sim_sim`] | [`sim`] | the rapier3d simulator and the ideal plant |
//! | [`drive_sim_protocol`] | [`protocol`] | the DRIVE loop on a plant, and its samplers |
//! | [`drive_sim_log`] | [`log`] | MCAP, rosbag2 and CSV readers and writers |
//! | [`drive_sim_analysis`] | [`analysis`] | slips, ρ, the spaces U/S/T, smoothed transfer functions |
//! | [`drive_sim_report`] | [`report`] | figures and HTML reports |
//! | [`drive_sim_harness`] | [`harness`] | runs, the analysis command, sampler comparisons, sweeps, the demo |
//! | [`drive_sim_calibration`] | [`calibration`], [`discovery`] | calibration by replay and equation discovery |
//! | [`drive_sim_compare`] | [`compare`] | compare a twin with its robot, tune it in closed loop, judge it |
//! | [`drive_sim_twin`] | [`twin`] | a judged twin from a robot's runs in one call |
//!
//! See `docs/architecture.md` in the repository for the design and how to add an effect, a
//! sampler, a reader or a robot.

pub use drive_sim_model::{
    config, effects, effects_table, error, geometry, interrupt, kinematics, measurement, output, provenance,
    robot, terrain, Error, Result,
};

pub use drive_sim_analysis as analysis;
pub use drive_sim_calibration as calibration;
pub use drive_sim_calibration::discovery;
pub use drive_sim_compare as compare;
pub use drive_sim_harness as harness;
pub use drive_sim_log as log;
pub use drive_sim_protocol as protocol;
pub use drive_sim_report as report;
pub use drive_sim_sim as sim;
pub use drive_sim_twin as twin;
