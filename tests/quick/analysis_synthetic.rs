//! The pipeline on synthetic logs whose true slips, sensor faults and exclusions are known.

use drive_sim::analysis::crosscheck::{Verdict, YawRateSource};
use drive_sim::analysis::{analyze, AnalysisParams, SmootherParams};
use drive_sim::kinematics::{BodyVelocity, WheelSpeeds};
use drive_sim::log::{DriveLog, Frame, ImuReading, LogMeta, Measurement, Nominal, Origin, Phase, Pose};

fn meta() -> LogMeta {
    LogMeta {
        name: "synthetic".into(),
        robot: "warthog".into(),
        terrain: "test".into(),
        rate_hz: 20.0,
        window_s: 2.0,
        windows_per_step: 3,
        samples_per_window: 40,
        nominal: Nominal {
            wheel_radius_m: 0.3,
            baseline_m: 1.08,
            max_wheel_rad_s: 16.6667,
            max_lin_m_s: 5.0,
            max_ang_rad_s: 4.0,
            mass_kg: 470.0,
            width_m: 1.52,
            length_m: 2.13,
            height_m: None,
            max_lin_acc_m_s2: None,
            command_turn_scale: None,
        },
        origin: Origin::Simulated {
            seed: 0,
            robot_file: "-".into(),
            terrain_file: "-".into(),
            sampler: "-".into(),
            injected: vec![],
        },
    }
}

/// Options of the synthetic robot.
#[derive(Clone, Copy)]
struct Synth {
    /// Realized body velocity = `body_gain` × IDD(cmd) in steady state (vy = `vy_m_s`).
    body_gain: f64,
    vy_m_s: f64,
    /// Encoders = `wheel_gain` × cmd.
    wheel_gain: f64,
    /// IMU yaw rate = `imu_sign` × true yaw rate delayed by `imu_delay_samples`.
    imu_sign: f64,
    imu_delay_samples: usize,
}

const CMDS: [(f64, f64); 8] = [
    (5.0, 8.0),
    (-6.0, 4.0),
    (10.0, 10.0),
    (3.0, -7.0),
    (-8.0, -5.0),
    (12.0, 6.0),
    (-2.0, 9.0),
    (7.0, -1.0),
];

/// True body velocity at time t in a step: first-order rise (τ = 0.4 s) to the steady value,
/// plus a small 1.3 Hz yaw-rate wobble so that every window has timing information.
fn truth(cmd: WheelSpeeds, o: &Synth, t: f64) -> BodyVelocity {
    let ss = meta().nominal.idd().body_from_wheels(cmd);
    let rise = 1.0 - (-t / 0.4).exp();
    let wobble = 0.05 * (2.0 * std::f64::consts::PI * 1.3 * t).sin();
    BodyVelocity::new(
        o.body_gain * ss.vx_m_s * rise,
        o.vy_m_s * rise,
        o.body_gain * ss.wz_rad_s * rise + wobble,
    )
}

/// Frames of a DRIVE run over CMDS, pose integrated in one continuous odom frame (as a
/// simulator logs it) with 1 ms sub-steps.
fn frames(o: Synth) -> Vec<Frame> {
    let mut out = Vec::new();
    let (mut x, mut y, mut psi) = (0.0f64, 0.0f64, 0.0f64);
    let mut stamp = 0.0;
    for (step, &(l, r)) in CMDS.iter().enumerate() {
        let cmd = WheelSpeeds::new(l, r);
        let mut wz_hist: Vec<f64> = Vec::new();
        for i in 0..120u32 {
            let t = i as f64 / 20.0;
            let v = truth(cmd, &o, t);
            wz_hist.push(v.wz_rad_s);
            let delayed = if (i as usize) >= o.imu_delay_samples {
                wz_hist[i as usize - o.imu_delay_samples]
            } else {
                truth(cmd, &o, 0.0).wz_rad_s
            };
            out.push(Frame {
                stamp_s: stamp,
                phase: Phase::Step {
                    step: step as u32,
                    attempt: 0,
                    window: i / 40,
                    k: i % 40,
                    t_in_step_s: t,
                },
                m: Measurement {
                    cmd,
                    enc: WheelSpeeds::new(o.wheel_gain * l, o.wheel_gain * r),
                    pose: Pose {
                        x_m: x,
                        y_m: y,
                        yaw_rad: (psi + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                            - std::f64::consts::PI,
                        ..Default::default()
                    },
                    imu: ImuReading {
                        wz_rad_s: o.imu_sign * delayed,
                        az_m_s2: 9.81,
                        ..Default::default()
                    },
                    reference: None,
                    truth: None,
                },
            });
            for sub in 0..50 {
                let ts = t + sub as f64 * 0.001;
                let v = truth(cmd, &o, ts);
                let (s, c) = psi.sin_cos();
                x += (c * v.vx_m_s - s * v.vy_m_s) * 0.001;
                y += (s * v.vx_m_s + c * v.vy_m_s) * 0.001;
                psi += v.wz_rad_s * 0.001;
            }
            stamp += 0.05;
        }
    }
    out
}

fn good() -> Synth {
    Synth {
        body_gain: 0.8,
        vy_m_s: 0.1,
        wheel_gain: 0.9,
        imu_sign: 1.0,
        imu_delay_samples: 0,
    }
}

fn quick() -> AnalysisParams {
    AnalysisParams {
        smoother: SmootherParams {
            enabled: false,
            ..SmootherParams::default()
        },
        ..AnalysisParams::default()
    }
}

#[test]
fn known_slips_are_recovered() {
    let log = DriveLog::from_frames(meta(), &frames(good()));
    let a = analyze(&log, &quick()).unwrap();
    assert_eq!(a.steps.len(), CMDS.len());
    assert_eq!(a.yaw_rate_source, YawRateSource::Imu);
    let idd = meta().nominal.idd();
    for (s, &(l, r)) in a.steps.iter().zip(&CMDS) {
        let u = idd.body_from_wheels(WheelSpeeds::new(l, r));
        // Steady windows start 2 s in: the rise exp(-2/0.4) = 0.7 % is left; the wobble's mean
        // over 4 s is small but not zero: (0.05 / (2 pi 1.3)) * 2 / 4 < 0.004 rad/s.
        let rise = |t0: f64, t1: f64| 1.0 - 0.4 * ((-t0 / 0.4f64).exp() - (-t1 / 0.4f64).exp()) / (t1 - t0);
        let k = rise(2.0, 6.0);
        let g = s.steady.slip_body;
        assert!(
            (g.vx_m_s - (u.vx_m_s - 0.8 * k * u.vx_m_s)).abs() < 0.02,
            "{g:?} vs {u:?}"
        );
        assert!((g.vy_m_s - (-0.1 * k)).abs() < 0.02, "{g:?}");
        assert!(
            (g.wz_rad_s - (u.wz_rad_s - 0.8 * k * u.wz_rad_s)).abs() < 0.01,
            "{g:?} vs {u:?}"
        );
        // Wheels at 0.9 of the command: slip = 0.1 cmd exactly.
        assert!((s.steady.slip_wheels.left_rad_s - 0.1 * l).abs() < 1e-9);
        assert!((s.steady.slip_wheels.right_rad_s - 0.1 * r).abs() < 1e-9);
        // Slower than the command: positive slip along the command.
        assert!(g.vx_m_s * u.vx_m_s > 0.0);
    }
    // The IDD RMSE of vx is the RMS of (1 - 0.8 k) vx over the commands.
    let k = 1.0 - 0.4 * ((-5.0f64).exp() - (-15.0f64).exp()) / 4.0;
    let rms = (CMDS
        .iter()
        .map(|&(l, r)| ((1.0 - 0.8 * k) * 0.3 * (l + r) / 2.0).powi(2))
        .sum::<f64>()
        / CMDS.len() as f64)
        .sqrt();
    assert!(
        (a.idd_rmse.vx_m_s - rms).abs() < 0.02,
        "{} vs {rms}",
        a.idd_rmse.vx_m_s
    );
    assert!(
        a.crosscheck.verdicts.iter().take(3).all(|v| v.verdict.passed()),
        "{:?}",
        a.crosscheck.verdicts
    );
}

#[test]
fn the_next_command_recorded_early_changes_nothing_but_the_note() {
    // The same run, with the last two samples of steps 2 and 5 (and the last step's last one)
    // recording the next step's command, as warthog_asphalt_b and husky_2023 do: the robot
    // did not see it (encoders, poses and IMU are the same samples), so every step's command,
    // slips and ρ must come out as before, and the note must name exactly those steps.
    let clean = frames(good());
    let mut early = clean.clone();
    let per_step = 120;
    for (step, n) in [(2usize, 2usize), (5, 2), (CMDS.len() - 1, 1)] {
        let next = CMDS.get(step + 1).copied().unwrap_or((0.0, 0.0));
        let end = (step + 1) * per_step;
        for f in &mut early[end - n..end] {
            f.m.cmd = WheelSpeeds::new(next.0, next.1);
        }
    }
    let a = analyze(&DriveLog::from_frames(meta(), &clean), &quick()).unwrap();
    let b = analyze(&DriveLog::from_frames(meta(), &early), &quick()).unwrap();
    assert!(a.steady_command_changes.is_empty());
    let noted: Vec<(u32, usize, usize)> = b
        .steady_command_changes
        .iter()
        .map(|c| (c.step, c.held.samples, c.held.steady_samples))
        .collect();
    assert_eq!(noted, vec![(2, 78, 80), (5, 78, 80), (7, 79, 80)]);
    assert_eq!(a.steps, b.steps);
    assert_eq!(a.stats, b.stats);
    assert_eq!(a.rows, b.rows);
}

#[test]
fn crosscheck_detects_an_inverted_imu() {
    let log = DriveLog::from_frames(
        meta(),
        &frames(Synth {
            imu_sign: -1.0,
            ..good()
        }),
    );
    let a = analyze(&log, &quick()).unwrap();
    match a.crosscheck.verdict("imu_yaw_rate").unwrap() {
        Verdict::Fault { description } => assert!(description.contains("sign inverted"), "{description}"),
        v => panic!("expected a fault, got {v:?}"),
    }
    assert_eq!(a.yaw_rate_source, YawRateSource::Pose);
    assert!(a.crosscheck.verdict("pose_yaw_rate").unwrap().passed());
    // The pipeline's wz then comes from the pose, so the slip is still right.
    let good_a = analyze(&DriveLog::from_frames(meta(), &frames(good())), &quick()).unwrap();
    for (x, y) in a.steps.iter().zip(&good_a.steps) {
        assert!((x.steady.slip_body.wz_rad_s - y.steady.slip_body.wz_rad_s).abs() < 0.01);
    }
}

#[test]
fn crosscheck_measures_imu_latency() {
    // 4 samples = 0.2 s late.
    let log = DriveLog::from_frames(
        meta(),
        &frames(Synth {
            imu_delay_samples: 4,
            ..good()
        }),
    );
    let a = analyze(&log, &quick()).unwrap();
    let c = a.crosscheck.comparison("imu_wz", "pose_wz").unwrap();
    assert!((c.latency_s - 0.2).abs() < 0.03, "{c:?}");
    match a.crosscheck.verdict("imu_yaw_rate").unwrap() {
        Verdict::Fault { description } => assert!(description.contains("latency"), "{description}"),
        v => panic!("expected a latency fault, got {v:?}"),
    }
    // No delay: latency ~ 0.
    let a = analyze(&DriveLog::from_frames(meta(), &frames(good())), &quick()).unwrap();
    assert!(
        a.crosscheck
            .comparison("imu_wz", "pose_wz")
            .unwrap()
            .latency_s
            .abs()
            < 0.03
    );
}

#[test]
fn incomplete_steps_are_excluded_with_reasons() {
    let mut f = frames(good());
    // Step 1: drop window 2. Step 2: keep only 10 samples of window 1. Step 3: a NaN encoder.
    f.retain(|fr| match fr.phase {
        Phase::Step {
            step: 1, window: 2, ..
        } => false,
        Phase::Step {
            step: 2,
            window: 1,
            k,
            ..
        } => k < 10,
        _ => true,
    });
    for fr in f.iter_mut() {
        if let Phase::Step {
            step: 3,
            window: 1,
            k: 5,
            ..
        } = fr.phase
        {
            fr.m.enc.left_rad_s = f64::NAN;
        }
    }
    let log = DriveLog::from_frames(meta(), &f);
    let a = analyze(&log, &quick()).unwrap();
    let steps: Vec<u32> = a.steps.iter().map(|s| s.step).collect();
    assert_eq!(steps, vec![0, 4, 5, 6, 7]);
    let reason = |s: u32| a.exclusions.iter().find(|e| e.step == s).unwrap().reason.clone();
    assert!(reason(1).contains("missing window(s) 2"), "{}", reason(1));
    assert!(reason(2).contains("window 1 has 10 samples"), "{}", reason(2));
    assert!(reason(3).contains("non-finite"), "{}", reason(3));
    // The summary rows carry the exclusions too.
    let ex: Vec<u32> = a
        .rows
        .iter()
        .filter(|r| r.excluded.is_some())
        .map(|r| r.step)
        .collect();
    assert_eq!(ex, vec![1, 2, 3]);
    // 5 analysed steps x (3 windows + steady) + 3 excluded rows.
    assert_eq!(a.rows.len(), 5 * 4 + 3);
}

#[test]
fn nothing_to_analyse_is_an_error() {
    let f: Vec<Frame> = frames(good())
        .into_iter()
        .filter(|fr| !matches!(fr.phase, Phase::Step { window: 2, .. }))
        .collect();
    let log = DriveLog::from_frames(meta(), &f);
    match analyze(&log, &quick()) {
        Err(e @ drive_sim::analysis::Error::NoCompleteStep { .. }) => {
            let m = e.to_string();
            assert!(
                m.contains("no complete step") && m.contains("missing window"),
                "{m}"
            )
        }
        other => panic!(
            "expected an analysis error, got {:?}",
            other.map(|a| a.steps.len())
        ),
    }
}

#[test]
fn summary_json_round_trip() {
    let log = DriveLog::from_frames(meta(), &frames(good()));
    let a = analyze(&log, &AnalysisParams::default()).unwrap();
    let json = serde_json::to_string(&a.rows).unwrap();
    assert!(json.contains("\"slip_vx_m_s\""));
    assert!(a.transfer.is_some());
    // The whole analysis serializes (NaN as null).
    assert!(serde_json::to_string(&a).is_ok());
}
