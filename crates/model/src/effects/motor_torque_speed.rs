//! A DC motor's torque falls with its speed: at full voltage the back-EMF leaves less current
//! the faster it turns.

use super::{Effect, ParamDef, ParamKind, PlantModifiers, ReachOf, SearchBox, Stage};

/// The motor's torque-speed line at full voltage, `τ_max(ω) = τ_stall (1 − |ω| / ω_0)` while the
/// motor drives its wheel (torque and spin of one sign), per side at the wheels; braking
/// keeps the powertrain's torque limit. One line explains two things a fixed speed clip
/// cannot: a wheel-speed ceiling that is lower under load than free-running (turning on
/// asphalt against driving straight), and wheels that fall short of their targets wherever
/// the ground resists (skid-steer turns), with a body that then pivots about its gripping
/// inner side instead of dragging it. Needs the contact model's load torque: the kinematic
/// model cannot run it.
pub struct MotorTorqueSpeed;

const PARAMS: &[ParamDef] = &[
    ParamDef {
        key: "motor_stall_torque_nm",
        unit: "N·m",
        kind: ParamKind::Limit,
        min: 0.0,
        max: 1.0e5,
        neutral: f64::INFINITY,
        search: SearchBox::Fixed {
            lower: 200.0,
            upper: 5000.0,
        },
        resolution: None,
    },
    ParamDef {
        key: "motor_no_load_speed_rad_s",
        unit: "rad/s",
        kind: ParamKind::Limit,
        min: 0.0,
        max: 1000.0,
        neutral: f64::INFINITY,
        search: SearchBox::Reach {
            of: ReachOf::Wheel,
            lower: 0.5,
            upper: 1.5,
        },
        resolution: None,
    },
];

impl Effect for MotorTorqueSpeed {
    fn name(&self) -> &'static str {
        "motor_torque_speed"
    }
    fn doc(&self) -> &'static str {
        "the motor's torque falls linearly with its speed (back-EMF at full voltage): wheels fall short under load and the speed ceiling is lower in turns"
    }
    fn stage(&self) -> Stage {
        Stage::Wheel
    }
    fn params(&self) -> &'static [ParamDef] {
        PARAMS
    }
    fn kinematic(&self) -> bool {
        false
    }
    fn default_candidate(&self) -> bool {
        false
    }
    fn modify_plant(&self, p: &[f64], m: &mut PlantModifiers) {
        m.motor_stall_torque_nm = p[0];
        m.motor_no_load_speed_rad_s = p[1];
    }
}

/// The torque a motor can give at wheel spin `omega_rad_s` towards `need_nm`, under the
/// powertrain's fixed `limit_nm` and the torque-speed line (`stall_nm`, `no_load_rad_s`; either
/// infinite: no line).
#[inline]
pub fn available_torque_nm(
    limit_nm: f64,
    stall_nm: f64,
    no_load_rad_s: f64,
    omega_rad_s: f64,
    need_nm: f64,
) -> f64 {
    if need_nm * omega_rad_s <= 0.0 || (stall_nm.is_infinite() && no_load_rad_s.is_infinite()) {
        return limit_nm;
    }
    let line = if no_load_rad_s.is_infinite() {
        stall_nm
    } else if omega_rad_s.abs() >= no_load_rad_s {
        0.0
    } else {
        stall_nm * (1.0 - omega_rad_s.abs() / no_load_rad_s)
    };
    limit_nm.min(line.max(0.0))
}

#[cfg(test)]
mod tests {
    use super::available_torque_nm;

    #[test]
    fn the_line_falls_to_zero_at_the_no_load_speed_and_only_when_motoring() {
        let inf = f64::INFINITY;
        assert_eq!(available_torque_nm(700.0, inf, inf, 5.0, 100.0), 700.0);
        assert_eq!(available_torque_nm(700.0, 1000.0, 10.0, 5.0, 100.0), 500.0);
        assert_eq!(available_torque_nm(700.0, 1000.0, 10.0, 0.0, 100.0), 700.0);
        assert!((available_torque_nm(700.0, 1000.0, 10.0, -8.0, -100.0) - 200.0).abs() < 1e-9);
        assert_eq!(available_torque_nm(700.0, 1000.0, 10.0, 12.0, 100.0), 0.0);
        // Braking (torque against the spin) keeps the powertrain's limit.
        assert_eq!(available_torque_nm(700.0, 1000.0, 10.0, 12.0, -100.0), 700.0);
        // Only a no-load speed: a hard ceiling; only a stall torque: a lower fixed limit.
        assert_eq!(available_torque_nm(700.0, inf, 10.0, 9.0, 1.0), 700.0);
        assert_eq!(available_torque_nm(700.0, inf, 10.0, 10.0, 1.0), 0.0);
        assert_eq!(available_torque_nm(700.0, 400.0, inf, 9.0, 1.0), 400.0);
    }
}
