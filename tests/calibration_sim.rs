//! Calibration with the rapier simulator as the model.
//!
//! CI: a synthetic DRIVE run of the simulator carrying an undeclared effect (sensor noise on)
//! must be diagnosed by `calibrate` with the simulator as the model; the measured gravel and
//! ice runs must give the known findings with their intervals. All four measured datasets:
//! `CALIB_OUT=/tmp/calib cargo test --release --test calibration_sim -- --ignored --nocapture`
//! (`DATASETS=warthog_ice,...` to choose).

use drive_sim::calibration::{
    calibrate, models_for_log, write_report, CalibrationOptions, CalibrationReport, SimFactory,
};
use drive_sim::effects::Effects;
use drive_sim::log::csv::read_measured_csv;
use drive_sim::log::DriveLog;
use drive_sim::protocol::sampler::UniformWheel;
use drive_sim::protocol::{run_drive, ProtocolConfig};
use drive_sim::robot::Robot;
use drive_sim::sim::{SensorNoise, SimConfig, Simulator};
use drive_sim::terrain::Terrain;

mod common;

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data/measured");

/// A simulated DRIVE run on asphalt with `effects` injected but not declared, by the
/// Warthog without the effects its file declares (the cases inject their own truth and start
/// the calibration from a model that declares nothing).
fn synthetic_log(effects: &[(&str, f64)], steps: u32, seed: u64) -> (DriveLog, Robot, Terrain) {
    let (terrain, _) = Terrain::resolve("asphalt").unwrap();
    synthetic_log_on(&terrain, effects, steps, seed)
}

/// [`synthetic_log`] on `terrain` (the truth), returned as the log was simulated on.
fn synthetic_log_on(
    terrain: &Terrain,
    effects: &[(&str, f64)],
    steps: u32,
    seed: u64,
) -> (DriveLog, Robot, Terrain) {
    let (mut robot, _) = Robot::resolve("warthog").unwrap();
    robot.effects = Effects::default();
    let terrain = terrain.clone();
    let mut e = Effects::default();
    for (n, v) in effects {
        e.set(n, *v).unwrap();
    }
    let cfg = SimConfig {
        seed,
        noise: SensorNoise {
            encoder_rad_s: 0.1,
            pose_position_m: 0.01,
            pose_yaw_rad: 0.005,
            imu_gyro_rad_s: 0.02,
            imu_accel_m_s2: 0.1,
        },
        effects: e,
        ..SimConfig::default()
    };
    let mut sim = Simulator::new(&robot, &terrain, cfg).unwrap();
    let pc = ProtocolConfig {
        steps,
        ..ProtocolConfig::default()
    };
    let mut frames = Vec::new();
    run_drive(&mut sim, &robot, &mut UniformWheel::new(seed), &pc, &mut frames).unwrap();
    let log = common::undeclared_log("synthetic_sim", &robot, seed, &pc, &frames);
    (log, robot, terrain)
}

fn cheap_options() -> CalibrationOptions {
    CalibrationOptions {
        seed: 3,
        max_effects: 1,
        grid_step: 0.5,
        // The full candidate list is exercised by the kinematic-model tests; here the
        // simulator's own effects (turning resistance, torsion) against their look-alikes.
        candidates: Some(
            [
                "motor_gain",
                "wheel_radius_scale",
                "encoder_scale",
                "turning_resistance_scale",
                "suspension_torsion_m",
            ]
            .map(String::from)
            .to_vec(),
        ),
        discover: false,
        ..CalibrationOptions::default()
    }
}

/// Calibrates the simulator on a synthetic run of `steps` steps carrying `effects`
/// (undeclared), and prints the report.
fn diagnose(effects: &[(&str, f64)], steps: u32, seed: u64, opts: &CalibrationOptions) -> CalibrationReport {
    let t0 = std::time::Instant::now();
    let (log, robot, terrain) = synthetic_log(effects, steps, seed);
    let r = calibrate(&log, &robot, &terrain, &SimFactory::default(), opts).unwrap();
    common::print_summary(
        &format!("synthetic simulator, injected {effects:?}"),
        &r,
        t0.elapsed().as_secs_f64(),
    );
    r
}

/// `candidate` ranked first, and the held-out score cut to a fifth.
fn assert_found(r: &CalibrationReport, candidate: &str) {
    assert_eq!(
        r.rounds[0].ranking[0].effect, candidate,
        "{:#?}",
        r.rounds[0].ranking
    );
    assert!(
        r.after.score < 0.2 * r.before.score,
        "{} -> {}",
        r.before.score,
        r.after.score
    );
}

fn fitted(r: &CalibrationReport, name: &str) -> Option<f64> {
    r.effects.iter().find(|e| e.name == name).map(|e| e.value)
}

#[test]
fn simulator_with_a_weak_left_motor_is_diagnosed() {
    let r = diagnose(&[("motor_gain_left", 0.8)], 24, 21, &cheap_options());
    assert_found(&r, "motor_gain");
    let (l, rr) = (
        fitted(&r, "effect.motor_gain_left").unwrap(),
        fitted(&r, "effect.motor_gain_right").unwrap(),
    );
    assert!((l - 0.8).abs() < 0.05 && (rr - 1.0).abs() < 0.05, "{l} {rr}");
}

/// A wheel-speed saturation, undeclared, against the effects that look like it in the
/// residual (the curvature-preserving controller limit, a weak motor, a smaller wheel).
#[test]
fn simulator_with_a_saturated_motor_is_diagnosed() {
    let opts = CalibrationOptions {
        candidates: Some(
            [
                "wheel_speed_saturation_rad_s",
                "controller_wheel_limit_rad_s",
                "motor_gain",
                "wheel_radius_scale",
            ]
            .map(String::from)
            .to_vec(),
        ),
        ..cheap_options()
    };
    // 40 steps: few steps command past the limit and they carry the whole reduction, so the
    // evidence needs validation steps. With 24 (5 validation steps) and a faster
    // re-orientation the reduction is 289 ± 248, short of 2 SE; with 32 and the simulated
    // operator that plans on the motion it saw, 200.8 ± 128.5 (and the fit does not converge,
    // 40 s); with 40, 889 ± 240, found at 10.003, test score 0.95, in 14 s.
    let r = diagnose(&[("wheel_speed_saturation_rad_s", 10.0)], 40, 23, &opts);
    assert_found(&r, "wheel_speed_saturation_rad_s");
    let sat = fitted(&r, "effect.wheel_speed_saturation_rad_s");
    assert!(sat.is_some_and(|v| (v - 10.0).abs() < 0.3), "{:?}", r.effects);
}

#[test]
fn simulator_with_nothing_injected_adds_nothing() {
    let r = diagnose(&[], 16, 22, &cheap_options());
    assert!(r.effects.is_empty(), "{:?}", r.effects);
}

/// The fall of the longitudinal friction past its peak is a base parameter: a simulated run on
/// asphalt whose sliding friction is 0.9 of its peak, calibrated from the declared share (0.76),
/// gives it back within its interval (the clustered sandwich's), and adds no effect for it.
#[test]
fn simulator_with_a_gentler_friction_fall_gives_back_its_share() {
    let (declared, _) = Terrain::resolve("asphalt").unwrap();
    let mut truth = declared.clone();
    truth.friction.sliding_longitudinal = 0.9 * truth.friction.peak_longitudinal;
    let (log, robot, _) = synthetic_log_on(&truth, &[], 40, 24);
    let r = calibrate(&log, &robot, &declared, &SimFactory::default(), &cheap_options()).unwrap();
    common::print_summary("synthetic simulator, sliding friction 0.9 of the peak", &r, 0.0);
    let fit = r.final_fit.as_ref().or(r.terrain_fit.as_ref()).unwrap();
    let p = fit
        .params
        .iter()
        .find(|p| p.name == "terrain.friction.sliding_longitudinal_share")
        .unwrap();
    assert!((p.value - 0.9).abs() < 0.05, "{p:?}");
    assert!(p.ci95.is_some_and(|[lo, hi]| lo <= 0.9 && 0.9 <= hi), "{p:?}");
    assert!(r.effects.is_empty(), "{:?}", r.effects);
}

/// The simulator calibrated on a measured dataset, all its training steps, default options.
fn calibrate_measured(name: &str) -> CalibrationReport {
    let t0 = std::time::Instant::now();
    let log = read_measured_csv(format!("{DATA}/{name}.csv")).unwrap();
    let (robot, terrain, _) = models_for_log(&log).unwrap();
    let r = calibrate(
        &log,
        &robot,
        &terrain,
        &SimFactory::default(),
        // The catalogue's findings on measured data; discovery (minutes more on these logs)
        // is tested on generated data in tests/long/discovery.rs and measured with the CLI.
        &CalibrationOptions {
            discover: false,
            ..CalibrationOptions::default()
        },
    )
    .unwrap();
    common::print_summary(name, &r, t0.elapsed().as_secs_f64());
    if let Ok(dir) = std::env::var("CALIB_OUT") {
        write_report(&r, &std::path::Path::new(&dir).join(name)).unwrap();
    }
    r
}

/// The known findings on the measured Warthog runs, fitted on all training steps and
/// reported on untouched test steps: the IMU's yaw axis is upside down, and the
/// wheels saturate near 12.4–12.9 rad/s (nominal 16.67). Both must be found with evidence, the
/// limit's 95 % interval must lie in [12, 13.3] rad/s, and the test score must fall.
fn assert_known_warthog_findings(r: &CalibrationReport, must_converge: bool) {
    let flip = r
        .effects
        .iter()
        .find(|e| e.name == "effect.imu_yaw_rate_sign_flip");
    assert_eq!(flip.map(|e| e.value), Some(1.0), "{:?}", r.effects);
    let sat = r
        .effects
        .iter()
        .find(|e| {
            e.name == "effect.wheel_speed_saturation_rad_s" || e.name == "effect.controller_wheel_limit_rad_s"
        })
        .unwrap_or_else(|| panic!("no wheel-speed limit: {:?}", r.effects));
    let ci = sat.ci95.unwrap_or_else(|| panic!("no interval: {sat:?}"));
    assert!(ci[0] > 12.0 && ci[1] < 13.3, "{sat:?}");
    // The Warthog file declares the measured limit: this log must confirm it (switching it
    // off costs beyond the selection's standard errors on the test steps), not find it again.
    let declared = r
        .declared_effects
        .iter()
        .find(|d| d.effect == "wheel_speed_saturation_rad_s")
        .unwrap_or_else(|| panic!("the declared limit was not judged: {:?}", r.declared_effects));
    assert!(declared.confirmed, "{}", declared.verdict);
    assert!(
        !r.rounds
            .iter()
            .flat_map(|round| &round.ranking)
            .any(|c| c.effect.contains("wheel_speed_saturation_rad_s")),
        "a declared effect is not a candidate"
    );
    assert!(
        r.after.score < r.before.score,
        "{} -> {}",
        r.before.score,
        r.after.score
    );
    if must_converge {
        assert!(r.status.converged, "{:?}", r.status);
    }
}

#[test]
fn measured_gravel_imu_flip_and_wheel_limit() {
    // On gravel every fit must stop on a convergence criterion.
    assert_known_warthog_findings(&calibrate_measured("warthog_gravel"), true);
}

#[test]
fn measured_ice_imu_flip_and_wheel_limit() {
    // On ice the first joint refit (6 parameters) uses its 30-iteration budget; the report
    // says so in its notes, the findings stand.
    assert_known_warthog_findings(&calibrate_measured("warthog_ice"), false);
}

/// Every measured dataset (the README's table): `DATASETS=warthog_ice,... CALIB_OUT=DIR
/// cargo test --release --test calibration_sim -- --ignored --nocapture`.
#[test]
#[ignore = "all four datasets, minutes; the README's table"]
fn measured_datasets_with_the_simulator() {
    let names = std::env::var("DATASETS")
        .unwrap_or_else(|_| "warthog_asphalt,warthog_gravel,warthog_ice,husky_2023".into());
    let mut worse: Vec<String> = Vec::new();
    for name in names.split(',') {
        let r = calibrate_measured(name);
        if r.after.score > r.before.score {
            worse.push(format!("{name}: {} -> {}", r.before.score, r.after.score));
        }
    }
    // The test score is never worse after calibration.
    assert!(worse.is_empty(), "{worse:?}");
}

/// A reset simulator replays a step exactly as a new one does (bit for bit), whatever it did
/// before: replays reuse one world for many steps, and their result must not depend on which
/// steps share a world (nor on the number of threads).
#[test]
fn a_reset_simulator_replays_exactly_as_a_new_one() {
    use drive_sim::calibration::replay::replay_step;
    use drive_sim::calibration::steps::{step_slices, step_start};
    use drive_sim::calibration::{ModelParams, PlantFactory};
    let (log, robot, terrain) = synthetic_log(&[("dead_time_s", 0.1)], 3, 5);
    let slices = step_slices(&log);
    let mut params = ModelParams::new(robot, terrain);
    params.effects.set("dead_time_s", 0.1).unwrap();
    let f = SimFactory::default();
    let run = |plant: &mut dyn drive_sim::sim::Plant, i: usize| {
        let s = slices[i];
        replay_step(plant, s, &step_start(s.samples).unwrap(), log.meta.rate_hz).unwrap()
    };
    let fresh = run(f.build(&params).unwrap().as_mut(), 2);
    let mut reused = f.build(&params).unwrap();
    run(reused.as_mut(), 0);
    run(reused.as_mut(), 1);
    let again = run(reused.as_mut(), 2);
    assert_eq!(fresh.len(), again.len());
    for (a, b) in fresh.iter().zip(&again) {
        assert_eq!(a.m, b.m, "sample {} {}", a.window, a.k);
    }
}

/// The same on measured steps, which end in motion (the synthetic ones above end braking): a
/// reused world replays each of the first twenty steps of a measured run exactly as a new one
/// does, after the step before it. The Husky's run commands its wheels far beyond what its
/// motors give, so its sides saturate and their wheel spins are unknowns of the physics step's
/// solve, started from its predictor (the last step's change): without clearing it on reset,
/// a replay depended in the last digits on the step replayed before, and a calibration's
/// result on which step a pooled world had replayed last.
#[test]
fn a_reused_world_replays_a_measured_step_exactly_as_a_new_one() {
    use drive_sim::calibration::replay::replay_step;
    use drive_sim::calibration::steps::{step_slices, step_start};
    use drive_sim::calibration::{models_for_log, ModelParams, PlantFactory};
    for dataset in ["warthog_gravel", "husky_2023"] {
        let log = read_measured_csv(format!("{DATA}/{dataset}.csv")).unwrap();
        let (robot, terrain, _) = models_for_log(&log).unwrap();
        let slices = step_slices(&log);
        let params = ModelParams::new(robot, terrain);
        let f = SimFactory::default();
        let run = |plant: &mut dyn drive_sim::sim::Plant, i: usize| {
            let s = slices[i];
            replay_step(plant, s, &step_start(s.samples).unwrap(), log.meta.rate_hz).unwrap()
        };
        let mut reused = f.build(&params).unwrap();
        run(reused.as_mut(), 0);
        for i in 1..20 {
            let fresh = run(f.build(&params).unwrap().as_mut(), i);
            let again = run(reused.as_mut(), i);
            assert_eq!(fresh.len(), again.len());
            for (a, b) in fresh.iter().zip(&again) {
                assert_eq!(a.m, b.m, "{dataset} step {i} sample {} {}", a.window, a.k);
            }
        }
    }
}
