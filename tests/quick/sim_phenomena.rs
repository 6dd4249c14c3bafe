//! The paper's phenomena must emerge from the simulator's physics. Each test holds a command
//! open-loop and compares steady means with numbers derived independently (IDD, force balances,
//! friction limits).

use drive_sim::kinematics::{BodyVelocity, WheelSpeeds};
use drive_sim::log::Measurement;
use drive_sim::robot::Robot;
use drive_sim::sim::{Plant, SimConfig, Simulator, GRAVITY_M_S2};
use drive_sim::terrain::Terrain;

const TICK_S: f64 = 0.05;

/// The robot file's geometry and physics without the effects it declares (the Warthog's
/// measured 12.7 rad/s wheel-speed limit): the numbers here are derived by hand for the tyres
/// and the protocol, with every command in U reachable; the effects have `tests/quick/sim_effects.rs`.
fn robot(name: &str) -> Robot {
    let mut r = Robot::resolve(name).unwrap().0;
    r.effects = Default::default();
    r
}
fn terrain(name: &str) -> Terrain {
    Terrain::resolve(name).unwrap().0
}

/// A settled simulator (1 s of rest) of `robot` on `terrain`.
fn sim(robot: &Robot, terrain: &Terrain, cfg: SimConfig) -> Simulator {
    let mut s = Simulator::new(robot, terrain, cfg).unwrap();
    s.advance(1.0).unwrap();
    s
}

/// Holds `cmd` for `secs`, measuring at 20 Hz; returns the measurements and true velocities.
fn hold(s: &mut Simulator, cmd: WheelSpeeds, secs: f64) -> Vec<(f64, Measurement, BodyVelocity)> {
    s.command(cmd);
    let t0 = s.time_s();
    let n = (secs / TICK_S).round() as usize;
    (0..n)
        .map(|_| {
            s.advance(TICK_S).unwrap();
            (s.time_s() - t0, s.measure(), s.true_velocity())
        })
        .collect()
}

struct Means {
    enc: WheelSpeeds,
    v: BodyVelocity,
}

/// Means over `from_s..to_s` of the hold.
fn means(run: &[(f64, Measurement, BodyVelocity)], from_s: f64, to_s: f64) -> Means {
    let sel: Vec<_> = run
        .iter()
        .filter(|(t, _, _)| *t > from_s && *t <= to_s + 1e-9)
        .collect();
    let n = sel.len() as f64;
    let sum =
        |f: &dyn Fn(&(f64, Measurement, BodyVelocity)) -> f64| sel.iter().map(|x| f(x)).sum::<f64>() / n;
    Means {
        enc: WheelSpeeds::new(sum(&|x| x.1.enc.left_rad_s), sum(&|x| x.1.enc.right_rad_s)),
        v: BodyVelocity::new(sum(&|x| x.2.vx_m_s), sum(&|x| x.2.vy_m_s), sum(&|x| x.2.wz_rad_s)),
    }
}

#[test]
fn ice_wheels_reach_the_command_the_body_does_not() {
    let r = robot("warthog");
    let t = terrain("ice");
    let mut s = sim(&r, &t, SimConfig::default());
    let w = r.powertrain.max_wheel_rad_s;
    let run = hold(&mut s, WheelSpeeds::new(w, w), 6.0);
    // First steady window of a DRIVE step (2-4 s).
    let m = means(&run, 2.0, 4.0);
    let idd = r.idd().body_from_wheels(WheelSpeeds::new(w, w));
    eprintln!(
        "ice: enc {:.3} of {w:.3} rad/s, vx {:.3} of IDD {:.3} m/s (2-4 s)",
        m.enc.left_rad_s, m.v.vx_m_s, idd.vx_m_s
    );
    assert!((m.enc.left_rad_s - w).abs() < 0.02 * w, "{}", m.enc.left_rad_s);
    assert!(
        m.v.vx_m_s < 0.5 * idd.vx_m_s,
        "vx {} vs IDD {}",
        m.v.vx_m_s,
        idd.vx_m_s
    );
    // Independent bound: with spinning wheels the body accelerates at most at mu_peak g and at
    // least at mu_slide g minus rolling resistance.
    let f = &t.friction;
    for pair in run.windows(2).filter(|p| p[0].0 > 1.0 && p[1].0 < 5.0) {
        let a = (pair[1].2.vx_m_s - pair[0].2.vx_m_s) / TICK_S;
        assert!(a <= f.peak_longitudinal * GRAVITY_M_S2 * 1.02, "a = {a}");
        assert!(
            a >= (f.sliding_longitudinal - t.resistance.rolling_coefficient) * GRAVITY_M_S2 * 0.98,
            "a = {a}"
        );
    }
}

#[test]
fn asphalt_straight_follows_the_idd_and_turning_in_place_skids() {
    let t = terrain("asphalt");
    for name in ["warthog", "husky"] {
        let r = robot(name);
        let w = 0.8 * r.powertrain.max_wheel_rad_s;
        let mut s = sim(&r, &t, SimConfig::default());
        let m = means(&hold(&mut s, WheelSpeeds::new(w, w), 6.0), 2.0, 6.0);
        let idd = r.idd().body_from_wheels(WheelSpeeds::new(w, w));
        let slip = 1.0 - m.v.vx_m_s / idd.vx_m_s;
        eprintln!(
            "{name} asphalt straight: vx {:.4} vs IDD {:.4}, slip {slip:.4}",
            m.v.vx_m_s, idd.vx_m_s
        );
        assert!((0.0..0.03).contains(&slip), "{name}: longitudinal slip {slip}");

        // Turning in place: every tyre slides, pushing against its sliding velocity with the
        // same force (equal peak/sliding coefficients). Yaw balance of longitudinal against
        // lateral forces, (b/2) (r w - wz b/2) = (l/2)^2 wz, gives
        // wz / wz_idd = (b/2)^2 / ((b/2)^2 + (l/2)^2) with l the wheelbase.
        let wt = 0.4 * r.powertrain.max_wheel_rad_s;
        let cmd = WheelSpeeds::new(-wt, wt);
        let mut s = sim(&r, &t, SimConfig::default());
        let m = means(&hold(&mut s, cmd, 6.0), 2.0, 6.0);
        let (hb, hl) = (r.wheels.baseline_m / 2.0, r.wheels.wheelbase_m / 2.0);
        let expected = hb * hb / (hb * hb + hl * hl);
        let ratio = m.v.wz_rad_s / r.idd().body_from_wheels(cmd).wz_rad_s;
        eprintln!("{name} asphalt turn in place: wz/wz_idd {ratio:.4}, Coulomb balance {expected:.4}");
        assert!(
            (ratio - expected).abs() < 0.03,
            "{name}: wz/wz_idd = {ratio}, expected {expected}"
        );
        assert!(
            ratio < 0.6,
            "{name}: the effective baseline must exceed the geometric one"
        );
        assert!((m.enc.right_rad_s - wt).abs() < 0.01 * wt);
    }
}

#[test]
fn mud_saturates_the_motors() {
    let t = terrain("mud");
    let res = &t.resistance;
    for (name, tol) in [("warthog", 0.03), ("husky", 0.05)] {
        let r = robot(name);
        let w = r.powertrain.max_wheel_rad_s;
        let mut s = sim(&r, &t, SimConfig::default());
        let m = means(&hold(&mut s, WheelSpeeds::new(w, w), 6.0), 2.0, 6.0);
        // Steady straight run with a saturated side: torque limit = tyre reaction + rolling
        // resistance + churning, and the tyre force balances the bulldozing of that side.
        let rad = r.wheels.radius_m;
        let n_side = r.body.mass_kg * GRAVITY_M_S2 / 2.0;
        let per_side = r.wheels.per_side as f64;
        let bulldoze = per_side * res.bulldozing_pressure_pa * r.wheels.width_m * res.sinkage_m;
        let rim = (r.powertrain.torque_limit_nm / rad - bulldoze - res.rolling_coefficient * n_side)
            / (res.churning_drag_s_m * n_side);
        let expected = rim / rad;
        let enc = 0.5 * (m.enc.left_rad_s + m.enc.right_rad_s);
        eprintln!("{name} mud full speed: enc {enc:.3} of {w:.3}, force balance {expected:.3}");
        assert_eq!(
            s.torque_saturated(),
            [true, true],
            "{name}: motors at their limit"
        );
        let tq = s.motor_torques_nm();
        assert!((tq[0] - r.powertrain.torque_limit_nm).abs() < 1e-9, "{tq:?}");
        assert!(enc < 0.8 * w, "{name}: encoders {enc} should stay well below {w}");
        assert!(
            (enc / expected - 1.0).abs() < tol,
            "{name}: encoders {enc}, force balance predicts {expected}"
        );
    }
    // Turning in mud piles dirt beside the wheels: the Husky's motors nearly stall.
    let r = robot("husky");
    let wt = 0.5 * r.powertrain.max_wheel_rad_s;
    let mut s = sim(&r, &t, SimConfig::default());
    let m = means(&hold(&mut s, WheelSpeeds::new(-wt, wt), 6.0), 2.0, 6.0);
    eprintln!("husky mud turn in place: enc {:.3} of {wt:.3}", m.enc.right_rad_s);
    assert!(m.enc.right_rad_s < 0.3 * wt, "{}", m.enc.right_rad_s);
}

#[test]
fn fast_combined_turns_drift_outwards() {
    let r = robot("warthog");
    let t = terrain("asphalt");
    let mut vys = Vec::new();
    for scale in [0.3, 1.0] {
        let cmd = WheelSpeeds::new(10.0 * scale, 16.6 * scale);
        let mut s = sim(&r, &t, SimConfig::default());
        let run = hold(&mut s, cmd, 6.0);
        let m = means(&run, 3.0, 6.0);
        // Left turn: the body slides to the right (outwards).
        vys.push(m.v.vy_m_s);
        // The IMU's lateral specific force is the centripetal acceleration vx wz at steady state.
        let ay = run
            .iter()
            .filter(|x| x.0 > 3.0)
            .map(|x| x.1.imu.ay_m_s2)
            .sum::<f64>()
            / run.iter().filter(|x| x.0 > 3.0).count() as f64;
        let centripetal = m.v.vx_m_s * m.v.wz_rad_s;
        assert!(
            (ay - centripetal).abs() < 0.05 * centripetal.abs() + 0.02,
            "{ay} vs {centripetal}"
        );
    }
    eprintln!("warthog asphalt (10, 16.6) x (0.3, 1): vy {vys:?}");
    assert!(vys[1] < -0.2, "fast turn: vy = {}", vys[1]);
    assert!(
        vys[0].abs() < 0.2 * vys[1].abs(),
        "slow turn drifts much less: {vys:?}"
    );
}

#[test]
fn rest_is_rest_on_flat_and_rough_ground() {
    for (robot_name, terrain_name) in [("warthog", "asphalt"), ("warthog", "mud"), ("husky", "grass")] {
        let r = robot(robot_name);
        let t = terrain(terrain_name);
        let mut s = Simulator::new(&r, &t, SimConfig::default()).unwrap();
        s.advance(2.0).unwrap();
        let p0 = s.true_pose();
        let run = hold(&mut s, WheelSpeeds::default(), 10.0);
        let p1 = s.true_pose();
        let drift = (p1.x_m - p0.x_m).hypot(p1.y_m - p0.y_m);
        eprintln!("rest {robot_name} {terrain_name}: drift {drift:.2e} m over 10 s");
        assert!(drift < 1e-3, "{robot_name} on {terrain_name}: drift {drift} m");
        assert!((p1.yaw_rad - p0.yaw_rad).abs() < 1e-3);
        let last = &run.last().unwrap().1;
        assert_eq!(last.enc, WheelSpeeds::default());
        // The accelerometer reads +g along the body z axis (tilted by the rough ground).
        let imu = last.imu;
        let g = (imu.ax_m_s2.powi(2) + imu.ay_m_s2.powi(2) + imu.az_m_s2.powi(2)).sqrt();
        assert!((g - GRAVITY_M_S2).abs() < 0.01 && imu.az_m_s2 > 9.7, "{imu:?}");
    }
}

#[test]
fn turning_in_place_stays_in_place() {
    for name in ["warthog", "husky"] {
        let r = robot(name);
        let t = terrain("asphalt");
        let mut s = sim(&r, &t, SimConfig::default());
        let p0 = s.true_pose();
        let w = 0.5 * r.powertrain.max_wheel_rad_s;
        let run = hold(&mut s, WheelSpeeds::new(w, -w), 6.0);
        let p1 = s.true_pose();
        let drift = (p1.x_m - p0.x_m).hypot(p1.y_m - p0.y_m);
        eprintln!("{name} turn in place: centre drift {drift:.2e} m over 6 s");
        assert!(drift < 0.01, "{name}: centre moved {drift} m");
        assert!(run.last().unwrap().2.wz_rad_s < -0.3, "it turns (clockwise)");
        assert!(run.iter().all(|x| x.2.vy_m_s.abs() < 0.01), "no sideways slide");
    }
}

#[test]
fn full_speed_straight_on_every_terrain() {
    for (tname, _) in drive_sim::terrain::BUILTIN_TERRAINS {
        for rname in ["warthog", "husky"] {
            let r = robot(rname);
            let t = terrain(tname);
            let w = r.powertrain.max_wheel_rad_s;
            let mut s = sim(&r, &t, SimConfig::default());
            let run = hold(&mut s, WheelSpeeds::new(w, w), 6.0);
            let m = means(&run, 2.0, 6.0);
            let idd = r.idd().body_from_wheels(WheelSpeeds::new(w, w)).vx_m_s;
            assert!(
                m.v.vx_m_s > 0.1 * idd && m.v.vx_m_s < 1.01 * idd,
                "{rname} {tname}: {}",
                m.v.vx_m_s
            );
            let p = s.true_pose();
            eprintln!("{rname} {tname} full speed: vx {:.3} of IDD {idd:.3}", m.v.vx_m_s);
            assert!(p.yaw_rad.abs() < 0.15, "{rname} {tname}: heading {}", p.yaw_rad);
            assert!(
                p.roll_rad.abs() < 0.1 && p.pitch_rad.abs() < 0.1,
                "{rname} {tname}: {p:?}"
            );
        }
    }
}

#[test]
fn bad_files_and_settings_name_the_field() {
    // The built-in asphalt file with one key's value replaced (whatever the file declares).
    let with_value = |key: &str, value: &str| {
        let file = drive_sim::terrain::BUILTIN_TERRAINS[0].1;
        let out: Vec<String> = file
            .lines()
            .map(|l| match l.strip_prefix(key) {
                Some(rest) if rest.trim_start().starts_with('=') => format!("{key} = {value}"),
                _ => l.to_string(),
            })
            .collect();
        let out = out.join("\n");
        assert_ne!(
            out.trim_end(),
            file.trim_end(),
            "no `{key}` line in the built-in terrain"
        );
        out
    };
    let bad_terrain = with_value("peak_longitudinal", "-0.85");
    let e = drive_sim::config::parse_toml::<Terrain>(&bad_terrain, "t.toml".as_ref()).unwrap_err();
    assert!(e.to_string().contains("friction.peak_longitudinal"), "{e}");
    let bad_terrain = with_value("rolling_coefficient", "nan");
    let e = drive_sim::config::parse_toml::<Terrain>(&bad_terrain, "t.toml".as_ref()).unwrap_err();
    assert!(e.to_string().contains("resistance.rolling_coefficient"), "{e}");

    let mut r = robot("warthog");
    r.suspension.stiffness_n_m = 1000.0;
    let e = Simulator::new(&r, &terrain("asphalt"), SimConfig::default()).unwrap_err();
    assert!(e.to_string().contains("suspension.stiffness_n_m"), "{e}");
    let mut t = terrain("mud");
    t.resistance.sinkage_m = 0.1;
    let e = Simulator::new(&robot("husky"), &t, SimConfig::default()).unwrap_err();
    assert!(e.to_string().contains("resistance.sinkage_m"), "{e}");
    let cfg = SimConfig {
        physics_hz: f64::NAN,
        ..Default::default()
    };
    let e = Simulator::new(&robot("husky"), &terrain("ice"), cfg).unwrap_err();
    assert!(e.to_string().contains("physics_hz"), "{e}");
    let mut cfg = SimConfig::default();
    cfg.noise.encoder_rad_s = -1.0;
    let e = Simulator::new(&robot("husky"), &terrain("ice"), cfg).unwrap_err();
    assert!(e.to_string().contains("noise.encoder_rad_s"), "{e}");
    let mut s = Simulator::new(&robot("husky"), &terrain("ice"), SimConfig::default()).unwrap();
    match s.advance(f64::INFINITY) {
        Err(drive_sim::Error::Diverged { .. }) => {}
        other => panic!("{other:?}"),
    }
}

#[test]
fn physics_rate_converges() {
    // The default 100 Hz gives the same steady means as 400 Hz (the implicit tyre solve is not
    // the accuracy bottleneck).
    for (rname, tname, cmd) in [
        ("warthog", "asphalt", WheelSpeeds::new(9.0, 16.0)),
        ("husky", "gravel", WheelSpeeds::new(-2.0, 5.0)),
        ("warthog", "ice", WheelSpeeds::new(12.0, 16.0)),
    ] {
        let (r, t) = (robot(rname), terrain(tname));
        let at = |hz: f64| {
            let cfg = SimConfig {
                physics_hz: hz,
                ..Default::default()
            };
            let mut s = sim(&r, &t, cfg);
            means(&hold(&mut s, cmd, 6.0), 2.0, 6.0)
        };
        let (a, b) = (at(100.0), at(400.0));
        let scale = a.v.vx_m_s.abs().max(a.v.wz_rad_s.abs()).max(0.1);
        for (x, y) in [
            (a.v.vx_m_s, b.v.vx_m_s),
            (a.v.vy_m_s, b.v.vy_m_s),
            (a.v.wz_rad_s, b.v.wz_rad_s),
            (a.enc.left_rad_s / 3.0, b.enc.left_rad_s / 3.0),
        ] {
            eprintln!("{rname} {tname}: 100 Hz {x:.4}, 400 Hz {y:.4}");
            assert!((x - y).abs() < 0.01 * scale, "{rname} {tname}: {x} vs {y}");
        }
    }
}
