//! What a calibrated model is: a robot, a terrain and a set of effects ([`ModelParams`]); a
//! [`PlantFactory`] turns one into a [`Plant`] and says which of its parameters the data can
//! fit.

use super::params::{Param, ParamSpec};
use super::surrogate::KinematicPlant;
use crate::error::Result;
use drive_sim_model::effects::{Effect, Effects};
use drive_sim_model::robot::Robot;
use drive_sim_model::terrain::Terrain;
use drive_sim_sim::{IdealPlant, Plant, SimConfig, Simulator};
use serde::{Deserialize, Serialize};

/// Everything a plant is built from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelParams {
    /// Robot model (declared values, possibly refitted).
    pub robot: Robot,
    /// Terrain profile.
    pub terrain: Terrain,
    /// Model effects switched on, with their parameter values (a map from parameter name to
    /// value in JSON).
    pub effects: Effects,
}

impl ModelParams {
    /// A model with no effect.
    pub fn new(robot: Robot, terrain: Terrain) -> Self {
        Self {
            robot,
            terrain,
            effects: Effects::default(),
        }
    }
}

/// Builds plants from model parameters; one factory per simulator kind.
pub trait PlantFactory: Sync {
    /// Short name for reports (`simulator`, `kinematic`, `idd`).
    fn name(&self) -> String;
    /// Builds a plant (noise-free: the calibration compares a deterministic prediction).
    fn build(&self, params: &ModelParams) -> Result<Box<dyn Plant>>;
    /// Whether this plant can run `effect`.
    fn supports(&self, effect: &dyn Effect) -> bool;
    /// Terrain and robot parameters this plant depends on, with their search boxes: what the
    /// base fit adjusts and what is refit beside a candidate effect.
    fn base_params(&self, params: &ModelParams) -> Vec<ParamSpec>;
    /// Whether `param` is a property of the ground under the robot in this plant (fitted once
    /// per log in a joint calibration, [`super::joint`]): [`Param::on_terrain`] unless the
    /// plant's own base parameter stands in for the ground.
    fn on_terrain(&self, param: &Param) -> bool {
        param.on_terrain()
    }
}

/// The ideal differential drive with instantaneous wheels: the "IDD prediction" reference.
#[derive(Debug, Clone, Copy, Default)]
pub struct IddFactory;

impl PlantFactory for IddFactory {
    fn name(&self) -> String {
        "idd".into()
    }
    fn build(&self, params: &ModelParams) -> Result<Box<dyn Plant>> {
        Ok(Box::new(IdealPlant::new(params.robot.idd(), 0.0)))
    }
    fn supports(&self, _effect: &dyn Effect) -> bool {
        false
    }
    fn base_params(&self, _params: &ModelParams) -> Vec<ParamSpec> {
        Vec::new()
    }
}

/// The kinematic grey-box model ([`KinematicPlant`]): IDD + first-order wheel lag + effects.
/// Cheap (microseconds per step): the screening model of simulator calibrations, the test bed
/// of the calibration, and a fast model of its own. It ignores the terrain; its base
/// parameters are the effective baseline and the powertrain time constant.
#[derive(Debug, Clone, Copy, Default)]
pub struct KinematicFactory;

impl PlantFactory for KinematicFactory {
    fn name(&self) -> String {
        "kinematic".into()
    }
    fn build(&self, params: &ModelParams) -> Result<Box<dyn Plant>> {
        Ok(Box::new(KinematicPlant::new(
            params.robot.idd(),
            params.robot.powertrain.time_constant_s,
            params.effects.clone(),
            None,
        )?))
    }
    fn supports(&self, effect: &dyn Effect) -> bool {
        effect.kinematic()
    }
    fn base_params(&self, params: &ModelParams) -> Vec<ParamSpec> {
        let b = params.robot.wheels.baseline_m;
        // Skid-steer effective baselines are reported up to ~2x the geometric one; the robot
        // file's validation caps the baseline at 1.5x the body width. Never narrower than 0.7x.
        let upper = (2.5 * b).min(1.5 * params.robot.body.width_m);
        vec![
            ParamSpec::new(Param::Baseline, 0.7 * b, upper.max(b)),
            ParamSpec::new(Param::TimeConstant, 0.02, 1.5),
        ]
    }
    fn on_terrain(&self, param: &Param) -> bool {
        // The effective baseline of a skid-steer is how far its wheels slip sideways in a
        // turn: a property of the ground (2.24, 1.86 and 2.02 m on the Warthog's asphalt, ice
        // and gravel runs for a geometric 1.08 m).
        *param == Param::Baseline || param.on_terrain()
    }
}

/// The rapier simulator ([`Simulator`]), noise-free, with the model's effects. Its base
/// parameters are the terrain's friction profile and rolling resistance, the powertrain
/// time constant and, where the robot file calls it an estimate, the wheelbase.
#[derive(Debug, Clone, Copy)]
pub struct SimFactory {
    /// Physics rate, Hz.
    pub physics_hz: f64,
}

impl Default for SimFactory {
    fn default() -> Self {
        Self {
            physics_hz: SimConfig::default().physics_hz,
        }
    }
}

impl PlantFactory for SimFactory {
    fn name(&self) -> String {
        "simulator".into()
    }
    fn build(&self, params: &ModelParams) -> Result<Box<dyn Plant>> {
        let cfg = SimConfig {
            seed: 0,
            physics_hz: self.physics_hz,
            effects: params.effects.clone(),
            ..SimConfig::default()
        };
        Ok(Box::new(Simulator::new(&params.robot, &params.terrain, cfg)?))
    }
    fn supports(&self, _effect: &dyn Effect) -> bool {
        true
    }
    fn base_params(&self, params: &ModelParams) -> Vec<ParamSpec> {
        let f = &params.terrain.friction;
        // Peaks are searched above the (fixed) sliding values, so every point of the box is a
        // valid terrain; the terrain file's validation caps friction at 3.
        let top = |declared: f64| (1.5 * declared).clamp(1.2, 3.0);
        let mut specs = vec![
            ParamSpec::new(
                Param::PeakLongitudinal,
                f.sliding_longitudinal,
                top(f.peak_longitudinal),
            ),
            ParamSpec::new(Param::PeakLateral, f.sliding_lateral, top(f.peak_lateral)),
            ParamSpec::new(Param::PeakSlipRatio, 0.02, 0.5),
            ParamSpec::new(Param::RollingCoefficient, 0.0, 0.3),
            ParamSpec::new(Param::SlidingShareLongitudinal, 0.5, 1.0),
            ParamSpec::new(Param::TimeConstant, 0.02, 1.5),
        ];
        // The wheelbase is fitted where the robot file calls it an estimate: a datasheet's
        // wheelbase is geometry, and a fit that moves it stands in for a turning resistance
        // the model lacks (the Husky's 0.512 m went to the top of its box). Robots with one
        // wheel a side have none. The box: from 0.6 of the declared (the contact patches of
        // wide, soft tyres and a suspension that unloads the outer wheels shorten the scrub's
        // lever) to the body's length.
        let w = &params.robot.wheels;
        if w.wheelbase_estimated && w.per_side > 1 && w.wheelbase_m > 0.0 {
            let top = (1.2 * w.wheelbase_m).min(params.robot.body.length_m);
            specs.push(ParamSpec::new(Param::Wheelbase, 0.6 * w.wheelbase_m, top));
        }
        specs
    }
}
