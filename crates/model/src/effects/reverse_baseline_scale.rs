//! The effective baseline differs when driving backwards.

use super::term::TermInput;
use super::{Effect, ParamDef, ParamKind, SearchBox, Stage};
use crate::kinematics::BodyVelocity;

/// Driving backwards, the robot turns as if its baseline were `scale` times the nominal one
/// (the load moves to the other axle, the contact patch the skid turns about moves): the yaw
/// rate from the wheels is divided by `scale` when the command drives backwards.
pub(crate) struct ReverseBaselineScale;

const PARAMS: &[ParamDef] = &[ParamDef {
    key: "reverse_baseline_scale",
    unit: "-",
    kind: ParamKind::Continuous,
    min: 0.1,
    max: 10.0,
    neutral: 1.0,
    search: SearchBox::Fixed {
        lower: 0.5,
        upper: 2.5,
    },
    resolution: None,
}];

impl Effect for ReverseBaselineScale {
    fn name(&self) -> &'static str {
        "reverse_baseline_scale"
    }
    fn doc(&self) -> &'static str {
        "driving backwards the robot turns as with a different baseline (load on the other axle)"
    }
    fn stage(&self) -> Stage {
        Stage::Body
    }
    fn moves_body(&self) -> bool {
        true
    }
    fn params(&self) -> &'static [ParamDef] {
        PARAMS
    }
    fn body_offset(&self, p: &[f64], x: &TermInput) -> BodyVelocity {
        if x.cmd_body.vx_m_s < 0.0 {
            BodyVelocity::new(0.0, 0.0, x.body.wz_rad_s * (1.0 / p[0] - 1.0))
        } else {
            BodyVelocity::default()
        }
    }
}
