//! The simulator's settings: sensor noise, physics rate, injected effects (and, for tests,
//! how a physics step is computed).

use drive_sim_model::effects::Effects;
use serde::{Deserialize, Serialize};

/// Standard deviations of the sensor noise, per channel. All zero (off) by default.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SensorNoise {
    /// Encoder wheel speed noise, rad/s.
    pub encoder_rad_s: f64,
    /// Lidar/ICP position noise (x and y), m.
    pub pose_position_m: f64,
    /// Lidar/ICP yaw noise, rad.
    pub pose_yaw_rad: f64,
    /// Gyro (yaw rate) noise, rad/s.
    pub imu_gyro_rad_s: f64,
    /// Accelerometer noise, m/s².
    pub imu_accel_m_s2: f64,
}

impl SensorNoise {
    /// Noise of typical field sensors, for runs meant to look like real data: a lidar ICP pose
    /// good to about 1 cm and 0.2° between scans, a MEMS gyro with 0.01 rad/s of white noise
    /// and 0.05 m/s² on the accelerometer, and encoders quantized to about 0.02 rad/s at 20 Hz.
    /// \[est\] orders of magnitude of the Warthog's sensors, not fitted.
    pub fn typical() -> Self {
        Self {
            encoder_rad_s: 0.02,
            pose_position_m: 0.01,
            pose_yaw_rad: 0.0035,
            imu_gyro_rad_s: 0.01,
            imu_accel_m_s2: 0.05,
        }
    }
}

/// Simulator settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SimConfig {
    /// Seed of the terrain height field and the sensor noise.
    pub seed: u64,
    /// Physics rate, Hz (rounded per `advance` call so that steps tile the call exactly).
    /// 100 Hz by default: the tyre and wheel dynamics are solved implicitly, so the rate is
    /// bounded by the explicit suspension modes (Husky roll ~36 rad/s) and the 20 Hz logging;
    /// 400 Hz changes steady means by under 1 % of the speed scale (test `physics_rate_converges`).
    pub physics_hz: f64,
    /// Sensor noise.
    pub noise: SensorNoise,
    /// Injected model effects.
    pub effects: Effects,
}

impl Default for SimConfig {
    fn default() -> Self {
        Self {
            seed: 0,
            physics_hz: 100.0,
            noise: SensorNoise::default(),
            effects: Effects::default(),
        }
    }
}

/// How a physics step is computed (feature `oracle`, for tests and benches): both give the same
/// physics, and the tests hold the fast step to the reference's tolerances.
#[cfg(feature = "oracle")]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Stepping {
    /// The tyre solve started at a prediction (the last step's change) with its Jacobian kept
    /// while it contracts; suspension rays by direct lookup on the ground's triangles; the
    /// chassis integrated directly (rapier's free-body scheme, without the pipeline around it).
    /// What every build of the binary runs.
    #[default]
    Fast,
    /// Finite-difference Jacobian of an independently written residual, rays cast by parry,
    /// the chassis integrated by rapier's `PhysicsPipeline::step`.
    Reference,
}
