//! rosbag2 recordings of the DRIVE node read into the common log, checked against bags written
//! by an independent writer: `tests/write_drive_bag.py` (the Python `rosbags` package) turns a
//! measured CSV of `../shared/data/measured` into the bag the DRIVE node records, in sqlite3
//! and MCAP storage. Analysing the bag must give the CSV's steps (± 2) and median ρ (± 0.03).
//!
//! Needs `python3` with `pip install rosbags` (CI installs it). The tests fail when it is
//! missing; `DRIVE_SIM_SKIP_PYTHON=1` skips them explicitly.

use drive_sim::analysis::{analyze, stats::median, AnalysisParams};
use drive_sim::log::{open, DriveLog, OpenOptions};
use std::path::{Path, PathBuf};
use std::process::Command;

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data/measured");
const INSTALL: &str =
    "install Python 3 and `pip install rosbags` (or set DRIVE_SIM_SKIP_PYTHON=1 to skip this test)";

fn skip() -> bool {
    if std::env::var("DRIVE_SIM_SKIP_PYTHON").is_ok_and(|v| v == "1") {
        eprintln!("\n!!!!! SKIPPED: bags written by Python rosbags (DRIVE_SIM_SKIP_PYTHON=1) !!!!!\n");
        return true;
    }
    false
}

/// Writes `csv` as a DRIVE bag at `out` with the writer's extra arguments.
fn write_bag(csv: &str, out: &Path, args: &[&str]) {
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/write_drive_bag.py");
    let o = Command::new("python3")
        .arg(script)
        .arg(format!("{DATA}/{csv}.csv"))
        .arg(out)
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("cannot run python3 ({e}): {INSTALL}"));
    assert!(
        o.status.success(),
        "write_drive_bag.py failed ({}):\n{}\n{}",
        o.status,
        String::from_utf8_lossy(&o.stderr),
        if o.status.code() == Some(3) { INSTALL } else { "" }
    );
}

fn opts() -> OpenOptions {
    OpenOptions {
        robot: Some("warthog".into()),
        terrain: Some("gravel".into()),
        roles: None,
    }
}

fn steps_and_median_rho(log: &DriveLog) -> (usize, f64) {
    let a = analyze(log, &AnalysisParams::default()).unwrap();
    (a.steps.len(), median(&a.steady_rhos()))
}

fn data_file(dir: &Path, ext: &str) -> PathBuf {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.extension().is_some_and(|e| e == ext))
        .unwrap_or_else(|| panic!("no .{ext} in {}", dir.display()))
}

#[test]
fn a_measured_run_as_a_drive_bag_gives_the_csv_steps_and_median_rho_in_both_storages() {
    if skip() {
        return;
    }
    let csv = drive_sim::log::csv::read_measured_csv(format!("{DATA}/warthog_gravel.csv")).unwrap();
    let (csv_steps, csv_rho) = steps_and_median_rho(&csv);
    let tmp = tempfile::tempdir().unwrap();
    for (storage, ext) in [("sqlite3", "db3"), ("mcap", "mcap")] {
        let dir = tmp.path().join(storage);
        write_bag("warthog_gravel", &dir, &["--storage", storage, "--params"]);
        // The directory, and the data file alone.
        for path in [dir.clone(), data_file(&dir, ext)] {
            let o = open(&path, &opts()).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            assert!(o.warnings.is_empty(), "{:?}", o.warnings);
            assert!(
                o.notes.iter().any(|n| n.contains("preset `warthog`")),
                "{:?}",
                o.notes
            );
            assert!(
                o.notes.iter().any(|n| n.contains("step index topic")),
                "{:?}",
                o.notes
            );
            assert_eq!(o.log.meta.terrain, "gravel");
            let (n, c) = (&o.log.meta.nominal, &csv.meta.nominal);
            assert_eq!(
                (n.wheel_radius_m, n.baseline_m, n.mass_kg),
                (c.wheel_radius_m, c.baseline_m, c.mass_kg)
            );
            assert!((n.max_wheel_rad_s - c.max_wheel_rad_s).abs() < 1e-3, "{n:?}");
            let (steps, rho) = steps_and_median_rho(&o.log);
            eprintln!(
                "{storage} {}: {steps} steps, median rho {rho:.4}; CSV {csv_steps}, {csv_rho:.4}",
                path.display()
            );
            assert!(
                steps.abs_diff(csv_steps) <= 2,
                "{storage}: {steps} steps, CSV {csv_steps}"
            );
            assert!(
                (rho - csv_rho).abs() <= 0.03,
                "{storage}: median rho {rho}, CSV {csv_rho}"
            );
        }
    }
}

/// Without the step topic, steps are runs of constant command. A zero command cannot be told
/// from a stop when it is next to one: warthog_gravel's steps 0 and 1 (zero commands right
/// after the idle start) are the two it cannot find.
#[test]
fn without_the_step_topic_steps_come_from_command_constancy_and_interruptions_are_found() {
    if skip() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let with = tmp.path().join("with");
    let without = tmp.path().join("without");
    write_bag("warthog_gravel", &with, &["--interrupt", "4"]);
    write_bag(
        "warthog_gravel",
        &without,
        &["--interrupt", "4", "--no-step-topic"],
    );
    let a = open(&with, &opts()).unwrap();
    let b = open(&without, &opts()).unwrap();
    assert!(
        b.notes.iter().any(|n| n.contains("constant command")),
        "{:?}",
        b.notes
    );
    assert_eq!(a.log.steps().len(), 100);
    let n = b.log.steps().len();
    assert!(n.abs_diff(100) <= 2, "{n} steps by command constancy");
    for o in [&a, &b] {
        assert_eq!(o.log.interruptions.len(), 1, "{:?}", o.log.interruptions);
        let i = &o.log.interruptions[0];
        assert_eq!(i.attempt, 0);
        assert!((i.t_in_step_s - 1.95).abs() < 1e-6, "{i:?}");
        assert!((i.time_lost_s - 3.0).abs() < 1e-6, "{i:?}");
        assert!((i.stamp_s - a.log.interruptions[0].stamp_s).abs() < 1e-9);
    }
    // The steps found are the same steps, give or take the tick where the recorded command
    // still is the previous one.
    for s in b.log.samples.iter().filter(|s| s.k == 0 && s.window == 0) {
        let near = a.log.samples.iter().filter(|x| x.k == 0 && x.window == 0);
        let d = near
            .map(|x| (x.stamp_s - s.stamp_s).abs())
            .fold(f64::INFINITY, f64::min);
        assert!(
            d <= 0.05 + 1e-9,
            "step {} starts {d} s from any step-topic step",
            s.step
        );
    }
}

#[test]
fn bad_bags_give_errors_naming_topic_time_and_expectation() {
    if skip() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let bag = |name: &str, args: &[&str]| {
        let dir = tmp.path().join(name);
        let mut all = vec!["--steps", "8"];
        all.extend(args);
        write_bag("warthog_gravel", &dir, &all);
        dir
    };
    let err = |p: &Path| {
        let e = open(p, &opts()).map(|_| ()).unwrap_err();
        assert!(e.is_bad_input(), "{e}");
        e.to_string()
    };

    // A missing role (the IMU is optional: see the test of bags without one).
    let e = err(&bag("no_cmd", &["--drop", "/doughnut_cmd_vel"]));
    assert!(e.contains("cmd") && e.contains("geometry_msgs/msg/Twist"), "{e}");
    // A wrong message type on a role's topic.
    let e = err(&bag("wrong", &["--wrong-type", "/icp_odom"]));
    assert!(
        e.contains("/icp_odom") && e.contains("expects nav_msgs/msg/Odometry"),
        "{e}"
    );
    // A gap longer than a window inside a step: that step goes, with a named warning.
    let o = open(&bag("gap", &["--gap", "3"]), &opts()).unwrap();
    assert_eq!(o.log.steps().len(), 7);
    assert!(!o.log.steps().contains(&3));
    let w = o.warnings.join("\n");
    assert!(
        w.contains("step 3") && w.contains("/MTI_imu/data_unbiased") && w.contains("t = "),
        "{w}"
    );

    // Unsupported storage and compression, as metadata.yaml declares them.
    let good = bag("good", &[]);
    let meta = std::fs::read_to_string(good.join("metadata.yaml")).unwrap();
    let edited = |name: &str, from: &str, to: &str| {
        let dir = tmp.path().join(name);
        std::fs::create_dir(&dir).unwrap();
        for f in std::fs::read_dir(&good).unwrap() {
            let f = f.unwrap().path();
            std::fs::copy(&f, dir.join(f.file_name().unwrap())).unwrap();
        }
        assert!(meta.contains(from), "{from} not in metadata.yaml");
        std::fs::write(dir.join("metadata.yaml"), meta.replace(from, to)).unwrap();
        dir
    };
    let e = err(&edited(
        "storage",
        "storage_identifier: sqlite3",
        "storage_identifier: rosbag_v2",
    ));
    assert!(e.contains("rosbag_v2") && e.contains("sqlite3"), "{e}");
    let e = err(&edited(
        "lz4",
        "compression_format: ''",
        "compression_format: lz4",
    ));
    assert!(
        e.contains("`lz4`") && e.contains("compression_format") && e.contains("`zstd`"),
        "{e}"
    );

    // A truncated .db3: an error, never a panic; inspect still lists what it can.
    let trunc = tmp.path().join("trunc");
    std::fs::create_dir(&trunc).unwrap();
    let db = data_file(&good, "db3");
    let bytes = std::fs::read(&db).unwrap();
    let cut = trunc.join("cut.db3");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let e = err(&cut);
    assert!(e.contains("cut.db3"), "{e}");
    let i = drive_sim::log::bag::inspect(&cut, &opts());
    assert!(!i.problems.is_empty());
    let shown = i.to_string();
    assert!(shown.contains("problem:"), "{shown}");

    // The command line exits with code 2 on bad input, and inspect prints before failing.
    let out = Command::new(env!("CARGO_BIN_EXE_drive-sim"))
        .arg("inspect")
        .arg(tmp.path().join("no_cmd"))
        .output()
        .unwrap();
    assert_eq!(
        out.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("/icp_odom") && stdout.contains("MISSING"),
        "{stdout}"
    );
}

#[test]
fn roles_are_guessed_and_reported_without_a_fitting_preset() {
    if skip() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("b");
    write_bag("warthog_gravel", &dir, &["--steps", "6"]);
    // Rename the encoder topics so no preset fits: the guess must still find them.
    let roles = tmp.path().join("roles.toml");
    let preset = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/roles/warthog.toml")).unwrap();
    std::fs::write(&roles, preset.replace("/icp_odom", "/no_such_odom")).unwrap();
    let o = open(
        &dir,
        &OpenOptions {
            roles: Some(roles.display().to_string()),
            ..opts()
        },
    );
    let e = o.map(|_| ()).unwrap_err().to_string();
    assert!(e.contains("odom") && e.contains("/no_such_odom"), "{e}");
    let bag = drive_sim::log::bag::Bag::open(&dir).unwrap();
    let g = drive_sim::log::bag::roles::guess(&bag);
    assert!(g.missing.is_empty(), "{:?}", g.missing);
    assert_eq!(
        g.roles[&drive_sim::log::bag::Role::WheelLeft].topic,
        "/left_drive/status/speed"
    );
    assert_eq!(g.roles[&drive_sim::log::bag::Role::Odom].topic, "/icp_odom");
    assert_eq!(
        g.roles[&drive_sim::log::bag::Role::Imu].topic,
        "/MTI_imu/data_unbiased"
    );
}

/// Steps, median ρ and every sample's values of a bag, to compare two readings exactly.
fn fingerprint(path: &Path) -> (usize, f64, Vec<[f64; 4]>, Vec<String>) {
    let o = open(path, &opts()).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let (steps, rho) = steps_and_median_rho(&o.log);
    let samples = o
        .log
        .samples
        .iter()
        .map(|s| [s.stamp_s, s.m.enc.left_rad_s, s.m.imu.wz_rad_s, s.m.pose.yaw_rad])
        .collect();
    (steps, rho, samples, o.warnings)
}

/// rosbag2's zstd compression (`ros2 bag record --compression-mode file|message
/// --compression-format zstd`) and MCAP's own chunk compression (zstd written by rosbags, lz4
/// by the Python `mcap` writer) read to the very same log as the uncompressed bag; so does an
/// MCAP file without a summary section (streamed whole, with a warning naming why).
#[test]
fn compressed_and_unindexed_bags_read_like_the_uncompressed_one() {
    if skip() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    for (storage, ext) in [("sqlite3", "db3"), ("mcap", "mcap")] {
        let plain = tmp.path().join(format!("{storage}_plain"));
        write_bag("warthog_gravel", &plain, &["--storage", storage, "--steps", "30"]);
        let (steps, rho, samples, warnings) = fingerprint(&plain);
        assert_eq!(steps, 30, "{storage}");
        assert!(warnings.is_empty(), "{warnings:?}");
        let mut variants: Vec<(&str, Vec<&str>)> = vec![
            ("file", vec!["--compression", "file"]),
            ("message", vec!["--compression", "message"]),
        ];
        if storage == "mcap" {
            variants.push(("zstd_chunks", vec!["--mcap-chunks", "zstd"]));
            variants.push(("lz4_chunks", vec!["--mcap-chunks", "lz4"]));
            variants.push(("no_summary", vec!["--mcap-no-summary"]));
        }
        for (name, args) in variants {
            let dir = tmp.path().join(format!("{storage}_{name}"));
            let mut all = vec!["--storage", storage, "--steps", "30"];
            all.extend(args);
            write_bag("warthog_gravel", &dir, &all);
            let mut paths = vec![dir.clone()];
            // The data file alone too: a file-compressed one is recognised by its zstd magic.
            paths.push(if name == "file" {
                data_file(&dir, "zstd")
            } else {
                data_file(&dir, ext)
            });
            for path in paths {
                let (s, r, x, w) = fingerprint(&path);
                let what = format!("{storage} {name} {}", path.display());
                assert_eq!(s, steps, "{what}");
                assert_eq!(r, rho, "{what}");
                assert_eq!(x.len(), samples.len(), "{what}");
                assert!(x == samples, "{what}: samples differ");
                if name == "no_summary" {
                    assert!(
                        w.len() == 1 && w[0].contains("no summary section") && w[0].contains("streamed"),
                        "{what}: {w:?}"
                    );
                } else {
                    assert!(w.is_empty(), "{what}: {w:?}");
                }
            }
            let i = drive_sim::log::bag::inspect(&dir, &opts());
            assert!(i.problems.is_empty(), "{:?}", i.problems);
            let shown = i.to_string();
            let want = match name {
                "file" => "compression zstd, file mode",
                "message" => "compression zstd, message mode",
                _ => "compression none",
            };
            assert!(shown.contains(want), "{shown}");
            assert!(shown.contains("/rslidar_points"), "{shown}");
        }
    }
}

/// `inspect` of an MCAP bag gives its counts and spans from the summary and message indexes,
/// the same as a streamed scan of the same messages in a file without a summary.
#[test]
fn mcap_counts_from_the_indexes_match_a_streamed_scan() {
    if skip() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let a = tmp.path().join("indexed");
    let b = tmp.path().join("streamed");
    write_bag(
        "warthog_gravel",
        &a,
        &["--storage", "mcap", "--steps", "5", "--cloud-hz", "10"],
    );
    write_bag(
        "warthog_gravel",
        &b,
        &[
            "--storage",
            "mcap",
            "--steps",
            "5",
            "--cloud-hz",
            "10",
            "--mcap-no-summary",
        ],
    );
    let (ba, bb) = (
        drive_sim::log::bag::Bag::open(&a).unwrap(),
        drive_sim::log::bag::Bag::open(&b).unwrap(),
    );
    assert!(ba.warnings.is_empty(), "{:?}", ba.warnings);
    assert_eq!(bb.warnings.len(), 1, "{:?}", bb.warnings);
    assert_eq!(ba.topics, bb.topics);
    let (sa, sb) = (ba.stats().unwrap(), bb.stats().unwrap());
    assert_eq!(sa, sb);
    // A cloud every 0.1 s from the start up to the last step's last tick (1 s idle, 5 steps
    // of 6 s; the writer sends clouds with the step ticks only).
    let clouds = sa["/rslidar_points"];
    assert_eq!(clouds.count, 310, "{clouds:?}");
    assert_eq!(sa.len(), ba.topics.len());
}

/// A truncated MCAP bag (its summary cut off): an error naming the file and where reading
/// stopped, never a panic; `inspect` names the problem.
#[test]
fn a_truncated_mcap_bag_is_an_error_naming_the_file() {
    if skip() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("b");
    write_bag("warthog_gravel", &dir, &["--storage", "mcap", "--steps", "4"]);
    let file = data_file(&dir, "mcap");
    let bytes = std::fs::read(&file).unwrap();
    let cut = tmp.path().join("cut.mcap");
    std::fs::write(&cut, &bytes[..bytes.len() * 2 / 3]).unwrap();
    let e = open(&cut, &opts()).map(|_| ()).unwrap_err();
    assert!(e.is_bad_input(), "{e}");
    let e = e.to_string();
    assert!(e.contains("cut.mcap") && e.contains("MCAP record"), "{e}");
    let i = drive_sim::log::bag::inspect(&cut, &opts());
    let shown = i.to_string();
    assert!(
        shown.contains("problem:") && shown.contains("cut.mcap"),
        "{shown}"
    );
    // What came before the cut is still listed.
    assert!(
        shown.contains("/icp_odom") && shown.contains("roles ("),
        "{shown}"
    );
}

/// `compare` reads bags through `log::open` like `analyze`: a file-compressed sqlite3 bag
/// against the same run as an MCAP bag with lz4 chunks is the same run, every difference 0.
#[test]
fn compare_accepts_bags() {
    if skip() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let real = tmp.path().join("real");
    let sim = tmp.path().join("sim");
    write_bag(
        "warthog_gravel",
        &real,
        &["--steps", "8", "--compression", "file"],
    );
    write_bag(
        "warthog_gravel",
        &sim,
        &["--steps", "8", "--storage", "mcap", "--mcap-chunks", "lz4"],
    );
    let out = tmp.path().join("cmp");
    let o = Command::new(env!("CARGO_BIN_EXE_drive-sim"))
        .args([
            "compare",
            "--robot",
            "warthog",
            "--terrain",
            "gravel",
            "--resamples",
            "100",
            "--out",
        ])
        .arg(&out)
        .arg(&real)
        .arg(&sim)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{}\n{stdout}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(out.join("comparison.json").is_file());
    assert!(stdout.contains("RMS 0.0000"), "{stdout}");
}

/// The commands read a bag from the command line as the library does: `analyze` gives the
/// bag's steps, `replay` and `calibrate` (kinematic, catalogue only, to stay fast) run on it.
#[test]
fn analyze_replay_and_calibrate_read_a_bag_from_the_command_line() {
    if skip() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let bag = tmp.path().join("bag");
    write_bag("warthog_gravel", &bag, &["--steps", "30", "--storage", "mcap"]);
    let log = open(&bag, &opts()).unwrap().log;
    let (analysed, _) = steps_and_median_rho(&log);
    let expected = log.steps().len();
    let run = |args: &[&str]| {
        let o = Command::new(env!("CARGO_BIN_EXE_drive-sim"))
            .args(args)
            .arg(&bag)
            .args(["--robot", "warthog", "--terrain", "gravel"])
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    };
    let json = |p: PathBuf| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display())))
            .unwrap()
    };
    let an = tmp.path().join("an");
    run(&["analyze", "--out", an.to_str().unwrap()]);
    let summary = json(an.join("summary.json"));
    let key = format!("\"steps_analysed\":{analysed}");
    assert!(summary.to_string().contains(&key), "no {key} in {summary}");
    let rep = tmp.path().join("rep");
    run(&["replay", "--model", "kinematic", "--out", rep.to_str().unwrap()]);
    assert!(rep.join("replay.json").is_file());
    let cal = tmp.path().join("cal");
    run(&[
        "calibrate",
        "--model",
        "kinematic",
        "--no-discovery",
        "--candidates",
        "wheel_speed_saturation_rad_s",
        "--out",
        cal.to_str().unwrap(),
    ]);
    let c = json(cal.join("calibration.json"));
    let used = c["train_steps"].as_array().unwrap().len()
        + c["validation_steps"].as_array().unwrap().len()
        + c["heldout_steps"].as_array().unwrap().len();
    assert_eq!(used, expected, "{c}");
}

/// A lab's remapping: the IMU and the odometry under names no keyword matches, the step and
/// state topics under a namespace. The only topic of a role's type is taken.
const RENAMED: [&str; 8] = [
    "--rename",
    "/MTI_imu/data_unbiased=/sensors/gyro",
    "--rename",
    "/icp_odom=/mapping/pose",
    "--rename",
    "/calib_step=/lab/drive/calib_step",
    "--rename",
    "/calib_state=/lab/drive/calib_state",
];

/// Bags with renamed topics are guessed, the choices by type alone printed, and analysed like
/// their CSV; without an IMU like the CSV with its yaw rate from the pose. `inspect` calls both
/// readable and prints a roles file that reads them the same way.
#[test]
fn renamed_topics_and_a_missing_imu_are_read_like_the_csv() {
    use drive_sim::analysis::crosscheck::YawRateSource;
    if skip() {
        return;
    }
    let csv = drive_sim::log::csv::read_measured_csv(format!("{DATA}/warthog_gravel.csv")).unwrap();
    let (csv_steps, csv_rho) = steps_and_median_rho(&csv);
    let from_pose = AnalysisParams {
        yaw_rate_source: Some(YawRateSource::Pose),
        ..AnalysisParams::default()
    };
    let a = analyze(&csv, &from_pose).unwrap();
    let csv_pose_rho = median(&a.steady_rhos());
    let tmp = tempfile::tempdir().unwrap();
    let with = tmp.path().join("with_imu");
    let without = tmp.path().join("without_imu");
    write_bag("warthog_gravel", &with, &RENAMED);
    let mut args = RENAMED.to_vec();
    args.extend(["--drop", "/MTI_imu/data_unbiased"]);
    write_bag("warthog_gravel", &without, &args);
    for (dir, imu) in [(&with, true), (&without, false)] {
        let o = open(dir, &opts()).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
        let notes = o.notes.join("\n");
        assert!(notes.contains("guessed from types and names"), "{notes}");
        assert!(
            notes.contains("/mapping/pose (nav_msgs/msg/Odometry): the only topic of its type"),
            "{notes}"
        );
        assert!(notes.contains("step index topic"), "{notes}");
        assert_eq!(
            notes.contains("/sensors/gyro (sensor_msgs/msg/Imu): the only topic of its type"),
            imu,
            "{notes}"
        );
        assert_eq!(notes.contains("no IMU"), !imu, "{notes}");
        let an = analyze(&o.log, &AnalysisParams::default()).unwrap();
        let (steps, rho) = (an.steps.len(), median(&an.steady_rhos()));
        let expected = if imu { csv_rho } else { csv_pose_rho };
        eprintln!(
            "{}: {steps} steps, median rho {rho:.6} (yaw rate {:?}); CSV {csv_steps} steps, median rho \
             {expected:.6} (yaw rate {})",
            dir.display(),
            an.yaw_rate_source,
            if imu {
                "the cross-check's choice"
            } else {
                "from the pose"
            }
        );
        assert_eq!(steps, csv_steps);
        // Equal but for the rounding of the pose through a quaternion.
        assert!((rho - expected).abs() <= 1e-9, "median rho {rho}, CSV {expected}");
        assert_eq!(an.crosscheck.imu, imu);
        if !imu {
            assert_eq!(an.yaw_rate_source, YawRateSource::Pose);
            assert!(
                an.crosscheck.yaw_rate_reason.contains("no IMU"),
                "{:?}",
                an.crosscheck
            );
            assert!(
                matches!(
                    an.crosscheck.verdict("imu_yaw_rate"),
                    Some(drive_sim::analysis::crosscheck::Verdict::Inconclusive { description })
                        if description.contains("no IMU")
                ),
                "{:?}",
                an.crosscheck.verdicts
            );
        }
        // inspect: readable, and its roles file reads the bag the same way.
        let i = drive_sim::log::bag::inspect(dir, &opts());
        assert!(i.problems.is_empty(), "{:?}", i.problems);
        let shown = i.to_string();
        let toml = i
            .roles
            .as_ref()
            .unwrap()
            .to_toml(&dir.file_name().unwrap().to_string_lossy());
        assert!(shown.contains(&toml), "{shown}");
        assert_eq!(toml.contains("# [roles.imu]"), !imu, "{toml}");
        let file = tmp.path().join("roles.toml");
        std::fs::write(&file, &toml).unwrap();
        let by_file = open(
            dir,
            &OpenOptions {
                roles: Some(file.display().to_string()),
                ..opts()
            },
        )
        .unwrap_or_else(|e| panic!("{e}\n{toml}"));
        assert_eq!(by_file.log.samples.len(), o.log.samples.len());
    }
}

/// A bag without a role the guess needs names the missing role in a sentence; with several
/// topics of a role's type and no name to decide, the candidates are listed.
#[test]
fn a_bag_the_guess_cannot_read_says_what_is_missing() {
    if skip() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("b");
    write_bag(
        "warthog_gravel",
        &dir,
        &[
            "--steps",
            "4",
            "--rename",
            "/left_drive/status/speed=/drive/a/speed",
            "--rename",
            "/right_drive/status/speed=/drive/b/speed",
        ],
    );
    let e = open(&dir, &opts()).map(|_| ()).unwrap_err().to_string();
    assert!(
        e.contains("with the roles guessed from types and names")
            && e.contains("candidates: /drive/a/speed, /drive/b/speed"),
        "{e}"
    );
}

/// `calibrate` runs on a bag without an IMU, leaving the `imu_wz` channel out of its score.
#[test]
fn calibrate_reads_a_bag_without_an_imu() {
    if skip() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let bag = tmp.path().join("bag");
    let mut args = RENAMED.to_vec();
    args.extend(["--drop", "/MTI_imu/data_unbiased", "--steps", "20"]);
    write_bag("warthog_gravel", &bag, &args);
    let cal = tmp.path().join("cal");
    let o = Command::new(env!("CARGO_BIN_EXE_drive-sim"))
        .args([
            "calibrate",
            "--model",
            "kinematic",
            "--no-discovery",
            "--candidates",
            "wheel_speed_saturation_rad_s",
            "--out",
            cal.to_str().unwrap(),
        ])
        .arg(&bag)
        .args(["--robot", "warthog", "--terrain", "gravel"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    let json = std::fs::read_to_string(cal.join("calibration.json")).unwrap();
    assert!(
        json.contains("leaves out the imu_wz channel") || stderr.contains("leaves out the imu_wz channel"),
        "{stderr}"
    );
}
