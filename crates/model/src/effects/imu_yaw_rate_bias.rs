//! The gyro reads a constant offset.

use super::{Effect, ParamDef, ParamKind, SearchBox, Stage};

/// A constant gyro bias on the yaw rate.
pub(crate) struct ImuYawRateBias;

const PARAMS: &[ParamDef] = &[ParamDef {
    key: "imu_yaw_rate_bias_rad_s",
    unit: "rad/s",
    kind: ParamKind::Continuous,
    min: -100.0,
    max: 100.0,
    neutral: 0.0,
    search: SearchBox::Fixed {
        lower: -0.2,
        upper: 0.2,
    },
    resolution: None,
}];

impl Effect for ImuYawRateBias {
    fn name(&self) -> &'static str {
        "imu_yaw_rate_bias_rad_s"
    }
    fn doc(&self) -> &'static str {
        "the gyro reads a constant yaw-rate offset"
    }
    fn stage(&self) -> Stage {
        Stage::Sensor
    }
    fn params(&self) -> &'static [ParamDef] {
        PARAMS
    }
    fn imu_yaw_rate(&self, p: &[f64], wz: f64) -> f64 {
        wz + p[0]
    }
}
