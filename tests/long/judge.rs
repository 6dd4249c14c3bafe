//! Judging a twin (`drive_sim::compare::judge`): a Monte Carlo test of whether `compare`
//! can tell a real run from the twin's own runs, on cases whose answer is known:
//! - the null case: the "real" run is a run of the model itself, with a seed neither its runs
//!   nor its references use: indistinguishable (the test's level over several such runs is
//!   measured in the statistics tier, `tests/statistics/judge_level.rs`); the same on the even
//!   steps of such a run, the references drawn as that half was;
//! - an independent generator (`tests/common/generator.rs`, not the project's plants) whose
//!   motors clip at 10 rad/s, against the simulated Warthog without any limit: distinguishable,
//!   the real run more extreme than every reference on the loss (which decides), every run of
//!   the twin called "differs";
//! - a run of the model itself whose commands turn right nine times in ten: not told apart,
//!   the twin's runs drawn in its quadrants.

use crate::common;
use common::judging::{generator_and_model, judged, judged_with, opts, STEPS};
use drive_sim::calibration::twin;
use drive_sim::compare::judge::{judge, JudgeOptions, JudgeRequest, DIFFERS};
use drive_sim::log::UseSteps;
use drive_sim::terrain::Terrain;

/// The null case: a run of the model itself (a seed neither its runs nor its references use)
/// in the real run's place is not told apart. One seed here; the test's level over several
/// (`tests/statistics/judge_level.rs`) is a measurement of the statistics tier.
#[test]
fn a_run_of_the_model_itself_is_not_told_apart() {
    let (_, model) = generator_and_model(10.0, STEPS);
    let own = drive_sim::compare::tune::twin_run(&model, STEPS, 777).unwrap();
    let null = judged(&own, &model);
    assert_eq!(null.criteria[0].criterion, DIFFERS);
    assert_eq!(null.references.len(), 9);
    assert_eq!(null.sim_seeds, vec![0, 1, 2, 3]);
    // Every reference saw the same runs: one score per run each.
    assert!(null.references.iter().all(|r| r.runs.len() == 4));
    assert!(null.indistinguishable, "p {}", null.loss.p);
}

/// The null case on one half of a run: the even steps of a run of the model itself. Each
/// reference is drawn the same way, the even steps of a run as long (not a run as long as the
/// half, whose steps follow one another: `ReferenceRuns`), and the half is not told apart.
#[test]
fn the_even_steps_of_a_run_of_the_model_itself_are_not_told_apart() {
    let (_, model) = generator_and_model(10.0, STEPS);
    let own = drive_sim::compare::tune::twin_run(&model, 2 * STEPS, 778).unwrap();
    let o = JudgeOptions {
        real_steps: UseSteps::Even,
        ..opts()
    };
    let null = judged_with(&own, &model, &o);
    assert_eq!(
        null.reference_run_steps,
        2 * STEPS,
        "references as long as the real run"
    );
    assert_eq!(null.reference_steps, UseSteps::Even);
    assert_eq!(null.steps_per_run as usize, null.real_steps_analysed);
    // Each reference holds the half of its run: about as many steps as the judged half.
    for r in &null.references {
        assert!(
            r.steps.abs_diff(null.real_steps_analysed) <= 3,
            "{} against {}",
            r.steps,
            null.real_steps_analysed
        );
    }
    assert!(null.indistinguishable, "p {}", null.loss.p);
}

/// A run of the model itself that drew nine right turns in ten is not told apart: the judge's
/// runs and references draw in the quadrants of its commands (forward or backward, turning
/// left or right), step by step. `warthog_asphalt` drew 62 right turns in 98 steps, a fair coin's two-sided p of 0.011 under the paper's uniform draws; a skid-steering
/// robot's yaw slip changes sign with the turn, so its median is the right turns'. That the mix
/// matters here too: against a run of the uniform draws, compare finds the lopsided run's
/// median yaw slip beyond its threshold.
#[test]
fn a_run_of_the_model_itself_with_a_lopsided_turn_mix_is_not_told_apart() {
    use drive_sim::compare::tune::{twin_run, twin_run_matched};
    use drive_sim::compare::{compare, CompareOptions, Input};
    use drive_sim::kinematics::WheelSpeeds;
    let (_, model) = generator_and_model(10.0, STEPS);
    // Right turns (the left wheel faster, forward and backward), and one left turn in ten.
    let like: Vec<WheelSpeeds> = (0..STEPS)
        .map(|i| match i % 10 {
            0 => WheelSpeeds::new(1.0, 2.0),
            k if k % 2 == 1 => WheelSpeeds::new(2.0, 1.0),
            _ => WheelSpeeds::new(-1.0, -2.0),
        })
        .collect();
    let lopsided = twin_run_matched(&model, &like, STEPS, 779).unwrap();
    let held = lopsided.held_commands();
    assert_eq!(held.len(), STEPS as usize);
    for (i, (c, l)) in held.iter().zip(&like).enumerate() {
        assert_eq!(c.quadrant(), l.quadrant(), "step {i}: {c:?}");
    }
    let uniform = twin_run(&model, STEPS, 780).unwrap();
    let c = compare(
        Input {
            log: &lopsided,
            file: None,
        },
        &[Input {
            log: &uniform,
            file: None,
        }],
        &CompareOptions::default(),
    )
    .unwrap();
    assert!(
        c.warnings.iter().any(|w| w.name == "lopsided_draw"),
        "compare warns of the draw: {:?}",
        c.warnings
    );
    let yaw = c.sims[0].loss.as_ref().unwrap().term("median_slip_wz").unwrap();
    eprintln!("median yaw slip's term against the uniform draws: {yaw:.2}");
    assert!(yaw.abs() > 1.0, "{yaw}");
    let null = judged(&lopsided, &model);
    assert!(null.indistinguishable, "p {}", null.loss.p);
}

#[test]
fn a_robot_whose_motors_clip_is_told_apart_from_a_model_without_a_limit() {
    let (generator, model) = generator_and_model(10.0, 100);
    let j = judged(&generator, &model);
    assert!(!j.indistinguishable, "{:?}", j.loss);
    assert_eq!(j.real.fails[0], 4, "every run differs: {:?}", j.real.runs);
    // The count of runs called "differs" has little power where the twin's runs already fail
    // one another often (a reference may tie with the real run's four): the loss decides, the
    // real run beyond every reference.
    assert!((j.loss.p - 0.1).abs() < 1e-12, "{:?}", j.loss);
    // The loss term by term: each candidate's terms add up to its mean loss (every run forms
    // every term here), and the term on which the real run is farthest lies beyond every
    // reference, as the loss does.
    for c in std::iter::once(&j.real).chain(&j.references) {
        let sum: f64 = c.term_means.iter().filter_map(|t| t.mean_square).sum();
        assert!(
            (sum - c.mean_loss).abs() < 1e-9 * c.mean_loss.max(1.0),
            "{sum} against {}",
            c.mean_loss
        );
    }
    let worst = j
        .loss
        .terms
        .iter()
        .filter(|t| t.real.is_some())
        .max_by(|a, b| a.real.unwrap().total_cmp(&b.real.unwrap()))
        .unwrap();
    assert!((worst.p - 0.1).abs() < 1e-12, "{:?}", j.loss.terms);
    // Same seeds, same judgement.
    assert_eq!(judged(&generator, &model), j);
}

#[test]
fn bad_options_and_a_log_of_another_robot_are_refused_before_any_run() {
    let (generator, model) = generator_and_model(10.0, STEPS);
    let bad = JudgeOptions {
        references: 2,
        ..opts()
    };
    let e = judge(
        &JudgeRequest {
            real: &generator,
            model: &model,
            opts: &bad,
        },
        &|_| panic!("no run should start"),
    )
    .unwrap_err();
    assert!(e.to_string().contains("--references"), "{e}");
    let (husky, _) = drive_sim::robot::Robot::resolve("husky").unwrap();
    let (terrain, _) = Terrain::resolve("asphalt").unwrap();
    let other = twin::lift_effects(&husky, &terrain).unwrap();
    let e = judge(
        &JudgeRequest {
            real: &generator,
            model: &other,
            opts: &opts(),
        },
        &|_| panic!("no run should start"),
    )
    .unwrap_err();
    assert!(e.to_string().contains("robot"), "{e}");
}

/// `drive-sim judge` on a measured run's even steps, small: the table first on stdout, and
/// `judge.json` (its decision and provenance), `judge.md` and the figure written.
#[test]
fn the_command_prints_the_table_and_writes_its_files() {
    let dir = tempfile::tempdir().unwrap();
    let log = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../shared/data/measured/warthog_gravel.csv"
    );
    let out = dir.path().join("j");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_drive-sim"))
        .args([
            "judge",
            log,
            "--real-steps",
            "even",
            "--sims",
            "2",
            "--references",
            "4",
            // 4 references reach p = 0.2 at best: the level must allow it.
            "--alpha",
            "0.2",
            "--resamples",
            "100",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        stdout.starts_with("warthog_gravel: the twin's 2 runs ("),
        "{stdout}"
    );
    // The references are the even steps of runs as long as the measured run.
    assert!(
        stdout.contains("the even steps of 4 runs of its own as long as the real run"),
        "{stdout}"
    );
    assert!(stdout.contains("| differs (the verdict) |"), "{stdout}");
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("judge.json")).unwrap()).unwrap();
    assert_eq!(j["references"].as_array().unwrap().len(), 4);
    assert_eq!(j["options"]["real_steps"], "even");
    assert_eq!(j["reference_steps"], "even");
    assert!(j["indistinguishable"].is_boolean());
    assert!(j["provenance"].is_object(), "{j}");
    for f in ["judge.md", "judge_rates.svg", "judge_rates.png"] {
        assert!(out.join(f).metadata().unwrap().len() > 0, "{f}");
    }
}

/// The judge inverted into a set for one parameter, where the answer is known: the "real" run
/// is a run of the model itself with its wheel-speed limit at 10 rad/s (a seed neither its runs
/// nor its references use), so that the true value lies in the model family (the independent
/// generator does not match the simulator closely enough for any value to be the truth: its
/// clip at 10 rad/s with the right limit still gives p 0.1 above). The set holds 10, and both
/// ends are bounded inside the box: a limit at a third of the largest command clips every
/// step, one at the largest command clips none.
#[test]
fn the_inverted_judge_gives_a_set_that_holds_the_true_limit() {
    use drive_sim::compare::judge::interval::{interval_specs, intervals, IntervalOptions, IntervalRequest};
    let (_, mut model) = generator_and_model(10.0, STEPS);
    model.effects.set("wheel_speed_saturation_rad_s", 10.0).unwrap();
    let real = drive_sim::compare::tune::twin_run(&model, STEPS, 777).unwrap();
    let generator = &real;
    let o = opts();
    let specs = interval_specs(&["wheel_speed_saturation_rad_s".into()], &[], &model, generator).unwrap();
    let request = JudgeRequest {
        real: generator,
        model: &model,
        opts: &o,
    };
    let centre = judge(&request, &|_| {}).unwrap();
    assert!(
        centre.indistinguishable,
        "the right limit is rejected: {:?}",
        centre.loss
    );
    let walk = IntervalOptions {
        refine: 1,
        max_per_side: 4,
    };
    let sets = intervals(
        &IntervalRequest {
            judge: request,
            centre: &centre,
            specs: &specs,
            opts: &walk,
        },
        &|event| eprintln!("{event}"),
    )
    .unwrap();
    let set = &sets[0];
    eprintln!("{}", serde_json::to_string_pretty(set).unwrap());
    let (lo, hi) = (set.lower.unwrap(), set.upper.unwrap());
    assert!(lo.value <= 10.0 && 10.0 <= hi.value, "{lo:?} {hi:?}");
    let rejected_below = lo.rejected_at.expect("bounded below");
    let rejected_above = hi.rejected_at.expect("bounded above");
    assert!(rejected_below > set.box_lower && rejected_above < set.box_upper);
    assert!(
        hi.value - lo.value < 0.6 * (set.box_upper - set.box_lower),
        "{lo:?} {hi:?}"
    );
    // At most 1 + 2 x 4 judgements.
    assert!(set.evaluations.len() <= 9, "{}", set.evaluations.len());
}
