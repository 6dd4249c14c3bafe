//! What calibration varies, as typed parameters: a robot or terrain quantity, or a parameter
//! of a registered effect ([`drive_sim_model::effects`]), each with its unit, and a search box.

use super::model::ModelParams;
use crate::error::{Error, Result};
use drive_sim_model::config::Validate;
use drive_sim_model::effects::{self, CommandReach, Effect, ParamDef, ParamKind, REGISTRY};

/// A quantity of the model the optimizer may vary.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Param {
    /// Terrain: peak longitudinal friction coefficient.
    PeakLongitudinal,
    /// Terrain: peak lateral friction coefficient.
    PeakLateral,
    /// Terrain: slip ratio at the friction peak.
    PeakSlipRatio,
    /// Terrain: rolling-resistance coefficient.
    RollingCoefficient,
    /// Terrain: the longitudinal sliding friction as a share of its peak (1: no fall past the
    /// peak). A share, not the sliding value, so that every point of the box is a valid
    /// terrain whatever the peak is fitted to.
    SlidingShareLongitudinal,
    /// Robot: baseline (wheel separation), m; the kinematic model's effective baseline.
    Baseline,
    /// Robot: wheelbase (front to rear wheel of a side), m; in the simulator, the lever of the
    /// sideways scrub that a skid-steer's wheels oppose to its yaw, so it sets how much of its
    /// wheels' yaw rate the body turns at, and the lateral friction stays what resists a
    /// sideways slide. Robot files estimate it from the footprint.
    Wheelbase,
    /// Robot: wheel-speed loop time constant, s.
    TimeConstant,
    /// Parameter `param` of the effect `effect` (indices in [`REGISTRY`]).
    Effect {
        /// Index of the effect in the registry.
        effect: usize,
        /// Index of the parameter in the effect.
        param: usize,
    },
}

impl Param {
    /// The parameter of an effect named by its key (`dead_time_s`, `motor_gain_left`, ...).
    pub fn effect_param(key: &str) -> Option<Self> {
        effects::param_owner(key).map(|(effect, param)| Self::Effect { effect, param })
    }

    /// Name in reports: `terrain.friction.peak_longitudinal`, `robot.wheels.baseline_m`,
    /// `effect.<parameter>` (the names `calibration.json` has always used).
    pub fn name(&self) -> String {
        match self {
            Self::PeakLongitudinal => "terrain.friction.peak_longitudinal".into(),
            Self::PeakLateral => "terrain.friction.peak_lateral".into(),
            Self::PeakSlipRatio => "terrain.friction.peak_slip_ratio".into(),
            Self::RollingCoefficient => "terrain.resistance.rolling_coefficient".into(),
            Self::SlidingShareLongitudinal => "terrain.friction.sliding_longitudinal_share".into(),
            Self::Baseline => "robot.wheels.baseline_m".into(),
            Self::Wheelbase => "robot.wheels.wheelbase_m".into(),
            Self::TimeConstant => "robot.powertrain.time_constant_s".into(),
            Self::Effect { .. } => format!("effect.{}", self.def().map_or("?", |d| d.key)),
        }
    }

    /// The name options take (`--tune`, `--box`, `judge --interval`): an effect parameter's
    /// key (`speed_droop_rad_s_per_knm`), a base parameter's report name ([`Param::name`]).
    pub fn key(&self) -> String {
        self.def().map_or_else(|| self.name(), |d| d.key.to_string())
    }

    /// A property of the ground under the robot (fitted once per log when several logs of one
    /// robot are calibrated together, [`super::joint`]) rather than of the robot (fitted once
    /// for all): the terrain's friction and rolling resistance, and the effects that say so
    /// ([`Effect::on_terrain`]).
    pub fn on_terrain(&self) -> bool {
        match self {
            Self::PeakLongitudinal
            | Self::PeakLateral
            | Self::PeakSlipRatio
            | Self::RollingCoefficient
            | Self::SlidingShareLongitudinal => true,
            Self::Baseline | Self::Wheelbase | Self::TimeConstant => false,
            Self::Effect { .. } => self.effect().is_some_and(|e| e.on_terrain()),
        }
    }

    /// Unit.
    pub fn unit(&self) -> &'static str {
        match self {
            Self::PeakLongitudinal
            | Self::PeakLateral
            | Self::PeakSlipRatio
            | Self::RollingCoefficient
            | Self::SlidingShareLongitudinal => "-",
            Self::Baseline | Self::Wheelbase => "m",
            Self::TimeConstant => "s",
            Self::Effect { .. } => self.def().map_or("-", |d| d.unit),
        }
    }

    /// The effect this parameter belongs to.
    pub fn effect(&self) -> Option<&'static dyn Effect> {
        match self {
            Self::Effect { effect, .. } => REGISTRY.get(*effect).copied(),
            _ => None,
        }
    }

    /// The effect parameter's definition.
    pub fn def(&self) -> Option<&'static ParamDef> {
        match self {
            Self::Effect { effect, param } => REGISTRY.get(*effect)?.params().get(*param),
            _ => None,
        }
    }

    /// The value at which the parameter changes nothing (effects only).
    pub fn neutral(&self) -> Option<f64> {
        self.def().map(|d| d.neutral)
    }

    /// A limit (a clamp that does nothing above what the log commands): its cost is flat
    /// wherever it clamps nothing, so a local search needs a start where it does.
    pub fn is_limit(&self) -> bool {
        self.def()
            .is_some_and(|d| d.kind == drive_sim_model::effects::ParamKind::Limit)
    }

    /// Smallest change that makes a difference (finite differences step no smaller).
    pub fn resolution(&self) -> Option<f64> {
        self.def().and_then(|d| d.resolution)
    }

    /// Current value in `m`.
    pub fn get(&self, m: &ModelParams) -> f64 {
        match self {
            Self::PeakLongitudinal => m.terrain.friction.peak_longitudinal,
            Self::PeakLateral => m.terrain.friction.peak_lateral,
            Self::PeakSlipRatio => m.terrain.friction.peak_slip_ratio,
            Self::RollingCoefficient => m.terrain.resistance.rolling_coefficient,
            Self::SlidingShareLongitudinal => {
                m.terrain.friction.sliding_longitudinal / m.terrain.friction.peak_longitudinal
            }
            Self::Baseline => m.robot.wheels.baseline_m,
            Self::Wheelbase => m.robot.wheels.wheelbase_m,
            Self::TimeConstant => m.robot.powertrain.time_constant_s,
            Self::Effect { .. } => self.def().and_then(|d| m.effects.get(d.key)).unwrap_or(f64::NAN),
        }
    }

    /// Sets the value in `m` without the cross-field validation of robot and terrain (see
    /// [`ModelParams::with_values`]); an effect value is checked against its range.
    fn set_unchecked(&self, m: &mut ModelParams, v: f64) -> Result<()> {
        // An effect's limit is off at infinity; everything else must be finite.
        let off_limit = self
            .def()
            .is_some_and(|d| d.kind == ParamKind::Limit && v == f64::INFINITY);
        if !(v.is_finite() || off_limit) {
            return Err(Error::NonFiniteParameter {
                name: self.name().to_string(),
                value: v,
            });
        }
        match self {
            Self::PeakLongitudinal => m.terrain.friction.peak_longitudinal = v,
            Self::PeakLateral => m.terrain.friction.peak_lateral = v,
            Self::PeakSlipRatio => m.terrain.friction.peak_slip_ratio = v,
            Self::RollingCoefficient => m.terrain.resistance.rolling_coefficient = v,
            Self::SlidingShareLongitudinal => {
                m.terrain.friction.sliding_longitudinal = v * m.terrain.friction.peak_longitudinal
            }
            Self::Baseline => m.robot.wheels.baseline_m = v,
            Self::Wheelbase => m.robot.wheels.wheelbase_m = v,
            Self::TimeConstant => m.robot.powertrain.time_constant_s = v,
            Self::Effect { .. } => {
                let d = self.def().ok_or(Error::UnknownEffectParameter)?;
                m.effects.set(d.key, v)?;
            }
        }
        Ok(())
    }
}

/// One parameter the optimizer may vary, with its search box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParamSpec {
    /// The parameter.
    pub param: Param,
    /// Lower bound.
    pub lower: f64,
    /// Upper bound.
    pub upper: f64,
    /// Only the two bounds are meaningful (an on/off effect such as a sign flip).
    pub discrete: bool,
    /// Where the search starts when the model's value lies outside the box (an effect that is
    /// off): the neutral value when inside the box, else its middle.
    pub start: f64,
}

impl ParamSpec {
    /// A continuous parameter in `[lower, upper]`, started at the middle.
    pub fn new(param: Param, lower: f64, upper: f64) -> Self {
        Self {
            param,
            lower,
            upper,
            discrete: false,
            start: 0.5 * (lower + upper),
        }
    }

    /// The search spec of an effect parameter for a log commanding up to `reach`: the
    /// registry's box, started at the neutral value (limits, whose neutral value is
    /// infinity, mid-box: near the largest command the cost is flat, and a search started in
    /// a flat region stops at once).
    pub fn for_effect(effect: usize, param: usize, reach: &CommandReach) -> Self {
        let def = &REGISTRY[effect].params()[param];
        let (lower, upper) = def.search.bounds(reach);
        let start = if (lower..=upper).contains(&def.neutral) {
            def.neutral
        } else {
            0.5 * (lower + upper)
        };
        Self {
            param: Param::Effect { effect, param },
            lower,
            upper,
            discrete: def.kind == ParamKind::Flag,
            start,
        }
    }

    /// The value the search starts from for the model `m`: the model's own when inside the
    /// box, else [`ParamSpec::start`]. An effect's parameter still at its neutral value (the
    /// effect is off in `m`) starts at [`ParamSpec::start`] when that was set elsewhere: a
    /// discovered term starts at the regression's coefficients, a named effect an equation
    /// points to where the equation reads it.
    pub fn start_in(&self, m: &ModelParams) -> f64 {
        let v = self.param.get(m);
        let off = self.param.neutral() == Some(v);
        if off && self.start != v && self.start >= self.lower && self.start <= self.upper {
            return self.start;
        }
        self.model_start_in(m)
    }

    /// The model's own value when inside the box, else [`ParamSpec::start`]: where a search
    /// falls back to when [`ParamSpec::start_in`] gives a model that cannot run.
    pub fn model_start_in(&self, m: &ModelParams) -> f64 {
        let v = self.param.get(m);
        if v >= self.lower && v <= self.upper {
            v
        } else {
            self.start
        }
    }

    /// `value` lies in the outer half percent of the box (a continuous parameter only).
    pub fn at_bound(&self, value: f64) -> bool {
        let c = (value - self.lower) / (self.upper - self.lower);
        !self.discrete && !(0.005..=0.995).contains(&c)
    }
}

impl ModelParams {
    /// This model with `specs` set to `values`, then the robot and terrain validated once
    /// (a cross-field rule such as peak friction ≥ sliding friction names the field).
    pub fn with_values(&self, specs: &[ParamSpec], values: &[f64]) -> Result<ModelParams> {
        let mut m = self.clone();
        // A share of a peak is set after the peak, whatever the order of `specs` (a stable
        // sort keeps the others' order).
        let mut pairs: Vec<(&ParamSpec, f64)> = specs.iter().zip(values.iter().copied()).collect();
        pairs.sort_by_key(|(s, _)| s.param == Param::SlidingShareLongitudinal);
        for (s, v) in pairs {
            s.param.set_unchecked(&mut m, v)?;
        }
        m.robot
            .validate()
            .map_err(|(field, message)| Error::InvalidModel {
                model: "robot",
                field: field.to_string(),
                message: message.to_string(),
            })?;
        m.terrain
            .validate()
            .map_err(|(field, message)| Error::InvalidModel {
                model: "terrain",
                field: field.to_string(),
                message: message.to_string(),
            })?;
        Ok(m)
    }

    /// The values of `specs` in this model.
    pub fn values_of(&self, specs: &[ParamSpec]) -> Vec<f64> {
        specs.iter().map(|s| s.param.get(self)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use drive_sim_model::robot::Robot;
    use drive_sim_model::terrain::Terrain;

    fn params() -> ModelParams {
        let (robot, _) = Robot::resolve("warthog").unwrap();
        let (terrain, _) = Terrain::resolve("asphalt").unwrap();
        ModelParams::new(robot, terrain)
    }

    #[test]
    fn a_share_of_the_peak_is_set_after_the_peak_whatever_the_order() {
        let p = params();
        let specs = [
            ParamSpec::new(Param::SlidingShareLongitudinal, 0.5, 1.0),
            ParamSpec::new(Param::PeakLongitudinal, 0.75, 1.5),
        ];
        let m = p.with_values(&specs, &[0.8, 1.2]).unwrap();
        assert_eq!(m.terrain.friction.peak_longitudinal, 1.2);
        assert!((m.terrain.friction.sliding_longitudinal - 0.96).abs() < 1e-12);
        assert!((Param::SlidingShareLongitudinal.get(&m) - 0.8).abs() < 1e-12);
        // Every point of the box is a valid terrain, the flat curve included.
        assert!(p.with_values(&specs, &[1.0, 0.75]).is_ok());
    }

    #[test]
    fn typed_parameters_set_and_get() {
        let p = params();
        let dead = Param::effect_param("dead_time_s").unwrap();
        let specs = [
            ParamSpec::new(Param::PeakLongitudinal, 0.5, 1.5),
            ParamSpec::new(Param::Baseline, 1.0, 2.0),
            ParamSpec::new(dead, 0.0, 0.6),
        ];
        let m = p.with_values(&specs, &[0.93, 1.5, 0.1]).unwrap();
        assert_eq!(m.terrain.friction.peak_longitudinal, 0.93);
        assert_eq!(m.robot.wheels.baseline_m, 1.5);
        assert_eq!(m.effects.get("dead_time_s"), Some(0.1));
        assert_eq!(m.values_of(&specs), vec![0.93, 1.5, 0.1]);
        assert_eq!(dead.name(), "effect.dead_time_s");
        assert_eq!(dead.unit(), "s");
        assert_eq!(dead.neutral(), Some(0.0));
        assert_eq!(Param::PeakLateral.name(), "terrain.friction.peak_lateral");
    }

    #[test]
    fn the_simulator_fits_the_wheelbase_the_robot_file_calls_an_estimate() {
        use crate::model::{PlantFactory, SimFactory};
        let p = params();
        assert!(
            p.robot.wheels.wheelbase_estimated,
            "the Warthog's file estimates it"
        );
        let specs = SimFactory::default().base_params(&p);
        let wb = specs.iter().find(|s| s.param == Param::Wheelbase).unwrap();
        assert_eq!((wb.lower, wb.upper), (0.6 * 1.3, 1.2 * 1.3));
        assert!(!Param::Wheelbase.on_terrain());
        assert_eq!(Param::Wheelbase.name(), "robot.wheels.wheelbase_m");
        let m = p.with_values(&[*wb], &[1.05]).unwrap();
        assert_eq!(m.robot.wheels.wheelbase_m, 1.05);
        assert_eq!(Param::Wheelbase.get(&m), 1.05);
        // One wheel a side: no wheelbase, nothing to fit.
        let mut one = p.clone();
        one.robot.wheels.per_side = 1;
        one.robot.wheels.wheelbase_m = 0.0;
        let specs = SimFactory::default().base_params(&one);
        assert!(specs.iter().all(|s| s.param != Param::Wheelbase));
        // A datasheet's wheelbase (not an estimate): kept, not fitted.
        let mut given = p.clone();
        given.robot.wheels.wheelbase_estimated = false;
        let specs = SimFactory::default().base_params(&given);
        assert!(specs.iter().all(|s| s.param != Param::Wheelbase));
        let (husky, _) = Robot::resolve("husky").unwrap();
        assert!(
            !husky.wheels.wheelbase_estimated,
            "the Husky's is its datasheet's"
        );
    }

    #[test]
    fn invalid_values_are_errors_naming_the_field() {
        let p = params();
        // Peak below sliding friction is refused by the terrain's validation.
        let e = p
            .with_values(&[ParamSpec::new(Param::PeakLongitudinal, 0.0, 1.0)], &[0.1])
            .unwrap_err()
            .to_string();
        assert!(e.contains("sliding_longitudinal"), "{e}");
        let gain = Param::effect_param("motor_gain_left").unwrap();
        assert!(p.with_values(&[ParamSpec::new(gain, 0.5, 1.3)], &[-1.0]).is_err());
        assert!(p
            .with_values(&[ParamSpec::new(gain, 0.5, 1.3)], &[f64::NAN])
            .is_err());
        assert!(Param::effect_param("warp_drive").is_none());
    }
}
