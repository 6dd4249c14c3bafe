//! The encoders count with a wrong scale.

use super::{Effect, ParamDef, ParamKind, SearchBox, Stage};
use crate::kinematics::WheelSpeeds;

/// Multiplies the encoder readings (wrong counts per revolution or gear ratio).
pub(crate) struct EncoderScale;

const PARAMS: &[ParamDef] = &[ParamDef {
    key: "encoder_scale",
    unit: "-",
    kind: ParamKind::Continuous,
    min: 0.01,
    max: 100.0,
    neutral: 1.0,
    search: SearchBox::Fixed {
        lower: 0.7,
        upper: 1.3,
    },
    resolution: None,
}];

impl Effect for EncoderScale {
    fn name(&self) -> &'static str {
        "encoder_scale"
    }
    fn doc(&self) -> &'static str {
        "the encoders read a multiple of the wheel spin (wrong counts per turn or gear ratio)"
    }
    fn stage(&self) -> Stage {
        Stage::Sensor
    }
    fn params(&self) -> &'static [ParamDef] {
        PARAMS
    }
    fn encoders(&self, p: &[f64], w: WheelSpeeds) -> WheelSpeeds {
        WheelSpeeds::new(w.left_rad_s * p[0], w.right_rad_s * p[0])
    }
    fn wheels_from_encoders(&self, p: &[f64], w: WheelSpeeds) -> WheelSpeeds {
        WheelSpeeds::new(w.left_rad_s / p[0], w.right_rad_s / p[0])
    }
}
