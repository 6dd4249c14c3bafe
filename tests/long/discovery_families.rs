//! One case of each family that discovery explains today, from the randomized benchmark
//! (`benches/discovery_benchmark.rs`: the independent generator of `tests/common/generator.rs`
//! with effects drawn at random, `tests/common/random_cases.rs`), calibrated with the kinematic
//! model and discovery as the benchmark does (the catalogue without its structural effects):
//! - every channel ends within its flag on the test steps (2× its floor steady, 3× transient
//!   and pose), and the structure is recovered (the exact catalogue effect, its value within
//!   10 % or 3 standard errors; else a discovered term where the effect acts and nowhere else);
//! - the dead time alone is picked within 10 %, and nothing else is kept;
//! - a gain curve ω·(1 + a·|ω|) is explained in one competition: the catalogue's stand-in (a
//!   controller's kinematics) loses to discovery from the base model, whose term in the
//!   command's odd square has the curve's coefficient within 10 %;
//! - a deadband is the catalogue's `wheel_deadband_rad_s`, which discovery brings in from the
//!   wheel equations' negative term in sign(ω_cmd), its width within 10 %;
//! - the wheel maps a polynomial describes only roughly are the named effects the wheel
//!   equations point to, their parameters within 10 %: a soft limit S·tanh(ω/S), a knee
//!   (where the gain changes, and to what), a gain backwards;
//! - one encoder's scale is that encoder's, not its wheel's gain;
//! - a body lag is the catalogue's lag; a yaw rate damped by speed is one body term, −k·|vx|·wz,
//!   its coefficient within 10 % of the generator's k;
//! - noise alone proposes nothing.
//!
//! Where the effect acts, every channel also ends within 1.5× its floor on the test steps.
//!
//! The cases are the first of each family in the benchmark's draw (`--cases 30 --nulls 10
//! --seed 1`), on logs of 60 steps (the benchmark's are 90; the coupling between the sides
//! keeps 90, see its test). A late pose is the catalogue's latency; counting encoders need no effect. The
//! families left to the benchmark are measured there, its table in docs/results/discovery.md:
//! the turn memory (its first case is the benchmark's miss, 3.5× against a flag of 3; its
//! replay at the generator's values is the last test here), the backlash (no effect has the
//! gap's state) and the dropouts (within their flags, nothing kept: the encoder scale they
//! average to is not found).

use crate::bench_cases;
use crate::common;
use bench_cases::benchmark::{calibrate_case, score, Record};
use bench_cases::random_cases::{cases, Case, Family};
use common::CATALOGUE_WITHOUT_STRUCTURAL;
use drive_sim::calibration::CalibrationReport;

/// The benchmark's draw: its first case of `family`.
fn first_of(family: Family) -> Case {
    cases(&Family::EFFECTS, 30, 10, 1)
        .into_iter()
        .find(|c| c.family == family)
        .unwrap_or_else(|| panic!("no {family:?} case in the benchmark's draw"))
}

/// Steps of a CI case's log: shorter than the benchmark's, as a CI test should be.
const CI_STEPS: u32 = 60;
/// The benchmark's steps, for the one case that needs them (see its test).
const BENCHMARK_STEPS: u32 = 90;

/// The case calibrated and scored as the benchmark scores it, on a log of [`CI_STEPS`].
fn run(case: &Case) -> Record {
    run_with_report(case, CI_STEPS).0
}

/// [`run`] on a log of `steps`, with the calibration's report.
fn run_with_report(case: &Case, steps: u32) -> (Record, CalibrationReport) {
    let candidates = CATALOGUE_WITHOUT_STRUCTURAL
        .iter()
        .map(|s| s.to_string())
        .collect();
    let t0 = std::time::Instant::now();
    let r = calibrate_case(case, steps, Some(candidates)).unwrap();
    let rec = score(case, &r, t0.elapsed().as_secs_f64());
    eprintln!(
        "{}: kept {:?}; worst {} {:.2} (flag {}); within flags {}, structure {}; effect's channels {:?}; {:.1} s",
        rec.name,
        rec.kept,
        rec.worst_channel,
        rec.worst_ratio,
        rec.worst_threshold,
        rec.within_flags,
        rec.structure,
        rec.effect_channel_ratios,
        rec.seconds
    );
    (rec, r)
}

fn assert_explained(rec: &Record) {
    assert!(
        rec.within_flags,
        "{}: flagged after {:?}",
        rec.name, rec.flagged_after
    );
    assert!(
        rec.structure,
        "{}: kept {:?}, equations {:#?}",
        rec.name, rec.kept, rec.equations
    );
    for v in &rec.values {
        assert!(v.ok, "{}: {v:?}", rec.name);
    }
    // The bar, tighter than the flags: where the effect acts, every channel within
    // 1.5× its floor on the test steps.
    for (channel, ratio) in &rec.effect_channel_ratios {
        assert!(
            *ratio <= EFFECT_CHANNEL_BOUND,
            "{}: {channel} at {ratio:.2}× its floor",
            rec.name
        );
    }
}

/// Where the effect acts, a channel's RMSE over its floor on the test steps at most this.
const EFFECT_CHANNEL_BOUND: f64 = 1.5;

#[test]
fn a_body_lag_is_the_catalogue_lag() {
    assert_explained(&run(&first_of(Family::BodyLag)));
}

#[test]
fn a_yaw_damped_by_speed_is_one_body_term_in_the_speed_times_the_yaw_rate() {
    // The generator turns the body at w·(1 − k·|v|): Δwz = −k·|vx|·wz, one term, and the IMU
    // needs none of its own (it reads the body).
    let case = first_of(Family::YawDamping);
    let rec = run(&case);
    assert_explained(&rec);
    assert_eq!(rec.term_targets, ["body_wz"], "{:?}", rec.kept);
    let k = case.magnitudes[0].1;
    let fitted = rec.kept[0]
        .split_once("abs_vx_wz=")
        .and_then(|(_, v)| v.trim_end_matches(')').parse::<f64>().ok())
        .unwrap_or_else(|| panic!("no |vx|·wz coefficient in {:?}", rec.kept));
    assert!((fitted + k).abs() < 0.1 * k, "fitted {fitted}, generator −{k}");
}

#[test]
fn the_dead_time_alone_is_picked_within_ten_percent() {
    let rec = run(&first_of(Family::DeadTime));
    assert_explained(&rec);
    assert_eq!(rec.values.len(), 1, "{:?}", rec.values);
    assert_eq!(rec.kept.len(), 1, "nothing but the dead time: {:?}", rec.kept);
    assert!(rec.added.is_empty(), "discovery added {:?}", rec.added);
}

#[test]
fn noise_alone_proposes_nothing() {
    for case in cases(&[], 0, 2, 1) {
        let rec = run(&case);
        assert!(
            !rec.false_discovery(),
            "{}: kept {:?}, added {:?}",
            rec.name,
            rec.kept,
            rec.added
        );
        assert!(rec.equations.is_empty(), "{}: {:?}", rec.name, rec.equations);
    }
}

#[test]
fn a_drifting_gain_is_the_catalogue_drift() {
    assert_explained(&run(&first_of(Family::GainDrift)));
}

#[test]
fn a_drifting_gyro_bias_is_a_term_in_the_step_index() {
    assert_explained(&run(&first_of(Family::ImuBiasDrift)));
}

#[test]
fn one_side_driven_by_the_other_is_a_wheel_term() {
    // On 60 steps (36 to fit) the right wheel's equation is not stable under resampling (no
    // term in 70 % of the resamples, though the residual is 5 floors), the body takes a
    // stand-in and steady enc_right ends 19.7× its floor: the coupling needs the benchmark's
    // 90 steps.
    assert_explained(&run_with_report(&first_of(Family::CrossCoupling), BENCHMARK_STEPS).0);
}

#[test]
fn a_centripetal_slip_is_the_catalogue_slip() {
    assert_explained(&run(&first_of(Family::Centripetal)));
}

#[test]
fn a_deadband_is_the_catalogue_deadband_the_wheel_equations_point_to() {
    let rec = run(&first_of(Family::Deadband));
    assert_explained(&rec);
    assert_eq!(rec.values.len(), 1, "{:?}", rec.values);
}

#[test]
fn a_late_pose_is_the_catalogue_latency() {
    // The replay starts each step where the robot was, not where its late pose says, and
    // the start's yaw rate is the gyro's, which is not late.
    let rec = run(&first_of(Family::PoseLatency));
    assert_explained(&rec);
    assert_eq!(rec.values.len(), 1, "{:?}", rec.values);
}

#[test]
fn counting_encoders_need_no_effect() {
    // Zero-mean counts: nothing to find, and the replay's start wheels, read from the previous
    // step's last second rather than one count-quantised sample, keep every channel in its flag.
    let rec = run(&first_of(Family::EncoderQuantization));
    assert_explained(&rec);
    assert!(
        rec.kept.is_empty() && rec.added.is_empty(),
        "{:?} {:?}",
        rec.kept,
        rec.added
    );
}

#[test]
fn a_gyro_fault_is_the_catalogue_fault() {
    assert_explained(&run(&first_of(Family::ImuFault)));
}

#[test]
fn a_gain_curve_is_one_term_in_the_command_found_from_the_base_model() {
    let case = first_of(Family::GainCurve);
    let (rec, r) = run_with_report(&case, CI_STEPS);
    assert_explained(&rec);
    let competition = r
        .discovery
        .as_ref()
        .and_then(|d| d.competition.as_ref())
        .expect("the catalogue's order leaves the curve flagged: the competition runs");
    assert_eq!(competition.kept, "discovery first", "{competition:#?}");
    let truth = |side: &str| {
        case.magnitudes
            .iter()
            .find(|(k, _)| *k == "a_s_rad" || *k == format!("a_{side}_s_rad"))
            .map(|(_, v)| *v)
    };
    let mut checked = 0;
    for side in ["left", "right"] {
        let key = format!("term_wheel_{side}__cmd_wheel_odd");
        match truth(side) {
            Some(a) => {
                let fitted = r.model_after.effects.get(&key).unwrap();
                assert!(
                    (fitted - a).abs() <= 0.1 * a.abs(),
                    "{key}: {fitted} against the curve's {a}"
                );
                checked += 1;
            }
            None => assert_eq!(
                r.model_after.effects.get(&key),
                Some(0.0),
                "{key} on the straight side"
            ),
        }
    }
    assert!(checked > 0, "{:?}", case.magnitudes);
}

/// The named effect's every parameter is checked against its truth (within 10 % or 3 SE).
fn assert_named(family: Family, effect: &str, params: usize) {
    let rec = run(&first_of(family));
    assert_explained(&rec);
    assert!(
        rec.kept.iter().any(|k| k.starts_with(effect)),
        "{}: kept {:?}",
        rec.name,
        rec.kept
    );
    assert_eq!(rec.values.len(), params, "{:?}", rec.values);
}

#[test]
fn a_soft_saturation_is_the_named_soft_limit() {
    assert_named(Family::SoftSaturation, "wheel_speed_soft_limit_rad_s", 1);
}

#[test]
fn a_hinge_is_the_named_knee_between_the_grids_points() {
    assert_named(Family::Hinge, "wheel_gain_knee", 2);
}

#[test]
fn a_gain_backwards_is_the_named_reverse_gain() {
    assert_named(Family::ReverseGain, "wheel_reverse_gain", 1);
}

#[test]
fn one_encoders_scale_is_that_encoders_not_its_wheels() {
    assert_named(Family::EncoderScale, "encoder_side_scale", 2);
}

#[test]
fn the_exact_turn_memory_replays_its_run_within_its_flag_where_steps_follow_each_other() {
    use drive_sim::calibration::{metrics, steps, ErrorSummary, KinematicFactory, ModelParams, StepSet};
    // The named effect at the generator's own values, on the benchmark's first turn-memory
    // case (τ 7.9 s): a replay of a step that follows its predecessor without a break knows
    // the load the loop has learnt, up to what earlier breaks left in a memory this long, and
    // is within the transient flag (3× the floor); without the effect it is far beyond. After
    // an operator's break (a re-orientation whose commands a DRIVE log does not hold), the
    // generator's loop has learnt on unlogged commands; that ratio is printed, not asserted:
    // it is what the model cannot know.
    let case = first_of(Family::TurnMemory);
    let exact = case
        .truth
        .exact
        .as_ref()
        .expect("the turn memory has a named effect");
    let (log, robot) = common::generator::drive_log_with(&case.name, case.spec(), case.extra, 90);
    let (terrain, _) = drive_sim::terrain::Terrain::resolve("asphalt").unwrap();
    let mut params = ModelParams::new(robot, terrain);
    params.robot.powertrain.time_constant_s = case.spec().lag_s;
    for (key, value) in &exact.params {
        params.effects.set(key, *value).unwrap();
    }
    let (slices, _) = steps::usable_step_slices(&log);
    let ids: Vec<u32> = slices.iter().map(|s| s.step).collect();
    let all = StepSet::new(&slices, &ids, log.meta.rate_hz).unwrap();
    let floor = metrics::NoiseFloor::estimate(&all.features).unwrap();
    let with = all.errors(&KinematicFactory, &params).unwrap();
    let without = all
        .errors(
            &KinematicFactory,
            &ModelParams::new(params.robot.clone(), params.terrain.clone()),
        )
        .unwrap();
    let period = 1.0 / log.meta.rate_hz;
    let after_break = |i: usize| {
        i == 0 || {
            let end = slices[i - 1]
                .samples
                .last()
                .map_or(f64::NEG_INFINITY, |s| s.stamp_s);
            slices[i].samples[0].stamp_s - end > 1.5 * period
        }
    };
    let ratio = |errors: &[metrics::StepErrors], want_break: bool| {
        let e: Vec<_> = (0..errors.len())
            .filter(|&i| after_break(i) == want_break)
            .map(|i| errors[i].clone())
            .collect();
        (
            e.len(),
            ErrorSummary::pool(&e, &floor).transient_wz_rad_s / floor.series[1],
        )
    };
    let (n_follow, follow) = ratio(&with, false);
    let (n_break, broken) = ratio(&with, true);
    let (_, follow_without) = ratio(&without, false);
    eprintln!(
        "{}: transient wz / floor: {follow:.2} on the {n_follow} steps that follow their predecessor ({follow_without:.2} without the effect), {broken:.2} on the {n_break} after a break",
        case.name
    );
    assert!(n_follow >= 30, "{n_follow} steps follow their predecessor");
    assert!(follow <= 3.0, "transient wz {follow:.2}× its floor");
    assert!(
        follow_without > 3.0,
        "without the effect: {follow_without:.2}× its floor"
    );
}
