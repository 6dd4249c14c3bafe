//! How much a tyre's sideslip takes from its grip along the wheel.

use super::{Effect, ParamDef, ParamKind, PlantModifiers, SearchBox, Stage};

/// Weight of the slip angle in the longitudinal force's combined slip. The terrain's tyre
/// model puts both slips on one friction ellipse, so a tyre that scrubs sideways (both sides
/// of a skid-steer in a pivot or a turn in place) loses its grip along the wheel with it, and
/// the sides' pull apart turns the body less. At 1 that is the model unchanged; below 1 the
/// longitudinal force sees less of the sideslip, as lugged or deformable tyres whose tread
/// holds along the rolling direction while it scrubs across; near 0 traction and braking
/// ignore it. The lateral force keeps the ellipse: a spinning wheel still loses its lateral
/// grip, which is what lets a skid-steer turn.
pub(crate) struct TractionSideslip;

const PARAMS: &[ParamDef] = &[ParamDef {
    key: "traction_sideslip_weight",
    unit: "-",
    kind: ParamKind::Continuous,
    // Above 0 so that the longitudinal slip's norm stays positive wherever the slip is.
    min: 0.05,
    max: 1.0,
    neutral: 1.0,
    search: SearchBox::Fixed {
        lower: 0.05,
        upper: 1.0,
    },
    resolution: None,
}];

impl Effect for TractionSideslip {
    fn name(&self) -> &'static str {
        "traction_sideslip_weight"
    }
    fn doc(&self) -> &'static str {
        "a tyre scrubbing sideways keeps more grip along the wheel than one friction ellipse gives (skid-steer turns pull harder)"
    }
    fn stage(&self) -> Stage {
        Stage::Contact
    }
    fn params(&self) -> &'static [ParamDef] {
        PARAMS
    }
    fn default_candidate(&self) -> bool {
        false
    }
    fn modify_plant(&self, p: &[f64], m: &mut PlantModifiers) {
        m.traction_sideslip_weight = p[0];
    }
}
