//! One side's wheel-speed loop settles off its target.

use super::{Effect, ParamDef, ParamKind, SearchBox, Stage};
use crate::kinematics::WheelSpeeds;

/// Gains of the left and right wheel-speed loops: each wheel settles at `gain x target`
/// (a weaker motor, a miscalibrated loop).
pub(crate) struct MotorGain;

const fn gain(key: &'static str) -> ParamDef {
    ParamDef {
        key,
        unit: "-",
        kind: ParamKind::Continuous,
        min: 0.01,
        max: 100.0,
        neutral: 1.0,
        search: SearchBox::Fixed {
            lower: 0.5,
            upper: 1.3,
        },
        resolution: None,
    }
}

const PARAMS: &[ParamDef] = &[gain("motor_gain_left"), gain("motor_gain_right")];

impl Effect for MotorGain {
    fn name(&self) -> &'static str {
        "motor_gain"
    }
    fn doc(&self) -> &'static str {
        "each side's wheel settles at a gain times its target (one motor weaker than the other)"
    }
    fn stage(&self) -> Stage {
        Stage::Wheel
    }
    fn params(&self) -> &'static [ParamDef] {
        PARAMS
    }
    fn wheel_targets(&self, p: &[f64], w: WheelSpeeds) -> WheelSpeeds {
        WheelSpeeds::new(w.left_rad_s * p[0], w.right_rad_s * p[1])
    }
}
