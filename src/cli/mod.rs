//! The `drive-sim` command line: what each subcommand does, and how it reports progress.

pub mod run;

use crate::robot::{Robot, BUILTIN_ROBOTS};
use crate::terrain::{Terrain, BUILTIN_TERRAINS};
use clap::{Parser, Subcommand};
use std::io::Write;
use std::path::PathBuf;

/// Simulation-backed test harness for the DRIVE protocol.
#[derive(Debug, Parser)]
#[command(name = "drive-sim", version, about, long_about = None)]
pub struct Cli {
    /// What to do; without one, runs the demonstration (`drive-sim demo`).
    #[command(subcommand)]
    pub command: Option<Command>,
}

/// Subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Runs DRIVE in closed loop on a simulated robot and terrain; writes an MCAP log.
    Run(run::RunArgs),
    /// Lists the robots (built-in and ./robots/*.toml).
    Robots,
    /// Lists the terrains (built-in and ./terrains/*.toml).
    Terrains,
    /// Analyses DRIVE logs (simulated .mcap or measured .csv): slips, transfer functions, ρ,
    /// risk; writes summary.json, figures and report.html. Several logs are compared.
    Analyze(AnalyzeArgs),
}

/// Options of `drive-sim analyze`.
#[derive(Debug, clap::Args)]
pub struct AnalyzeArgs {
    /// Logs to analyse: `.mcap` written by `drive-sim run`, or measured `.csv` (JSON beside it).
    #[arg(required = true)]
    pub logs: Vec<PathBuf>,
    /// Output directory.
    #[arg(long, default_value = "out/analysis")]
    pub out: PathBuf,
    /// Transfer-function grid resolution in vx (m/s) and wz (rad/s).
    #[arg(long, default_value_t = 0.1)]
    pub resolution: f64,
    /// Kernel variance Σ = diag(v, v) in (m/s)² and (rad/s)² (paper: 0.64 Warthog, 0.25 Husky).
    #[arg(long, default_value_t = 0.64)]
    pub kernel_variance: f64,
}

/// Runs the command line; returns the process exit code.
pub fn main() -> i32 {
    let cli = Cli::parse();
    match dispatch(cli) {
        Ok(()) => 0,
        // A closed pipe (`drive-sim robots | head`) is the reader's choice, not an error.
        Err(e)
            if e.downcast_ref::<std::io::Error>()
                .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe) =>
        {
            0
        }
        Err(e) => {
            eprintln!("drive-sim: error: {e:#}");
            1
        }
    }
}

fn dispatch(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        None => Err(anyhow::anyhow!("no demo yet")),
        Some(Command::Run(a)) => {
            eprintln!(
                "drive-sim: running DRIVE: {} on {}, {} steps, seed {}, sampler {}",
                a.robot, a.terrain, a.steps, a.seed, a.sampler
            );
            let r = run::run(&a)?;
            println!("{}", run::describe(&r));
            Ok(())
        }
        Some(Command::Robots) => list_robots(),
        Some(Command::Terrains) => list_terrains(),
        Some(Command::Analyze(a)) => analyze(&a),
    }
}

fn list_robots() -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "{:<10} {:>8} {:>7} {:>7} {:>9} {:>10}  source",
        "robot", "mass_kg", "r_m", "b_m", "vmax_m_s", "wmax_rad_s"
    )?;
    for e in crate::config::catalog("robot", BUILTIN_ROBOTS) {
        match crate::config::parse_toml::<Robot>(&e.text, &e.origin) {
            Ok(r) => writeln!(
                out,
                "{:<10} {:>8.1} {:>7.3} {:>7.3} {:>9.2} {:>10.2}  {}",
                e.name,
                r.body.mass_kg,
                r.wheels.radius_m,
                r.wheels.baseline_m,
                r.limits.max_lin_m_s,
                r.limits.max_ang_rad_s,
                e.origin.display()
            )?,
            Err(err) => writeln!(out, "{:<10} INVALID: {err}", e.name)?,
        }
    }
    Ok(())
}

fn list_terrains() -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "{:<10} {:>8} {:>8} {:>8}  description",
        "terrain", "mu_peak", "mu_slide", "c_roll"
    )?;
    for e in crate::config::catalog("terrain", BUILTIN_TERRAINS) {
        match crate::config::parse_toml::<Terrain>(&e.text, &e.origin) {
            Ok(t) => writeln!(
                out,
                "{:<10} {:>8.2} {:>8.2} {:>8.3}  {}",
                e.name,
                t.friction.peak_longitudinal,
                t.friction.sliding_longitudinal,
                t.resistance.rolling_coefficient,
                t.description
            )?,
            Err(err) => writeln!(out, "{:<10} INVALID: {err}", e.name)?,
        }
    }
    Ok(())
}

fn analysis_params(args: &AnalyzeArgs) -> anyhow::Result<crate::analysis::AnalysisParams> {
    use crate::analysis::{smoother::KernelCovariance, AnalysisParams, SmootherParams};
    if !(args.resolution > 0.0 && args.resolution.is_finite()) {
        anyhow::bail!("--resolution must be > 0, got {}", args.resolution);
    }
    if !(args.kernel_variance > 0.0 && args.kernel_variance.is_finite()) {
        anyhow::bail!("--kernel-variance must be > 0, got {}", args.kernel_variance);
    }
    Ok(AnalysisParams {
        smoother: SmootherParams {
            resolution_vx_m_s: args.resolution,
            resolution_wz_rad_s: args.resolution,
            covariance: KernelCovariance {
                var_vx: args.kernel_variance,
                var_wz: args.kernel_variance,
            },
            ..SmootherParams::default()
        },
        ..AnalysisParams::default()
    })
}

fn analyze(args: &AnalyzeArgs) -> anyhow::Result<()> {
    let params = analysis_params(args)?;
    let mut logs = Vec::new();
    for path in &args.logs {
        eprintln!("drive-sim: reading {}", path.display());
        logs.push(crate::log::read_log(path)?);
    }
    let mut analyses = Vec::new();
    for log in &logs {
        eprintln!(
            "drive-sim: analysing {} ({} on {}, {} steps)",
            log.meta.name,
            log.meta.robot,
            log.meta.terrain,
            log.steps().len()
        );
        analyses.push(crate::analysis::analyze(log, &params)?);
    }
    let items: Vec<_> = logs.iter().zip(&analyses).collect();
    let files = crate::report::analysis_report::write_analysis_report(&items, &args.out)?;
    print_analysis_table(&analyses)?;
    eprintln!(
        "drive-sim: wrote {} and {} figures; report: {}",
        files.summary.display(),
        files.figures.len(),
        files.html.display()
    );
    Ok(())
}

/// The headline figures of each analysed log, one line each.
fn print_analysis_table(analyses: &[crate::analysis::Analysis]) -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "{:<18} {:>5} {:>4} {:>8} {:>8} {:>8} {:>7} {:>7} {:>6} {:>22} {:>7}  yaw source",
        "dataset",
        "steps",
        "excl",
        "g_vx",
        "g_vy",
        "g_wz",
        "g_left",
        "g_right",
        "rho",
        "IDD RMSE vx/vy/wz",
        "T/U %"
    )?;
    let med = |b: Option<crate::analysis::stats::BoxStats>| b.map_or(f64::NAN, |b| b.median);
    for a in analyses {
        let s = &a.stats;
        writeln!(
            out,
            "{:<18} {:>5} {:>4} {:>8.3} {:>8.3} {:>8.3} {:>7.2} {:>7.2} {:>6.3} {:>6.3}/{:>6.3}/{:>6.3}   {:>7.1}  {:?}",
            a.dataset,
            a.steps.len(),
            a.exclusions.len(),
            med(s.vx_m_s),
            med(s.vy_m_s),
            med(s.wz_rad_s),
            med(s.left_rad_s),
            med(s.right_rad_s),
            med(s.rho),
            a.idd_rmse.vx_m_s,
            a.idd_rmse.vy_m_s,
            a.idd_rmse.wz_rad_s,
            a.spaces.t_area_pct_body,
            a.yaw_rate_source
        )?;
    }
    Ok(())
}
