//! One encoder counts with a wrong scale.

use super::{Effect, ParamDef, ParamKind, SearchBox, Stage};
use crate::kinematics::WheelSpeeds;

/// Multiplies each encoder's reading by its own factor: a counts-per-revolution or gear ratio
/// configured wrong on one side (`encoder_scale` is the error both sides share). Only the
/// readings change, not the wheels: the body moves as commanded while one encoder says
/// otherwise, which a motor gain (the wheel itself turning faster) cannot reproduce.
/// Discovery reads it from a wheel equation linear in the side's own speed.
pub(crate) struct EncoderSideScale;

const PARAMS: &[ParamDef] = &[
    ParamDef {
        key: "encoder_scale_left",
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
    },
    ParamDef {
        key: "encoder_scale_right",
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
    },
];

impl Effect for EncoderSideScale {
    fn name(&self) -> &'static str {
        "encoder_side_scale"
    }
    fn doc(&self) -> &'static str {
        "each encoder reads its own multiple of its wheel's spin (a side's counts per turn or gear ratio configured wrong)"
    }
    fn stage(&self) -> Stage {
        Stage::Sensor
    }
    fn params(&self) -> &'static [ParamDef] {
        PARAMS
    }
    // Discovery brings it in where a wheel equation is linear in the side's speed; the
    // measured calibrations have not been measured with it in their catalogue.
    fn default_candidate(&self) -> bool {
        false
    }
    fn encoders(&self, p: &[f64], w: WheelSpeeds) -> WheelSpeeds {
        WheelSpeeds::new(w.left_rad_s * p[0], w.right_rad_s * p[1])
    }
    fn wheels_from_encoders(&self, p: &[f64], w: WheelSpeeds) -> WheelSpeeds {
        WheelSpeeds::new(w.left_rad_s / p[0], w.right_rad_s / p[1])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_side_reads_its_own_scale_and_the_inverse_undoes_it() {
        let e = EncoderSideScale;
        let w = e.encoders(&[1.1, 0.9], WheelSpeeds::new(2.0, -4.0));
        assert!((w.left_rad_s - 2.2).abs() < 1e-12 && (w.right_rad_s + 3.6).abs() < 1e-12);
        let back = e.wheels_from_encoders(&[1.1, 0.9], w);
        assert!((back.left_rad_s - 2.0).abs() < 1e-12 && (back.right_rad_s + 4.0).abs() < 1e-12);
    }
}
