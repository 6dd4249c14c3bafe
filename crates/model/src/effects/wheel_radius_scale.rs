//! The wheels roll with another radius than the nominal one.

use super::{Effect, ParamDef, ParamKind, PlantModifiers, SearchBox, Stage};

/// Effective rolling radius over the nominal one (tyre pressure, load, wear).
pub(crate) struct WheelRadiusScale;

const PARAMS: &[ParamDef] = &[ParamDef {
    key: "wheel_radius_scale",
    unit: "-",
    kind: ParamKind::Continuous,
    min: 0.1,
    max: 10.0,
    neutral: 1.0,
    search: SearchBox::Fixed {
        lower: 0.7,
        upper: 1.3,
    },
    resolution: None,
}];

impl Effect for WheelRadiusScale {
    fn name(&self) -> &'static str {
        "wheel_radius_scale"
    }
    fn doc(&self) -> &'static str {
        "the effective rolling radius differs from the nominal one (tyre pressure, load, wear)"
    }
    fn stage(&self) -> Stage {
        Stage::Body
    }
    fn params(&self) -> &'static [ParamDef] {
        PARAMS
    }
    fn modify_plant(&self, p: &[f64], m: &mut PlantModifiers) {
        m.wheel_radius_scale = p[0];
    }
}
