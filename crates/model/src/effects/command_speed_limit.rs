//! The velocity controller clamps the forward speed it is asked for.

use super::{Effect, ParamDef, ParamKind, ReachOf, SearchBox, Stage};
use crate::kinematics::BodyVelocity;

/// A clamp on the commanded forward speed, in the nominal body space.
pub(crate) struct CommandSpeedLimit;

const PARAMS: &[ParamDef] = &[ParamDef {
    key: "command_speed_limit_m_s",
    unit: "m/s",
    kind: ParamKind::Limit,
    min: 0.0,
    max: 100.0,
    neutral: f64::INFINITY,
    // A controller's body-space limits can sit far below what a protocol commands (a Husky
    // commanded at 8.7 rad/s turns at under 2): searched down to a tenth.
    search: SearchBox::Reach {
        of: ReachOf::Speed,
        lower: 0.1,
        upper: 1.0,
    },
    resolution: None,
}];

impl Effect for CommandSpeedLimit {
    fn name(&self) -> &'static str {
        "command_speed_limit_m_s"
    }
    fn doc(&self) -> &'static str {
        "the velocity controller clamps the commanded forward speed"
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
            vx_m_s: v.vx_m_s.clamp(-p[0], p[0]),
            ..v
        }
    }
}
