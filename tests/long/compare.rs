//! `compare` on the measured data: a log against itself and against its own split halves finds
//! no difference, against another terrain's log it finds one; the intervals of a tiny fixture
//! match a hand (brute-force) computation; logs of two robots are refused as bad input; two
//! runs of one exact model fail the wheel maps with the paper's kernel smoother and not with the
//! local-linear one.

use drive_sim::analysis::stats::quantile_sorted;
use drive_sim::compare::{analysis_of, compare, CompareOptions, Input, Pairing, TfSmoother};
use drive_sim::log::csv::read_measured_csv;
use drive_sim::log::DriveLog;
use std::path::Path;

use crate::common;

const DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data/measured");

fn log(name: &str) -> DriveLog {
    read_measured_csv(Path::new(DIR).join(format!("{name}.csv"))).unwrap()
}

fn input(l: &DriveLog) -> Input<'_> {
    Input { log: l, file: None }
}

#[test]
fn a_log_against_itself_and_its_halves_shows_no_difference() {
    let real = log("warthog_asphalt");
    let opts = CompareOptions::default();
    let r = compare(input(&real), &[input(&real)], &opts).unwrap();
    let c = &r.sims[0];
    assert_eq!(c.pairing, Pairing::TwoSample);
    assert!(c.verdict.reproduces, "{:#?}", c.verdict);
    assert!(c
        .metrics
        .iter()
        .all(|m| m.difference == 0.0 && m.difference_ci95.unwrap().contains(0.0)));
    assert!(c.transfer.iter().all(|t| t.rms == 0.0 && t.points > 0));
    // The loss `tune` minimises, carried by the comparison: nothing to pay against itself.
    assert_eq!(c.loss.as_ref().map(|l| l.total), Some(0.0), "{:?}", c.loss);
    // Every exchange of steps between two identical runs differs at least as much: p = 1.
    assert!(
        c.transfer.iter().all(|t| t.p_permutation == Some(1.0)),
        "{:#?}",
        c.transfer
    );
    assert!(c.verdict.tf_significant.is_empty());
    assert!(r.warnings.iter().any(|w| w.name == "time_not_recorded"));
    // The step scatter beside the verdict: the same on both sides.
    let sc = c.step_scatter.unwrap();
    assert_eq!(sc.real, sc.sim);
    assert!(!sc.differs && sc.offset_to_add_rad_s.is_none(), "{sc:?}");
    // The breakdown by curvature: every class of the run, no difference in any statistic.
    let classes = &c.curvature.classes;
    assert!(classes.len() >= 4, "{classes:#?}");
    assert_eq!(classes.iter().map(|k| k.steps.0).sum::<usize>(), c.steps_used.0);
    for k in classes {
        assert_eq!(k.steps.0, k.steps.1);
        for s in [&k.forward_ratio, &k.yaw_ratio, &k.rho] {
            assert!(s.difference == 0.0 || s.real.is_nan(), "{}: {s:?}", k.class);
        }
    }

    // The run against its own halves (alternate steps): each half is a sample of the same
    // robot on the same ground. Medians and transfer functions agree. (The area of T does
    // not: the hull of 50 steps is smaller than that of 100, by 7-8 points here; T/U areas
    // compare runs of similar length.)
    let odd = real.with_steps("odd", |s| s % 2 == 1);
    let even = real.with_steps("even", |s| s % 2 == 0);
    let r = compare(input(&real), &[input(&odd), input(&even)], &opts).unwrap();
    for c in &r.sims {
        assert!(
            c.verdict.significant.is_empty(),
            "{}: {:#?}",
            c.sim.name,
            c.metrics
        );
        // The areas are judged by their tolerance, not tested: a resampled hull is the hull of
        // a subset of the steps, so the bootstrap of an area never exceeds the run's own area.
        for m in c.metrics.iter().filter(|m| m.metric.starts_with("t_area")) {
            assert!(!m.significant && m.p_holm.is_nan(), "{m:#?}");
            for (v, ci) in [(m.real, m.real_ci95), (m.sim, m.sim_ci95)] {
                assert!(ci.unwrap().upper <= v + 1e-9, "{m:#?}");
            }
        }
        assert!(
            c.verdict.tf_beyond_yardstick.is_empty(),
            "{}: {:#?}",
            c.sim.name,
            c.transfer
        );
        assert!(c.transfer.iter().all(|t| t.points > 0));
    }
    // One half against the other (same length): no metric differs. The yardstick is then the
    // split of a half (25-step quarters), itself noisy: the ratios stay below 2 (1.56 at most
    // measured, lateral slip).
    let r = compare(input(&odd), &[input(&even)], &opts).unwrap();
    let c = &r.sims[0];
    assert!(c.verdict.significant.is_empty(), "{:#?}", c.metrics);
    // The maps' permutation test (the halves' steps exchanged) finds no difference either.
    assert!(c.verdict.tf_significant.is_empty(), "{:#?}", c.transfer);
    assert!(
        c.transfer.iter().all(|t| t.points > 0 && t.ratio < 2.0),
        "{:#?}",
        c.transfer
    );
}

#[test]
fn another_terrain_differs() {
    let asphalt = log("warthog_asphalt");
    let ice = log("warthog_ice");
    let r = compare(input(&asphalt), &[input(&ice)], &CompareOptions::default()).unwrap();
    let c = &r.sims[0];
    assert!(!c.verdict.reproduces);
    assert!(
        c.verdict.significant.iter().any(|m| m == "median_rho"),
        "{:#?}",
        c.verdict
    );
    assert!(!c.verdict.tf_beyond_yardstick.is_empty(), "{:#?}", c.transfer);
    // Failing verdicts cost: at least one term above 1.
    let loss = c.loss.as_ref().unwrap();
    assert!(
        loss.terms.iter().any(|t| t.value.is_some_and(|v| v.abs() > 1.0)),
        "{loss:?}"
    );
    assert!(loss.total > 1.0, "{loss:?}");
    // Ice's maps against asphalt's are beyond any exchange of their steps (the smallest p a
    // test of 200 permutations gives, 1/201, Holm-adjusted over five maps).
    assert!(c.verdict.tf_significant.len() >= 3, "{:#?}", c.transfer);
    // On ice the body falls behind its wheels even driving straight (0.89 of their speed
    // against 0.98 on asphalt): the breakdown says so where the maps only say "differs".
    let straight = c
        .curvature
        .classes
        .iter()
        .find(|k| k.class == "straight")
        .unwrap();
    let f = &straight.forward_ratio;
    assert!(
        f.difference < -0.05 && f.difference_ci95.unwrap().upper < 0.0,
        "{f:?}"
    );
}

#[test]
fn the_terminal_names_the_clearest_body_against_wheels_difference() {
    let asphalt = log("warthog_asphalt");
    let ice = log("warthog_ice");
    let opts = diagnostic_opts();
    let text = |sim: &DriveLog| {
        let r = compare(input(&asphalt), &[input(sim)], &opts).unwrap();
        drive_sim::compare::write::verdict_text(&r)
    };
    let other = text(&ice);
    assert!(
        other.contains("by curvature, largest clear difference"),
        "{other}"
    );
    // Against itself no interval excludes a zero difference: nothing to name.
    let same = text(&asphalt);
    assert!(!same.contains("by curvature"), "{same}");
}

#[test]
fn the_report_draws_the_body_and_the_wheel_maps() {
    let asphalt = log("warthog_asphalt");
    let gravel = log("warthog_gravel");
    let r = compare(input(&asphalt), &[input(&gravel)], &CompareOptions::default()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let u = asphalt.meta.nominal.command_space().polygon_body();
    let paths = drive_sim::compare::write::write_comparison(&r, &u, dir.path()).unwrap();
    for f in ["tf_difference_0.png", "tf_difference_wheels_0.png", "report.html"] {
        assert!(paths.iter().any(|p| p.ends_with(f)), "{f} not in {paths:?}");
    }
    let html = std::fs::read_to_string(dir.path().join("report.html")).unwrap();
    assert!(html.contains("by commanded curvature"), "no curvature table");
}

#[test]
fn another_robot_is_refused_as_bad_input() {
    let w = log("warthog_asphalt");
    let h = log("husky_2023");
    let e = compare(input(&w), &[input(&h)], &CompareOptions::default()).unwrap_err();
    assert!(e.is_bad_input(), "{e}");
    assert!(
        e.to_string().contains("husky") && e.to_string().contains("warthog"),
        "{e}"
    );
}

/// Median of three values.
fn med3(mut v: [f64; 3]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[1]
}

#[test]
fn intervals_of_a_three_step_fixture_match_a_hand_computation() {
    let full = log("warthog_asphalt");
    let steps = full.steps();
    let (a, b) = (&steps[..3], &steps[3..6]);
    let real = full.with_steps("a", |s| a.contains(&s));
    let sim = full.with_steps("b", |s| b.contains(&s));
    let rho = |l: &DriveLog| -> Vec<f64> {
        analysis_of(l)
            .unwrap()
            .steps
            .iter()
            .map(|s| s.steady_rho.rho)
            .collect()
    };
    let (rr, rs) = (rho(&real), rho(&sim));
    assert_eq!((rr.len(), rs.len()), (3, 3));
    // Every resample of three steps (27) in each run, every pair of them (729): the exact
    // two-sample bootstrap of the difference of medians.
    let resamples = |v: &[f64]| -> Vec<f64> {
        let mut out = Vec::new();
        for i in 0..3 {
            for j in 0..3 {
                for k in 0..3 {
                    out.push(med3([v[i], v[j], v[k]]));
                }
            }
        }
        out
    };
    let (mr, ms) = (resamples(&rr), resamples(&rs));
    let mut diffs: Vec<f64> = ms.iter().flat_map(|s| mr.iter().map(move |r| s - r)).collect();
    diffs.sort_by(f64::total_cmp);
    let (lo, hi) = (quantile_sorted(&diffs, 0.025), quantile_sorted(&diffs, 0.975));
    let below = diffs.iter().filter(|&&d| d <= 0.0).count() as f64 / 729.0;
    let above = diffs.iter().filter(|&&d| d >= 0.0).count() as f64 / 729.0;
    let p = (2.0 * below.min(above)).min(1.0);

    let r = compare(input(&real), &[input(&sim)], &CompareOptions::default()).unwrap();
    let m = &r.sims[0].metrics[0];
    assert_eq!(m.metric, "median_rho");
    let ci = m.difference_ci95.unwrap();
    assert!(
        (ci.lower - lo).abs() < 1e-12 && (ci.upper - hi).abs() < 1e-12,
        "{ci:?} vs [{lo}, {hi}]"
    );
    assert!((m.p - p).abs() < 1e-12, "{} vs {p}", m.p);
    assert!((m.difference - (med3([rs[0], rs[1], rs[2]]) - med3([rr[0], rr[1], rr[2]]))).abs() < 1e-12);
    // Too few steps for a reliable interval: said by name, for both runs.
    assert_eq!(
        r.warnings.iter().filter(|w| w.name == "too_few_steps").count(),
        2,
        "{:#?}",
        r.warnings
    );
}

/// Two runs of the declared Warthog on asphalt (seeds 0 and 1, 100 steps), an exact model and
/// its "robot": with the paper's kernel-weighted mean the left wheel's map is 2.5× its
/// yardstick, because beyond the declared 12.7 rad/s limit the slip is a ramp and the mean's
/// bias there depends on which commands each run drew; with the local-linear smoother, which
/// has no bias on a ramp, every map is within 1.5× (README, "Why the wheel maps fail an exact
/// model"; measured 2.51 → 1.44 for the left wheel).
#[test]
fn an_exact_model_passes_the_wheel_maps_with_the_local_linear_smoother() {
    use drive_sim::harness::simulate::simulate;
    use drive_sim::robot::Robot;
    use drive_sim::sim::SensorNoise;
    use drive_sim::terrain::Terrain;
    let (robot, _) = Robot::resolve("warthog").unwrap();
    let (terrain, _) = Terrain::resolve("asphalt").unwrap();
    let run = |seed| {
        simulate(
            &robot,
            &terrain,
            "uniform-wheel",
            100,
            seed,
            SensorNoise::typical(),
        )
        .unwrap()
        .log
    };
    let (a, b) = (run(0), run(1));
    let ratios = |smoother| {
        let opts = CompareOptions {
            tf_permutations: 0,
            tf_smoother: smoother,
            ..CompareOptions::default()
        };
        let r = compare(input(&a), &[input(&b)], &opts).unwrap();
        r.sims[0].transfer.iter().map(|t| t.ratio).collect::<Vec<_>>()
    };
    let kernel = ratios(TfSmoother::Kernel);
    let local = ratios(TfSmoother::LocalLinear);
    eprintln!("map RMS / yardstick (vx, vy, wz, left, right): kernel {kernel:.2?}, local-linear {local:.2?}");
    assert!(kernel[3] > 1.5, "{kernel:?}");
    assert!(local.iter().all(|r| *r <= 1.5), "{local:?}");
}

/// `compare`'s options for the diagnostics beside the verdict (the step scatter, the turn
/// memory, the breakdown by curvature): without the maps' permutation test, which plays no part
/// in them (as in `tune` and `judge`) and was about a third of each comparison's time.
fn diagnostic_opts() -> CompareOptions {
    CompareOptions {
        tf_permutations: 0,
        ..CompareOptions::default()
    }
}

/// The step scatter beside the verdict, on an independent generator (`tests/common/generator.rs`)
/// whose wheels settle off their targets by a new offset each step (sd 0.6 rad/s, its own
/// equation and random stream): against the simulated Warthog without one, `compare` says the
/// simulated run lacks it and how much to add; the model with `wheel_speed_scatter` at that
/// value no longer differs; and the generator without offsets is not flagged (the null case).
#[test]
fn the_step_scatter_a_model_lacks_is_measured_and_added() {
    use common::generator::{drive_log_with, TestRobotSpec, Unmodelled};
    use drive_sim::calibration::twin;
    use drive_sim::terrain::Terrain;
    let generator = |offset: f64| {
        let extra = Unmodelled {
            step_offset_rad_s: offset,
            centripetal_s: -0.20,
            pose_yaw_noise_rad: 0.01,
            ..Unmodelled::default()
        };
        drive_log_with("generator", TestRobotSpec::warthog_on_asphalt(5), extra, 150)
    };
    let (real, robot) = generator(0.6);
    let (terrain, _) = Terrain::resolve("asphalt").unwrap();
    let mut model = twin::lift_effects(&robot, &terrain).unwrap();
    let scatter_of = |real: &DriveLog, model: &drive_sim::calibration::ModelParams| {
        let sim = drive_sim::compare::tune::twin_run(model, 150, 11).unwrap();
        let r = compare(input(real), &[input(&sim)], &diagnostic_opts()).unwrap();
        let d = r.sims[0].step_scatter.unwrap();
        eprintln!("{}", d.line());
        d
    };
    let without = scatter_of(&real, &model);
    assert!(without.differs, "{without:?}");
    let add = without.offset_to_add_rad_s.unwrap();
    assert!((0.4..0.85).contains(&add), "offset to add {add} for a true 0.6");
    model.effects.set("wheel_speed_scatter_rad_s", add).unwrap();
    let with = scatter_of(&real, &model);
    assert!(!with.differs, "{with:?}");
    // The null case: a generator without offsets, the model without scatter.
    let (plain, _) = generator(0.0);
    model.effects.set("wheel_speed_scatter_rad_s", 0.0).unwrap();
    let null = scatter_of(&plain, &model);
    assert!(!null.differs, "{null:?}");
}

/// The turn memory (`compare`'s diagnostic): a generator whose speed loop remembers the last
/// turn (its own equation of the commands, not the simulator's torque-driven integral) against
/// the simulated Warthog without one: `compare` says the simulated loop forgets; the simulator
/// with `droop_recovery` has a memory of its own (interval above zero); and the generator without
/// memory is not flagged against the model without it (the null case).
#[test]
fn the_turn_memory_a_model_lacks_is_measured() {
    use common::generator::{drive_log_with, TestRobotSpec, Unmodelled};
    use drive_sim::calibration::twin;
    use drive_sim::terrain::Terrain;
    let generator = |memory_rad_s: f64| {
        let extra = Unmodelled {
            turn_memory_rad_s: memory_rad_s,
            turn_memory_s: 3.0,
            pose_yaw_noise_rad: 0.01,
            ..Unmodelled::default()
        };
        drive_log_with("generator", TestRobotSpec::warthog_on_asphalt(5), extra, 150).0
    };
    let (terrain, _) = Terrain::resolve("asphalt").unwrap();
    let (robot, _) = drive_sim::robot::Robot::resolve("warthog").unwrap();
    let mut model = twin::lift_effects(&robot, &terrain).unwrap();
    let memory_of = |real: &DriveLog, model: &drive_sim::calibration::ModelParams| {
        let sim = drive_sim::compare::tune::twin_run(model, 150, 11).unwrap();
        let r = compare(input(real), &[input(&sim)], &diagnostic_opts()).unwrap();
        let d = r.sims[0].turn_memory.unwrap();
        eprintln!("{}", d.line());
        d
    };
    let remembering = generator(2.0);
    let without = memory_of(&remembering, &model);
    assert!(
        without.differs && without.line().contains("forgets"),
        "{without:?}"
    );
    let real = without.real.reversed_minus_same.unwrap();
    assert!(real > 0.1, "the generator's memory is measured: {real}");
    model.effects.set("speed_droop_rad_s_per_knm", 3.0).unwrap();
    model.effects.set("droop_recovery_s", 2.0).unwrap();
    let with = memory_of(&remembering, &model);
    let sim = with.sim.ci95.unwrap();
    assert!(sim.lower > 0.0, "the simulator's integral remembers: {with:?}");
    // The null case: a generator without memory, the model without it.
    model.effects.set("droop_recovery_s", 0.0).unwrap();
    model.effects.set("speed_droop_rad_s_per_knm", 0.0).unwrap();
    let null = memory_of(&generator(0.0), &model);
    assert!(!null.differs, "{null:?}");
    // Measured as nothing: well within the tolerance (an exact interval may still miss zero by
    // a hair, as 5 % of 95 % intervals do).
    assert!(null.real.reversed_minus_same.unwrap().abs() < 0.02, "{null:?}");
}
