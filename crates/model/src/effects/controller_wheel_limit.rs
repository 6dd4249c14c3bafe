//! The controller scales both wheel targets together to keep the faster under a limit.

use super::{Effect, ParamDef, ParamKind, ReachOf, SearchBox, Stage};
use crate::kinematics::WheelSpeeds;

/// A curvature-preserving wheel limit: both targets scaled down together so that the faster
/// one stays at the limit (unlike the per-motor saturation, which clips each side on its own).
pub(crate) struct ControllerWheelLimit;

const PARAMS: &[ParamDef] = &[ParamDef {
    key: "controller_wheel_limit_rad_s",
    unit: "rad/s",
    kind: ParamKind::Limit,
    min: 0.0,
    max: 1000.0,
    neutral: f64::INFINITY,
    search: SearchBox::Reach {
        of: ReachOf::Wheel,
        lower: 0.2,
        upper: 1.0,
    },
    resolution: None,
}];

impl Effect for ControllerWheelLimit {
    fn name(&self) -> &'static str {
        "controller_wheel_limit_rad_s"
    }
    fn doc(&self) -> &'static str {
        "the controller scales both wheel targets together so the faster stays under a limit"
    }
    fn stage(&self) -> Stage {
        Stage::Wheel
    }
    fn params(&self) -> &'static [ParamDef] {
        PARAMS
    }
    fn wheel_targets(&self, p: &[f64], w: WheelSpeeds) -> WheelSpeeds {
        let fastest = w.left_rad_s.abs().max(w.right_rad_s.abs());
        if fastest > p[0] {
            let k = p[0] / fastest;
            WheelSpeeds::new(k * w.left_rad_s, k * w.right_rad_s)
        } else {
            w
        }
    }
}
