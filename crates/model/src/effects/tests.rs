use super::*;

#[test]
fn registry_names_and_keys_are_unique_and_documented() {
    let mut names: Vec<&str> = REGISTRY.iter().map(|e| e.name()).collect();
    names.sort_unstable();
    names.dedup();
    assert_eq!(names.len(), REGISTRY.len());
    let mut keys = param_keys();
    let n = keys.len();
    keys.sort_unstable();
    keys.dedup();
    assert_eq!(keys.len(), n, "parameter names must be unique");
    for e in REGISTRY.iter() {
        assert!(!e.doc().is_empty() && !e.params().is_empty(), "{}", e.name());
        for p in e.params() {
            // The neutral value is valid and switches the effect off.
            let c = p.check(p.neutral).unwrap();
            assert!(p.is_neutral(c), "{}", p.key);
            let reach = CommandReach {
                wheel_rad_s: 10.0,
                speed_m_s: 3.0,
                yaw_rate_rad_s: 2.0,
            };
            let (lo, hi) = p.search.bounds(&reach);
            assert!(lo < hi && p.check(hi).is_ok(), "{}", p.key);
        }
    }
    // 16 original catalogue effects, 5 structural ones that discovery points to, the motor's
    // torque-speed line, the turning centre's offset and the crab angle, the speed loop's
    // droop, the wheels' step scatter, the droop's recovery, the wheels' deadband, knee, soft
    // limit and reverse gain, one encoder's scale, the turn's learnt load, the odometry's fade
    // and its update intervals (35 named effects),
    // and 6 generic terms: 48 features on a wheel, the 29 that do not read a side's own command
    // on the body and the IMU.
    assert_eq!(REGISTRY.iter().filter(|e| !e.generic()).count(), 35);
    assert_eq!(REGISTRY.len(), 41);
    assert_eq!(n, 43 + 2 * 48 + 4 * 29);
}

#[test]
fn default_declares_nothing_and_every_name_round_trips() {
    let mut e = Effects::default();
    assert!(e.declared().is_empty());
    for n in param_keys() {
        let v = match n {
            "imu_yaw_rate_sign_flip" => 1.0,
            "dead_time_s" | "pose_latency_s" | "suspension_torsion_m" | "crab_angle_rad" => 0.3,
            "motor_gain_drift_per_step" => 0.01,
            "odometry_fade_per_s" => 0.05,
            _ => 0.7,
        };
        e.set(n, v).unwrap();
        assert_eq!(e.get(n), Some(v), "{n}");
    }
    assert_eq!(e.declared().len(), param_keys().len());
    // Serde: a map of parameter names, which reads back to the same set.
    let json = serde_json::to_string(&e).unwrap();
    let back: Effects = serde_json::from_str(&json).unwrap();
    assert_eq!(back, e);
    assert!(serde_json::from_str::<Effects>(r#"{"warp_drive": 1.0}"#).is_err());
    // Back to neutral, the effect is off.
    e.set("dead_time_s", 0.0).unwrap();
    assert!(!e.active().any(|x| x.name() == "dead_time_s"));
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
    assert!(e.set("dead_time_s", 6.0).is_err());
    let msg = e.apply_assignment("encoder_scale=abc").unwrap_err().to_string();
    assert!(msg.contains("encoder_scale"), "{msg}");
    e.apply_assignment("imu_yaw_rate_sign_flip=true").unwrap();
    assert_eq!(e.get("imu_yaw_rate_sign_flip"), Some(1.0));
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
    let close = |w: WheelSpeeds, l: f64, r: f64| {
        assert!(
            (w.left_rad_s - l).abs() < 1e-12 && (w.right_rad_s - r).abs() < 1e-12,
            "{w:?} vs ({l}, {r})"
        )
    };
    let mut e = Effects::default();
    // Controller r = 0.25 m, b = 2 m: wheels (v -+ w b/2) / r = (0, 8).
    e.set("controller_radius_scale", 0.5).unwrap();
    e.set("controller_baseline_scale", 2.0).unwrap();
    close(e.wheel_targets(cmd, &nominal), 0.0, 8.0);
    // Yaw rate clamped to 0.5 rad/s: (1 -+ 0.5) / 0.25 = (2, 6).
    e.set("command_yaw_rate_limit_rad_s", 0.5).unwrap();
    close(e.wheel_targets(cmd, &nominal), 2.0, 6.0);
    // Speed clamped to 0.75 m/s: (0.75 -+ 0.5) / 0.25 = (1, 5).
    e.set("command_speed_limit_m_s", 0.75).unwrap();
    close(e.wheel_targets(cmd, &nominal), 1.0, 5.0);
    // Both scaled so the faster is at 2.5: (0.5, 2.5), same curvature; then the left motor's
    // gain 2: (1, 2.5); then a per-motor clip at 0.9: (0.9, 0.9).
    e.set("controller_wheel_limit_rad_s", 2.5).unwrap();
    e.set("motor_gain_left", 2.0).unwrap();
    close(e.wheel_targets(cmd, &nominal), 1.0, 2.5);
    e.set("wheel_speed_saturation_rad_s", 0.9).unwrap();
    assert_eq!(e.wheel_targets(cmd, &nominal), WheelSpeeds::new(0.9, 0.9));
    // Limits come off with 0 or infinity.
    e.set("controller_wheel_limit_rad_s", 0.0).unwrap();
    assert_eq!(e.get("controller_wheel_limit_rad_s"), Some(f64::INFINITY));
    assert!(e.set("command_yaw_rate_limit_rad_s", -1.0).is_err());
}

#[test]
fn sensors_by_hand() {
    let mut e = Effects::default();
    e.set("imu_yaw_rate_sign_flip", 1.0).unwrap();
    e.set("imu_yaw_rate_scale", 0.8).unwrap();
    e.set("imu_yaw_rate_bias_rad_s", 0.1).unwrap();
    // sign * scale * wz + bias.
    assert!((e.imu_yaw_rate(1.0) - (-0.8 + 0.1)).abs() < 1e-12);
    e.set("encoder_scale", 1.25).unwrap();
    let w = WheelSpeeds::new(2.0, -4.0);
    assert_eq!(e.encoders(w), WheelSpeeds::new(2.5, -5.0));
    assert_eq!(e.wheels_from_encoders(e.encoders(w)), w);
    e.set("dead_time_s", 0.2).unwrap();
    e.set("turning_resistance_scale", 2.0).unwrap();
    let m = e.modifiers();
    assert_eq!((m.dead_time_s, m.lateral_friction_scale), (0.2, 2.0));
    assert_eq!(
        e.first_contact_effect().map(|x| x.name()),
        Some("turning_resistance_scale")
    );
}

#[test]
fn structural_effects_and_terms_by_hand() {
    let nominal = IdealDiffDrive {
        wheel_radius_m: 0.5,
        baseline_m: 1.0,
    };
    let cmd = WheelSpeeds::new(-2.0, -1.0);
    let x = TermInput {
        cmd,
        cmd_body: nominal.body_from_wheels(cmd),
        body: BodyVelocity::new(-0.5, 0.0, 0.4),
        step: 10,
        ..TermInput::default()
    };
    let mut e = Effects::default();
    // Gain 1 - 0.01 * 10 at step 10.
    e.set("motor_gain_drift_per_step", -0.01).unwrap();
    let w = e.wheel_targets_in(cmd, &nominal, &x);
    assert!((w.left_rad_s + 1.8).abs() < 1e-12 && (w.right_rad_s + 0.9).abs() < 1e-12);
    // Body offsets add: drift 0.1, centripetal 0.2 s * (-0.5 * 0.4), reverse baseline 2:
    // wz / 2 - wz = -0.2.
    e.set("lateral_drift_m_s", 0.1).unwrap();
    e.set("centripetal_slip_s", 0.2).unwrap();
    e.set("reverse_baseline_scale", 2.0).unwrap();
    let o = e.body_offset(&x);
    assert!(
        (o.vy_m_s - (0.1 - 0.04)).abs() < 1e-12 && (o.wz_rad_s + 0.2).abs() < 1e-12,
        "{o:?}"
    );
    // A turning centre 0.1 m behind the origin: it slides at -x_ICR * wz = 0.1 * 0.4 sideways
    // (the body's yaw rate before any body term, as every offset reads it).
    let mut icr = Effects::default();
    icr.set("icr_x_m", -0.1).unwrap();
    assert!((icr.body_offset(&x).vy_m_s - 0.04).abs() < 1e-12);
    assert!(icr.acts_on_body());
    // A crab angle of atan(0.1): the origin slides at 0.1 * vx = -0.05 m/s, backwards here.
    let mut crab = Effects::default();
    crab.set("crab_angle_rad", 0.1f64.atan()).unwrap();
    assert!((crab.body_offset(&x).vy_m_s + 0.05).abs() < 1e-12);
    assert!(e.acts_on_body());
    // Forward, the reverse baseline does nothing.
    let fwd = TermInput {
        cmd_body: BodyVelocity::new(0.5, 0.0, 0.0),
        ..x
    };
    assert_eq!(e.body_offset(&fwd).wz_rad_s, 0.0);
    // A generic term: Δvy = 0.3 vx·wz - 0.05, by its keys.
    let mut t = Effects::default();
    t.set(&TermTarget::BodyVy.key(Feature::VxWz), 0.3).unwrap();
    t.set(&TermTarget::BodyVy.key(Feature::One), -0.05).unwrap();
    assert!((t.body_offset(&x).vy_m_s - (0.3 * -0.2 - 0.05)).abs() < 1e-12);
    assert_eq!(t.declared().len(), 2);
    // A wheel term reads its own side's command: Δω = 0.1 k ω_cmd on the left only.
    let mut w = Effects::default();
    w.set("term_wheel_left__step_cmd_wheel", 0.001).unwrap();
    let out = w.wheel_targets_in(cmd, &nominal, &x);
    assert!((out.left_rad_s - (-2.0 - 0.02)).abs() < 1e-12 && out.right_rad_s == -1.0);
    // An IMU term sees the reading, not the wheels.
    let mut i = Effects::default();
    i.set("term_imu_wz__1", 0.02).unwrap();
    assert!((i.imu_yaw_rate_in(0.4, &x) - 0.42).abs() < 1e-12);
    // Terms are generic: the catalogue does not list them.
    assert!(REGISTRY
        .iter()
        .filter(|e| e.generic())
        .all(|e| e.name().starts_with("term_")));
    assert!(param_owner("term_wheel_left__step_cmd_wheel").is_some());
    assert!(param_owner("term_body_vy__cmd_wheel").is_none());
}

/// The hinges' names and symbols are written out (the registry's keys are 'static): each must
/// name its own knee.
#[test]
fn every_hinge_is_named_after_its_knee() {
    for (i, knee) in term::HINGES_RAD_S.iter().enumerate() {
        let f = Feature::Hinge(i as u8);
        let k = format!("{knee}");
        assert_eq!(f.name(), format!("hinge_{k}"));
        assert!(f.symbol().ends_with(&format!("−{k})₊")), "{}", f.symbol());
        assert_eq!(Feature::from_name(f.name()), Some(f));
    }
}

/// The features with memory: the filtered copies follow the command's first-order filter
/// across steps (the context's recurrence, then the closed form within the step), as a
/// filter integrated tick by tick does; a delayed copy reads the previous step's command until
/// its delay has passed.
#[test]
fn filtered_and_delayed_copies_of_the_command_remember_the_steps_before() {
    use crate::effects::{Side, StepContext};
    let idd = IdealDiffDrive {
        wheel_radius_m: 0.3,
        baseline_m: 1.0,
    };
    let cmds = [
        WheelSpeeds::new(4.0, -2.0),
        WheelSpeeds::new(-1.0, 3.0),
        WheelSpeeds::new(2.0, 2.0),
    ];
    let (step_s, dt): (f64, f64) = (3.0, 1e-4);
    // A filter integrated by small exact steps over the three steps.
    let tau = term::FILTERS_S[1];
    let mut y = 0.0;
    let mut ctx = StepContext::default();
    for (k, cmd) in cmds.iter().enumerate() {
        let at = |t: f64| TermInput {
            t_in_step_s: t,
            ..TermInput::at_step(&ctx, *cmd, &idd)
        };
        for i in 0..(step_s / dt).round() as usize {
            let t = i as f64 * dt;
            let f = Feature::FilteredWheel(1).value(&at(t), Side::Left);
            assert!((f - y).abs() < 1e-6, "step {k} at {t:.3} s: {f} against {y}");
            y = cmd.left_rad_s + (y - cmd.left_rad_s) * (-dt / tau).exp();
        }
        // Body space: the filtered wheels through the nominal geometry.
        let x = at(1.0);
        let wz = Feature::FilteredWz(1).value(&x, Side::Neither);
        let both = WheelSpeeds::new(
            Feature::FilteredWheel(1).value(&x, Side::Left),
            Feature::FilteredWheel(1).value(&x, Side::Right),
        );
        assert!((wz - idd.body_from_wheels(both).wz_rad_s).abs() < 1e-9);
        // The delayed copy: the previous step's command for its first 0.1 s.
        let d = Feature::DelayedWheel(0);
        assert_eq!(d.value(&at(0.05), Side::Right), ctx.previous_cmd.right_rad_s);
        assert_eq!(d.value(&at(0.15), Side::Right), cmd.right_rad_s);
        ctx = ctx.next(*cmd, step_s);
    }
    assert_eq!(ctx.step, 3);
    assert_eq!(Feature::FilteredWz(2).memory_s(), Some(8.0));
    assert_eq!(Feature::DelayedWheel(1).memory_s(), Some(0.3));
    assert_eq!(Feature::Vx.memory_s(), None);
    // An operator's manoeuvre settles the memory on its own command.
    let held = ctx.holding(WheelSpeeds::new(1.0, 1.0));
    assert_eq!(held.filtered_cmd, [WheelSpeeds::new(1.0, 1.0); 3]);
}
