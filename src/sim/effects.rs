//! Named model components that real robots show and that the nominal model lacks: powertrain
//! imperfections, geometry errors, compliance and sensor faults. All are off by default; the
//! CLI injects them (`--inject NAME=VALUE`) and calibration fits them to measured data.

use crate::error::{Error, Result};
use crate::kinematics::{BodyVelocity, IdealDiffDrive, WheelSpeeds};
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
    /// The robot's velocity controller turns the (nominal) command into wheel-speed targets
    /// with its own wheel radius: this one over the nominal radius. A wheel command is read as
    /// the nominal body velocity it stands for, and the controller's kinematics give the
    /// wheels, so this scales the common mode (speed) of the targets by its inverse.
    pub controller_radius_scale: f64,
    /// The controller's wheel separation over the nominal baseline (e.g. a
    /// `wheel_separation_multiplier` in a ROS diff-drive controller): scales the differential
    /// mode (turning) of the targets.
    pub controller_baseline_scale: f64,
    /// The controller clamps the commanded forward speed (nominal body space) to this, m/s.
    pub command_speed_limit_m_s: Option<f64>,
    /// The controller clamps the commanded yaw rate (nominal body space) to this, rad/s.
    pub command_yaw_rate_limit_rad_s: Option<f64>,
    /// The controller scales both wheel targets down together so that the faster one stays at
    /// this limit, rad/s, which keeps the commanded curvature (unlike
    /// `wheel_speed_saturation_rad_s`, which clips each motor on its own).
    pub controller_wheel_limit_rad_s: Option<f64>,
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
            controller_radius_scale: 1.0,
            controller_baseline_scale: 1.0,
            command_speed_limit_m_s: None,
            command_yaw_rate_limit_rad_s: None,
            controller_wheel_limit_rad_s: None,
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
        "controller_radius_scale",
        "controller_baseline_scale",
        "command_speed_limit_m_s",
        "command_yaw_rate_limit_rad_s",
        "controller_wheel_limit_rad_s",
    ];

    /// Names of the effects that act in the wheel-terrain contact (the tyre model): a plant
    /// without one (the kinematic model) cannot represent them.
    pub const CONTACT: &'static [&'static str] = &["turning_resistance_scale", "suspension_torsion_m"];

    /// The wheel-speed targets the motors receive for the command `cmd`, given the nominal
    /// geometry the command was computed with: body-space clamps, the controller's own
    /// kinematics, the curvature-preserving wheel limit, then each motor's gain and
    /// saturation. Neutral effects return `cmd` unchanged (bit for bit).
    pub fn wheel_targets(&self, cmd: WheelSpeeds, nominal: &IdealDiffDrive) -> WheelSpeeds {
        let mut w = cmd;
        let body_stage = self.controller_radius_scale != 1.0
            || self.controller_baseline_scale != 1.0
            || self.command_speed_limit_m_s.is_some()
            || self.command_yaw_rate_limit_rad_s.is_some();
        if body_stage {
            let v = nominal.body_from_wheels(cmd);
            let clamp = |x: f64, lim: Option<f64>| lim.map_or(x, |l| x.clamp(-l, l));
            let v = BodyVelocity {
                vx_m_s: clamp(v.vx_m_s, self.command_speed_limit_m_s),
                vy_m_s: 0.0,
                wz_rad_s: clamp(v.wz_rad_s, self.command_yaw_rate_limit_rad_s),
            };
            let controller = IdealDiffDrive {
                wheel_radius_m: nominal.wheel_radius_m * self.controller_radius_scale,
                baseline_m: nominal.baseline_m * self.controller_baseline_scale,
            };
            w = controller.wheels_from_body(v);
        }
        if let Some(lim) = self.controller_wheel_limit_rad_s {
            let fastest = w.left_rad_s.abs().max(w.right_rad_s.abs());
            if fastest > lim {
                let k = lim / fastest;
                w = WheelSpeeds::new(k * w.left_rad_s, k * w.right_rad_s);
            }
        }
        let sat = |x: f64| self.wheel_speed_saturation_rad_s.map_or(x, |s| x.clamp(-s, s));
        WheelSpeeds::new(
            sat(w.left_rad_s * self.motor_gain_left),
            sat(w.right_rad_s * self.motor_gain_right),
        )
    }

    /// The IMU yaw-rate reading for the true yaw rate `wz_rad_s` (sign, scale, bias).
    pub fn imu_yaw_rate(&self, wz_rad_s: f64) -> f64 {
        let sign = if self.imu_yaw_rate_sign_flip { -1.0 } else { 1.0 };
        sign * self.imu_yaw_rate_scale * wz_rad_s + self.imu_yaw_rate_bias_rad_s
    }

    /// The wheel spins that give the encoder readings `encoders` (inverse of
    /// [`Effects::encoders`]).
    pub fn wheels_from_encoders(&self, encoders: WheelSpeeds) -> WheelSpeeds {
        WheelSpeeds::new(
            encoders.left_rad_s / self.encoder_scale,
            encoders.right_rad_s / self.encoder_scale,
        )
    }

    /// The encoder readings for the true wheel spins.
    pub fn encoders(&self, wheels: WheelSpeeds) -> WheelSpeeds {
        WheelSpeeds::new(
            wheels.left_rad_s * self.encoder_scale,
            wheels.right_rad_s * self.encoder_scale,
        )
    }

    /// Sets one effect by name. Booleans take 0 or 1; limits (`wheel_speed_saturation_rad_s`,
    /// `command_*_limit_*`, `controller_wheel_limit_rad_s`) take a positive value, or
    /// 0 / infinity to remove the limit. Rejects unknown names and
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
        // A limit: 0 or infinity removes it.
        let limit = |v: f64| -> Result<Option<f64>> {
            if v == 0.0 || v == f64::INFINITY {
                Ok(None)
            } else {
                positive(v).map(Some)
            }
        };
        match name {
            "wheel_speed_saturation_rad_s" => self.wheel_speed_saturation_rad_s = limit(value)?,
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
            "controller_radius_scale" => self.controller_radius_scale = positive(value)?,
            "controller_baseline_scale" => self.controller_baseline_scale = positive(value)?,
            "command_speed_limit_m_s" => self.command_speed_limit_m_s = limit(value)?,
            "command_yaw_rate_limit_rad_s" => self.command_yaw_rate_limit_rad_s = limit(value)?,
            "controller_wheel_limit_rad_s" => self.controller_wheel_limit_rad_s = limit(value)?,
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
    /// unknown name. A missing limit reads as infinity, booleans as 0 or 1.
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
            "controller_radius_scale" => self.controller_radius_scale,
            "controller_baseline_scale" => self.controller_baseline_scale,
            "command_speed_limit_m_s" => self.command_speed_limit_m_s.unwrap_or(f64::INFINITY),
            "command_yaw_rate_limit_rad_s" => self.command_yaw_rate_limit_rad_s.unwrap_or(f64::INFINITY),
            "controller_wheel_limit_rad_s" => self.controller_wheel_limit_rad_s.unwrap_or(f64::INFINITY),
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

    #[test]
    fn wheel_targets_by_hand() {
        // Nominal r = 0.5 m, b = 1 m: the command (1, 3) rad/s stands for v = 1 m/s, w = 1 rad/s.
        let nominal = IdealDiffDrive {
            wheel_radius_m: 0.5,
            baseline_m: 1.0,
        };
        let cmd = WheelSpeeds::new(1.0, 3.0);
        assert_eq!(Effects::default().wheel_targets(cmd, &nominal), cmd);
        let mut e = Effects::default();
        // Controller r = 0.25 m, b = 2 m: wheels (v -+ w b/2) / r = (0, 8).
        e.set("controller_radius_scale", 0.5).unwrap();
        e.set("controller_baseline_scale", 2.0).unwrap();
        let w = e.wheel_targets(cmd, &nominal);
        assert!(
            (w.left_rad_s - 0.0).abs() < 1e-12 && (w.right_rad_s - 8.0).abs() < 1e-12,
            "{w:?}"
        );
        // Yaw rate clamped to 0.5 rad/s: (1 -+ 0.5) / 0.25 = (2, 6).
        e.set("command_yaw_rate_limit_rad_s", 0.5).unwrap();
        let w = e.wheel_targets(cmd, &nominal);
        assert!(
            (w.left_rad_s - 2.0).abs() < 1e-12 && (w.right_rad_s - 6.0).abs() < 1e-12,
            "{w:?}"
        );
        // Speed clamped to 0.75 m/s: (0.75 -+ 0.5) / 0.25 = (1, 5).
        e.set("command_speed_limit_m_s", 0.75).unwrap();
        let w = e.wheel_targets(cmd, &nominal);
        assert!(
            (w.left_rad_s - 1.0).abs() < 1e-12 && (w.right_rad_s - 5.0).abs() < 1e-12,
            "{w:?}"
        );
        // Both scaled so the faster is at 2.5: (0.5, 2.5), same curvature.
        e.set("controller_wheel_limit_rad_s", 2.5).unwrap();
        // Then the left motor's gain 2 and a per-motor clip at 0.9: (0.9, 0.9).
        e.set("motor_gain_left", 2.0).unwrap();
        let w = e.wheel_targets(cmd, &nominal);
        assert!(
            (w.left_rad_s - 1.0).abs() < 1e-12 && (w.right_rad_s - 2.5).abs() < 1e-12,
            "{w:?}"
        );
        e.set("wheel_speed_saturation_rad_s", 0.9).unwrap();
        assert_eq!(e.wheel_targets(cmd, &nominal), WheelSpeeds::new(0.9, 0.9));
        // Limits come off with 0 or infinity.
        e.set("controller_wheel_limit_rad_s", 0.0).unwrap();
        assert_eq!(e.controller_wheel_limit_rad_s, None);
        assert!(e.set("command_yaw_rate_limit_rad_s", -1.0).is_err());
    }
}
