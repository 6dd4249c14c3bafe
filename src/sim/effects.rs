//! Named model components that real robots show and that the nominal model lacks: powertrain
//! imperfections, geometry errors, compliance and sensor faults. All are off by default; the
//! CLI injects them (`--inject NAME=VALUE`) and calibration fits them to measured data.

use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};

/// Configurable effects. The default value of each field is the "absent" value.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Effects {
    /// The motor controller cannot drive a wheel faster than this, rad/s (e.g. voltage limit, or
    /// a wrong nominal radius making the command unreachable). `None`: no saturation.
    pub wheel_speed_saturation_rad_s: Option<f64>,
    /// Gain of the left wheel-speed loop: the wheel settles at `gain x command` (1 = exact).
    pub motor_gain_left: f64,
    /// Gain of the right wheel-speed loop.
    pub motor_gain_right: f64,
    /// Effective rolling radius over the nominal one (tyre pressure, load, wear).
    pub wheel_radius_scale: f64,
    /// Pure delay between a command and the controller acting on it, s.
    pub dead_time_s: f64,
    /// Multiplies the robot's wheel-speed-loop time constant.
    pub time_constant_scale: f64,
    /// Multiplies the lateral friction coefficients (peak and sliding): more lateral
    /// resistance makes skid-steer turning harder, i.e. a wider effective baseline.
    pub turning_resistance_scale: f64,
    /// Low-speed torsion-spring compliance of suspension and low-pressure tyres, expressed as
    /// the tyres' lateral relaxation length, m: the lateral tyre force follows a deflection state
    /// that builds up over this distance of lateral travel instead of responding to the slip
    /// angle at once. At low speed the tyres behave as a lateral (hence yaw-torsion) spring of
    /// stiffness `C_alpha / length`: a turn winds it up and the chassis springs back on stop.
    /// 0: off (quasi-static tyre).
    pub suspension_torsion_m: f64,
    /// Multiplies the IMU yaw rate (gyro scale error).
    pub imu_yaw_rate_scale: f64,
    /// The IMU yaw axis is mounted upside down (yaw rate sign flipped).
    pub imu_yaw_rate_sign_flip: bool,
    /// Constant gyro bias on the yaw rate, rad/s.
    pub imu_yaw_rate_bias_rad_s: f64,
    /// Age of the lidar/ICP pose when it is read, s.
    pub pose_latency_s: f64,
    /// Multiplies the encoder readings (wrong counts per revolution or gear ratio).
    pub encoder_scale: f64,
}

impl Default for Effects {
    fn default() -> Self {
        Self {
            wheel_speed_saturation_rad_s: None,
            motor_gain_left: 1.0,
            motor_gain_right: 1.0,
            wheel_radius_scale: 1.0,
            dead_time_s: 0.0,
            time_constant_scale: 1.0,
            turning_resistance_scale: 1.0,
            suspension_torsion_m: 0.0,
            imu_yaw_rate_scale: 1.0,
            imu_yaw_rate_sign_flip: false,
            imu_yaw_rate_bias_rad_s: 0.0,
            pose_latency_s: 0.0,
            encoder_scale: 1.0,
        }
    }
}

impl Effects {
    /// Names accepted by [`Effects::set`], in declaration order.
    pub const NAMES: &'static [&'static str] = &[
        "wheel_speed_saturation_rad_s",
        "motor_gain_left",
        "motor_gain_right",
        "wheel_radius_scale",
        "dead_time_s",
        "time_constant_scale",
        "turning_resistance_scale",
        "suspension_torsion_m",
        "imu_yaw_rate_scale",
        "imu_yaw_rate_sign_flip",
        "imu_yaw_rate_bias_rad_s",
        "pose_latency_s",
        "encoder_scale",
    ];

    /// Sets one effect by name. Booleans take 0 or 1; `wheel_speed_saturation_rad_s` takes a
    /// positive limit, or 0 / infinity to remove the saturation. Rejects unknown names and
    /// impossible values, naming them.
    pub fn set(&mut self, name: &str, value: f64) -> Result<()> {
        let bad = |why: &str| Error::config("--inject", name, format!("{why}, got {value}"));
        if value.is_nan() {
            return Err(bad("must be a number"));
        }
        let positive = |v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(v)
            } else {
                Err(bad("must be a finite number > 0"))
            }
        };
        let non_negative = |v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(v)
            } else {
                Err(bad("must be a finite number >= 0"))
            }
        };
        match name {
            "wheel_speed_saturation_rad_s" => {
                self.wheel_speed_saturation_rad_s = if value == 0.0 || value == f64::INFINITY {
                    None
                } else {
                    Some(positive(value)?)
                }
            }
            "motor_gain_left" => self.motor_gain_left = positive(value)?,
            "motor_gain_right" => self.motor_gain_right = positive(value)?,
            "wheel_radius_scale" => self.wheel_radius_scale = positive(value)?,
            "dead_time_s" => {
                if value > 5.0 {
                    return Err(bad("dead time above 5 s is not a powertrain delay"));
                }
                self.dead_time_s = non_negative(value)?
            }
            "time_constant_scale" => self.time_constant_scale = positive(value)?,
            "turning_resistance_scale" => self.turning_resistance_scale = positive(value)?,
            "suspension_torsion_m" => self.suspension_torsion_m = non_negative(value)?,
            "imu_yaw_rate_scale" => {
                if !value.is_finite() {
                    return Err(bad("must be finite"));
                }
                self.imu_yaw_rate_scale = value
            }
            "imu_yaw_rate_sign_flip" => {
                self.imu_yaw_rate_sign_flip = if value == 0.0 {
                    false
                } else if value == 1.0 {
                    true
                } else {
                    return Err(bad("must be 0 or 1"));
                }
            }
            "imu_yaw_rate_bias_rad_s" => {
                if !value.is_finite() {
                    return Err(bad("must be finite"));
                }
                self.imu_yaw_rate_bias_rad_s = value
            }
            "pose_latency_s" => {
                if value > 5.0 {
                    return Err(bad("latency above 5 s is not supported"));
                }
                self.pose_latency_s = non_negative(value)?
            }
            "encoder_scale" => self.encoder_scale = positive(value)?,
            _ => {
                return Err(Error::config(
                    "--inject",
                    name,
                    format!("unknown effect; known: {}", Self::NAMES.join(", ")),
                ))
            }
        }
        Ok(())
    }

    /// Current value of an effect as a number (the inverse of [`Effects::set`]); `None` for an
    /// unknown name. A missing saturation reads as infinity, booleans as 0 or 1.
    pub fn get(&self, name: &str) -> Option<f64> {
        Some(match name {
            "wheel_speed_saturation_rad_s" => self.wheel_speed_saturation_rad_s.unwrap_or(f64::INFINITY),
            "motor_gain_left" => self.motor_gain_left,
            "motor_gain_right" => self.motor_gain_right,
            "wheel_radius_scale" => self.wheel_radius_scale,
            "dead_time_s" => self.dead_time_s,
            "time_constant_scale" => self.time_constant_scale,
            "turning_resistance_scale" => self.turning_resistance_scale,
            "suspension_torsion_m" => self.suspension_torsion_m,
            "imu_yaw_rate_scale" => self.imu_yaw_rate_scale,
            "imu_yaw_rate_sign_flip" => f64::from(u8::from(self.imu_yaw_rate_sign_flip)),
            "imu_yaw_rate_bias_rad_s" => self.imu_yaw_rate_bias_rad_s,
            "pose_latency_s" => self.pose_latency_s,
            "encoder_scale" => self.encoder_scale,
            _ => return None,
        })
    }

    /// The effects that differ from their default, as `(name, value)` pairs in declaration
    /// order (what a log records as "injected").
    pub fn declared(&self) -> Vec<(&'static str, f64)> {
        let default = Effects::default();
        Self::NAMES
            .iter()
            .filter_map(|&n| {
                let (v, d) = (self.get(n)?, default.get(n)?);
                (v != d).then_some((n, v))
            })
            .collect()
    }

    /// Parses `NAME=VALUE` (the CLI's `--inject` syntax) and applies it.
    pub fn apply_assignment(&mut self, assignment: &str) -> Result<()> {
        let (name, value) = assignment
            .split_once('=')
            .ok_or_else(|| Error::config("--inject", assignment, "expected NAME=VALUE"))?;
        let name = name.trim();
        let v: f64 = match value.trim() {
            "true" => 1.0,
            "false" => 0.0,
            t => t
                .parse()
                .map_err(|_| Error::config("--inject", name, format!("`{t}` is not a number")))?,
        };
        self.set(name, v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_declares_nothing_and_every_name_round_trips() {
        let mut e = Effects::default();
        assert!(e.declared().is_empty());
        for &n in Effects::NAMES {
            let v = match n {
                "imu_yaw_rate_sign_flip" => 1.0,
                "dead_time_s" | "pose_latency_s" | "suspension_torsion_m" => 0.3,
                _ => 0.7,
            };
            e.set(n, v).unwrap();
            assert_eq!(e.get(n), Some(v), "{n}");
        }
        assert_eq!(e.declared().len(), Effects::NAMES.len());
    }

    #[test]
    fn bad_values_and_names_are_named() {
        let mut e = Effects::default();
        let msg = e.set("motor_gain_left", -1.0).unwrap_err().to_string();
        assert!(msg.contains("motor_gain_left"), "{msg}");
        let msg = e.set("warp_drive", 1.0).unwrap_err().to_string();
        assert!(
            msg.contains("warp_drive") && msg.contains("encoder_scale"),
            "{msg}"
        );
        assert!(e.set("imu_yaw_rate_sign_flip", 0.5).is_err());
        assert!(e.set("dead_time_s", f64::NAN).is_err());
        let msg = e.apply_assignment("encoder_scale=abc").unwrap_err().to_string();
        assert!(msg.contains("encoder_scale"), "{msg}");
        e.apply_assignment("imu_yaw_rate_sign_flip=true").unwrap();
        assert!(e.imu_yaw_rate_sign_flip);
        e.apply_assignment("wheel_speed_saturation_rad_s=12").unwrap();
        assert_eq!(
            e.declared(),
            vec![
                ("wheel_speed_saturation_rad_s", 12.0),
                ("imu_yaw_rate_sign_flip", 1.0)
            ]
        );
    }
}
