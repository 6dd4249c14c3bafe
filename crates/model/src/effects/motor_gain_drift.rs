//! The motors' gain drifts over the run.

use super::term::TermInput;
use super::{Effect, ParamDef, ParamKind, SearchBox, Stage};
use crate::kinematics::WheelSpeeds;

/// Both wheel-speed loops settle at `(1 + d · k)` times their target at step `k` (a battery
/// sagging over the run, motors heating up): the gain changes with the step index.
pub(crate) struct MotorGainDrift;

const PARAMS: &[ParamDef] = &[ParamDef {
    key: "motor_gain_drift_per_step",
    unit: "1/step",
    kind: ParamKind::Continuous,
    min: -0.1,
    max: 0.1,
    neutral: 0.0,
    search: SearchBox::Fixed {
        lower: -0.01,
        upper: 0.01,
    },
    resolution: None,
}];

impl Effect for MotorGainDrift {
    fn name(&self) -> &'static str {
        "motor_gain_drift"
    }
    fn doc(&self) -> &'static str {
        "the wheels' gain changes linearly with the step index (battery sag, motors heating)"
    }
    fn stage(&self) -> Stage {
        Stage::Wheel
    }
    fn params(&self) -> &'static [ParamDef] {
        PARAMS
    }
    fn wheel_targets_in(&self, p: &[f64], w: WheelSpeeds, x: &TermInput) -> WheelSpeeds {
        // A gain below zero would reverse the wheels; a drift that large is out of any box.
        let g = (1.0 + p[0] * x.step as f64).max(0.0);
        WheelSpeeds::new(w.left_rad_s * g, w.right_rad_s * g)
    }
}
