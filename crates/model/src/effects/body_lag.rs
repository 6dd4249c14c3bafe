//! The body follows its wheels with a lag.

use super::{Effect, ParamDef, ParamKind, PlantModifiers, SearchBox, Stage};

/// First-order lag of the body velocity behind the velocity its wheels command through the
/// ground (compliant tyres and suspension, a heavy body on soft ground): the encoders settle
/// at once, the pose follows with a time constant.
pub(crate) struct BodyLag;

const PARAMS: &[ParamDef] = &[ParamDef {
    key: "body_time_constant_s",
    unit: "s",
    kind: ParamKind::Continuous,
    min: 0.0,
    max: 10.0,
    neutral: 0.0,
    search: SearchBox::Fixed {
        lower: 0.0,
        upper: 1.5,
    },
    resolution: None,
}];

impl Effect for BodyLag {
    fn name(&self) -> &'static str {
        "body_lag"
    }
    fn doc(&self) -> &'static str {
        "the body velocity follows the wheels' with a first-order lag (compliant tyres, soft ground)"
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
    fn modify_plant(&self, p: &[f64], m: &mut PlantModifiers) {
        m.body_time_constant_s = p[0];
    }
}
