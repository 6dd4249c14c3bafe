//! Suspension and low-pressure tyres act as a torsion spring at low speed.

use super::{Effect, ParamDef, ParamKind, PlantModifiers, SearchBox, Stage};

/// Low-speed torsion-spring compliance of suspension and low-pressure tyres, as the tyres'
/// lateral relaxation length: the lateral tyre force follows a deflection state that builds up
/// over this distance of lateral travel instead of responding to the slip angle at once. At low
/// speed the tyres behave as a lateral (hence yaw-torsion) spring of stiffness
/// `C_alpha / length`: a turn winds it up and the chassis springs back on stop.
pub(crate) struct SuspensionTorsion;

const PARAMS: &[ParamDef] = &[ParamDef {
    key: "suspension_torsion_m",
    unit: "m",
    kind: ParamKind::Continuous,
    min: 0.0,
    max: 10.0,
    neutral: 0.0,
    // From off to about two tyre diameters.
    search: SearchBox::Fixed {
        lower: 0.0,
        upper: 1.2,
    },
    resolution: None,
}];

impl Effect for SuspensionTorsion {
    fn name(&self) -> &'static str {
        "suspension_torsion_m"
    }
    fn doc(&self) -> &'static str {
        "suspension and soft tyres act as a torsion spring at low speed (tyre relaxation length)"
    }
    fn stage(&self) -> Stage {
        Stage::Contact
    }
    fn params(&self) -> &'static [ParamDef] {
        PARAMS
    }
    fn modify_plant(&self, p: &[f64], m: &mut PlantModifiers) {
        m.relaxation_length_m = p[0];
    }
}
