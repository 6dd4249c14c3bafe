//! An independent reader decodes our MCAP logs: `tests/decode_mcap.py` runs the official Python
//! `mcap` reader with `mcap-ros2-support`'s CDR decoder on every message of every topic, and
//! its JSON summary must match the frames written.
//!
//! Needs `python3` with `pip install mcap mcap-ros2-support` (CI installs them). The test fails
//! when they are missing; `DRIVE_SIM_SKIP_PYTHON=1` skips it explicitly.

use drive_sim::log::mcap::{write_mcap, EPOCH_OFFSET_NS};
use drive_sim::log::{Frame, LogMeta, Nominal, Origin, Phase};
use drive_sim::protocol::{run_drive, sampler::UniformWheel, ProtocolConfig, RunSummary};
use drive_sim::robot::Robot;
use drive_sim::sim::IdealPlant;
use serde_json::Value;
use std::path::Path;
use std::process::Command;

const INSTALL: &str = "install Python 3 and `pip install mcap mcap-ros2-support` \
                       (or set DRIVE_SIM_SKIP_PYTHON=1 to skip this test)";

fn skip() -> bool {
    if std::env::var("DRIVE_SIM_SKIP_PYTHON").is_ok_and(|v| v == "1") {
        eprintln!("\n!!!!! SKIPPED: independent Python MCAP decoding (DRIVE_SIM_SKIP_PYTHON=1) !!!!!\n");
        return true;
    }
    false
}

/// Runs the decoder script on `file` and parses its JSON.
fn decode_with_python(file: &Path) -> Value {
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/decode_mcap.py");
    let out = Command::new("python3")
        .arg(script)
        .arg(file)
        .output()
        .unwrap_or_else(|e| panic!("cannot run python3 ({e}): {INSTALL}"));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success(),
        "decode_mcap.py failed ({}):\n{stderr}\n{}",
        out.status,
        if out.status.code() == Some(3) { INSTALL } else { "" }
    );
    serde_json::from_slice(&out.stdout).expect("decode_mcap.py printed invalid JSON")
}

fn run(robot: &Robot, steps: u32, seed: u64) -> (Vec<Frame>, RunSummary) {
    let mut plant = IdealPlant::new(robot.idd(), 0.1);
    let mut sampler = UniformWheel::new(seed);
    let cfg = ProtocolConfig {
        steps,
        ..Default::default()
    };
    let mut frames = Vec::new();
    let s = run_drive(&mut plant, robot, &mut sampler, &cfg, &mut frames).unwrap();
    (frames, s)
}

fn meta(robot: &Robot) -> LogMeta {
    LogMeta {
        name: "python_check".into(),
        robot: robot.name.clone(),
        terrain: "ideal".into(),
        rate_hz: 20.0,
        window_s: 2.0,
        windows_per_step: 3,
        samples_per_window: 40,
        nominal: Nominal::from_robot(robot),
        origin: Origin::Simulated {
            seed: 4,
            robot_file: "robots/husky.toml".into(),
            terrain_file: "terrains/ideal.toml".into(),
            sampler: "uniform-wheel".into(),
            injected: vec![],
        },
    }
}

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("not a number: {v}"))
}

/// Sums a field over the frames in order, as the script does (starting from 0.0).
fn sum(frames: &[Frame], g: impl Fn(&Frame) -> f64) -> f64 {
    frames.iter().fold(0.0, |a, x| a + g(x))
}

fn marker_fields(fr: &Frame) -> (&'static str, u32, u32, u32, u32, f64) {
    match fr.phase {
        Phase::Step {
            step,
            attempt,
            window,
            k,
            t_in_step_s,
        } => ("step", step, attempt, window, k, t_in_step_s),
        Phase::Reorient { step } => ("reorient", step, 0, 0, 0, 0.0),
        Phase::Idle => ("idle", 0, 0, 0, 0, 0.0),
    }
}

fn check(frames: &[Frame], meta: &LogMeta, j: &Value) {
    let n = frames.len() as u64;
    assert_eq!(j["profile"], "ros2");
    // The metadata record carries the LogMeta as JSON.
    let log_meta: LogMeta =
        serde_json::from_str(j["metadata"]["drive_sim"]["log_meta"].as_str().unwrap()).unwrap();
    assert_eq!(&log_meta, meta);

    let topics = j["topics"].as_object().unwrap();
    let expected = [
        ("/drive/marker", "drive_sim_msgs/msg/DriveMarker"),
        ("/cmd_vel", "geometry_msgs/msg/TwistStamped"),
        ("/wheel_cmd", "sensor_msgs/msg/JointState"),
        ("/joint_states", "sensor_msgs/msg/JointState"),
        ("/icp_odom", "nav_msgs/msg/Odometry"),
        ("/imu/data_raw", "sensor_msgs/msg/Imu"),
        ("/tf", "tf2_msgs/msg/TFMessage"),
        ("/ground_truth/odom", "nav_msgs/msg/Odometry"),
        ("/ground_truth/joint_states", "sensor_msgs/msg/JointState"),
    ];
    let mut names: Vec<&str> = topics.keys().map(|s| s.as_str()).collect();
    names.sort_unstable();
    let mut want: Vec<&str> = expected.iter().map(|e| e.0).collect();
    want.sort_unstable();
    assert_eq!(names, want);
    let t0 = EPOCH_OFFSET_NS + (frames[0].stamp_s * 1e9).round() as u64;
    let t1 = EPOCH_OFFSET_NS + (frames[frames.len() - 1].stamp_s * 1e9).round() as u64;
    for (topic, schema) in expected {
        let t = &topics[topic];
        assert_eq!(t["schema"], schema, "{topic}");
        assert_eq!(t["encoding"], serde_json::json!(["ros2msg", "cdr"]), "{topic}");
        assert_eq!(t["count"].as_u64(), Some(n), "{topic}");
        assert_eq!(t["first_log_time_ns"].as_u64(), Some(t0), "{topic}");
        assert_eq!(t["last_log_time_ns"].as_u64(), Some(t1), "{topic}");
    }

    // Marker: first and last exactly, and sums over all messages.
    let mk = &topics["/drive/marker"];
    for (which, fr) in [("first", &frames[0]), ("last", &frames[frames.len() - 1])] {
        let v = &mk[which];
        let (phase, step, attempt, window, k, t) = marker_fields(fr);
        assert_eq!(v["phase"], phase);
        assert_eq!(v["step"].as_u64(), Some(step as u64));
        assert_eq!(v["attempt"].as_u64(), Some(attempt as u64));
        assert_eq!(v["window"].as_u64(), Some(window as u64));
        assert_eq!(v["k"].as_u64(), Some(k as u64));
        assert_eq!(f(&v["t_in_step"]), t);
        assert_eq!(f(&v["stamp"]), fr.stamp_s);
    }
    assert_eq!(f(&mk["sums"]["step"]), sum(frames, |x| marker_fields(x).1 as f64));
    assert_eq!(f(&mk["sums"]["t_in_step"]), sum(frames, |x| marker_fields(x).5));
    assert_eq!(f(&mk["sums"]["stamp"]), sum(frames, |x| x.stamp_s));

    // Body command through the declared IDD.
    let idd = meta.nominal.idd();
    let cv = &topics["/cmd_vel"];
    assert_eq!(cv["first"]["frame_id"], "base_link");
    assert_eq!(
        f(&cv["sums"]["linear_x"]),
        sum(frames, |x| idd.body_from_wheels(x.m.cmd).vx_m_s)
    );
    assert_eq!(
        f(&cv["sums"]["angular_z"]),
        sum(frames, |x| idd.body_from_wheels(x.m.cmd).wz_rad_s)
    );

    // Wheels: command, encoders, truth.
    type Get = fn(&Frame) -> (f64, f64);
    let wheel_topics: [(&str, Get); 3] = [
        ("/wheel_cmd", |x| (x.m.cmd.left_rad_s, x.m.cmd.right_rad_s)),
        ("/joint_states", |x| (x.m.enc.left_rad_s, x.m.enc.right_rad_s)),
        ("/ground_truth/joint_states", |x| {
            let w = x.m.truth.unwrap().wheels;
            (w.left_rad_s, w.right_rad_s)
        }),
    ];
    for (topic, get) in wheel_topics {
        let t = &topics[topic];
        assert_eq!(
            t["first"]["name"],
            serde_json::json!(["left_wheel", "right_wheel"])
        );
        let last = get(&frames[frames.len() - 1]);
        assert_eq!(
            t["last"]["velocity"],
            serde_json::json!([last.0, last.1]),
            "{topic}"
        );
        assert_eq!(f(&t["sums"]["left"]), sum(frames, |x| get(x).0), "{topic}");
        assert_eq!(f(&t["sums"]["right"]), sum(frames, |x| get(x).1), "{topic}");
    }
    // The encoders move: a log of zeros would pass the sums above trivially.
    assert!(sum(frames, |x| x.m.enc.left_rad_s.abs()) > 1.0);

    // Odometry: positions; the ICP twist is unknown (NaN -> null, covariance[0] = -1).
    let icp = &topics["/icp_odom"];
    assert_eq!(icp["first"]["frame_id"], "odom");
    assert_eq!(icp["first"]["child_frame_id"], "base_link");
    assert!(icp["last"]["twist_linear_x"].is_null());
    assert_eq!(f(&icp["last"]["twist_covariance0"]), -1.0);
    assert_eq!(f(&icp["sums"]["x"]), sum(frames, |x| x.m.pose.x_m));
    assert_eq!(f(&icp["sums"]["y"]), sum(frames, |x| x.m.pose.y_m));
    let last = &frames[frames.len() - 1];
    let yaw = last.m.pose.yaw_rad;
    // A yaw-only attitude is the quaternion (0, 0, sin(yaw/2), cos(yaw/2)).
    assert!((f(&icp["last"]["qz"]) - (yaw / 2.0).sin()).abs() < 1e-15);
    assert!((f(&icp["last"]["qw"]) - (yaw / 2.0).cos()).abs() < 1e-15);
    let gt = &topics["/ground_truth/odom"];
    assert_eq!(
        f(&gt["last"]["twist_linear_x"]),
        last.m.truth.unwrap().velocity.vx_m_s
    );
    assert_eq!(f(&gt["last"]["twist_covariance0"]), 0.0);
    assert_eq!(f(&gt["sums"]["x"]), sum(frames, |x| x.m.truth.unwrap().pose.x_m));

    // IMU.
    let imu = &topics["/imu/data_raw"];
    assert_eq!(f(&imu["first"]["orientation_covariance0"]), -1.0);
    assert_eq!(imu["first"]["frame_id"], "base_link");
    assert_eq!(f(&imu["sums"]["wz"]), sum(frames, |x| x.m.imu.wz_rad_s));
    assert_eq!(f(&imu["sums"]["az"]), sum(frames, |x| x.m.imu.az_m_s2));

    // tf: odom -> base_link (lidar) and odom -> base_link_truth.
    let tf = &topics["/tf"];
    assert_eq!(tf["first"]["parents"], serde_json::json!(["odom", "odom"]));
    assert_eq!(
        tf["first"]["children"],
        serde_json::json!(["base_link", "base_link_truth"])
    );
    assert_eq!(f(&tf["sums"]["x"]), sum(frames, |x| x.m.pose.x_m));
}

#[test]
fn python_mcap_ros2_decodes_every_message() {
    if skip() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let (husky, _) = Robot::resolve("husky").unwrap();

    // Husky's 9 x 6 m area: commands get interrupted; the log has re-orientations.
    let (frames, s) = run(&husky, 4, 4);
    assert!(s.interruptions > 0, "{s:?}");
    let path = dir.path().join("interrupted.mcap");
    let m = meta(&husky);
    write_mcap(&path, &m, &frames).unwrap();
    check(&frames, &m, &decode_with_python(&path));

    // A safe area so large that nothing is interrupted.
    let mut roomy = husky.clone();
    roomy.safe_area.length_m = 1000.0;
    roomy.safe_area.width_m = 1000.0;
    let (frames, s) = run(&roomy, 2, 4);
    assert_eq!(s.interruptions, 0);
    assert!(!frames.iter().any(|x| matches!(x.phase, Phase::Reorient { .. })));
    let path = dir.path().join("clean.mcap");
    let m = meta(&roomy);
    write_mcap(&path, &m, &frames).unwrap();
    check(&frames, &m, &decode_with_python(&path));
}
