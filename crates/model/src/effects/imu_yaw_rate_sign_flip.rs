//! The IMU is mounted with its yaw axis upside down.

use super::{Effect, ParamDef, ParamKind, SearchBox, Stage};

/// The IMU's yaw rate has the wrong sign (axis mounted upside down, frame misdeclared).
pub(crate) struct ImuYawRateSignFlip;

const PARAMS: &[ParamDef] = &[ParamDef {
    key: "imu_yaw_rate_sign_flip",
    unit: "-",
    kind: ParamKind::Flag,
    min: 0.0,
    max: 1.0,
    neutral: 0.0,
    search: SearchBox::Fixed {
        lower: 0.0,
        upper: 1.0,
    },
    resolution: None,
}];

impl Effect for ImuYawRateSignFlip {
    fn name(&self) -> &'static str {
        "imu_yaw_rate_sign_flip"
    }
    fn doc(&self) -> &'static str {
        "the IMU yaw rate has the wrong sign (axis mounted upside down)"
    }
    fn stage(&self) -> Stage {
        Stage::Sensor
    }
    fn params(&self) -> &'static [ParamDef] {
        PARAMS
    }
    fn imu_yaw_rate(&self, p: &[f64], wz: f64) -> f64 {
        if p[0] == 1.0 {
            -wz
        } else {
            wz
        }
    }
}
