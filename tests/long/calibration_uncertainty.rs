//! The calibration's honesty checks, on data from an independent generator written in the
//! tests (`tests/common/generator.rs`), with the answer known:
//! - a pair of parameters that act identically on every channel is flagged as not
//!   identifiable, and the effect is not added;
//! - changing the test steps' data changes nothing but the reported test scores.
//!
//! The standard errors against the spread of refits on resampled steps are a measurement of the
//! statistics tier (`tests/statistics/standard_errors.rs`); the formula itself is checked by hand
//! in `crates/calibration/src/solver/covariance.rs`.

use drive_sim::calibration::{calibrate, CalibrationOptions, KinematicFactory};
use drive_sim::terrain::Terrain;

use crate::common;
use common::generator::{drive_log, TestRobotSpec};

/// The lag of the generator is slower than the declared one. The kinematic model's base fit
/// adjusts its time constant; the candidate `time_constant_scale`, refit beside it, acts on
/// every channel exactly as the time constant does (τ · scale): the pair is not identifiable,
/// and the effect is not added.
#[test]
fn a_pair_that_acts_identically_is_not_identifiable_and_not_added() {
    let mut s = TestRobotSpec::uneven_motors(6);
    s.gain = [1.0, 1.0];
    s.lag_s = 0.4;
    let (log, robot) = drive_log("collinear", s, 40);
    let (terrain, _) = Terrain::resolve("asphalt").unwrap();
    let opts = CalibrationOptions {
        candidates: Some(vec!["time_constant_scale".into()]),
        grid_step: 0.5,
        ..CalibrationOptions::default()
    };
    let r = calibrate(&log, &robot, &terrain, &KinematicFactory, &opts).unwrap();
    let ev = &r.rounds[0].ranking[0];
    assert_eq!(ev.effect, "time_constant_scale");
    assert_eq!(ev.identifiable, Some(false), "{ev:#?}");
    assert!(!ev.significant);
    let p = &ev.params[0];
    assert_eq!(p.identifiable, Some(false), "{p:?}");
    assert!(
        p.identifiability_note
            .as_deref()
            .is_some_and(|n| n.contains("time_constant_s") || n.contains("constrain")),
        "{p:?}"
    );
    assert!(r.effects.is_empty(), "{:?}", r.effects);
    // The base fit found the generator's lag on its own.
    let tc = r.model_after.robot.powertrain.time_constant_s;
    assert!((tc - 0.4).abs() < 0.05, "{tc}");
}

/// Perturbing every sample of the test steps (encoders off by 1 rad/s, poses shifted) leaves
/// the split, the choices and the fitted values as they were; only the test scores move.
#[test]
fn test_steps_touch_nothing_but_the_reported_scores() {
    let (log, robot) = drive_log("untouched", TestRobotSpec::uneven_motors(7), 40);
    let (terrain, _) = Terrain::resolve("asphalt").unwrap();
    let opts = CalibrationOptions {
        grid_step: 0.5,
        max_effects: 2,
        ..CalibrationOptions::default()
    };
    let a = calibrate(&log, &robot, &terrain, &KinematicFactory, &opts).unwrap();
    for e in a.rounds[0].ranking.iter().take(3) {
        eprintln!(
            "{} {} {} ± {} sig {} id {:?} {:?}",
            e.effect,
            e.heldout_before,
            e.heldout_after,
            e.reduction_se,
            e.significant,
            e.identifiable,
            e.params
                .iter()
                .map(|p| (p.value, p.identifiability_note.clone()))
                .collect::<Vec<_>>()
        );
    }
    let mut changed = log.clone();
    for s in &mut changed.samples {
        if a.heldout_steps.contains(&s.step) {
            s.m.enc.left_rad_s += 1.0;
            s.m.enc.right_rad_s -= 1.0;
            s.m.pose.x_m += 0.3 * s.t_in_step_s;
            s.m.imu.wz_rad_s += 0.2;
        }
    }
    let b = calibrate(&changed, &robot, &terrain, &KinematicFactory, &opts).unwrap();
    assert_eq!(a.heldout_steps, b.heldout_steps);
    assert_eq!(a.model_after, b.model_after);
    assert_eq!(a.effects, b.effects);
    assert_eq!(a.rounds, b.rounds);
    assert_eq!(a.floor, b.floor);
    assert!(
        a.after.score != b.after.score,
        "the test scores must see the change"
    );
    // The generator's weak left motor was found.
    assert!(
        a.effects
            .iter()
            .any(|e| e.name == "effect.motor_gain_left" && (e.value - 0.85).abs() < 0.02),
        "{:?}",
        a.effects
    );
}
