//! `drive-sim analyze`: the slip and ρ pipeline on any DRIVE logs, and its report.

use std::io::Write;
use std::path::PathBuf;

/// Options of `drive-sim analyze`.
#[derive(Debug, Clone, clap::Args)]
pub struct AnalyzeArgs {
    /// Logs to analyse: `.mcap` written by `drive-sim run`, measured `.csv` (JSON beside it), or
    /// rosbag2 bags of the DRIVE node (directory, `.db3` or `.mcap`).
    #[arg(required = true)]
    pub logs: Vec<PathBuf>,
    /// How to read bags.
    #[command(flatten)]
    pub input: super::input::InputArgs,
    /// Output directory.
    #[arg(long, default_value = "out/analysis")]
    pub out: PathBuf,
    /// Transfer-function grid resolution in vx (m/s) and wz (rad/s).
    #[arg(long, default_value_t = 0.1)]
    pub resolution: f64,
    /// Kernel variance Σ = diag(v, v) in (m/s)² and (rad/s)²; default: the paper's value for
    /// the log's robot (0.25 for the Husky, 0.64 otherwise).
    #[arg(long)]
    pub kernel_variance: Option<f64>,
}

/// The paper's kernel variance for a robot: 0.25 for the Husky (lessons learned), 0.64 for
/// the Warthog figures, used for any other robot too.
pub fn paper_kernel_variance(robot: &str) -> f64 {
    if robot == "husky" {
        0.25
    } else {
        0.64
    }
}

fn analysis_params(args: &AnalyzeArgs, robot: &str) -> anyhow::Result<crate::analysis::AnalysisParams> {
    use crate::analysis::{smoother::KernelCovariance, AnalysisParams, SmootherParams};
    if !(args.resolution > 0.0 && args.resolution.is_finite()) {
        anyhow::bail!("--resolution must be > 0, got {}", args.resolution);
    }
    let variance = args
        .kernel_variance
        .unwrap_or_else(|| paper_kernel_variance(robot));
    if !(variance > 0.0 && variance.is_finite()) {
        anyhow::bail!("--kernel-variance must be > 0, got {variance}");
    }
    Ok(AnalysisParams {
        smoother: SmootherParams {
            resolution_vx_m_s: args.resolution,
            resolution_wz_rad_s: args.resolution,
            covariance: KernelCovariance {
                var_vx: variance,
                var_wz: variance,
            },
            ..SmootherParams::default()
        },
        ..AnalysisParams::default()
    })
}

/// Reads, analyses and reports the logs of `args`.
pub fn analyze(args: &AnalyzeArgs) -> anyhow::Result<()> {
    let mut logs = Vec::new();
    for path in &args.logs {
        eprintln!("drive-sim: reading {}", path.display());
        logs.push(super::input::open_log(path, &args.input)?);
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
        analyses.push(crate::analysis::analyze(
            log,
            &analysis_params(args, &log.meta.robot)?,
        )?);
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

/// The headline figures of each analysed log, one line each: median steady-state slips signed
/// along the command (positive = slower than commanded; |vy| for the lateral one), median ρ,
/// the ideal differential-drive RMSE, the area of T, the yaw-rate source.
fn print_analysis_table(analyses: &[crate::analysis::Analysis]) -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "{:<20} {:>5} {:>4} {:>5} {:>7} {:>7} {:>7} {:>7} {:>7} {:>6} {:>20} {:>6} {:>6}  yaw source",
        "dataset",
        "steps",
        "excl",
        "outU",
        "g_vx",
        "|g_vy|",
        "g_wz",
        "g_left",
        "g_right",
        "rho",
        "IDD RMSE vx/vy/wz",
        "T/U B%",
        "T/U W%"
    )?;
    let med = |b: Option<crate::analysis::stats::BoxStats>| b.map_or(f64::NAN, |b| b.median);
    for a in analyses {
        let s = &a.stats.along_command;
        writeln!(
            out,
            "{:<20} {:>5} {:>4} {:>5} {:>7.3} {:>7.3} {:>7.3} {:>7.3} {:>7.3} {:>6.3} {:>6.3}/{:>6.3}/{:>6.3} {:>6.1} {:>6.1}  {:?}",
            a.dataset,
            a.steps.len(),
            a.exclusions.len(),
            a.commands_outside_u,
            med(s.vx_m_s),
            med(s.vy_abs_m_s),
            med(s.wz_rad_s),
            med(s.left_rad_s),
            med(s.right_rad_s),
            med(a.stats.rho),
            a.idd_rmse.vx_m_s,
            a.idd_rmse.vy_m_s,
            a.idd_rmse.wz_rad_s,
            a.spaces.t_area_pct_body,
            a.spaces.t_area_pct_wheels,
            a.yaw_rate_source
        )?;
    }
    Ok(())
}
