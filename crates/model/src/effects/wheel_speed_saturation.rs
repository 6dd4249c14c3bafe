//! A motor cannot turn its wheel faster than a limit.

use super::{Effect, ParamDef, ParamKind, ReachOf, SearchBox, Stage};
use crate::kinematics::WheelSpeeds;

/// Per-motor saturation of the wheel-speed target (a voltage limit, or a wrong nominal radius
/// making the command unreachable).
pub(crate) struct WheelSpeedSaturation;

const PARAMS: &[ParamDef] = &[ParamDef {
    key: "wheel_speed_saturation_rad_s",
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

impl Effect for WheelSpeedSaturation {
    fn name(&self) -> &'static str {
        "wheel_speed_saturation_rad_s"
    }
    fn doc(&self) -> &'static str {
        "each motor clips its wheel speed at a limit (voltage limit)"
    }
    fn stage(&self) -> Stage {
        Stage::Wheel
    }
    fn params(&self) -> &'static [ParamDef] {
        PARAMS
    }
    fn wheel_targets(&self, p: &[f64], w: WheelSpeeds) -> WheelSpeeds {
        WheelSpeeds::new(w.left_rad_s.clamp(-p[0], p[0]), w.right_rad_s.clamp(-p[0], p[0]))
    }
}
