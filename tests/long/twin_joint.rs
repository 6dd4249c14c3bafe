//! Several logs, one robot: three DRIVE runs of one generator robot whose motors clip at a
//! wheel-speed limit (the robot's), each on a ground with its own centripetal slip (the
//! terrain's). The joint calibration recovers the shared limit with a tighter interval than any
//! log alone, and each log's slip. Logs of different robots are refused before any work.

use crate::common;

use common::generator::{drive_log_with, TestRobotSpec, Unmodelled};
use drive_sim::calibration::joint::{calibrate_joint, JointInput, JointLog};
use drive_sim::calibration::{CalibrationOptions, KinematicFactory};
use drive_sim::terrain::Terrain;

const LIMIT: f64 = 11.0;
const SLIPS: [f64; 3] = [0.05, 0.15, 0.25];

fn log(k: usize) -> drive_sim::log::DriveLog {
    let extra = Unmodelled {
        wheel_limit_rad_s: LIMIT,
        centripetal_s: SLIPS[k],
        pose_yaw_noise_rad: 0.003,
        ..Unmodelled::default()
    };
    let (mut log, _) = drive_log_with(
        &format!("ground{k}"),
        TestRobotSpec::discovery(40 + k as u64),
        extra,
        40,
    );
    log.meta.terrain = format!("ground{k}");
    log
}

fn opts() -> CalibrationOptions {
    CalibrationOptions {
        candidates: Some(vec![
            "wheel_speed_saturation_rad_s".into(),
            "centripetal_slip".into(),
        ]),
        max_effects: 2,
        discover: false,
        ..CalibrationOptions::default()
    }
}

#[test]
fn joint_fit_shares_the_robot_and_fits_a_terrain_per_log() {
    let logs: Vec<_> = (0..3).map(log).collect();
    let (robot, _) = drive_sim::robot::Robot::resolve("warthog").unwrap();
    let (terrain, _) = Terrain::resolve("asphalt").unwrap();
    let opts = opts();
    let input = JointInput {
        logs: logs
            .iter()
            .map(|l| JointLog {
                log: l,
                terrain: terrain.clone(),
            })
            .collect(),
        robot: &robot,
        factory: &KinematicFactory,
        opts: &opts,
    };
    let r = calibrate_joint(&input, &|line| eprintln!("{line}")).unwrap();
    for p in &r.robot_params {
        eprintln!("robot {} = {} ± {:?}", p.name, p.value, p.se);
    }
    for s in &r.singles {
        for p in drive_sim::calibration::twin::fitted_params(s) {
            eprintln!("{} alone: {} = {} ± {:?}", s.dataset, p.name, p.value, p.se);
        }
    }
    for l in &r.logs {
        eprintln!(
            "{}: joint {:.3}, single {:.3}, {:?}",
            l.dataset,
            l.joint.score,
            l.single_score,
            l.terrain_params
                .iter()
                .map(|p| (p.name.as_str(), p.value, p.se))
                .collect::<Vec<_>>()
        );
    }
    // The robot block holds the limit, the terrain blocks the slip: from the registry, not
    // from names in the joint code.
    let lim_name = "effect.wheel_speed_saturation_rad_s";
    assert!(
        r.robot_param_names.iter().any(|n| n == lim_name),
        "{:?}",
        r.robot_param_names
    );
    assert!(
        r.terrain_param_names
            .iter()
            .any(|n| n == "effect.centripetal_slip_s"),
        "{:?}",
        r.terrain_param_names
    );
    let lim = r.robot_params.iter().find(|p| p.name == lim_name).unwrap();
    let se = lim.se.expect("the joint limit has an interval");
    assert!(
        (lim.value - LIMIT).abs() < 0.05 * LIMIT,
        "joint limit {} ± {se}, true {LIMIT}",
        lim.value
    );
    // Tighter than any log alone.
    for s in &r.singles {
        let own = drive_sim::calibration::twin::fitted_params(s)
            .into_iter()
            .find(|p| p.name == lim_name);
        if let Some(own_se) = own.and_then(|p| p.se) {
            assert!(se < own_se, "joint se {se} vs {} alone {own_se}", s.dataset);
        }
    }
    for (l, truth) in r.logs.iter().zip(SLIPS) {
        let p = l
            .terrain_params
            .iter()
            .find(|p| p.name == "effect.centripetal_slip_s")
            .unwrap();
        assert!(
            (p.value - truth).abs() < 0.03,
            "{}: slip {} (true {truth})",
            l.dataset,
            p.value
        );
        assert_eq!(l.terrain_file, format!("terrain_{}.toml", l.dataset));
    }

    // Each log's twin runs its own DRIVE in closed loop; one that cannot complete its steps is
    // named.
    let mut checked = r.clone();
    let failed = drive_sim::calibration::joint::check_joint_twin(&mut checked, 1).unwrap();
    assert!(failed.is_empty(), "{failed:?} {:?}", checked.notes);
    assert!(checked
        .logs
        .iter()
        .all(|l| l.twin_check.as_ref().is_some_and(|c| c.ran)));
    let mut broken = r.clone();
    // Sliding sideways at ten times its commanded forward speed: no attempt of a step stays in
    // the safe area.
    broken.logs[1]
        .model
        .effects
        .set("term_body_vy__cmd_vx", 10.0)
        .unwrap();
    let failed = drive_sim::calibration::joint::check_joint_twin(&mut broken, 1).unwrap();
    assert_eq!(failed, vec![broken.logs[1].dataset.clone()]);
    assert!(
        broken
            .notes
            .iter()
            .any(|n| n.contains("twin check") && n.contains(&broken.logs[1].dataset)),
        "{:?}",
        broken.notes
    );
}

#[test]
fn logs_of_different_robots_are_refused_before_any_work() {
    let a = log(0);
    let mut b = log(1);
    b.meta.robot = "husky".into();
    let e = drive_sim::calibration::joint::check_one_robot(&[&a, &b]).unwrap_err();
    assert!(e.is_bad_input(), "{e}");
    assert!(e.to_string().contains("husky"), "{e}");
}

fn drive_sim_cli(args: &[&str], cwd: &std::path::Path) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_drive-sim"))
        .args(args)
        .current_dir(cwd)
        .output()
        .expect("the drive-sim binary runs")
}

fn run_log(robot: &str, terrain: &str, steps: &str, cwd: &std::path::Path) {
    let out = drive_sim_cli(
        &[
            "run",
            "--robot",
            robot,
            "--terrain",
            terrain,
            "--steps",
            steps,
            "--seed",
            "3",
            "--out",
            "logs",
            "--quiet",
        ],
        cwd,
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}

#[test]
fn cli_joint_calibration_writes_one_report_per_log_and_refuses_two_robots() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    run_log("warthog", "asphalt", "16", d);
    run_log("warthog", "gravel", "16", d);
    run_log("husky", "asphalt", "4", d);
    // Two robots: exit 2, nothing written.
    let out = drive_sim_cli(
        &[
            "calibrate",
            "logs/warthog_asphalt_s3.mcap",
            "logs/husky_asphalt_s3.mcap",
            "--model",
            "kinematic",
            "--out",
            "bad",
        ],
        d,
    );
    assert_eq!(
        out.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("husky") && err.contains("one robot"), "{err}");
    assert!(!d.join("bad").exists());
    // One robot on two terrains: the joint report and each log's own.
    let out = drive_sim_cli(
        &[
            "calibrate",
            "logs/warthog_asphalt_s3.mcap",
            "logs/warthog_gravel_s3.mcap",
            "--model",
            "kinematic",
            "--candidates",
            "wheel_speed_saturation_rad_s",
            "--out",
            "joint",
        ],
        d,
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("joint/calibration.json")).unwrap()).unwrap();
    assert_eq!(json["robot"], "warthog");
    assert_eq!(json["logs"].as_array().unwrap().len(), 2);
    assert_eq!(json["logs"][1]["terrain_file"], "terrain_warthog_gravel_s3.toml");
    for ds in ["warthog_asphalt_s3", "warthog_gravel_s3"] {
        assert!(d.join("joint").join(ds).join("calibration.json").exists(), "{ds}");
    }
}
