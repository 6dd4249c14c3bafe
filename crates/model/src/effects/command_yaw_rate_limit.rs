//! The velocity controller clamps the yaw rate it is asked for.

use super::{Effect, ParamDef, ParamKind, ReachOf, SearchBox, Stage};
use crate::kinematics::BodyVelocity;

/// A clamp on the commanded yaw rate, in the nominal body space.
pub(crate) struct CommandYawRateLimit;

const PARAMS: &[ParamDef] = &[ParamDef {
    key: "command_yaw_rate_limit_rad_s",
    unit: "rad/s",
    kind: ParamKind::Limit,
    min: 0.0,
    max: 100.0,
    neutral: f64::INFINITY,
    search: SearchBox::Reach {
        of: ReachOf::YawRate,
        lower: 0.1,
        upper: 1.0,
    },
    resolution: None,
}];

impl Effect for CommandYawRateLimit {
    fn name(&self) -> &'static str {
        "command_yaw_rate_limit_rad_s"
    }
    fn doc(&self) -> &'static str {
        "the velocity controller clamps the commanded yaw rate"
    }
    fn stage(&self) -> Stage {
        Stage::Command
    }
    fn params(&self) -> &'static [ParamDef] {
        PARAMS
    }
    fn uses_body_space(&self) -> bool {
        true
    }
    fn body_command(&self, p: &[f64], v: BodyVelocity) -> BodyVelocity {
        BodyVelocity {
            wz_rad_s: v.wz_rad_s.clamp(-p[0], p[0]),
            ..v
        }
    }
}
