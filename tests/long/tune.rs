//! Closed-loop tuning (`drive_sim::compare::tune`) on DRIVE runs of an independent
//! generator (`tests/common/generator.rs`, not the project's plants), whose answer is known:
//! - its motors clip at 10 rad/s: tuning the simulated Warthog's wheel-speed limit against
//!   the generator's odd steps finds it, the check on fresh seeds accepts it, and on the even
//!   steps (never used) the tuned twin is closer than the start on every judging seed;
//! - its motors do not clip: the same tuning accepts nothing (the twin stays the start).
//!
//! The generator is a kinematic skid-steer with the effective track width the simulated
//! Warthog shows on asphalt, and its side slip in turns (vy = −0.20 s · vx · wz: `drive-sim run
//! --robot warthog --terrain asphalt --steps 200 --seed 0 --inject
//! wheel_speed_saturation_rad_s=10`, `drive-sim analyze`, `scripts/lateral_slip_regression.py`:
//! −0.202 [−0.215, −0.187] s), so that its runs and the simulator's are alike but for the limit.
//! With +0.05 s instead the lateral-slip map differs by 5–8× its yardstick whatever the limit,
//! and a lower limit, slowing the turns, shrinks that difference: the search trades the limit
//! for the lateral map (8.55 rad/s chosen with the yardstick averaged over 64 halvings).

use crate::common;
use common::generator::{drive_log_with, TestRobotSpec, Unmodelled};
use drive_sim::calibration::twin;
use drive_sim::compare::tune::{search::SearchOptions, tune, TuneEvent, TuneOptions, TuneRequest};
use drive_sim::log::UseSteps;
use drive_sim::terrain::Terrain;

const LIMIT_RAD_S: f64 = 10.0;

/// The generator's DRIVE run (80 steps), its motors clipping at `limit_rad_s` (0: no limit).
fn generator_log(limit_rad_s: f64) -> (drive_sim::log::DriveLog, drive_sim::robot::Robot) {
    let extra = Unmodelled {
        wheel_limit_rad_s: limit_rad_s,
        centripetal_s: -0.20,
        pose_yaw_noise_rad: 0.01,
        ..Unmodelled::default()
    };
    drive_log_with("generator", TestRobotSpec::warthog_on_asphalt(3), extra, 80)
}

fn tuned(limit_rad_s: f64) -> drive_sim::compare::tune::TuneOutcome {
    let (log, robot) = generator_log(limit_rad_s);
    let (terrain, _) = Terrain::resolve("asphalt").unwrap();
    let start = twin::lift_effects(&robot, &terrain).unwrap();
    let opts = TuneOptions {
        choose_on: UseSteps::Odd,
        steps: None,
        seed: 0,
        choose_seeds: 3,
        check_seeds: 2,
        search: SearchOptions {
            max_evaluations: 14,
            ..SearchOptions::default()
        },
        loss_resamples: 200,
        ..TuneOptions::default()
    };
    let names = vec!["wheel_speed_saturation_rad_s".to_string()];
    // The search's points as it reports them: numbered from 1, one per evaluation.
    let last_point = std::sync::Mutex::new(0);
    let o = tune(
        &TuneRequest {
            real: &log,
            start: &start,
            tune: &names,
            boxes: &[],
            opts: &opts,
        },
        &|event| {
            if let TuneEvent::Point { index, keys, .. } = event {
                assert_eq!(*keys, &names[..]);
                *last_point.lock().unwrap() = *index;
            }
            eprintln!("{event}")
        },
    )
    .unwrap();
    assert_eq!(*last_point.lock().unwrap(), o.evaluations.len());
    o
}

#[test]
fn a_wheel_speed_limit_is_found_in_closed_loop_and_judged_on_held_out_steps() {
    let o = tuned(LIMIT_RAD_S);
    for e in &o.evaluations {
        eprintln!("{:?} {:?} {:?}", e.values, e.loss, e.seed_losses);
    }
    let p = &o.params[0];
    eprintln!(
        "chosen {:.3} rad/s (true {LIMIT_RAD_S}), loss {:?} -> {:.2}, check {:.2} ± {:.2}",
        p.chosen, o.start_loss, o.chosen_loss, o.check.mean_reduction, o.check.se
    );
    assert!(o.accepted, "{:?}", o.check);
    assert!(
        (p.chosen - LIMIT_RAD_S).abs() < 1.0,
        "chosen {} rad/s, true {LIMIT_RAD_S}",
        p.chosen
    );
    let h = o
        .heldout
        .as_ref()
        .expect("chosen on odd steps: judged on even ones");
    assert_eq!(h.steps, UseSteps::Even);
    // The real halves against each other: the generator's odd and even steps are alike.
    let halves = h.real_halves.as_ref().expect("held out: the halves are compared");
    assert!(
        halves.verdict.as_ref().is_some_and(|v| v.reproduces),
        "{:?}",
        halves.verdict
    );
    for (a, b) in h.start.iter().zip(&h.chosen) {
        let (a, b) = (a.loss.as_ref().unwrap().total, b.loss.as_ref().unwrap().total);
        assert!(
            b < a,
            "seed {}: held-out loss {a:.2} (start) -> {b:.2}",
            h.start[0].seed
        );
    }
    // The twin carries the chosen limit.
    let m = o.model.as_ref().unwrap();
    assert_eq!(m.effects.get("wheel_speed_saturation_rad_s"), Some(p.chosen));
    // Its files round-trip, and running them (what `drive-sim run --robot twin/robot.toml
    // --terrain twin/terrain.toml --steps N --seed S` does, its commands drawn in the judged
    // steps' quadrants) gives the judged run again.
    let files = drive_sim::compare::tune::twin_of(&o, "the test's start", "cargo test").unwrap();
    assert!(
        files.robot_toml.contains("[tune] generator"),
        "{}",
        files.robot_toml
    );
    let r: drive_sim::robot::Robot =
        drive_sim::config::parse_toml(&files.robot_toml, "robot.toml".as_ref()).unwrap();
    let t: Terrain = drive_sim::config::parse_toml(&files.terrain_toml, "terrain.toml".as_ref()).unwrap();
    let back = twin::lift_effects(&r, &t).unwrap();
    assert_eq!(&back, m);
    let (log, _) = generator_log(LIMIT_RAD_S);
    let even = UseSteps::Even.select(&log);
    let seed = h.chosen[0].seed;
    let run = drive_sim::compare::tune::twin_run_matched(&back, &even.held_commands(), o.steps_per_run, seed)
        .unwrap();
    let c = drive_sim::compare::compare(
        drive_sim::compare::Input {
            log: &even,
            file: None,
        },
        &[drive_sim::compare::Input {
            log: &run,
            file: None,
        }],
        &drive_sim::compare::CompareOptions::default(),
    )
    .unwrap();
    let again = drive_sim::compare::loss::loss(&c.sims[0], &c.options).total;
    assert_eq!(again, h.chosen[0].loss.as_ref().unwrap().total);
}

#[test]
fn without_a_limit_nothing_is_accepted() {
    let o = tuned(0.0);
    eprintln!(
        "chosen {:.3} rad/s, loss {:?} -> {:.2}, check {:.2} ± {:.2}",
        o.params[0].chosen, o.start_loss, o.chosen_loss, o.check.mean_reduction, o.check.se
    );
    assert!(!o.accepted, "{:?}", o.check);
    let m = o.model.as_ref().unwrap();
    let limit = m.effects.get("wheel_speed_saturation_rad_s");
    assert!(limit.is_none_or(f64::is_infinite), "{limit:?}");
}

/// Bad input through the binary: exit code 2, the option and the entry named, before any run,
/// and no output directory left behind.
#[test]
fn bad_input_is_refused_before_any_run() {
    let log = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../shared/data/measured/warthog_asphalt.csv"
    );
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("t");
    let out_s = out.to_str().unwrap();
    let cases: &[(&[&str], &[&str])] = &[
        (
            &["--tune", "motor_torque_sped"],
            &["--tune", "did you mean `motor_torque_speed`"],
        ),
        (&["--tune", "imu_yaw_rate_sign_flip"], &["on/off"]),
        (
            &["--tune", "motor_torque_speed", "--check-seeds", "1"],
            &["--check-seeds", "2..=64"],
        ),
        (
            &["--tune", "motor_torque_speed", "--robot", "husky"],
            &["robot `warthog`"],
        ),
        (
            &[
                "--tune",
                "motor_torque_speed",
                "--inject",
                "wheel_speed_saturation_rad_s=-3",
            ],
            &["wheel_speed_saturation_rad_s"],
        ),
    ];
    for (args, needles) in cases {
        let mut all = vec!["tune", log, "--out", out_s];
        all.extend_from_slice(args);
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_drive-sim"))
            .args(&all)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        for n in *needles {
            assert!(err.contains(n), "{args:?}: `{n}` not in:\n{err}");
        }
        assert!(
            !err.contains("tune: point"),
            "{args:?} ran before refusing:\n{err}"
        );
        assert!(!out.exists(), "{args:?} left {}", out.display());
        assert_eq!(
            std::fs::read_dir(dir.path()).unwrap().count(),
            0,
            "{args:?} left files"
        );
    }
}
