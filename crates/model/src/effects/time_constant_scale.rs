//! The wheel-speed loop is slower or faster than declared.

use super::{Effect, ParamDef, ParamKind, PlantModifiers, SearchBox, Stage};

/// Multiplies the wheel-speed loop's time constant (a softer controller, a heavier load).
pub(crate) struct TimeConstantScale;

const PARAMS: &[ParamDef] = &[ParamDef {
    key: "time_constant_scale",
    unit: "-",
    kind: ParamKind::Continuous,
    min: 0.01,
    max: 100.0,
    neutral: 1.0,
    search: SearchBox::Fixed {
        lower: 0.2,
        upper: 5.0,
    },
    resolution: None,
}];

impl Effect for TimeConstantScale {
    fn name(&self) -> &'static str {
        "time_constant_scale"
    }
    fn doc(&self) -> &'static str {
        "the wheel-speed loop's time constant is a multiple of the declared one"
    }
    fn stage(&self) -> Stage {
        Stage::Wheel
    }
    fn params(&self) -> &'static [ParamDef] {
        PARAMS
    }
    fn modify_plant(&self, p: &[f64], m: &mut PlantModifiers) {
        m.time_constant_scale = p[0];
    }
}
