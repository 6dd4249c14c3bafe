//! The model of a DRIVE run, below every stage that simulates, logs or analyses one: robots and
//! terrains as commented data ([`robot`], [`terrain`]), the effects a real robot shows and the
//! nominal model lacks ([`effects`]), units and kinematics ([`geometry`], [`kinematics`]), the
//! measurement types and the log of completed steps ([`measurement`]), and the plumbing every
//! stage shares: validated configuration ([`config`]), outputs written whole or not at all
//! ([`output`]), provenance ([`provenance`]), the interrupt request ([`interrupt`]) and the error
//! type ([`error`]).

//!
//! ```
//! use drive_sim_model::kinematics::WheelSpeeds;
//! use drive_sim_model::robot::Robot;
//!
//! // A built-in robot by name (a path to a TOML file works too).
//! let (warthog, _file) = Robot::resolve("warthog")?;
//! // Its ideal differential drive: equal wheel speeds drive straight ahead.
//! let v = warthog.idd().body_from_wheels(WheelSpeeds::new(10.0, 10.0));
//! assert!((v.vx_m_s - 3.0).abs() < 1e-9 && v.wz_rad_s == 0.0);
//! // A slow turn in place is in the command space U (wheel and body limits); a fast one is not.
//! assert!(warthog.command_space().contains_wheels(WheelSpeeds::new(5.0, -5.0)));
//! assert!(!warthog.command_space().contains_wheels(WheelSpeeds::new(10.0, -10.0)));
//! # Ok::<(), drive_sim_model::Error>(())
//! ```
#![warn(missing_docs, unreachable_pub)]

pub mod config;
pub mod effects;
pub mod effects_table;
pub mod error;
pub mod geometry;
pub mod interrupt;
pub mod kinematics;
pub mod measurement;
pub mod output;
pub mod provenance;
pub mod robot;
pub mod terrain;

pub use error::{Error, Result};
