//! What the calibration varies: a model is a robot, a terrain and a set of named effects; a
//! [`PlantFactory`] turns one into a [`Plant`]. Parameters are addressed by dotted names
//! (`terrain.friction.peak_longitudinal`, `robot.wheels.baseline_m`, `effect.dead_time_s`) so
//! the optimizer never needs to know which struct holds them.

use super::surrogate::KinematicPlant;
use crate::config::Validate;
use crate::error::{Error, Result};
use crate::robot::Robot;
use crate::sim::effects::Effects;
use crate::sim::{IdealPlant, Plant, SimConfig, Simulator};
use crate::terrain::Terrain;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Everything a plant is built from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelParams {
    /// Robot model (declared values, possibly refitted).
    pub robot: Robot,
    /// Terrain profile.
    pub terrain: Terrain,
    /// Model effects switched on, by their `Effects` name, with their value.
    pub effects: BTreeMap<String, f64>,
}

impl ModelParams {
    /// A model with no effect.
    pub fn new(robot: Robot, terrain: Terrain) -> Self {
        Self {
            robot,
            terrain,
            effects: BTreeMap::new(),
        }
    }

    /// The effects as the simulator's [`Effects`] (validated by [`Effects::set`]).
    pub fn sim_effects(&self) -> Result<Effects> {
        let mut effects = Effects::default();
        for (name, value) in &self.effects {
            effects.set(name, *value)?;
        }
        Ok(effects)
    }

    /// Current value of a named parameter (an absent effect reads as `None`).
    pub fn get(&self, name: &str) -> Result<Option<f64>> {
        if let Some(effect) = name.strip_prefix("effect.") {
            return Ok(self.effects.get(effect).copied());
        }
        let (root, path) = split_root(name)?;
        let value = match root {
            "robot" => serde_json::to_value(&self.robot),
            _ => serde_json::to_value(&self.terrain),
        }
        .map_err(|e| Error::Analysis(format!("parameter `{name}`: {e}")))?;
        let mut v = &value;
        for part in path.split('.') {
            v = v
                .get(part)
                .ok_or_else(|| Error::Analysis(format!("unknown parameter `{name}`")))?;
        }
        Ok(v.as_f64())
    }

    /// Sets a named parameter; fails on an unknown name, or a value that makes the robot or
    /// terrain invalid (named in the error).
    pub fn set(&mut self, name: &str, value: f64) -> Result<()> {
        if !value.is_finite() {
            return Err(Error::Analysis(format!(
                "parameter `{name}`: non-finite value {value}"
            )));
        }
        if let Some(effect) = name.strip_prefix("effect.") {
            self.effects.insert(effect.to_string(), value);
            return Ok(());
        }
        let (root, path) = split_root(name)?;
        match root {
            "robot" => self.robot = set_path(&self.robot, name, path, value)?,
            _ => self.terrain = set_path(&self.terrain, name, path, value)?,
        }
        Ok(())
    }
}

fn split_root(name: &str) -> Result<(&str, &str)> {
    match name.split_once('.') {
        Some((root @ ("robot" | "terrain"), path)) if !path.is_empty() => Ok((root, path)),
        _ => Err(Error::Analysis(format!(
            "unknown parameter `{name}`: expected `robot.<field>`, `terrain.<field>` or `effect.<name>`"
        ))),
    }
}

/// Sets one numeric field of a serializable, validated struct through its serde form.
fn set_path<T>(obj: &T, name: &str, path: &str, value: f64) -> Result<T>
where
    T: Serialize + serde::de::DeserializeOwned + Validate,
{
    let err = |m: String| Error::Analysis(format!("parameter `{name}`: {m}"));
    let mut root = serde_json::to_value(obj).map_err(|e| err(e.to_string()))?;
    let mut v = &mut root;
    for part in path.split('.') {
        v = v.get_mut(part).ok_or_else(|| err("no such field".to_string()))?;
    }
    if !v.is_number() {
        return Err(err("not a numeric field".to_string()));
    }
    *v = if v.is_u64() || v.is_i64() {
        if value < 0.0 || value.fract() != 0.0 {
            return Err(err(format!("integer field, got {value}")));
        }
        serde_json::Value::from(value as u64)
    } else {
        serde_json::Value::from(value)
    };
    let out: T = serde_json::from_value(root).map_err(|e| err(e.to_string()))?;
    out.validate()
        .map_err(|(field, m)| err(format!("{field}: {m}")))?;
    Ok(out)
}

/// One parameter the optimizer may vary, with its search box.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ParamSpec {
    /// Dotted name (see [`ModelParams::set`]).
    pub name: String,
    /// Lower bound.
    pub lower: f64,
    /// Upper bound.
    pub upper: f64,
    /// Only the two bounds are meaningful (an on/off effect such as a sign flip).
    #[serde(default)]
    pub discrete: bool,
    /// Where the search starts when the model has no value for it (an effect that is off):
    /// the effect's neutral value. Midpoint of the box when `None`.
    #[serde(default)]
    pub start: Option<f64>,
}

impl ParamSpec {
    /// A continuous parameter in `[lower, upper]`.
    pub fn new(name: impl Into<String>, lower: f64, upper: f64) -> Self {
        Self {
            name: name.into(),
            lower,
            upper,
            discrete: false,
            start: None,
        }
    }
    /// Sets the start value.
    pub fn with_start(mut self, start: f64) -> Self {
        self.start = Some(start);
        self
    }
    /// Makes the parameter on/off: only `lower` and `upper` are tried.
    pub fn discrete(mut self) -> Self {
        self.discrete = true;
        self
    }
}

/// Builds plants from model parameters; one factory per simulator kind.
pub trait PlantFactory: Sync {
    /// Short name for reports (`simulator`, `kinematic`, `idd`).
    fn name(&self) -> String;
    /// Builds a plant (noise-free: the calibration compares a deterministic prediction).
    fn build(&self, params: &ModelParams) -> Result<Box<dyn Plant>>;
    /// Effect names this plant implements (a subset of the simulator's `Effects::NAMES`).
    fn effect_names(&self) -> Vec<String>;
    /// Terrain and robot parameters this plant depends on, with their search boxes: what the
    /// terrain-calibration stage fits.
    fn calibration_params(&self, params: &ModelParams) -> Vec<ParamSpec>;
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
    fn effect_names(&self) -> Vec<String> {
        Vec::new()
    }
    fn calibration_params(&self, _params: &ModelParams) -> Vec<ParamSpec> {
        Vec::new()
    }
}

/// The kinematic grey-box model ([`KinematicPlant`]): IDD + first-order wheel lag + effects.
/// Cheap (microseconds per step): the test bed of the calibration and a fast fallback model.
/// It ignores the terrain; its calibrated parameters are the effective baseline and the
/// powertrain time constant.
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
            params.sim_effects()?,
            None,
        )?))
    }
    fn effect_names(&self) -> Vec<String> {
        Effects::NAMES
            .iter()
            .filter(|n| !Effects::CONTACT.contains(n))
            .map(|s| s.to_string())
            .collect()
    }
    fn calibration_params(&self, params: &ModelParams) -> Vec<ParamSpec> {
        let b = params.robot.wheels.baseline_m;
        // Skid-steer effective baselines are reported up to ~2x the geometric one; the robot
        // file's validation caps the baseline at 1.5x the body width. Never narrower than 0.7x.
        let upper = (2.5 * b).min(1.5 * params.robot.body.width_m);
        vec![
            ParamSpec::new("robot.wheels.baseline_m", 0.7 * b, upper.max(b)),
            ParamSpec::new("robot.powertrain.time_constant_s", 0.02, 1.5),
        ]
    }
}

/// The rapier simulator ([`Simulator`]), noise-free, with the model's effects set through
/// [`Effects::set`]. Its calibrated parameters are the terrain's friction profile and rolling
/// resistance and the powertrain time constant.
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
        let effects = params.sim_effects()?;
        let cfg = SimConfig {
            seed: 0,
            physics_hz: self.physics_hz,
            effects,
            ..SimConfig::default()
        };
        Ok(Box::new(Simulator::new(&params.robot, &params.terrain, cfg)?))
    }
    fn effect_names(&self) -> Vec<String> {
        Effects::NAMES.iter().map(|s| s.to_string()).collect()
    }
    fn calibration_params(&self, params: &ModelParams) -> Vec<ParamSpec> {
        let f = &params.terrain.friction;
        // Peaks are searched above the (fixed) sliding values, so every point of the box is a
        // valid terrain; the terrain file's validation caps friction at 3.
        let top = |declared: f64| (1.5 * declared).clamp(1.2, 3.0);
        vec![
            ParamSpec::new(
                "terrain.friction.peak_longitudinal",
                f.sliding_longitudinal,
                top(f.peak_longitudinal),
            ),
            ParamSpec::new(
                "terrain.friction.peak_lateral",
                f.sliding_lateral,
                top(f.peak_lateral),
            ),
            ParamSpec::new("terrain.friction.peak_slip_ratio", 0.02, 0.5),
            ParamSpec::new("terrain.resistance.rolling_coefficient", 0.0, 0.3),
            ParamSpec::new("robot.powertrain.time_constant_s", 0.02, 1.5),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> ModelParams {
        let (robot, _) = Robot::resolve("warthog").unwrap();
        let (terrain, _) = Terrain::resolve("asphalt").unwrap();
        ModelParams::new(robot, terrain)
    }

    #[test]
    fn set_and_get_by_name() {
        let mut p = params();
        p.set("terrain.friction.peak_longitudinal", 0.93).unwrap();
        assert_eq!(p.terrain.friction.peak_longitudinal, 0.93);
        assert_eq!(p.get("terrain.friction.peak_longitudinal").unwrap(), Some(0.93));
        // Cross-field validation: peak below sliding friction is refused.
        let e = p
            .set("terrain.friction.peak_longitudinal", 0.1)
            .unwrap_err()
            .to_string();
        assert!(e.contains("sliding_longitudinal"), "{e}");
        p.set("robot.wheels.baseline_m", 1.5).unwrap();
        assert_eq!(p.robot.wheels.baseline_m, 1.5);
        p.set("effect.dead_time_s", 0.1).unwrap();
        assert_eq!(p.get("effect.dead_time_s").unwrap(), Some(0.1));
        assert_eq!(p.get("effect.motor_gain_left").unwrap(), None);
    }

    #[test]
    fn bad_names_and_values_are_errors() {
        let mut p = params();
        let e = p.set("terrain.friction.nope", 1.0).unwrap_err().to_string();
        assert!(e.contains("terrain.friction.nope"), "{e}");
        assert!(p.set("wheels.radius_m", 1.0).is_err());
        // Validation runs: a negative mass is refused, naming the field.
        let e = p.set("robot.body.mass_kg", -1.0).unwrap_err().to_string();
        assert!(e.contains("body.mass_kg"), "{e}");
        assert!(p.set("robot.wheels.per_side", 1.5).is_err());
        assert!(p.set("effect.dead_time_s", f64::NAN).is_err());
        // A failed set leaves the model unchanged.
        assert_eq!(p.robot.body.mass_kg, 470.0);
    }
}
