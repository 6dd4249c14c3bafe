//! The model of a DRIVE run, below every stage that simulates, logs or analyses one: robots and
//! terrains as commented data ([`robot`], [`terrain`]), the effects a real robot shows and the
//! nominal model lacks ([`effects`]), units and kinematics ([`geometry`], [`kinematics`]), the
//! measurement types and the log of completed steps ([`measurement`]), and the plumbing every
//! stage shares: validated configuration ([`config`]), outputs written whole or not at all
//! ([`output`]), provenance ([`provenance`]), the interrupt request ([`interrupt`]) and the error
//! type ([`error`]).

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
