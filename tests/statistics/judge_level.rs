//! The judge's level, measured: runs of the model itself in the real run's place, with seeds
//! neither its runs nor its references use, are rejected about as often as the test's level
//! says. CI holds one such run and one such half (`tests/long/judge.rs`); this counts several.

use crate::common;
use common::judging::{generator_and_model, judged_with, opts, STEPS};
use drive_sim::compare::judge::{JudgeOptions, DIFFERS};
use drive_sim::log::UseSteps;

/// Judges six runs of the model itself, each `run_steps` long and with its own seeds for the
/// twin's runs and references (so that the six judgements are independent), on the steps
/// `judged(k)` of the k-th; asserts that at most two are rejected. At level 0.1 a run is
/// rejected with probability 0.1 at most: 3 or more rejections of 6 has probability 0.016.
fn at_most_two_of_six_rejected(seeds: [u64; 6], run_steps: u32, judged: impl Fn(usize) -> UseSteps) {
    let (_, model) = generator_and_model(10.0, STEPS);
    let mut rejected = Vec::new();
    for (k, seed) in seeds.into_iter().enumerate() {
        let own = drive_sim::compare::tune::twin_run(&model, run_steps, seed).unwrap();
        let o = JudgeOptions {
            seed: 100 * k as u64,
            real_steps: judged(k),
            ..opts()
        };
        let null = judged_with(&own, &model, &o);
        assert_eq!(null.criteria[0].criterion, DIFFERS);
        assert_eq!(
            null.reference_run_steps, run_steps,
            "references as long as the run"
        );
        eprintln!("seed {seed} ({} steps): p {}", o.real_steps.as_str(), null.loss.p);
        if !null.indistinguishable {
            rejected.push(seed);
        }
    }
    eprintln!("rejected {} of {}: {rejected:?}", rejected.len(), seeds.len());
    assert!(rejected.len() <= 2, "rejected for seeds {rejected:?}");
}

/// The null case six times, every step judged.
#[test]
fn runs_of_the_model_itself_are_rejected_at_about_the_tests_level() {
    at_most_two_of_six_rejected([777, 778, 779, 780, 781, 782], STEPS, |_| UseSteps::All);
}

/// The same on one half of a run, as a twin's held-out judgement asks: the odd or even steps of
/// a run of the model itself (twice as long), in turn. The references are that half of runs as
/// long; drawn as runs as long as the half, whose steps follow one another, they mix their
/// commands differently from a run's every other step (the twin of `husky_2023` on the halves
/// of five of its own 201-step runs: three of ten told apart at 0.05, `docs/results/twins.md`).
#[test]
fn halves_of_runs_of_the_model_itself_are_rejected_at_about_the_tests_level() {
    at_most_two_of_six_rejected([787, 788, 789, 790, 791, 792], 2 * STEPS, |k| {
        if k % 2 == 0 {
            UseSteps::Even
        } else {
            UseSteps::Odd
        }
    });
}
