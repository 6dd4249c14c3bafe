//! The robot turns about a point ahead of or behind its frame's origin.

use super::term::TermInput;
use super::{Effect, ParamDef, ParamKind, SearchBox, Stage};
use crate::kinematics::BodyVelocity;

/// The longitudinal coordinate `x_ICR` of the instantaneous centre of rotation in the body
/// frame (the `x_ICRv` of Mandow et al., "Experimental kinematics for wheeled skid-steer
/// mobile robots", IROS 2007). A skid-steer robot turns about the point where its tyres'
/// sideways forces balance: the middle of the wheelbase only when the axles carry equal loads.
/// A load nearer one axle moves it there, and a localisation frame (a lidar mounted ahead of
/// the turning centre) reads the same: the origin slides sideways at `vy = −x_ICR · wz`,
/// whichever way it drives. `x_ICR < 0`: the robot turns about a point behind its origin.
pub(crate) struct IcrLongitudinalOffset;

const PARAMS: &[ParamDef] = &[ParamDef {
    key: "icr_x_m",
    unit: "m",
    kind: ParamKind::Continuous,
    min: -5.0,
    max: 5.0,
    neutral: 0.0,
    // Half a metre either way: beyond the axles of both robots (the Warthog's wheelbase is
    // 1.1 m, the Husky's 0.51 m), where a skid-steer could no longer turn on its wheels.
    search: SearchBox::Fixed {
        lower: -0.5,
        upper: 0.5,
    },
    resolution: None,
}];

impl Effect for IcrLongitudinalOffset {
    fn name(&self) -> &'static str {
        "icr_longitudinal_offset"
    }
    fn doc(&self) -> &'static str {
        "the robot turns about a point x_ICR ahead of (> 0) or behind (< 0) its origin (load nearer one axle, a pose frame off the turning centre): vy = -x_ICR·wz"
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
        BodyVelocity::new(0.0, -p[0] * x.body.wz_rad_s, 0.0)
    }
}
