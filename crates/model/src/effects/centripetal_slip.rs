//! Lateral slip in proportion to the centripetal acceleration.

use super::term::TermInput;
use super::{Effect, ParamDef, ParamKind, SearchBox, Stage};
use crate::kinematics::BodyVelocity;

/// In a turn the tyres carry the centripetal force with a slip angle, so the body slides
/// sideways at `vy = k · vx · wz` (`k` in s: m/s per m/s² of centripetal acceleration).
pub(crate) struct CentripetalSlip;

const PARAMS: &[ParamDef] = &[ParamDef {
    key: "centripetal_slip_s",
    unit: "s",
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

impl Effect for CentripetalSlip {
    fn name(&self) -> &'static str {
        "centripetal_slip"
    }
    fn doc(&self) -> &'static str {
        "lateral slip proportional to the centripetal acceleration vx·wz (tyre slip angle in turns)"
    }
    fn stage(&self) -> Stage {
        Stage::Body
    }
    fn on_terrain(&self) -> bool {
        // The slip angle is how this ground's grip carries the centripetal force.
        true
    }
    fn moves_body(&self) -> bool {
        true
    }
    fn params(&self) -> &'static [ParamDef] {
        PARAMS
    }
    fn body_offset(&self, p: &[f64], x: &TermInput) -> BodyVelocity {
        BodyVelocity::new(0.0, p[0] * x.body.vx_m_s * x.body.wz_rad_s, 0.0)
    }
}
