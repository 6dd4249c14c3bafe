//! What a twin's closed loop may vary: every physical parameter of the model that changes how
//! the robot drives, as a knob.
//!
//! A knob is one registered effect (all its parameters: a motor line has two ends) or one of
//! the simulator's base parameters (friction peaks, rolling resistance, the wheel loop's time
//! constant, the wheelbase). The pool is every effect on the command, the wheel loop, the body
//! or the wheel–terrain contact that the simulator runs, with continuous parameters; sensor effects
//! are left to the calibration by replay, which sees them sample by sample, and the generic
//! discovered terms are not physical knobs, and the random effects a log measures
//! ([`crate::measured::MEASURED`]) are declared from it, not searched. Nothing here says which knob matters for which
//! robot: [`crate::screen`] measures it on the run.

use drive_sim_calibration::params::ParamSpec;
use drive_sim_calibration::{ModelParams, PlantFactory, SimFactory};
use drive_sim_model::effects::{CommandReach, Stage, REGISTRY};
use serde::{Deserialize, Serialize};

/// One knob of the closed loop.
#[derive(Debug, Clone, PartialEq)]
pub struct Knob {
    /// The effect's registry name, or the base parameter's report name.
    pub name: String,
    /// Its parameters with their search boxes.
    pub specs: Vec<ParamSpec>,
    /// A property of the ground (one value per ground when several are tuned together).
    pub terrain_side: bool,
}

/// A knob as `twin.json` lists it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct KnobInfo {
    /// Name.
    pub name: String,
    /// Its parameters' keys.
    pub params: Vec<String>,
    /// A property of the ground.
    pub terrain_side: bool,
}

impl Knob {
    /// Its line in `twin.json`.
    pub fn info(&self) -> KnobInfo {
        KnobInfo {
            name: self.name.clone(),
            params: self.specs.iter().map(|s| s.param.key()).collect(),
            terrain_side: self.terrain_side,
        }
    }
}

/// The stages whose effects change how the robot drives in closed loop.
const DRIVING_STAGES: [Stage; 4] = [Stage::Command, Stage::Wheel, Stage::Body, Stage::Contact];

/// Every knob of the pool for a model `start` on a run commanding up to `reach` (the effects'
/// boxes scale with the largest command).
pub fn pool(start: &ModelParams, reach: &CommandReach) -> Vec<Knob> {
    let factory = SimFactory::default();
    let mut knobs: Vec<Knob> = REGISTRY
        .iter()
        .enumerate()
        .filter(|(_, e)| !e.generic() && DRIVING_STAGES.contains(&e.stage()))
        .filter(|(_, e)| !crate::measured::MEASURED.contains(&e.name()))
        .filter_map(|(i, e)| {
            let specs: Vec<ParamSpec> = (0..e.params().len())
                .map(|j| ParamSpec::for_effect(i, j, reach))
                .collect();
            (!specs.iter().any(|s| s.discrete)).then(|| Knob {
                name: e.name().to_string(),
                specs,
                terrain_side: e.on_terrain(),
            })
        })
        .collect();
    knobs.extend(factory.base_params(start).into_iter().map(|s| Knob {
        name: s.param.name(),
        terrain_side: factory.on_terrain(&s.param),
        specs: vec![s],
    }));
    knobs
}

#[cfg(test)]
mod tests {
    use super::*;
    use drive_sim_model::robot::Robot;
    use drive_sim_model::terrain::Terrain;

    #[test]
    fn the_pool_holds_the_driving_effects_and_base_parameters_not_sensors_or_terms() {
        let robot = Robot::resolve("warthog").unwrap().0;
        let terrain = Terrain::resolve("asphalt").unwrap().0;
        let start = ModelParams::new(robot.clone(), terrain);
        let reach = CommandReach::of_commands(
            [drive_sim_model::kinematics::WheelSpeeds::new(10.0, -10.0)],
            &robot.idd(),
        );
        let knobs = pool(&start, &reach);
        let names: Vec<&str> = knobs.iter().map(|k| k.name.as_str()).collect();
        for expected in [
            "motor_torque_speed",
            "speed_droop",
            "turning_resistance_scale",
            "dead_time_s",
            "terrain.friction.peak_lateral",
        ] {
            assert!(names.contains(&expected), "{expected} missing from {names:?}");
        }
        for absent in [
            "encoder_scale",
            "imu_yaw_rate_bias_rad_s",
            "wheel_speed_scatter",
            "pose_updates",
            "term_wheel_left",
            "imu_yaw_rate_sign_flip",
        ] {
            assert!(!names.contains(&absent), "{absent} in the pool");
        }
        let motor = knobs.iter().find(|k| k.name == "motor_torque_speed").unwrap();
        assert_eq!(motor.specs.len(), 2);
        assert!(
            knobs
                .iter()
                .find(|k| k.name == "turning_resistance_scale")
                .unwrap()
                .terrain_side
        );
    }
}
