//! Steady-state slip (paper eq. 5–6): `g_B = u_B − x_B` (vx, vy, wz) with `u_B = IDD(cmd)` from
//! the log's NOMINAL radius and baseline, and `g_W = u_W − x_W` (left, right) from the encoders.
//! A robot slower than its command has a positive slip.

use drive_sim_model::kinematics::{BodyVelocity, IdealDiffDrive, WheelSpeeds};
use serde::{Deserialize, Serialize};

/// Commanded and realized velocities of one window (or one step's steady state) and the slips.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SlipRecord {
    /// Commanded wheel speeds, rad/s.
    pub cmd_wheels: WheelSpeeds,
    /// Commanded body velocity (nominal IDD of the command; vy = 0).
    pub cmd_body: BodyVelocity,
    /// Realized wheel speeds (encoders), rad/s.
    pub realized_wheels: WheelSpeeds,
    /// Realized body velocity (pose for vx, vy; the selected source for wz).
    pub realized_body: BodyVelocity,
    /// Body-frame slip `u_B − x_B`.
    pub slip_body: BodyVelocity,
    /// Wheel-frame slip `u_W − x_W`, rad/s.
    pub slip_wheels: WheelSpeeds,
}

/// Slips of a command against realized velocities.
pub fn slip(
    idd: &IdealDiffDrive,
    cmd: WheelSpeeds,
    realized_wheels: WheelSpeeds,
    realized_body: BodyVelocity,
) -> SlipRecord {
    let cmd_body = idd.body_from_wheels(cmd);
    SlipRecord {
        cmd_wheels: cmd,
        cmd_body,
        realized_wheels,
        realized_body,
        slip_body: cmd_body.minus(realized_body),
        slip_wheels: cmd.minus(realized_wheels),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slower_than_commanded_is_positive_slip() {
        let idd = IdealDiffDrive {
            wheel_radius_m: 0.3,
            baseline_m: 1.08,
        };
        // Command 10 rad/s both sides: 3 m/s forward. Robot reaches 2.5 m/s, wheels 9 rad/s.
        let r = slip(
            &idd,
            WheelSpeeds::new(10.0, 10.0),
            WheelSpeeds::new(9.0, 9.5),
            BodyVelocity::new(2.5, -0.1, 0.2),
        );
        assert!((r.slip_body.vx_m_s - 0.5).abs() < 1e-12);
        assert!((r.slip_body.vy_m_s - 0.1).abs() < 1e-12);
        assert!((r.slip_body.wz_rad_s + 0.2).abs() < 1e-12);
        assert_eq!(r.slip_wheels, WheelSpeeds::new(1.0, 0.5));
        // Reverse command, robot slower in reverse: command -3 m/s, realized -2 m/s -> slip -1.
        let r = slip(
            &idd,
            WheelSpeeds::new(-10.0, -10.0),
            WheelSpeeds::default(),
            BodyVelocity::new(-2.0, 0.0, 0.0),
        );
        assert!((r.slip_body.vx_m_s + 1.0).abs() < 1e-12);
    }
}
