//! Simulation: the rapier3d vehicle model of a skid-steering robot on a terrain, its sensors,
//! and the ideal plant used as a reference.

pub mod plant;

pub use plant::{IdealPlant, Plant};
