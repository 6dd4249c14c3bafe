//! The ground resists sideways scrubbing more or less than the terrain file says.

use super::{Effect, ParamDef, ParamKind, PlantModifiers, SearchBox, Stage};

/// Multiplies the lateral friction coefficients (peak and sliding): more lateral resistance
/// makes skid-steer turning harder, i.e. a wider effective baseline.
pub(crate) struct TurningResistance;

const PARAMS: &[ParamDef] = &[ParamDef {
    key: "turning_resistance_scale",
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

impl Effect for TurningResistance {
    fn name(&self) -> &'static str {
        "turning_resistance_scale"
    }
    fn doc(&self) -> &'static str {
        "lateral friction is a multiple of the terrain's (skid-steer turning harder or easier)"
    }
    fn stage(&self) -> Stage {
        Stage::Contact
    }
    fn params(&self) -> &'static [ParamDef] {
        PARAMS
    }
    fn modify_plant(&self, p: &[f64], m: &mut PlantModifiers) {
        m.lateral_friction_scale = p[0];
    }
}
