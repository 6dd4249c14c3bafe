//! Old and new calibration side by side, in one run, on the measured datasets: the same split,
//! the same stages, Nelder–Mead (the first calibration's optimizer) against
//! Levenberg–Marquardt on the score. Prints each one's test score, wall time and convergence,
//! and the time ratio.
//!
//! `cargo bench --bench calibration` runs the kinematic model on the four datasets; with
//! `CALIBRATION_BENCH_SIM=warthog_gravel` (comma-separated) it also runs the simulator on those.

use drive_sim::calibration::{
    calibrate_timed, models_for_log, CalibrationOptions, KinematicFactory, Optimizer, PlantFactory,
    SimFactory,
};
use drive_sim::log::csv::read_measured_csv;
use std::time::Instant;

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/measured");

fn run(name: &str, factory: &dyn PlantFactory, optimizer: Optimizer) -> (f64, f64, f64, bool) {
    let log = read_measured_csv(format!("{DATA}/{name}.csv")).expect("measured dataset");
    let (robot, terrain, _) = models_for_log(&log).expect("models");
    let mut opts = CalibrationOptions::default();
    opts.fit.optimizer = optimizer;
    // The optimizers are compared on the calibration itself: discovery, which runs after it
    // and fits its terms with the same optimizer, would multiply Nelder–Mead's cost by its
    // many-coefficient equations and say nothing more about the two.
    opts.discover = false;
    let t0 = Instant::now();
    let (r, _) = calibrate_timed(&log, &robot, &terrain, factory, &opts, &|_| {}).expect("calibration");
    (
        r.before.score,
        r.after.score,
        t0.elapsed().as_secs_f64(),
        r.status.converged,
    )
}

fn main() {
    // `cargo bench` passes `--bench`; nothing to parse.
    let sim: Vec<String> = std::env::var("CALIBRATION_BENCH_SIM")
        .map(|s| s.split(',').map(String::from).collect())
        .unwrap_or_default();
    let mut cases: Vec<(String, Box<dyn PlantFactory>)> =
        ["warthog_asphalt", "warthog_gravel", "warthog_ice", "husky_2023"]
            .iter()
            .map(|n| (n.to_string(), Box::new(KinematicFactory) as Box<dyn PlantFactory>))
            .collect();
    for n in sim {
        cases.push((n, Box::new(SimFactory::default())));
    }
    println!(
        "{:<16} {:<10} {:>8} | {:>10} {:>8} {:>5} | {:>10} {:>8} {:>5} | {:>7}",
        "dataset", "model", "before", "NM after", "NM s", "conv", "LM after", "LM s", "conv", "NM/LM"
    );
    for (name, f) in &cases {
        let (before, nm_after, nm_s, nm_conv) = run(name, f.as_ref(), Optimizer::NelderMead);
        let (_, lm_after, lm_s, lm_conv) = run(name, f.as_ref(), Optimizer::LevenbergMarquardt);
        println!(
            "{:<16} {:<10} {:>8.2} | {:>10.3} {:>8.1} {:>5} | {:>10.3} {:>8.1} {:>5} | {:>6.1}x",
            name,
            f.name(),
            before,
            nm_after,
            nm_s,
            nm_conv,
            lm_after,
            lm_s,
            lm_conv,
            nm_s / lm_s
        );
    }
}
