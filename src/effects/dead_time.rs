//! Dead time: the command reaches the controller late (bus latency, a slow control loop).

use super::{Effect, ParamDef, ParamKind, PlantModifiers, SearchBox, Stage};

/// A pure delay between a command and the controller acting on it.
pub struct DeadTime;

const PARAMS: &[ParamDef] = &[ParamDef {
    key: "dead_time_s",
    unit: "s",
    kind: ParamKind::Continuous,
    min: 0.0,
    // Beyond a few seconds a delay is a protocol fault, not a powertrain.
    max: 5.0,
    neutral: 0.0,
    search: SearchBox::Fixed { lower: 0.0, upper: 0.6 },
    // Plants apply a delayed command at their integration steps (5 ms kinematic, 10 ms
    // simulator): below that, a change of delay changes nothing.
    resolution: Some(0.01),
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
