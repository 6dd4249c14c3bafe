//! Dead time: the command reaches the controller late (bus latency, a slow control loop).

use super::{Effect, ParamDef, ParamKind, PlantModifiers, SearchBox, Stage};

/// A pure delay between a command and the controller acting on it.
pub(crate) struct DeadTime;

const PARAMS: &[ParamDef] = &[ParamDef {
    key: "dead_time_s",
    unit: "s",
    kind: ParamKind::Continuous,
    min: 0.0,
    // Beyond a few seconds a delay is a protocol fault, not a powertrain.
    max: 5.0,
    neutral: 0.0,
    search: SearchBox::Fixed {
        lower: 0.0,
        upper: 0.6,
    },
    // Both plants release a delayed command at its time inside their integration step (its
    // target weighted by the part of the step it acts on), so the response is continuous in
    // the delay and a finite difference finer than the step sees it.
    resolution: None,
}];

impl Effect for DeadTime {
    fn name(&self) -> &'static str {
        "dead_time_s"
    }
    fn doc(&self) -> &'static str {
        "pure delay between a command and the controller acting on it (bus latency, slow loop)"
    }
    fn stage(&self) -> Stage {
        Stage::Command
    }
    fn params(&self) -> &'static [ParamDef] {
        PARAMS
    }
    fn modify_plant(&self, p: &[f64], m: &mut PlantModifiers) {
        m.dead_time_s = p[0];
    }
}
