//! One case of each family that discovery explains today, from the randomized benchmark
//! (`benches/discovery_benchmark.rs`: the independent generator of `tests/common/generator.rs`
//! with effects drawn at random, `tests/common/random_cases.rs`), calibrated with the kinematic
//! model and discovery as the benchmark does (the catalogue without its structural effects):
//! - every channel ends within its flag on the test steps (2× its floor steady, 3× transient
//!   and pose), and the structure is recovered (the exact catalogue effect, its value within
//!   10 % or 3 standard errors; else a discovered term where the effect acts and nowhere else);
//! - the dead time alone is picked within 10 %, and nothing else is kept;
//! - noise alone proposes nothing.
//!
//! The cases are the first of each family in the benchmark's draw (`--cases 30 --nulls 10
//! --seed 1`). The families discovery does not explain yet (gain curves, the soft saturation,
//! the deadband and the hinge, the reverse gain, the body lag, the turn memory, the backlash,
//! the yaw damping's structure, one encoder's scale, dropouts and quantization, the pose
//! latency) are measured by the benchmark, whose table is in docs/results/discovery.md.

#[allow(dead_code)] // the cases and scores this file does not use
mod bench_cases;
mod common;
use bench_cases::benchmark::{calibrate_case, score, Record};
use bench_cases::random_cases::{cases, Case, Family};
use common::CATALOGUE_WITHOUT_STRUCTURAL;

/// The benchmark's draw: its first case of `family`.
fn first_of(family: Family) -> Case {
    cases(&Family::EFFECTS, 30, 10, 1)
        .into_iter()
        .find(|c| c.family == family)
        .unwrap_or_else(|| panic!("no {family:?} case in the benchmark's draw"))
}

/// The case calibrated and scored as the benchmark scores it (90 steps).
fn run(case: &Case) -> Record {
    let candidates = CATALOGUE_WITHOUT_STRUCTURAL
        .iter()
        .map(|s| s.to_string())
        .collect();
    let t0 = std::time::Instant::now();
    let r = calibrate_case(case, 90, Some(candidates)).unwrap();
    let rec = score(case, &r, t0.elapsed().as_secs_f64());
    eprintln!(
        "{}: kept {:?}; worst {} {:.2} (flag {}); within flags {}, structure {}; {:.1} s",
        rec.name,
        rec.kept,
        rec.worst_channel,
        rec.worst_ratio,
        rec.worst_threshold,
        rec.within_flags,
        rec.structure,
        rec.seconds
    );
    rec
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
    assert_explained(&run(&first_of(Family::CrossCoupling)));
}

#[test]
fn a_centripetal_slip_is_the_catalogue_slip() {
    assert_explained(&run(&first_of(Family::Centripetal)));
}

#[test]
fn a_gyro_fault_is_the_catalogue_fault() {
    assert_explained(&run(&first_of(Family::ImuFault)));
}
