//! The sampler comparison behind `drive-sim samplers`: every registered sampling strategy on the
//! same budget, with the real simulator, against the open-loop ground truth of the transfer
//! functions; its table, figures and report.

use super::simulate::{
    analysis_params_without_smoother, kernel_for, simulate, simulator_truth, truth_grid, unknown_sampler,
};
use crate::error::{Error, Result};
use crate::ground_truth::{transfer_error, TransferError, TruthField};
use drive_sim_analysis::analyze;
use drive_sim_analysis::smoother::KernelCovariance;
use drive_sim_analysis::stats::mean_sd;
use drive_sim_model::robot::Robot;
use drive_sim_model::terrain::Terrain;
use drive_sim_protocol::sampler::SAMPLERS;
use drive_sim_protocol::samplers::metrics::{
    acceleration_coverage, command_coverage, log_commanded_energy_j_s, step_commands, time_use,
};
use drive_sim_report::{
    box_plots, line_bands, AxisLabel, BandPoint, BandSeries, BoxGroup, BoxPanel, HtmlReport, KeyFigure,
    LineAxes,
};
use drive_sim_sim::SensorNoise;
use rayon::prelude::*;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// What to compare: robot, terrain, budget, seeds, strategies, ground-truth grid.
#[derive(Debug, Clone)]
pub struct SamplersOptions {
    /// Robot name or file.
    pub robot: String,
    /// Terrain name or file.
    pub terrain: String,
    /// Steps per run (the budget every strategy gets).
    pub steps: u32,
    /// Seeds per strategy (1..=K).
    pub seeds: u64,
    /// Only these strategies (empty: every registered one).
    pub only: Vec<String>,
    /// Sensor noise of the runs.
    pub noise: SensorNoise,
    /// Ground-truth grid, points along vx.
    pub grid_vx: usize,
    /// Ground-truth grid, points along wz.
    pub grid_wz: usize,
}

/// Figures of one strategy and seed.
#[derive(Debug, Clone, Serialize)]
pub struct SamplerRun {
    /// Strategy.
    pub sampler: String,
    /// Seed.
    pub seed: u64,
    /// Transfer-function error against the truth at each checkpoint (steps, error).
    pub error_vs_steps: Vec<(u32, TransferError)>,
    /// Area of T (reached body velocities) as % of U.
    pub t_area_pct_body: f64,
    /// Fraction of U's cells with a command nearby (10 × 10 normalized grid, radius 0.15).
    pub command_coverage: f64,
    /// Normalized entropy of the |Δvx| histogram (10 bins): 1 = every acceleration as often.
    pub accel_entropy_linear: f64,
    /// Normalized entropy of the |Δwz| histogram (10 bins).
    pub accel_entropy_angular: f64,
    /// Interrupted attempts per completed step.
    pub interruptions_per_step: f64,
    /// Productive over total time.
    pub time_efficiency: f64,
    /// Commanded kinetic energy integrated over the completed steps, kJ·s.
    pub energy_kj_s: f64,
    /// Wall-clock time of the simulation, s.
    pub wall_s: f64,
}

/// Mean and standard deviation over seeds, and the ratio of the mean to the baseline's.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct MeanSd {
    /// Mean.
    pub mean: f64,
    /// Sample standard deviation (0 with one seed).
    pub sd: f64,
    /// Mean over the baseline's mean (NaN without a baseline).
    pub ratio_to_baseline: f64,
}

/// Names of the metrics of the table, their units, and how to read them off a run.
type Metric = (&'static str, &'static str, fn(&SamplerRun) -> f64);

fn final_error(r: &SamplerRun) -> TransferError {
    r.error_vs_steps.last().map(|e| e.1).unwrap_or(TransferError {
        vx_m_s: f64::NAN,
        vy_m_s: f64::NAN,
        wz_rad_s: f64::NAN,
        points: 0,
    })
}

const METRICS: &[Metric] = &[
    ("TF err vx", "m/s", |r| final_error(r).vx_m_s),
    ("TF err vy", "m/s", |r| final_error(r).vy_m_s),
    ("TF err wz", "rad/s", |r| final_error(r).wz_rad_s),
    ("T area", "% of U", |r| r.t_area_pct_body),
    ("U coverage", "", |r| r.command_coverage),
    ("acc entropy lin", "", |r| r.accel_entropy_linear),
    ("acc entropy ang", "", |r| r.accel_entropy_angular),
    ("interrupts/step", "", |r| r.interruptions_per_step),
    ("time eff", "", |r| r.time_efficiency),
    ("energy", "kJ·s", |r| r.energy_kj_s),
];

/// Per-strategy summary over seeds, in the order of the comparison table's metrics.
#[derive(Debug, Clone, Serialize)]
pub struct SamplerSummary {
    /// Strategy.
    pub sampler: String,
    /// (metric, unit, mean ± sd, ratio to the baseline).
    pub metrics: Vec<(String, String, MeanSd)>,
}

/// Everything `drive-sim samplers` writes to `samplers.json`.
#[derive(Debug, Clone, Serialize)]
pub struct SamplersReport {
    /// Robot.
    pub robot: String,
    /// Terrain.
    pub terrain: String,
    /// Steps per run.
    pub steps: u32,
    /// Seeds used.
    pub seeds: Vec<u64>,
    /// Checkpoints of the error curves, steps.
    pub checkpoints: Vec<u32>,
    /// Baseline strategy of the ratios.
    pub baseline: String,
    /// Kernel covariance of the smoothed estimates.
    pub kernel: KernelCovariance,
    /// Ground truth (grid and slips).
    pub truth: TruthField,
    /// Every run.
    pub runs: Vec<SamplerRun>,
    /// Summaries over seeds.
    pub summaries: Vec<SamplerSummary>,
}

/// Checkpoints of the error curve: 25, 50, 100 and `steps`, those not above `steps`.
pub fn checkpoints(steps: u32) -> Vec<u32> {
    let mut c: Vec<u32> = [25, 50, 100].into_iter().filter(|&s| s < steps).collect();
    c.push(steps);
    c
}

fn one_run(
    robot: &Robot,
    terrain: &Terrain,
    sampler: &str,
    seed: u64,
    args: &SamplersOptions,
    truth: &TruthField,
    kernel: &KernelCovariance,
) -> Result<SamplerRun> {
    let run = simulate(robot, terrain, sampler, args.steps, seed, args.noise)?;
    let a = analyze(&run.log, &analysis_params_without_smoother())?;
    let space = robot.command_space();
    let cmds = step_commands(&run.log);
    let acc = acceleration_coverage(&space, &cmds, 10);
    let t = time_use(&run.summary);
    Ok(SamplerRun {
        sampler: sampler.to_string(),
        seed,
        error_vs_steps: checkpoints(args.steps)
            .into_iter()
            .map(|s| (s, transfer_error(&a, s as usize, truth, kernel)))
            .collect(),
        t_area_pct_body: a.spaces.t_area_pct_body,
        command_coverage: command_coverage(&space, &cmds, 10, 0.15),
        accel_entropy_linear: acc.linear.normalized_entropy(),
        accel_entropy_angular: acc.angular.normalized_entropy(),
        interruptions_per_step: t.interruptions_per_step,
        time_efficiency: t.time_efficiency,
        energy_kj_s: log_commanded_energy_j_s(robot, &run.log) / 1e3,
        wall_s: run.wall_s,
    })
}

/// Runs every selected strategy on every seed, and summarizes.
pub fn compare(args: &SamplersOptions) -> Result<SamplersReport> {
    let (robot, _) = Robot::resolve(&args.robot)?;
    let (terrain, _) = Terrain::resolve(&args.terrain)?;
    let max_steps = super::run::MAX_STEPS;
    if args.steps == 0 || args.steps > max_steps {
        return Err(Error::config(
            "<command line>",
            "--steps",
            format!("must be in 1..={max_steps} steps, got {}", args.steps),
        ));
    }
    if args.seeds == 0 || args.seeds > 1_000 {
        return Err(Error::config(
            "<command line>",
            "--seeds",
            format!("must be in 1..=1000 seeds, got {}", args.seeds),
        ));
    }
    if !(2..=201).contains(&args.grid_vx) || !(2..=201).contains(&args.grid_wz) {
        return Err(Error::config(
            "<command line>",
            "--grid-vx/--grid-wz",
            format!(
                "need 2..=201 points per axis (each point is a simulated run), got {} x {}",
                args.grid_vx, args.grid_wz
            ),
        ));
    }
    let names: Vec<String> = if args.only.is_empty() {
        SAMPLERS.iter().map(|s| s.to_string()).collect()
    } else {
        for n in &args.only {
            if !SAMPLERS.contains(&n.as_str()) {
                return Err(unknown_sampler(n).into());
            }
        }
        args.only.clone()
    };
    let kernel = kernel_for(&robot);
    let truth = simulator_truth(&robot, &terrain, &truth_grid(&robot, args.grid_vx, args.grid_wz))?;
    let seeds: Vec<u64> = (1..=args.seeds).collect();
    let jobs: Vec<(String, u64)> = names
        .iter()
        .flat_map(|n| seeds.iter().map(move |s| (n.clone(), *s)))
        .collect();
    let runs: Vec<SamplerRun> = jobs
        .par_iter()
        .map(|(n, s)| one_run(&robot, &terrain, n, *s, args, &truth, &kernel))
        .collect::<Result<_>>()?;
    let baseline = "uniform-wheel".to_string();
    let base_means: Vec<f64> = METRICS
        .iter()
        .map(|m| {
            let v: Vec<f64> = runs.iter().filter(|r| r.sampler == baseline).map(m.2).collect();
            mean_sd(&v).0
        })
        .collect();
    let summaries = names
        .iter()
        .map(|n| SamplerSummary {
            sampler: n.clone(),
            metrics: METRICS
                .iter()
                .zip(&base_means)
                .map(|(m, b)| {
                    let v: Vec<f64> = runs.iter().filter(|r| &r.sampler == n).map(m.2).collect();
                    let (mean, sd) = mean_sd(&v);
                    (
                        m.0.to_string(),
                        m.1.to_string(),
                        MeanSd {
                            mean,
                            sd,
                            ratio_to_baseline: mean / b,
                        },
                    )
                })
                .collect(),
        })
        .collect();
    Ok(SamplersReport {
        robot: robot.name.clone(),
        terrain: terrain.name.clone(),
        steps: args.steps,
        seeds,
        checkpoints: checkpoints(args.steps),
        baseline,
        kernel,
        truth,
        runs,
        summaries,
    })
}

/// The comparison table, one row per strategy: `mean ± sd` and, in brackets, the ratio of the
/// mean to the baseline's.
pub fn table(report: &SamplersReport) -> String {
    let mut out = format!(
        "{} on {}, {} steps, seeds {:?}; transfer-function errors (RMS vs open-loop truth, kernel {:.2} I) at {} steps; [ratio to {}]\n",
        report.robot,
        report.terrain,
        report.steps,
        report.seeds,
        report.kernel.var_vx,
        report.steps,
        report.baseline
    );
    out.push_str(&format!("{:<16}", "sampler"));
    for m in METRICS {
        let h = if m.1.is_empty() {
            m.0.to_string()
        } else {
            format!("{} [{}]", m.0, m.1)
        };
        out.push_str(&format!(" {h:>26}"));
    }
    out.push('\n');
    for s in &report.summaries {
        out.push_str(&format!("{:<16}", s.sampler));
        for (_, _, v) in &s.metrics {
            let ratio = if v.ratio_to_baseline.is_finite() {
                format!("[{:.2}]", v.ratio_to_baseline)
            } else {
                "[-]".into()
            };
            out.push_str(&format!(
                " {:>26}",
                format!("{:.3} ± {:.3} {ratio}", v.mean, v.sd)
            ));
        }
        out.push('\n');
    }
    out
}

fn error_figure(
    report: &SamplersReport,
    dir: &Path,
    stem: &str,
    which: usize,
) -> Result<drive_sim_report::FigureFiles> {
    let (title, unit) = [
        ("longitudinal slip", "m/s"),
        ("lateral slip", "m/s"),
        ("angular slip", "rad/s"),
    ][which];
    let series: Vec<BandSeries> = report
        .summaries
        .iter()
        .map(|s| BandSeries {
            label: s.sampler.clone(),
            points: report
                .checkpoints
                .iter()
                .enumerate()
                .map(|(k, &steps)| {
                    let v: Vec<f64> = report
                        .runs
                        .iter()
                        .filter(|r| r.sampler == s.sampler)
                        .map(|r| {
                            let e = r.error_vs_steps[k].1;
                            [e.vx_m_s, e.vy_m_s, e.wz_rad_s][which]
                        })
                        .collect();
                    let (m, sd) = mean_sd(&v);
                    BandPoint {
                        x: steps as f64,
                        mean: m,
                        low: m - sd,
                        high: m + sd,
                    }
                })
                .collect(),
        })
        .collect();
    Ok(line_bands(
        dir,
        stem,
        &format!("Transfer-function error, {title} (mean ± 1 sd over seeds)"),
        &LineAxes {
            x: AxisLabel::new("DRIVE steps", ""),
            y: AxisLabel::new(format!("RMS error of {title}"), unit),
            log_x: false,
            log_y: false,
        },
        &series,
    )?)
}

/// Writes `samplers.json`, the figures and `report.html` into `dir`.
pub fn write_outputs(report: &SamplersReport, dir: &Path) -> Result<PathBuf> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    drive_sim_model::output::write_json_atomic(&dir.join("samplers.json"), report)?;
    let mut html = HtmlReport::new(format!(
        "Sampling strategies: {} on {}, {} steps",
        report.robot, report.terrain, report.steps
    ));
    html.section("Method").paragraph(format!(
        "Each strategy ran DRIVE with the simulator for {} steps with seeds {:?}. The truth of the transfer functions is the simulator held open-loop at each point of a {}×{} grid over U (6 s from rest, mean of the last 4 s, noise off); the error is the RMS over the grid points inside U of the kernel-smoothed estimate (Σ = {:.2} I) minus the truth. Ratios are to {}.",
        report.steps,
        report.seeds,
        report.truth.grid.vx_m_s.len(),
        report.truth.grid.wz_rad_s.len(),
        report.kernel.var_vx,
        report.baseline
    ));
    html.section("Transfer-function error against the number of steps");
    for (which, stem) in [(0, "error_vx"), (1, "error_vy"), (2, "error_wz")] {
        let f = error_figure(report, dir, stem, which)?;
        html.figure(format!("RMS error of the smoothed {stem} against the truth"), &f)?;
    }
    let panels: Vec<BoxPanel> = METRICS
        .iter()
        .map(|m| BoxPanel {
            title: m.0.to_string(),
            value: AxisLabel::new(m.0, m.1),
            groups: report
                .summaries
                .iter()
                .map(|s| {
                    BoxGroup::new(
                        s.sampler.clone(),
                        report
                            .runs
                            .iter()
                            .filter(|r| r.sampler == s.sampler)
                            .map(m.2)
                            .collect(),
                    )
                })
                .collect(),
        })
        .collect();
    let f = box_plots(dir, "metrics", "Strategies over seeds", &panels)?;
    html.section("Metrics over seeds")
        .figure("One box per strategy, over seeds", &f)?;
    for s in &report.summaries {
        let rows: Vec<KeyFigure> = s
            .metrics
            .iter()
            .map(|(name, unit, v)| {
                KeyFigure::new(
                    name.clone(),
                    format!("{:.3} ± {:.3} (×{:.2})", v.mean, v.sd, v.ratio_to_baseline),
                    unit.clone(),
                )
            })
            .collect();
        html.table(s.sampler.clone(), &rows);
    }
    Ok(html.write(dir)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(only: &[&str], steps: u32, seeds: u64) -> SamplersOptions {
        SamplersOptions {
            robot: "husky".into(),
            terrain: "asphalt".into(),
            steps,
            seeds,
            only: only.iter().map(|s| s.to_string()).collect(),
            noise: SensorNoise::default(),
            grid_vx: 5,
            grid_wz: 5,
        }
    }

    #[test]
    fn checkpoints_and_mean_sd() {
        assert_eq!(checkpoints(150), vec![25, 50, 100, 150]);
        assert_eq!(checkpoints(100), vec![25, 50, 100]);
        assert_eq!(checkpoints(10), vec![10]);
        let (m, sd) = mean_sd(&[1.0, 2.0, 3.0, f64::NAN]);
        assert_eq!(m, 2.0);
        assert!((sd - 1.0).abs() < 1e-12);
        assert_eq!(mean_sd(&[4.0]), (4.0, 0.0));
        assert!(mean_sd(&[]).0.is_nan());
    }

    #[test]
    fn bad_options_are_errors() {
        let e = compare(&args(&["no-such"], 5, 1)).unwrap_err().to_string();
        assert!(e.contains("no-such"), "{e}");
        let e = compare(&args(&[], 0, 1)).unwrap_err().to_string();
        assert!(e.contains("--steps"), "{e}");
        let mut a = args(&[], 5, 1);
        a.grid_wz = 1;
        assert!(compare(&a).is_err());
    }

    #[test]
    fn tiny_comparison_has_a_baseline_and_writes_its_outputs() {
        let dir = tempfile::tempdir().unwrap();
        let a = args(&["uniform-wheel", "halton"], 6, 2);
        let r = compare(&a).unwrap();
        assert_eq!(r.runs.len(), 4);
        assert_eq!(r.summaries.len(), 2);
        // The baseline's ratios are 1 wherever its mean is finite and non-zero.
        for (_, _, v) in &r.summaries[0].metrics {
            if v.mean.is_finite() && v.mean != 0.0 {
                assert!((v.ratio_to_baseline - 1.0).abs() < 1e-12);
            }
        }
        for run in &r.runs {
            assert_eq!(run.error_vs_steps.len(), 1);
            let e = run.error_vs_steps[0].1;
            assert!(e.points > 0 && e.vx_m_s.is_finite() && e.wz_rad_s >= 0.0);
            assert!(run.time_efficiency > 0.0 && run.time_efficiency <= 1.0);
        }
        let t = table(&r);
        assert!(
            t.contains("uniform-wheel") && t.contains("halton") && t.contains("[1.00]"),
            "{t}"
        );
        write_outputs(&r, dir.path()).unwrap();
        for f in ["samplers.json", "report.html", "error_wz.svg", "metrics.png"] {
            assert!(dir.path().join(f).exists(), "{f}");
        }
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.path().join("samplers.json")).unwrap())
                .unwrap();
        assert_eq!(json["runs"].as_array().unwrap().len(), 4);
    }
}
