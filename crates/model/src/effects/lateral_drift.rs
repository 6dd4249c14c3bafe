//! A constant sideways drift.

use super::term::TermInput;
use super::{Effect, ParamDef, ParamKind, SearchBox, Stage};
use crate::kinematics::BodyVelocity;

/// A constant lateral velocity in the body frame (a side slope the robot slides down, a
/// crabbing suspension).
pub(crate) struct LateralDrift;

const PARAMS: &[ParamDef] = &[ParamDef {
    key: "lateral_drift_m_s",
    unit: "m/s",
    kind: ParamKind::Continuous,
    min: -5.0,
    max: 5.0,
    neutral: 0.0,
    search: SearchBox::Fixed {
        lower: -0.5,
        upper: 0.5,
    },
    resolution: None,
}];

impl Effect for LateralDrift {
    fn name(&self) -> &'static str {
        "lateral_drift"
    }
    fn doc(&self) -> &'static str {
        "a constant sideways velocity in the body frame (side slope, crabbing suspension)"
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
    fn body_offset(&self, p: &[f64], _x: &TermInput) -> BodyVelocity {
        BodyVelocity::new(0.0, p[0], 0.0)
    }
}
