//! Robot models as data (`robots/*.toml`): geometry, mass, wheels, suspension, powertrain,
//! user limits and the safe area of the DRIVE protocol.

use crate::config::{non_negative, positive, Validate};
use crate::effects::Effects;
use crate::error::Result;
use crate::kinematics::{CommandSpace, IdealDiffDrive, WheelSpeeds};
use crate::measurement::Nominal;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// Robots shipped with the binary; files in `./robots/` override or extend them.
pub const BUILTIN_ROBOTS: &[(&str, &str)] = &[
    ("husky", include_str!("../../../robots/husky.toml")),
    ("warthog", include_str!("../../../robots/warthog.toml")),
];

/// A skid-steering robot.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Robot {
    /// Short name, e.g. `warthog`.
    pub name: String,
    /// One-line description.
    pub description: String,
    /// Chassis as a uniform box.
    pub body: BodySpec,
    /// Wheel geometry.
    pub wheels: WheelSpec,
    /// Per-wheel spring-damper suspension.
    pub suspension: SuspensionSpec,
    /// Motors and low-level wheel-speed controller.
    pub powertrain: PowertrainSpec,
    /// User limits on the body command.
    pub limits: UserLimits,
    /// Safe area of the DRIVE protocol.
    pub safe_area: SafeArea,
    /// Model effects the robot shows (motor saturation, gains, controller clamps, sensor faults), by the effect registry's parameter names (`[effects]` table;
    /// optional). Checked against the registry when the file is read; the simulator applies
    /// them (see [`crate::effects_table`]).
    #[serde(
        default,
        skip_serializing_if = "Effects::is_empty",
        serialize_with = "crate::effects_table::serialize",
        deserialize_with = "crate::effects_table::deserialize"
    )]
    pub effects: Effects,
}

/// Chassis mass and box dimensions.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodySpec {
    /// Total mass, kg.
    pub mass_kg: f64,
    /// Footprint length (depth d), m.
    pub length_m: f64,
    /// Footprint width (b), m.
    pub width_m: f64,
    /// Height (c), m.
    pub height_m: f64,
    /// Height of the centre of mass above the ground, m.
    pub com_height_m: f64,
}

/// Wheels: radius, lateral and longitudinal spacing, count, inertia.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WheelSpec {
    /// Nominal wheel radius r, m.
    pub radius_m: f64,
    /// Geometric baseline b (left to right wheel centre), m.
    pub baseline_m: f64,
    /// Distance between the front and rear axles, m (0 for a single axle per side).
    pub wheelbase_m: f64,
    /// Whether `wheelbase_m` is an estimate (`true`: the calibration by replay fits it, as the
    /// lever of the sideways scrub the wheels oppose to a turn) rather than a datasheet's or a
    /// tape's value (`false`, the default: kept). Optional; written only when `true`.
    #[serde(default, skip_serializing_if = "is_false")]
    pub wheelbase_estimated: bool,
    /// Wheels on each side, all driven by that side's motor.
    pub per_side: u32,
    /// Tyre width, m.
    pub width_m: f64,
    /// Spin inertia of one wheel including reflected motor and gearbox inertia, kg·m².
    pub inertia_kg_m2: f64,
}

/// Spring-damper suspension of each wheel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SuspensionSpec {
    /// Spring stiffness per wheel, N/m.
    pub stiffness_n_m: f64,
    /// Damping per wheel, N·s/m.
    pub damping_n_s_m: f64,
    /// Maximum travel from full extension, m.
    pub travel_m: f64,
}

/// Motors and the low-level wheel-speed controller of each side.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PowertrainSpec {
    /// Wheel speed limit, rad/s (also the bound of the command space).
    pub max_wheel_rad_s: f64,
    /// Torque limit of one side's motor at the wheels, N·m.
    pub torque_limit_nm: f64,
    /// Ramp applied by the controller to the wheel-speed target, rad/s².
    pub wheel_accel_limit_rad_s2: f64,
    /// First-order time constant of the wheel-speed loop, s.
    pub time_constant_s: f64,
}

/// User limits on the body command.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UserLimits {
    /// Maximum |vx|, m/s.
    pub max_lin_m_s: f64,
    /// Maximum |wz|, rad/s.
    pub max_ang_rad_s: f64,
    /// Maximum linear acceleration, m/s².
    pub max_lin_acc_m_s2: f64,
    /// How much more the robot's commands turn than the wheel square DRIVE drew them in, `-`
    /// ([`CommandSpace::turn_scale`]): 1 (the default) when the recorded commands are DRIVE's
    /// draws. A twin's start fits it when a run's commands leave the configured U.
    #[serde(
        default = "crate::kinematics::unit_turn_scale",
        skip_serializing_if = "is_unit"
    )]
    pub command_turn_scale: f64,
}

fn is_unit(x: &f64) -> bool {
    *x == 1.0
}

fn is_false(b: &bool) -> bool {
    !*b
}

/// Rectangular safe area centred on the start pose.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SafeArea {
    /// Extent along the world x axis, m.
    pub length_m: f64,
    /// Extent along the world y axis, m.
    pub width_m: f64,
}

impl Robot {
    /// Loads a robot by name (catalog) or path.
    pub fn resolve(name_or_path: &str) -> Result<(Self, PathBuf)> {
        crate::config::resolve("robot", name_or_path, BUILTIN_ROBOTS)
    }
    /// Ideal differential-drive kinematics with the nominal radius and baseline.
    pub fn idd(&self) -> IdealDiffDrive {
        IdealDiffDrive {
            wheel_radius_m: self.wheels.radius_m,
            baseline_m: self.wheels.baseline_m,
        }
    }
    /// The command space U.
    pub fn command_space(&self) -> CommandSpace {
        CommandSpace {
            idd: self.idd(),
            max_wheel_rad_s: self.powertrain.max_wheel_rad_s,
            max_lin_m_s: self.limits.max_lin_m_s,
            max_ang_rad_s: self.limits.max_ang_rad_s,
            turn_scale: self.limits.command_turn_scale,
        }
    }
    /// Widens the command space U to hold every command of a run: a robot's configured U (a
    /// log's nominal limits, a robot file) can be narrower than what its operators commanded,
    /// and a simulated DRIVE run inside the narrower U samples other commands than the run it
    /// is compared with. U becomes the most likely to have drawn the commands among those of
    /// its form with no limit below the configured one ([`CommandSpace::fitted_to`]); what
    /// changed is returned, one line per limit.
    pub fn cover_commands(&mut self, commands: &[WheelSpeeds]) -> Vec<String> {
        let before = self.command_space();
        let fit = before.fitted_to(commands);
        let after = fit.space;
        let reach = crate::effects::CommandReach::of_commands(commands.iter().copied(), &before.idd);
        let mut changed = Vec::new();
        let mut note = |name: &str, from: f64, to: f64, reached: f64, unit: &str| {
            if to != from {
                changed.push(format!(
                    "{name} widened from {from} to {to} {unit}: the run commanded up to {reached:.3} {unit}"
                ));
            }
        };
        if after.turn_scale == before.turn_scale {
            note(
                "powertrain.max_wheel_rad_s",
                before.max_wheel_rad_s,
                after.max_wheel_rad_s,
                reach.wheel_rad_s,
                "rad/s",
            );
        }
        note(
            "limits.max_lin_m_s",
            before.max_lin_m_s,
            after.max_lin_m_s,
            reach.speed_m_s,
            "m/s",
        );
        note(
            "limits.max_ang_rad_s",
            before.max_ang_rad_s,
            after.max_ang_rad_s,
            reach.yaw_rate_rad_s,
            "rad/s",
        );
        if after.turn_scale != before.turn_scale {
            changed.push(format!(
                "limits.command_turn_scale = {} with powertrain.max_wheel_rad_s = {} rad/s (from {}): \
                 the run's commands fill that wheel square once their turning is divided by {0}, \
                 a U of {:.2} (m/s)(rad/s) against {:.2} for the square holding them as they are \
                 (log-likelihood {:.0} nats higher)",
                after.turn_scale,
                after.max_wheel_rad_s,
                before.max_wheel_rad_s,
                after.area_body(),
                fit.at_declared_scale.area_body(),
                fit.gain_nats
            ));
        }
        self.powertrain.max_wheel_rad_s = after.max_wheel_rad_s;
        self.limits.max_lin_m_s = after.max_lin_m_s;
        self.limits.max_ang_rad_s = after.max_ang_rad_s;
        self.limits.command_turn_scale = after.turn_scale;
        changed
    }
    /// Yaw inertia of the uniform box, `m (d² + b²) / 12`, kg·m² (the paper's I_zz).
    pub fn yaw_inertia_kg_m2(&self) -> f64 {
        let b = &self.body;
        b.mass_kg * (b.length_m.powi(2) + b.width_m.powi(2)) / 12.0
    }
}

impl Validate for Robot {
    fn validate(&self) -> std::result::Result<(), (String, String)> {
        let b = &self.body;
        positive("body.mass_kg", b.mass_kg)?;
        positive("body.length_m", b.length_m)?;
        positive("body.width_m", b.width_m)?;
        positive("body.height_m", b.height_m)?;
        positive("body.com_height_m", b.com_height_m)?;
        let w = &self.wheels;
        positive("wheels.radius_m", w.radius_m)?;
        positive("wheels.baseline_m", w.baseline_m)?;
        non_negative("wheels.wheelbase_m", w.wheelbase_m)?;
        positive("wheels.width_m", w.width_m)?;
        positive("wheels.inertia_kg_m2", w.inertia_kg_m2)?;
        if w.per_side == 0 || w.per_side > 8 {
            return Err((
                "wheels.per_side".into(),
                format!("must be 1..=8, got {}", w.per_side),
            ));
        }
        if w.per_side == 1 && w.wheelbase_m != 0.0 {
            return Err((
                "wheels.wheelbase_m".into(),
                "must be 0 with one wheel per side".into(),
            ));
        }
        if w.per_side > 1 && w.wheelbase_m <= 0.0 {
            return Err((
                "wheels.wheelbase_m".into(),
                "must be > 0 with several wheels per side".into(),
            ));
        }
        if w.baseline_m > b.width_m * 1.5 {
            return Err((
                "wheels.baseline_m".into(),
                format!("{} m is far wider than the body ({} m)", w.baseline_m, b.width_m),
            ));
        }
        let s = &self.suspension;
        positive("suspension.stiffness_n_m", s.stiffness_n_m)?;
        non_negative("suspension.damping_n_s_m", s.damping_n_s_m)?;
        positive("suspension.travel_m", s.travel_m)?;
        let p = &self.powertrain;
        positive("powertrain.max_wheel_rad_s", p.max_wheel_rad_s)?;
        positive("powertrain.torque_limit_nm", p.torque_limit_nm)?;
        positive("powertrain.wheel_accel_limit_rad_s2", p.wheel_accel_limit_rad_s2)?;
        positive("powertrain.time_constant_s", p.time_constant_s)?;
        let l = &self.limits;
        positive("limits.max_lin_m_s", l.max_lin_m_s)?;
        positive("limits.max_ang_rad_s", l.max_ang_rad_s)?;
        positive("limits.max_lin_acc_m_s2", l.max_lin_acc_m_s2)?;
        positive("safe_area.length_m", self.safe_area.length_m)?;
        positive("safe_area.width_m", self.safe_area.width_m)?;
        self.validate_ranges()
    }
}

impl Robot {
    /// Physical ranges (with units) of a ground robot the simulator can run: a value outside is
    /// a typo (a unit slip, a missing decimal point) that would otherwise surface as a run that
    /// takes minutes or diverges.
    fn validate_ranges(&self) -> std::result::Result<(), (String, String)> {
        let (b, w, s, p, l) = (
            &self.body,
            &self.wheels,
            &self.suspension,
            &self.powertrain,
            &self.limits,
        );
        for (field, v, lo, hi, unit) in [
            ("body.mass_kg", b.mass_kg, 1.0, 20_000.0, "kg"),
            ("body.length_m", b.length_m, 0.1, 20.0, "m"),
            ("body.width_m", b.width_m, 0.1, 10.0, "m"),
            ("body.height_m", b.height_m, 0.05, 10.0, "m"),
            ("body.com_height_m", b.com_height_m, 0.01, 5.0, "m"),
            ("wheels.radius_m", w.radius_m, 0.02, 2.0, "m"),
            ("wheels.baseline_m", w.baseline_m, 0.05, 10.0, "m"),
            ("wheels.wheelbase_m", w.wheelbase_m, 0.0, 20.0, "m"),
            ("wheels.width_m", w.width_m, 0.005, 2.0, "m"),
            ("wheels.inertia_kg_m2", w.inertia_kg_m2, 1e-5, 1_000.0, "kg·m²"),
            ("suspension.stiffness_n_m", s.stiffness_n_m, 100.0, 1e10, "N/m"),
            ("suspension.damping_n_s_m", s.damping_n_s_m, 0.0, 1e7, "N·s/m"),
            ("suspension.travel_m", s.travel_m, 0.001, 2.0, "m"),
            (
                "powertrain.max_wheel_rad_s",
                p.max_wheel_rad_s,
                0.1,
                200.0,
                "rad/s",
            ),
            ("powertrain.torque_limit_nm", p.torque_limit_nm, 0.1, 1e6, "N·m"),
            (
                "powertrain.wheel_accel_limit_rad_s2",
                p.wheel_accel_limit_rad_s2,
                0.01,
                1e4,
                "rad/s²",
            ),
            ("powertrain.time_constant_s", p.time_constant_s, 1e-3, 10.0, "s"),
            ("limits.max_lin_m_s", l.max_lin_m_s, 0.01, 30.0, "m/s"),
            ("limits.max_ang_rad_s", l.max_ang_rad_s, 0.01, 20.0, "rad/s"),
            ("limits.max_lin_acc_m_s2", l.max_lin_acc_m_s2, 0.01, 50.0, "m/s²"),
            (
                "limits.command_turn_scale",
                l.command_turn_scale,
                crate::kinematics::TURN_SCALE.0,
                crate::kinematics::TURN_SCALE.1,
                "-",
            ),
            ("safe_area.length_m", self.safe_area.length_m, 1.0, 10_000.0, "m"),
            ("safe_area.width_m", self.safe_area.width_m, 1.0, 10_000.0, "m"),
        ] {
            crate::config::in_range(field, v, lo, hi, unit)?;
        }
        // The wheel rim speed bounds the body speed the protocol can command.
        let rim_m_s = p.max_wheel_rad_s * w.radius_m;
        if rim_m_s > 30.0 {
            return Err((
                "powertrain.max_wheel_rad_s".into(),
                format!(
                    "{} rad/s on {} m wheels is a rim speed of {rim_m_s:.1} m/s; must be at most 30 m/s",
                    p.max_wheel_rad_s, w.radius_m
                ),
            ));
        }
        Ok(())
    }
}

/// A robot model's values as a log declares them (the nominal robot of simulated logs).
///
/// Written here rather than beside [`Nominal`]: the log's data model sits below the robot model
/// and does not know it.
impl Nominal {
    /// Declared nominal values of a robot model.
    pub fn from_robot(r: &Robot) -> Self {
        Self {
            wheel_radius_m: r.wheels.radius_m,
            baseline_m: r.wheels.baseline_m,
            max_wheel_rad_s: r.powertrain.max_wheel_rad_s,
            max_lin_m_s: r.limits.max_lin_m_s,
            max_ang_rad_s: r.limits.max_ang_rad_s,
            mass_kg: r.body.mass_kg,
            width_m: r.body.width_m,
            length_m: r.body.length_m,
            height_m: Some(r.body.height_m),
            max_lin_acc_m_s2: Some(r.limits.max_lin_acc_m_s2),
            command_turn_scale: (r.limits.command_turn_scale != 1.0).then_some(r.limits.command_turn_scale),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::Error;

    #[test]
    fn builtins_load() {
        for (name, _) in BUILTIN_ROBOTS {
            let (r, _) = Robot::resolve(name).unwrap();
            assert_eq!(&r.name, name);
        }
    }

    /// Every file of `robots/`, built in or not (a deployment file such as `husky_2023.toml`
    /// is only read from there), loads, validates and runs its effects' checks.
    #[test]
    fn every_robot_file_of_the_repository_loads() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../robots");
        let mut n = 0;
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().is_some_and(|x| x == "toml") {
                Robot::resolve(path.to_str().unwrap()).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
                n += 1;
            }
        }
        assert!(n > BUILTIN_ROBOTS.len(), "{n} files in {}", dir.display());
    }

    #[test]
    fn warthog_inertia_by_hand() {
        let (r, _) = Robot::resolve("warthog").unwrap();
        // 470/12 * (2.13² + 1.52²) = 39.1667 * (4.5369 + 2.3104) = 268.19 kg m²
        assert!((r.yaw_inertia_kg_m2() - 268.1858).abs() < 1e-3);
    }

    #[test]
    fn negative_mass_names_the_field() {
        let text = BUILTIN_ROBOTS[1].1.replace("mass_kg = 470.0", "mass_kg = -470.0");
        let err = crate::config::parse_toml::<Robot>(&text, "bad.toml".as_ref()).unwrap_err();
        match &err {
            Error::Config { field, .. } => assert_eq!(field, "body.mass_kg"),
            e => panic!("wrong error {e}"),
        }
        assert!(err.to_string().contains("bad.toml"));
    }

    #[test]
    fn missing_field_names_the_field() {
        let text = BUILTIN_ROBOTS[1].1.replace("radius_m = 0.30", "");
        let err = crate::config::parse_toml::<Robot>(&text, "bad.toml".as_ref()).unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains("wheels") && msg.contains("radius_m"), "{msg}");
    }

    /// Two commands of the Husky's run (14.33 rad/s at a wheel, 8.27 rad/s of yaw rate through
    /// the nominal IDD) widen the metadata's U (6.06 rad/s, 2.0 rad/s); what U already holds
    /// stays, and two commands are too few to fit a turn scale.
    #[test]
    fn a_run_commanding_beyond_u_widens_it_and_only_it() {
        let (mut r, _) = Robot::resolve("husky").unwrap();
        let commands = [WheelSpeeds::new(-14.33, 13.5), WheelSpeeds::new(5.73, 5.73)];
        let changed = r.cover_commands(&commands);
        assert_eq!(r.powertrain.max_wheel_rad_s, 14.4);
        assert_eq!(r.limits.max_ang_rad_s, 8.3);
        assert_eq!(r.limits.max_lin_m_s, 1.0);
        assert_eq!(r.limits.command_turn_scale, 1.0);
        assert_eq!(changed.len(), 2, "{changed:?}");
        assert!(
            changed[0].contains("6.06") && changed[0].contains("14.330"),
            "{changed:?}"
        );
        assert!(
            r.cover_commands(&commands).is_empty(),
            "widening twice changes nothing"
        );
    }

    #[test]
    fn unknown_robot_lists_the_known_ones() {
        let msg = Robot::resolve("tank").unwrap_err().to_string();
        assert!(msg.contains("warthog") && msg.contains("husky"), "{msg}");
    }
}
