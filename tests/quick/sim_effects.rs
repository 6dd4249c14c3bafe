//! Each injectable effect shows its signature; sensors, noise, determinism, replay reset, and a
//! protocol run on the simulator.

use drive_sim::effects::Effects;
use drive_sim::kinematics::{BodyVelocity, WheelSpeeds};
use drive_sim::log::{Measurement, Pose};
use drive_sim::protocol::sampler::UniformWheel;
use drive_sim::protocol::{run_drive, ProtocolConfig};
use drive_sim::robot::Robot;
use drive_sim::sim::{Plant, SensorNoise, SimConfig, Simulator};
use drive_sim::terrain::Terrain;

const TICK_S: f64 = 0.05;

fn setup(robot: &str, terrain: &str, effects: &[(&str, f64)]) -> (Robot, Simulator) {
    let r = Robot::resolve(robot).unwrap().0;
    let t = Terrain::resolve(terrain).unwrap().0;
    let mut e = Effects::default();
    for (n, v) in effects {
        e.set(n, *v).unwrap();
    }
    let cfg = SimConfig {
        effects: e,
        ..Default::default()
    };
    let mut s = Simulator::new(&r, &t, cfg).unwrap();
    s.advance(1.0).unwrap();
    (r, s)
}

fn hold(s: &mut Simulator, cmd: WheelSpeeds, secs: f64) -> Vec<(Measurement, BodyVelocity)> {
    s.command(cmd);
    (0..(secs / TICK_S).round() as usize)
        .map(|_| {
            s.advance(TICK_S).unwrap();
            (s.measure(), s.true_velocity())
        })
        .collect()
}

fn mean_tail<T>(run: &[T], n: usize, f: impl Fn(&T) -> f64) -> f64 {
    run[run.len() - n..].iter().map(f).sum::<f64>() / n as f64
}

#[test]
fn weaker_left_motor_curves_left() {
    let (_, mut s) = setup("warthog", "asphalt", &[("motor_gain_left", 0.8)]);
    let run = hold(&mut s, WheelSpeeds::new(10.0, 10.0), 6.0);
    let enc_l = mean_tail(&run, 40, |x| x.0.enc.left_rad_s);
    let wz = mean_tail(&run, 40, |x| x.1.wz_rad_s);
    assert!((enc_l - 8.0).abs() < 0.05, "{enc_l}");
    assert!(wz > 0.1, "curves left: wz = {wz}");
    let (_, mut s) = setup("warthog", "asphalt", &[]);
    let run = hold(&mut s, WheelSpeeds::new(10.0, 10.0), 6.0);
    assert!(mean_tail(&run, 40, |x| x.1.wz_rad_s).abs() < 1e-3);
}

#[test]
fn saturation_radius_and_encoder_scale() {
    let (_, mut s) = setup("warthog", "asphalt", &[("wheel_speed_saturation_rad_s", 12.0)]);
    let run = hold(&mut s, WheelSpeeds::new(16.0, 16.0), 5.0);
    assert!((mean_tail(&run, 20, |x| x.0.enc.right_rad_s) - 12.0).abs() < 0.01);

    // A smaller effective radius: wheels at the command, body at scale x IDD.
    let (r, mut s) = setup("warthog", "asphalt", &[("wheel_radius_scale", 0.9)]);
    let run = hold(&mut s, WheelSpeeds::new(10.0, 10.0), 6.0);
    let vx = mean_tail(&run, 40, |x| x.1.vx_m_s);
    let idd = r.wheels.radius_m * 10.0;
    assert!((vx / idd - 0.9).abs() < 0.02, "{vx} vs {idd}");

    let (_, mut s) = setup("husky", "tile", &[("encoder_scale", 1.1)]);
    let run = hold(&mut s, WheelSpeeds::new(4.0, 4.0), 3.0);
    for (m, _) in &run {
        let t = m.truth.unwrap().wheels;
        assert!((m.enc.left_rad_s - 1.1 * t.left_rad_s).abs() < 1e-9);
    }
    assert!((mean_tail(&run, 10, |x| x.0.enc.left_rad_s) - 4.4).abs() < 0.02);
}

#[test]
fn dead_time_and_time_constant_delay_the_wheels() {
    // Small step (ramp over 0.15 s) so that the first-order loop dominates.
    let first_wheel = |effects: &[(&str, f64)]| {
        let (_, mut s) = setup("warthog", "asphalt", effects);
        let run = hold(&mut s, WheelSpeeds::new(2.0, 2.0), 4.0);
        run.iter().map(|x| x.0.enc.left_rad_s).collect::<Vec<_>>()
    };
    let base = first_wheel(&[]);
    let dead = first_wheel(&[("dead_time_s", 0.5)]);
    assert!(base[4] > 0.5, "{}", base[4]);
    // Nothing happens during the dead time (ticks end at 0.05 .. 0.5 s).
    assert!(dead[..9].iter().all(|w| w.abs() < 1e-9), "{:?}", &dead[..10]);
    // Afterwards the same response, shifted by 0.5 s (10 ticks).
    for k in 0..20 {
        assert!(
            (dead[k + 10] - base[k]).abs() < 0.02,
            "{k}: {} vs {}",
            dead[k + 10],
            base[k]
        );
    }
    // A slower loop: at t = 0.4 s the base (T = 0.25 s) is much closer to the target.
    let slow = first_wheel(&[("time_constant_scale", 3.0)]);
    assert!(slow[7] < base[7] - 0.3, "{} vs {}", slow[7], base[7]);
    // Both reach the command.
    assert!((slow.last().unwrap() - 2.0).abs() < 0.02);
}

#[test]
fn the_motor_torque_speed_line_lowers_the_ceiling_and_the_wheels_under_load() {
    // Straight on asphalt the load is the rolling resistance, a few N·m per side: the wheels
    // run up to just below the no-load speed (the command asks for 16 rad/s).
    let line = [
        ("motor_stall_torque_nm", 1000.0),
        ("motor_no_load_speed_rad_s", 11.0),
    ];
    let (_, mut s) = setup("warthog", "asphalt", &line);
    let run = hold(&mut s, WheelSpeeds::new(16.0, 16.0), 6.0);
    let enc = mean_tail(&run, 20, |x| x.0.enc.left_rad_s);
    assert!(enc < 11.0 && enc > 10.5, "{enc}");
    // Turning in place the sliding skid needs ~370 N·m per side: with 600 N·m at stall and
    // 14 rad/s free-running (343 N·m left at 6 rad/s) the motors cannot hold 6 rad/s, which
    // they do without the line.
    let turn = |effects: &[(&str, f64)]| {
        let (_, mut s) = setup("warthog", "asphalt", effects);
        let run = hold(&mut s, WheelSpeeds::new(-6.0, 6.0), 5.0);
        (
            mean_tail(&run, 40, |x| x.0.enc.right_rad_s),
            mean_tail(&run, 40, |x| x.1.wz_rad_s),
        )
    };
    let (free, free_wz) = turn(&[]);
    let (loaded, loaded_wz) = turn(&[
        ("motor_stall_torque_nm", 600.0),
        ("motor_no_load_speed_rad_s", 14.0),
    ]);
    assert!((free - 6.0).abs() < 0.05, "{free}");
    assert!(loaded < 5.8 && loaded > 3.0, "{loaded}");
    assert!(loaded_wz < free_wz, "{loaded_wz} vs {free_wz}");
}

/// The speed loop's droop: in a gentle curve on asphalt the ground couples the two sides, so
/// the body drags the slow side forward (its motor brakes) and holds the fast side back (its
/// motor drives). An ideal loop holds both commands; a drooping one lets the slow side run
/// faster than commanded and the fast side slower, as the Warthog's asphalt run does (README, "A
/// speed loop that gives way"); driving straight, with no such coupling, it barely moves.
#[test]
fn a_drooping_speed_loop_lets_the_ground_pull_both_sides_together() {
    let curve = |effects: &[(&str, f64)]| {
        let (_, mut s) = setup("warthog", "asphalt", effects);
        let run = hold(&mut s, WheelSpeeds::new(5.0, 8.0), 6.0);
        (
            mean_tail(&run, 40, |x| x.0.enc.left_rad_s),
            mean_tail(&run, 40, |x| x.0.enc.right_rad_s),
        )
    };
    let (l0, r0) = curve(&[]);
    assert!((l0 - 5.0).abs() < 0.05 && (r0 - 8.0).abs() < 0.05, "{l0} {r0}");
    let (l, r) = curve(&[("speed_droop_rad_s_per_knm", 2.0)]);
    eprintln!("droop: left {l:.3} right {r:.3}; ideal {l0:.3} {r0:.3}");
    assert!(l > 5.15, "slow side dragged faster than its 5 rad/s: {l}");
    assert!(r < 7.85, "fast side held back from its 8 rad/s: {r}");
    let (_, mut s) = setup("warthog", "asphalt", &[("speed_droop_rad_s_per_knm", 2.0)]);
    let run = hold(&mut s, WheelSpeeds::new(8.0, 8.0), 6.0);
    let straight = mean_tail(&run, 40, |x| x.0.enc.left_rad_s);
    assert!((straight - 8.0).abs() < 0.15, "{straight}");
}

/// The speed loop's integral (`droop_recovery`): with it, a pivot after a pivot the other way
/// starts from the opposite torque, falls further short than a pivot after one the same way and
/// wins the shortfall back over the step; a proportional droop falls short by the same amount
/// whatever came before and wins nothing back; the recovery alone, without a droop, changes
/// nothing.
#[test]
fn an_integral_in_the_speed_loop_remembers_the_previous_turn() {
    // Shortfall of the left wheel (commanded 5 rad/s) in the windows 2-4 s and 4-6 s of a pivot
    // that follows 6 s of `before`.
    let pivot_after = |effects: &[(&str, f64)], before: WheelSpeeds| {
        let (_, mut s) = setup("warthog", "asphalt", effects);
        hold(&mut s, before, 6.0);
        let run = hold(&mut s, WheelSpeeds::new(5.0, -5.0), 6.0);
        let window = |from: usize| {
            run[from..from + 40]
                .iter()
                .map(|x| x.0.enc.left_rad_s)
                .sum::<f64>()
                / 40.0
        };
        (1.0 - window(40) / 5.0, 1.0 - window(80) / 5.0)
    };
    let (same_way, other_way) = (WheelSpeeds::new(5.0, -5.0), WheelSpeeds::new(-5.0, 5.0));
    let memory = [("speed_droop_rad_s_per_knm", 3.0), ("droop_recovery_s", 2.0)];
    let (same1, same2) = pivot_after(&memory, same_way);
    let (rev1, rev2) = pivot_after(&memory, other_way);
    eprintln!("integral: same way {same1:.3} {same2:.3}, reversed {rev1:.3} {rev2:.3}");
    assert!(
        rev1 > same1 + 0.05,
        "a reversed pivot falls further short: {rev1} vs {same1}"
    );
    assert!(rev2 < rev1 - 0.02, "and wins it back: {rev1} -> {rev2}");
    assert!(same1.abs() < 0.05, "a learnt load costs little: {same1}");
    let droop = [("speed_droop_rad_s_per_knm", 3.0)];
    let (p_same1, p_same2) = pivot_after(&droop, same_way);
    let (p_rev1, p_rev2) = pivot_after(&droop, other_way);
    eprintln!("proportional: same way {p_same1:.3} {p_same2:.3}, reversed {p_rev1:.3} {p_rev2:.3}");
    assert!(p_same1 > 0.05, "a proportional droop falls short: {p_same1}");
    assert!(
        (p_rev1 - p_same1).abs() < 0.01 && (p_rev2 - p_rev1).abs() < 0.01,
        "and forgets"
    );
    let (ideal, _) = pivot_after(&[], other_way);
    let (alone, _) = pivot_after(&[("droop_recovery_s", 2.0)], other_way);
    assert_eq!(ideal, alone, "the recovery alone is the ideal loop");
}

#[test]
fn more_turning_resistance_turns_slower() {
    let wz = |effects: &[(&str, f64)]| {
        let (_, mut s) = setup("husky", "asphalt", effects);
        let run = hold(&mut s, WheelSpeeds::new(-3.0, 3.0), 5.0);
        mean_tail(&run, 40, |x| x.1.wz_rad_s)
    };
    let (base, stiff) = (wz(&[]), wz(&[("turning_resistance_scale", 1.5)]));
    assert!(stiff < 0.85 * base, "{stiff} vs {base}");
}

#[test]
fn torsion_springs_back_after_a_slow_turn() {
    // A slow turn in place winds up the tyres; when the command stops, the chassis rotates
    // back (yaw rate changes sign). Without the effect it just stops.
    let back = |effects: &[(&str, f64)]| {
        let (_, mut s) = setup("warthog", "asphalt", effects);
        hold(&mut s, WheelSpeeds::new(-1.0, 1.0), 3.0);
        let run = hold(&mut s, WheelSpeeds::default(), 2.0);
        run.iter().map(|x| x.1.wz_rad_s).fold(f64::INFINITY, f64::min)
    };
    let (off, on) = (back(&[]), back(&[("suspension_torsion_m", 0.3)]));
    let longer = back(&[("suspension_torsion_m", 0.6)]);
    eprintln!("torsion spring-back: min wz off {off:.4}, 0.3 m {on:.4}, 0.6 m {longer:.4}");
    assert!(longer < on, "a softer spring winds up more");
    assert!(off > -1e-3, "no spring-back without torsion: {off}");
    assert!(on < -0.005, "spring-back with torsion: {on}");
}

#[test]
fn imu_faults_and_pose_latency() {
    let (_, mut s) = setup(
        "husky",
        "asphalt",
        &[("imu_yaw_rate_scale", 2.0), ("imu_yaw_rate_bias_rad_s", 0.1)],
    );
    for (m, v) in hold(&mut s, WheelSpeeds::new(1.0, 3.0), 2.0) {
        assert!((m.imu.wz_rad_s - (2.0 * v.wz_rad_s + 0.1)).abs() < 1e-5);
    }
    let (_, mut s) = setup("husky", "asphalt", &[("imu_yaw_rate_sign_flip", 1.0)]);
    let run = hold(&mut s, WheelSpeeds::new(1.0, 3.0), 2.0);
    assert!(run
        .iter()
        .all(|(m, v)| (m.imu.wz_rad_s + v.wz_rad_s).abs() < 1e-5));
    assert!(run.last().unwrap().1.wz_rad_s > 0.1);

    let (_, mut s) = setup("warthog", "asphalt", &[("pose_latency_s", 0.5)]);
    let run = hold(&mut s, WheelSpeeds::new(10.0, 10.0), 6.0);
    let (m, v) = run.last().unwrap();
    let lag = m.truth.unwrap().pose.x_m - m.pose.x_m;
    // At a steady 3 m/s the pose is 0.5 s x 3 m/s behind.
    assert!((lag - 0.5 * v.vx_m_s).abs() < 0.02, "{lag}");
}

/// A fading odometry reads a held command's speed `1 − κ t` of the true one, from the step's
/// start, and a new step starts the fade again; the body itself drives on.
#[test]
fn a_fading_odometry_reads_the_held_speed_lower_as_the_step_goes_on() {
    use drive_sim::effects::StepContext;
    let k = 0.05;
    let (_, mut s) = setup("warthog", "asphalt", &[("odometry_fade_per_s", k)]);
    for step in 0..2 {
        s.begin_step(StepContext {
            step,
            ..StepContext::default()
        });
        let run = hold(&mut s, WheelSpeeds::new(10.0, 10.0), 6.0);
        // The read speed over one tick against the true one, at time t into the step.
        let ratio = |t: f64| {
            let i = (t / TICK_S).round() as usize;
            let read = run[i].0.pose.x_m - run[i - 1].0.pose.x_m;
            let truth = run[i].0.truth.unwrap().pose.x_m - run[i - 1].0.truth.unwrap().pose.x_m;
            read / truth
        };
        for t in [3.0, 5.0] {
            assert!(
                (ratio(t) - (1.0 - k * t)).abs() < 0.01,
                "step {step}, {t} s: {}",
                ratio(t)
            );
        }
        assert!(
            run[(5.0 / TICK_S) as usize].1.vx_m_s > 2.5,
            "the body still drives"
        );
    }
}

fn run_measurements(cfg: SimConfig, terrain: &str, ticks: usize) -> Vec<Measurement> {
    let r = Robot::resolve("warthog").unwrap().0;
    let t = Terrain::resolve(terrain).unwrap().0;
    let mut s = Simulator::new(&r, &t, cfg).unwrap();
    s.command(WheelSpeeds::new(6.0, 9.0));
    (0..ticks)
        .map(|_| {
            s.advance(TICK_S).unwrap();
            s.measure()
        })
        .collect()
}

#[test]
fn same_seed_same_bits_and_noise_has_the_configured_spread() {
    let noise = SensorNoise {
        encoder_rad_s: 0.1,
        pose_position_m: 0.01,
        pose_yaw_rad: 0.01,
        imu_gyro_rad_s: 0.02,
        imu_accel_m_s2: 0.05,
    };
    let cfg = |seed| SimConfig {
        seed,
        noise,
        ..Default::default()
    };
    let a = run_measurements(cfg(7), "gravel", 2000);
    let b = run_measurements(cfg(7), "gravel", 2000);
    let c = run_measurements(cfg(8), "gravel", 200);
    assert_eq!(a, b, "bit-identical with the same seed");
    assert_ne!(a, c);
    // Encoder noise: residual against the true wheel speed has the configured std.
    let res: Vec<f64> = a
        .iter()
        .map(|m| m.enc.left_rad_s - m.truth.unwrap().wheels.left_rad_s)
        .collect();
    let std = (res.iter().map(|x| x * x).sum::<f64>() / res.len() as f64).sqrt();
    // 2000 draws: the sample std is within 5 % (3.2 standard errors) of 0.1.
    assert!((std / 0.1 - 1.0).abs() < 0.05, "{std}");
    // Off by default: encoders equal the truth.
    let quiet = run_measurements(SimConfig::default(), "asphalt", 20);
    assert!(quiet.iter().all(|m| m.enc == m.truth.unwrap().wheels));
}

#[test]
fn reset_places_the_robot_moving() {
    let r = Robot::resolve("warthog").unwrap().0;
    let t = Terrain::resolve("asphalt").unwrap().0;
    let mut s = Simulator::new(&r, &t, SimConfig::default()).unwrap();
    let pose = Pose {
        x_m: 3.0,
        y_m: -2.0,
        yaw_rad: 1.0,
        ..Default::default()
    };
    let wheels = WheelSpeeds::new(8.0, 8.0);
    s.reset(pose, BodyVelocity::new(2.4, 0.0, 0.0), wheels);
    let p = s.true_pose();
    assert!((p.x_m - 3.0).abs() < 1e-5 && (p.yaw_rad - 1.0).abs() < 1e-5);
    assert!((p.z_m - r.body.com_height_m).abs() < 1e-3);
    // Rolling at the IDD speed of its wheels, it keeps going straight at 2.4 m/s.
    s.advance(1.0).unwrap();
    let v = s.true_velocity();
    assert!((v.vx_m_s - 2.4).abs() < 0.03 && v.wz_rad_s.abs() < 1e-3, "{v:?}");
    let q = s.true_pose();
    assert!(((q.x_m - 3.0) - 2.4 * 1f64.cos()).abs() < 0.05, "{q:?}");
    assert!((s.measure().enc.left_rad_s - 8.0).abs() < 0.05);
}

#[test]
fn drive_protocol_on_ice_completes() {
    let r = Robot::resolve("warthog").unwrap().0;
    let t = Terrain::resolve("ice").unwrap().0;
    let mut s = Simulator::new(&r, &t, SimConfig::default()).unwrap();
    let mut sampler = UniformWheel::new(3);
    let cfg = ProtocolConfig {
        steps: 5,
        ..Default::default()
    };
    let mut frames = Vec::new();
    let summary = run_drive(&mut s, &r, &mut sampler, &cfg, &mut frames).unwrap();
    assert_eq!(summary.steps_completed, 5);
    assert!(frames.len() >= 5 * 120);
    // On ice the operator's assumed braking (1.5 m/s²) exceeds what the ice gives (mu_slide g
    // = 0.69 m/s²): from full speed the robot slides past the predicted stop by at most
    // v²/(2 mu g) - v²/(2 x 1.5).
    let v = r.limits.max_lin_m_s;
    let extra =
        v * v / (2.0 * t.friction.sliding_longitudinal * 9.81) - v * v / (2.0 * cfg.operator_decel_m_s2);
    let mut worst: f64 = 0.0;
    for f in &frames {
        let p = f.m.truth.unwrap().pose;
        worst = worst.max(p.x_m.abs() - 22.5).max(p.y_m.abs() - 10.0);
    }
    assert!(worst <= extra, "{worst} m beyond the border, bound {extra}");
    eprintln!("ice DRIVE: {summary:?}, worst excursion {worst:.2} m");
}

#[test]
fn leaving_the_ground_for_good_is_a_divergence() {
    // The gravel height field covers 2 x 45 + 20 m around the origin; 500 m away there is no
    // ground: the simulator reports where the robot went instead of panicking (before it has
    // fallen far).
    let r = Robot::resolve("warthog").unwrap().0;
    let t = Terrain::resolve("gravel").unwrap().0;
    let mut s = Simulator::new(&r, &t, SimConfig::default()).unwrap();
    let far = Pose {
        x_m: 500.0,
        ..Default::default()
    };
    s.reset(far, BodyVelocity::default(), WheelSpeeds::default());
    let mut outcome = Ok(());
    for _ in 0..100 {
        outcome = s.advance(TICK_S);
        if outcome.is_err() {
            break;
        }
    }
    match outcome {
        Err(drive_sim::Error::Diverged { message, time_s, .. }) => {
            assert!(message.contains("left the simulated ground"), "{message}");
            assert!(time_s < 0.1, "{time_s}");
        }
        other => panic!("{other:?}"),
    }
}

/// Outside a DRIVE step (the operator's re-orientation) a term in the command change reads no
/// change: driving straight after a hard-turning step, a yaw-rate term in `Δwz_cmd` adds nothing
/// once the manoeuvre begins, where inside the step it adds its coefficient times the jump.
#[test]
fn a_command_change_term_is_neutral_in_a_manoeuvre() {
    use drive_sim::effects::StepContext;
    let straight = WheelSpeeds::new(8.0, 8.0);
    // The previous step turned in place at 8 rad/s per wheel: its yaw rate command was
    // 2 r ω / b, about 4.4 rad/s on the Warthog.
    let turning = WheelSpeeds::new(-8.0, 8.0);
    let yaw_rate = |manoeuvre: bool| {
        let (_, mut s) = setup("warthog", "asphalt", &[("term_body_wz__dcmd_wz", -0.1)]);
        s.begin_step(StepContext {
            step: 3,
            previous_cmd: turning,
            ..StepContext::default()
        });
        if manoeuvre {
            s.begin_manoeuvre();
        }
        let run = hold(&mut s, straight, 4.0);
        mean_tail(&run, 20, |x| x.1.wz_rad_s)
    };
    let in_step = yaw_rate(false);
    let in_manoeuvre = yaw_rate(true);
    // In the step: −0.1 × (0 − 4.4 rad/s) ≈ +0.44 rad/s of yaw on a straight command.
    assert!(in_step > 0.3, "the term acts inside a step: {in_step}");
    assert!(
        in_manoeuvre.abs() < 1e-3,
        "and not in a manoeuvre: {in_manoeuvre}"
    );
}

#[test]
fn a_stopped_robot_stands_still_whatever_its_terms() {
    // A discovered constant on the right wheel and a body yaw growing with time in the step:
    // both act while the robot drives; told to stop it brakes and stands, as a DRIVE twin's
    // operator needs (otherwise a twin with such terms cannot end its stops).
    let terms = [("term_wheel_right__1", -0.5), ("term_body_wz__t", -0.01)];
    let (_, mut s) = setup("warthog", "asphalt", &terms);
    let driving = hold(&mut s, WheelSpeeds::new(4.0, 4.0), 4.0);
    assert!(
        mean_tail(&driving, 20, |x| x.1.wz_rad_s) < -0.05,
        "the terms act in motion"
    );
    let stopped = hold(&mut s, WheelSpeeds::default(), 20.0);
    let v = stopped.last().unwrap().1;
    assert!(
        v.vx_m_s.abs() < 1e-3 && v.vy_m_s.abs() < 1e-3 && v.wz_rad_s.abs() < 1e-3,
        "{v:?}"
    );
    let enc = stopped.last().unwrap().0.enc;
    assert!(
        enc.left_rad_s.abs() < 1e-3 && enc.right_rad_s.abs() < 1e-3,
        "{enc:?}"
    );
}

/// `wheel_speed_scatter`: each step's wheels settle off their command by an offset held for the
/// step, of the asked standard deviation, the same for the same seed; a stop gets none.
#[test]
fn wheel_speed_scatter_offsets_each_step() {
    use drive_sim::effects::StepContext;
    let steady = |sigma: f64, seed: u64| -> Vec<f64> {
        let r = Robot::resolve("warthog").unwrap().0;
        let t = Terrain::resolve("asphalt").unwrap().0;
        let mut e = Effects::default();
        e.set("wheel_speed_scatter_rad_s", sigma).unwrap();
        let cfg = SimConfig {
            effects: e,
            seed,
            noise: SensorNoise::default(),
            ..Default::default()
        };
        let mut s = Simulator::new(&r, &t, cfg).unwrap();
        s.advance(1.0).unwrap();
        let mut out = Vec::new();
        for step in 0..16 {
            s.begin_step(StepContext {
                step,
                ..StepContext::default()
            });
            let run = hold(&mut s, WheelSpeeds::new(6.0, 6.0), 3.0);
            out.push(mean_tail(&run, 20, |x| x.0.enc.left_rad_s) - 6.0);
            out.push(mean_tail(&run, 20, |x| x.0.enc.right_rad_s) - 6.0);
        }
        // A stop: both wheels at rest whatever the scatter.
        let run = hold(&mut s, WheelSpeeds::default(), 3.0);
        assert!(
            mean_tail(&run, 20, |x| x.0.enc.left_rad_s.abs()) < 0.02,
            "a stop creeps"
        );
        out
    };
    let sd = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt();
    let off = steady(0.0, 1);
    let on = steady(0.5, 1);
    eprintln!("scatter off: rms {:.3}; 0.5 rad/s: rms {:.3}", sd(&off), sd(&on));
    assert!(sd(&off) < 0.03, "{off:?}");
    // 32 draws of N(0, 0.5): their rms lies in [0.33, 0.67] with probability > 0.99.
    assert!((0.33..0.67).contains(&sd(&on)), "{on:?}");
    assert_eq!(steady(0.5, 1), on, "same seed, same offsets");
    assert_ne!(steady(0.5, 2), on, "another seed, other offsets");
}

/// A robot that drives off the rough ground's height field is stopped with an error that says
/// so, not a rollover at its edge.
#[test]
fn leaving_the_height_field_is_named() {
    let (_, mut s) = setup("warthog", "gravel", &[]);
    s.command(WheelSpeeds::new(12.0, 12.0));
    let err = (0..4000)
        .find_map(|_| s.advance(TICK_S).err())
        .expect("a robot driving straight for 200 s leaves a 110 m field");
    assert!(err.to_string().contains("left the simulated ground"), "{err}");
}

/// An odometry slower than the logger: a DRIVE run on the simulator with `pose_updates`
/// declared (period 0.12 s, jitter 0.12 s, a Warthog run's) logs poses that stand still between
/// updates, and the analysis gives back the declared intervals from the log alone; the windows'
/// body speed over their wheels' scatters more than without it. Off, the pose changes at every
/// sample.
#[test]
fn an_odometry_that_publishes_now_and_then_is_measured_on_its_log() {
    use drive_sim::analysis::{analyze, AnalysisParams};
    let terrain = Terrain::resolve("asphalt").unwrap().0;
    let run = |period: f64, jitter: f64| {
        let mut robot = Robot::resolve("warthog").unwrap().0;
        robot.effects.set("pose_update_period_s", period).unwrap();
        robot.effects.set("pose_update_jitter_s", jitter).unwrap();
        let ran =
            drive_sim::harness::simulate(&robot, &terrain, "uniform-wheel", 30, 4, SensorNoise::typical())
                .unwrap();
        analyze(&ran.log, &AnalysisParams::default()).unwrap()
    };
    // The windows' forward speed over their wheels', straight-ish steps: its spread (MAD).
    let spread = |a: &drive_sim::analysis::Analysis| {
        let mut r: Vec<f64> = a
            .rows
            .iter()
            .filter(|x| x.excluded.is_none() && matches!(x.window, Some(1) | Some(2)))
            .filter(|x| {
                let wheels = 0.3 * (x.left_rad_s + x.right_rad_s) / 2.0;
                let d = (x.cmd_right_rad_s - x.cmd_left_rad_s).abs()
                    / (x.cmd_right_rad_s + x.cmd_left_rad_s).abs().max(1e-9);
                d < 0.5 && wheels.abs() > 1.0
            })
            .map(|x| x.vx_m_s / (0.3 * (x.left_rad_s + x.right_rad_s) / 2.0))
            .collect();
        r.sort_by(f64::total_cmp);
        let m = r[r.len() / 2];
        let mut d: Vec<f64> = r.iter().map(|v| (v - m).abs()).collect();
        d.sort_by(f64::total_cmp);
        d[d.len() / 2]
    };
    let held = run(0.12, 0.12);
    let p = held.pose_updates.expect("intervals measured");
    assert!(
        (p.period_s - 0.12).abs() < 0.03 && (p.jitter_s - 0.12).abs() < 0.03,
        "{p:?}"
    );
    assert!(p.held_share > 0.6, "{p:?}");
    let fresh = run(0.0, 0.0);
    let q = fresh.pose_updates.expect("intervals measured");
    assert!(q.every_sample() && q.held_share == 0.0, "{q:?}");
    let (with, without) = (spread(&held), spread(&fresh));
    assert!(
        with > 2.0 * without,
        "scatter of body over wheels: {with} held, {without} fresh"
    );
}
