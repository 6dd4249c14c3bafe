//! The judge's level, measured: runs of the model itself in the real run's place, with seeds
//! neither its runs nor its references use, are rejected about as often as the test's level
//! says. CI holds one such run (`tests/long/judge.rs`); this counts several.

use crate::common;
use common::judging::{generator_and_model, judged_with, opts, STEPS};
use drive_sim::compare::judge::{JudgeOptions, DIFFERS};
use drive_sim::log::UseSteps;

/// The null case six times, each with its own seeds for the twin's runs and references, so that
/// the six judgements are independent. At level 0.1 a run is rejected with probability 0.1 at
/// most: 3 or more rejections of 6 has probability 0.016.
#[test]
fn runs_of_the_model_itself_are_rejected_at_about_the_tests_level() {
    let (_, model) = generator_and_model(10.0, STEPS);
    let mut rejected = Vec::new();
    let seeds = [777, 778, 779, 780, 781, 782];
    for (k, seed) in seeds.into_iter().enumerate() {
        let own = drive_sim::compare::tune::twin_run(&model, STEPS, seed).unwrap();
        let o = JudgeOptions {
            seed: 100 * k as u64,
            ..opts()
        };
        let null = judged_with(&own, &model, &o);
        assert_eq!(null.criteria[0].criterion, DIFFERS);
        eprintln!("seed {seed}: p {}", null.loss.p);
        if !null.indistinguishable {
            rejected.push(seed);
        }
    }
    eprintln!("rejected {} of {}: {rejected:?}", rejected.len(), seeds.len());
    assert!(rejected.len() <= 2, "rejected for seeds {rejected:?}");
}

/// The same on one half of a run, as a twin's held-out judgement asks: the odd or even steps of
/// a run of the model itself (twice as long), six times. The references are that half of runs
/// as long; drawn as runs as long as the half, whose steps follow one another, they mix their
/// commands differently from a run's every other step (the twin of `husky_2023` on the even
/// steps of its own 201-step runs: two of three told apart, `docs/results/twins.md`).
#[test]
fn halves_of_runs_of_the_model_itself_are_rejected_at_about_the_tests_level() {
    let (_, model) = generator_and_model(10.0, STEPS);
    let mut rejected = Vec::new();
    let seeds = [787, 788, 789, 790, 791, 792];
    for (k, seed) in seeds.into_iter().enumerate() {
        let own = drive_sim::compare::tune::twin_run(&model, 2 * STEPS, seed).unwrap();
        let o = JudgeOptions {
            seed: 100 * k as u64,
            real_steps: if k % 2 == 0 { UseSteps::Even } else { UseSteps::Odd },
            ..opts()
        };
        let null = judged_with(&own, &model, &o);
        assert_eq!(null.reference_run_steps, 2 * STEPS);
        eprintln!("seed {seed} ({:?} steps): p {}", o.real_steps, null.loss.p);
        if !null.indistinguishable {
            rejected.push(seed);
        }
    }
    eprintln!("rejected {} of {}: {rejected:?}", rejected.len(), seeds.len());
    assert!(rejected.len() <= 2, "rejected for seeds {rejected:?}");
}
