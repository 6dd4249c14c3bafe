//! The gyro's scale factor is off.

use super::{Effect, ParamDef, ParamKind, SearchBox, Stage};

/// Multiplies the IMU yaw rate (gyro scale error).
pub(crate) struct ImuYawRateScale;

const PARAMS: &[ParamDef] = &[ParamDef {
    key: "imu_yaw_rate_scale",
    unit: "-",
    kind: ParamKind::Continuous,
    min: -100.0,
    max: 100.0,
    neutral: 1.0,
    search: SearchBox::Fixed {
        lower: 0.5,
        upper: 1.5,
    },
    resolution: None,
}];

impl Effect for ImuYawRateScale {
    fn name(&self) -> &'static str {
        "imu_yaw_rate_scale"
    }
    fn doc(&self) -> &'static str {
        "the gyro's scale factor is off"
    }
    fn stage(&self) -> Stage {
        Stage::Sensor
    }
    fn params(&self) -> &'static [ParamDef] {
        PARAMS
    }
    fn imu_yaw_rate(&self, p: &[f64], wz: f64) -> f64 {
        p[0] * wz
    }
}
