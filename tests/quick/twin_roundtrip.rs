//! A twin end to end, as a user makes and uses one: `drive-sim run --inject` writes a
//! simulated log with an undeclared dead time, `drive-sim calibrate --model simulator` writes
//! `OUT/twin/robot.toml` and `OUT/twin/terrain.toml`, and those files load, carry exactly the
//! fitted values, run the DRIVE protocol, and replayed on the log's commands reproduce the
//! calibration's test score. Bad twin files are refused with exit code 2.

use drive_sim::calibration::twin::lift_effects;
use drive_sim::robot::Robot;
use drive_sim::terrain::Terrain;
use std::path::Path;
use std::process::{Command, Output};

fn drive_sim(args: &[&str], cwd: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_drive-sim"))
        .args(args)
        .current_dir(cwd)
        .output()
        .expect("the drive-sim binary runs")
}

fn ok(args: &[&str], cwd: &Path) -> Output {
    let out = drive_sim(args, cwd);
    assert!(
        out.status.success(),
        "drive-sim {args:?} failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

#[test]
fn calibrated_twin_round_trips_runs_and_reproduces_its_score() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    ok(
        &[
            "run",
            "--robot",
            "warthog",
            "--terrain",
            "asphalt",
            "--steps",
            "24",
            "--seed",
            "5",
            "--inject",
            "dead_time_s=0.3",
            "--out",
            "logs",
            "--quiet",
        ],
        d,
    );
    ok(
        &[
            "calibrate",
            "logs/warthog_asphalt_s5.mcap",
            "--model",
            "simulator",
            "--candidates",
            "dead_time_s",
            "--max-effects",
            "1",
            "--max-fit-steps",
            "10",
            "--out",
            "cal",
        ],
        d,
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("cal/calibration.json")).unwrap()).unwrap();
    let robot_toml = std::fs::read_to_string(d.join("cal/twin/robot.toml")).unwrap();
    assert!(
        robot_toml.contains("dead_time_s = ") && robot_toml.contains("[fit] warthog_asphalt_s5"),
        "{robot_toml}"
    );

    // The twin was run in closed loop before it was written, and ran.
    let check = &json["twin_check"];
    assert_eq!(check["ran"], true, "{check}");
    assert_eq!(check["steps_completed"], check["steps"], "{check}");

    // Load: the twin's effects and terrain are the fitted ones, value for value.
    let (robot, _) = Robot::resolve(d.join("cal/twin/robot.toml").to_str().unwrap()).unwrap();
    let (terrain, _) = Terrain::resolve(d.join("cal/twin/terrain.toml").to_str().unwrap()).unwrap();
    let model = lift_effects(&robot, &terrain).unwrap();
    let fitted = json["model_after"]["effects"].as_object().unwrap();
    assert!(!fitted.is_empty(), "the injected dead time was not found");
    for (k, v) in fitted {
        assert_eq!(model.effects.get(k), v.as_f64(), "effect {k}");
    }
    let fitted_terrain: Terrain = serde_json::from_value(json["model_after"]["terrain"].clone()).unwrap();
    assert_eq!(model.terrain, fitted_terrain);
    assert_eq!(
        model.robot.powertrain.time_constant_s,
        json["model_after"]["robot"]["powertrain"]["time_constant_s"]
            .as_f64()
            .unwrap()
    );

    // Run: DRIVE on the twin.
    ok(
        &[
            "run",
            "--robot",
            "cal/twin/robot.toml",
            "--terrain",
            "cal/twin/terrain.toml",
            "--steps",
            "3",
            "--out",
            "twin_run",
            "--quiet",
            "--name",
            "twin",
        ],
        d,
    );
    let run: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("twin_run/twin.run.json")).unwrap()).unwrap();
    assert_eq!(run["summary"]["steps_completed"], 3);

    // Replay the log's commands on the twin: calibrate's test score, on the same steps.
    let out = ok(
        &[
            "replay",
            "logs/warthog_asphalt_s5.mcap",
            "--robot",
            "cal/twin/robot.toml",
            "--terrain",
            "cal/twin/terrain.toml",
            "--score-like",
            "cal/calibration.json",
            "--out",
            "rep",
        ],
        d,
    );
    let rep: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("rep/replay.json")).unwrap()).unwrap();
    let want = json["after"]["score"].as_f64().unwrap();
    let got = rep["test"]["score"].as_f64().unwrap();
    assert!(
        (got - want).abs() <= 1e-9 * want.abs().max(1.0),
        "replayed twin scores {got}, calibrate reported {want}\n{}",
        String::from_utf8_lossy(&out.stdout)
    );
}

#[test]
fn bad_twin_effects_are_refused_with_a_suggestion() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // The Warthog file without its own `[effects]` table (it declares the measured limit).
    let full = drive_sim::robot::BUILTIN_ROBOTS[1].1;
    let base = &full[..full.find("\n[effects]").unwrap_or(full.len())];
    for (name, table, want) in [
        (
            "typo.toml",
            "[effects]\nwheel_speed_saturaton_rad_s = 12.6\n",
            "did you mean `wheel_speed_saturation_rad_s`",
        ),
        (
            "range.toml",
            "[effects]\nturning_resistance_scale = 500.0\n",
            "turning_resistance_scale",
        ),
    ] {
        std::fs::write(d.join(name), format!("{base}\n{table}")).unwrap();
        let out = drive_sim(
            &["run", "--robot", name, "--steps", "1", "--out", "o", "--quiet"],
            d,
        );
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert!(err.contains(want) && err.contains(name), "{err}");
    }
}

/// A twin that cannot run its own DRIVE is reported, not hidden and not a crash: a body term
/// that adds ten times the forward speed (the body goes eleven times as fast as its wheels)
/// runs out of the safe area on every command, so no attempt of a step can complete. (A
/// constant drift no longer does: discovered terms are silent on a stop command, so the
/// operator can stop it. Nor does five times since the operator plans on the motion it saw: it
/// completes 10 steps with 18 interruptions each.)
#[test]
fn a_twin_that_cannot_run_is_reported_by_its_check() {
    use drive_sim::calibration::twin::check_twin;
    let (robot, _) = Robot::resolve("warthog").unwrap();
    let (terrain, _) = Terrain::resolve("asphalt").unwrap();
    let good = check_twin(&robot, &terrain, 10, 1).unwrap();
    assert!(good.ran && good.error.is_none(), "{good:?}");
    assert_eq!(good.steps_completed, 10);

    let mut drifting = robot;
    drifting.effects.set("term_body_vx__vx", 10.0).unwrap();
    let bad = check_twin(&drifting, &terrain, 10, 1).unwrap();
    assert!(!bad.ran, "{bad:?}");
    assert!(bad.steps_completed < 10, "{bad:?}");
    let why = bad.error.as_deref().unwrap_or_default();
    assert!(why.contains("interrupted attempts"), "{why}");
}
