//! The `drive-sim` binary on good and bad input: what a user sees, what is left on disk.

use std::path::Path;
use std::process::{Command, Output};

fn drive_sim(args: &[&str], cwd: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_drive-sim"))
        .args(args)
        .current_dir(cwd)
        .output()
        .expect("the drive-sim binary runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn builtin(kind: &str, name: &str) -> String {
    std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join(kind)
            .join(format!("{name}.toml")),
    )
    .unwrap()
}

/// A short run writes a complete MCAP and a run summary; the same seed gives the same bytes and
/// another seed different ones.
#[test]
fn run_writes_a_deterministic_log() {
    let dir = tempfile::tempdir().unwrap();
    let args = |seed: &'static str, name: &'static str| {
        vec![
            "run",
            "--robot",
            "husky",
            "--terrain",
            "gravel",
            "--steps",
            "3",
            "--seed",
            seed,
            "--out",
            "o",
            "--name",
            name,
            "--quiet",
        ]
    };
    let a = drive_sim(&args("5", "a"), dir.path());
    assert!(a.status.success(), "{}", stderr(&a));
    let stdout = String::from_utf8_lossy(&a.stdout);
    assert!(
        stdout.contains("3 steps") && stdout.contains("real time"),
        "{stdout}"
    );
    let b = drive_sim(&args("5", "b"), dir.path());
    assert!(b.status.success(), "{}", stderr(&b));
    let c = drive_sim(&args("6", "c"), dir.path());
    assert!(c.status.success(), "{}", stderr(&c));
    // The log name is in the metadata record, so compare the decoded samples.
    let samples = |n: &str| {
        drive_sim::log::mcap::read_mcap(dir.path().join("o").join(format!("{n}.mcap")))
            .unwrap()
            .samples
    };
    assert_eq!(samples("a"), samples("b"));
    assert_ne!(samples("a"), samples("c"));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("o/a.run.json")).unwrap()).unwrap();
    assert_eq!(json["summary"]["steps_completed"], 3);
    assert!(json["messages_per_topic"]["/joint_states"].as_u64().unwrap() >= 3 * 120);
}

/// Byte-identical logs for the same seed and files (the MCAP of two runs under one name).
#[test]
fn same_seed_byte_identical_mcap() {
    let dir = tempfile::tempdir().unwrap();
    let run = |out: &str| {
        let o = drive_sim(
            &[
                "run",
                "--terrain",
                "ice",
                "--steps",
                "2",
                "--seed",
                "3",
                "--out",
                out,
                "--quiet",
            ],
            dir.path(),
        );
        assert!(o.status.success(), "{}", stderr(&o));
        std::fs::read(dir.path().join(out).join("warthog_ice_s3.mcap")).unwrap()
    };
    assert_eq!(run("x"), run("y"));
}

#[test]
fn unknown_robot_terrain_sampler_and_effect_are_named() {
    let dir = tempfile::tempdir().unwrap();
    for (args, expect) in [
        (
            vec!["run", "--robot", "tank"],
            vec!["unknown robot `tank`", "warthog", "husky"],
        ),
        (
            vec!["run", "--terrain", "lava"],
            vec!["unknown terrain `lava`", "ice", "mud"],
        ),
        (
            vec!["run", "--sampler", "psychic"],
            vec!["unknown sampler `psychic`", "uniform-wheel"],
        ),
        (
            vec!["run", "--inject", "flux_capacitor=1"],
            vec!["flux_capacitor"],
        ),
        (
            vec!["run", "--inject", "motor_gain_left=abc"],
            vec!["motor_gain_left", "abc"],
        ),
    ] {
        let o = drive_sim(&args, dir.path());
        assert!(!o.status.success());
        let e = stderr(&o);
        for x in expect {
            assert!(e.contains(x), "{args:?}: `{x}` not in: {e}");
        }
        assert!(!e.contains("panicked"), "{e}");
    }
}

/// Impossible values in a robot or terrain file: the error names the file and the field.
#[test]
fn impossible_files_name_file_and_field() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        (
            "robots",
            "warthog",
            "mass_kg = 470.0",
            "mass_kg = -470.0",
            "body.mass_kg",
        ),
        (
            "robots",
            "warthog",
            "radius_m = 0.30",
            "radius_m = nan",
            "wheels.radius_m",
        ),
        ("robots", "husky", "[safe_area]", "[safe_areas]", "safe_area"),
        (
            "terrains",
            "ice",
            "peak_longitudinal = ",
            "peak_longitudinal = -",
            "friction.peak_longitudinal",
        ),
    ];
    for (kind, name, from, to, field) in cases {
        let text = builtin(kind, name);
        assert!(text.contains(from), "{kind}/{name} has no `{from}`");
        let path = dir.path().join(format!("bad_{name}.toml"));
        std::fs::write(&path, text.replacen(from, to, 1)).unwrap();
        let flag = if kind == "robots" { "--robot" } else { "--terrain" };
        let o = drive_sim(
            &["run", flag, path.to_str().unwrap(), "--steps", "1", "--out", "o"],
            dir.path(),
        );
        assert!(!o.status.success());
        let e = stderr(&o);
        assert!(
            e.contains(&format!("bad_{name}.toml")) && e.contains(field),
            "{field}: {e}"
        );
        assert!(!e.contains("panicked"), "{e}");
    }
    assert!(
        !dir.path().join("o").exists() || std::fs::read_dir(dir.path().join("o")).unwrap().next().is_none()
    );
}

#[test]
fn unwritable_output_directory_is_reported() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("not_a_dir");
    std::fs::write(&file, "x").unwrap();
    let out = file.join("sub");
    let o = drive_sim(
        &["run", "--steps", "1", "--out", out.to_str().unwrap()],
        dir.path(),
    );
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(e.contains("not_a_dir/sub") && !e.contains("panicked"), "{e}");
}

/// A simulation that diverges (a suspension far too stiff for the physics rate) stops with the
/// step and time, leaves no complete-looking log, and keeps what was written before.
#[test]
fn diverging_simulation_leaves_no_complete_log() {
    let dir = tempfile::tempdir().unwrap();
    let robot = builtin("robots", "warthog")
        .replacen("stiffness_n_m = 40000.0", "stiffness_n_m = 4.0e9", 1)
        .replacen("damping_n_s_m = 4000.0", "damping_n_s_m = 0.0", 1);
    let path = dir.path().join("stiff.toml");
    std::fs::write(&path, robot).unwrap();
    // A complete earlier log at the same path must survive the failed run (even with
    // `--force`, which allows replacing it only by a complete new one).
    std::fs::create_dir_all(dir.path().join("o")).unwrap();
    let earlier = dir.path().join("o/warthog_asphalt_s0.mcap");
    std::fs::write(&earlier, b"earlier log").unwrap();
    let o = drive_sim(
        &[
            "run",
            "--robot",
            path.to_str().unwrap(),
            "--steps",
            "2",
            "--out",
            "o",
            "--quiet",
            "--force",
        ],
        dir.path(),
    );
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(e.contains("diverged at step 0, t = "), "{e}");
    assert!(e.contains(".mcap.partial"), "{e}");
    assert_eq!(std::fs::read(&earlier).unwrap(), b"earlier log");
    assert!(dir.path().join("o/warthog_asphalt_s0.mcap.partial").exists());
}

/// `analyze` on a corrupt log and on a file of the wrong kind: an error naming it.
#[test]
fn analyze_rejects_bad_logs() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("broken.mcap"), b"\x89MCAP0\r\nnot really").unwrap();
    std::fs::write(dir.path().join("notes.txt"), b"hello").unwrap();
    for f in ["broken.mcap", "notes.txt"] {
        let o = drive_sim(&["analyze", f, "--out", "a"], dir.path());
        assert!(!o.status.success());
        let e = stderr(&o);
        assert!(e.contains(f) && !e.contains("panicked"), "{e}");
    }
}

/// `analyze` on logs of two robots: one transfer-function figure per robot and channel (none
/// overwrites another), the summary names both datasets.
#[test]
fn analyze_two_robots_writes_a_figure_per_robot() {
    let dir = tempfile::tempdir().unwrap();
    for (robot, terrain) in [("warthog", "asphalt"), ("husky", "grass")] {
        let o = drive_sim(
            &[
                "run",
                "--robot",
                robot,
                "--terrain",
                terrain,
                "--steps",
                "12",
                "--seed",
                "2",
                "--out",
                "logs",
                "--quiet",
            ],
            dir.path(),
        );
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let o = drive_sim(
        &[
            "analyze",
            "logs/warthog_asphalt_s2.mcap",
            "logs/husky_grass_s2.mcap",
            "--out",
            "a",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    for robot in ["warthog", "husky"] {
        for ch in ["slip_vx_m_s", "slip_vy_m_s", "slip_wz_rad_s", "rho"] {
            for ext in ["svg", "png"] {
                let f = dir.path().join(format!("a/tf_{ch}_{robot}.{ext}"));
                assert!(f.exists(), "{} missing", f.display());
            }
        }
    }
    let summary = std::fs::read_to_string(dir.path().join("a/summary.json")).unwrap();
    assert!(summary.contains("warthog_asphalt_s2") && summary.contains("husky_grass_s2"));
    assert!(dir.path().join("a/report.html").exists());
}

/// `drive-sim run` of the Warthog on asphalt, 20 steps of seed 4, into `o/<name>` under `cwd`,
/// with `extra` options.
fn warthog_run(cwd: &Path, name: &str, extra: &[&str]) -> Output {
    let mut a = vec![
        "run",
        "--robot",
        "warthog",
        "--terrain",
        "asphalt",
        "--steps",
        "20",
        "--seed",
        "4",
        "--quiet",
        "--out",
        "o",
        "--name",
        name,
    ];
    a.extend_from_slice(extra);
    drive_sim(&a, cwd)
}

/// `--safe-area` replaces the robot file's safe area for one deployment: a site twice as long
/// and wide interrupts the same seed's run less, the option is recorded in the run's
/// provenance, and a malformed or absurd area is bad input (exit code 2) that writes nothing.
#[test]
fn safe_area_is_a_deployment_option() {
    let dir = tempfile::tempdir().unwrap();
    let run = |extra: &[&str], name: &str| warthog_run(dir.path(), name, extra);
    let summary = |name: &str| -> serde_json::Value {
        let text = std::fs::read_to_string(dir.path().join(format!("o/{name}.run.json"))).unwrap();
        serde_json::from_str(&text).unwrap()
    };
    assert!(run(&[], "small").status.success());
    let o = run(&["--safe-area", "90x40"], "large");
    assert!(o.status.success(), "{}", stderr(&o));
    let (small, large) = (summary("small"), summary("large"));
    let interruptions = |v: &serde_json::Value| v["summary"]["interruptions"].as_u64().unwrap();
    assert!(
        interruptions(&large) < interruptions(&small),
        "{} -> {}",
        interruptions(&small),
        interruptions(&large)
    );
    assert_eq!(
        large["provenance"]["options"]["--safe-area"],
        serde_json::json!([90.0, 40.0])
    );
    assert!(small["provenance"]["options"].get("--safe-area").is_none());
    for (bad, needle) in [
        ("90", "LENGTHxWIDTH"),
        ("90xwide", "not a number"),
        ("0x20", "--safe-area"),
    ] {
        let o = run(&["--safe-area", bad], "bad");
        assert_eq!(o.status.code(), Some(2), "{bad}: {}", stderr(&o));
        assert!(stderr(&o).contains(needle), "{bad}: {}", stderr(&o));
        assert!(!dir.path().join("o/bad.mcap").exists());
    }
}

/// `--draw-like LOG` draws each step's command in the quadrant of the log's command of that
/// step: the run's held commands turn and drive as the measured run's did, step by step, and
/// the run records its sampler (`matched-quadrants`) and the log among its inputs. A log that
/// cannot be read is bad input (exit code 2) that writes nothing; with `--sampler` it is
/// refused as two answers to one question.
#[test]
fn draw_like_draws_in_the_quadrants_of_a_measured_run() {
    let dir = tempfile::tempdir().unwrap();
    let csv = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../shared/data/measured/warthog_asphalt.csv"
    );
    let run = |extra: &[&str], name: &str| warthog_run(dir.path(), name, extra);
    let o = run(&["--draw-like", csv], "like");
    assert!(o.status.success(), "{}", stderr(&o));
    let got = drive_sim::log::mcap::read_mcap(dir.path().join("o/like.mcap"))
        .unwrap()
        .held_commands();
    let measured = drive_sim::log::csv::read_measured_csv(csv)
        .unwrap()
        .held_commands();
    assert_eq!(got.len(), 20);
    for (i, (g, m)) in got.iter().zip(&measured).enumerate() {
        assert_eq!(g.quadrant(), m.quadrant(), "step {i}: {g:?} against {m:?}");
    }
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("o/like.run.json")).unwrap()).unwrap();
    assert_eq!(summary["sampler"], "matched-quadrants");
    assert_eq!(summary["provenance"]["options"]["--draw-like"], csv);
    assert!(summary["provenance"]["inputs"]
        .as_array()
        .unwrap()
        .iter()
        .any(|i| i["role"] == "draw_like" && i["sha256"].is_string()));
    let o = run(&["--draw-like", "no_such_run.csv"], "bad");
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("no_such_run"), "{}", stderr(&o));
    assert!(!dir.path().join("o/bad.mcap").exists());
    let o = run(&["--draw-like", csv, "--sampler", "halton"], "bad");
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(!dir.path().join("o/bad.mcap").exists());
}
