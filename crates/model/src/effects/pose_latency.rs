//! The localisation pose is old when it is read.

use super::{Effect, ParamDef, ParamKind, PlantModifiers, SearchBox, Stage};

/// Age of the lidar / ICP pose when it is read (scan matching takes time).
pub(crate) struct PoseLatency;

const PARAMS: &[ParamDef] = &[ParamDef {
    key: "pose_latency_s",
    unit: "s",
    kind: ParamKind::Continuous,
    min: 0.0,
    max: 5.0,
    neutral: 0.0,
    search: SearchBox::Fixed {
        lower: 0.0,
        upper: 0.5,
    },
    resolution: None,
}];

impl Effect for PoseLatency {
    fn name(&self) -> &'static str {
        "pose_latency_s"
    }
    fn doc(&self) -> &'static str {
        "the localisation pose is old when it is read (scan-matching time)"
    }
    fn stage(&self) -> Stage {
        Stage::Sensor
    }
    fn params(&self) -> &'static [ParamDef] {
        PARAMS
    }
    fn modify_plant(&self, p: &[f64], m: &mut PlantModifiers) {
        m.pose_latency_s = p[0];
    }
}
