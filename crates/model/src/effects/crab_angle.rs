//! The robot moves at an angle to its axis.

use super::term::TermInput;
use super::{Effect, ParamDef, ParamKind, SearchBox, Stage};
use crate::kinematics::BodyVelocity;

/// Driving straight, the robot's origin moves at an angle `ψ` to its x axis: the axles are out
/// of square (it crabs), or the localisation frame is yawed against the body (a lidar mounted a
/// few degrees off the robot's axis reads the same). Its origin slides sideways at
/// `vy = tan ψ · vx`, forward and backward alike.
pub(crate) struct CrabAngle;

const PARAMS: &[ParamDef] = &[ParamDef {
    key: "crab_angle_rad",
    unit: "rad",
    kind: ParamKind::Continuous,
    min: -0.5,
    max: 0.5,
    neutral: 0.0,
    // ±5.7°: a mounting or alignment error, not a robot driving sideways.
    search: SearchBox::Fixed {
        lower: -0.1,
        upper: 0.1,
    },
    resolution: None,
}];

impl Effect for CrabAngle {
    fn name(&self) -> &'static str {
        "crab_angle"
    }
    fn doc(&self) -> &'static str {
        "the robot moves at an angle to its axis (axles out of square, a pose frame yawed against the body): vy = tan(angle)·vx"
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
        BodyVelocity::new(0.0, p[0].tan() * x.body.vx_m_s, 0.0)
    }
}
