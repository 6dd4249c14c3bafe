//! `drive-sim analyze`: the slip and ρ pipeline on any DRIVE logs, and its report.

use drive_sim::harness::analyze::{analyze_logs, AnalyzeEvent, AnalyzeOptions};
use std::io::Write;
use std::path::PathBuf;

/// Options of `drive-sim analyze`.
#[derive(Debug, Clone, clap::Args)]
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
    /// Kernel variance Σ = diag(v, v) in (m/s)² and (rad/s)²; default: the paper's value for
    /// the log's robot (0.25 for the Husky, 0.64 otherwise).
    #[arg(long)]
    pub kernel_variance: Option<f64>,
    /// Keep the steps whose pose moves against the encoders where no physics can (a
    /// localisation fault); by default they are excluded and listed with their evidence.
    #[arg(long)]
    pub keep_pose_contradictions: bool,
    /// Robot, terrain and topic roles of rosbag2 bags.
    #[command(flatten)]
    pub input: super::input::InputArgs,
}

impl AnalyzeArgs {
    /// The analysis these arguments ask for.
    pub fn options(&self) -> AnalyzeOptions {
        AnalyzeOptions {
            logs: self.logs.clone(),
            out: self.out.clone(),
            resolution: self.resolution,
            kernel_variance: self.kernel_variance,
            keep_pose_contradictions: self.keep_pose_contradictions,
            input: self.input.options(),
        }
    }
}

/// Reads, analyses and reports the logs of `args`; prints the headline table.
pub fn analyze(args: &AnalyzeArgs) -> anyhow::Result<()> {
    let done = analyze_logs(&args.options(), &mut print_progress)?;
    print_analysis_table(&done.analyses)?;
    eprintln!(
        "drive-sim: wrote {} and {} figures; report: {}",
        done.files.summary.display(),
        done.files.figures.len(),
        done.files.html.display()
    );
    Ok(())
}

/// Progress of an analysis on stderr.
pub fn print_progress(event: AnalyzeEvent) {
    match event {
        AnalyzeEvent::Reading(path) => eprintln!("drive-sim: reading {}", path.display()),
        AnalyzeEvent::Note(n) => eprintln!("drive-sim: {n}"),
        AnalyzeEvent::Analysing(log) => eprintln!(
            "drive-sim: analysing {} ({} on {}, {} steps)",
            log.meta.name,
            log.meta.robot,
            log.meta.terrain,
            log.steps().len()
        ),
    }
}

/// The headline figures of each analysed log, one line each: median steady-state slips signed
/// along the command (positive = slower than commanded; |vy| for the lateral one), median ρ,
/// the ideal differential-drive RMSE, the area of T, the yaw-rate source; below it the medians'
/// intervals and the step-to-step scatter of the steady wheel speeds.
fn print_analysis_table(analyses: &[drive_sim::analysis::Analysis]) -> anyhow::Result<()> {
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
    let med = |b: Option<drive_sim::analysis::stats::BoxStats>| b.map_or(f64::NAN, |b| b.median);
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
        // The same medians' bootstrap-by-step intervals (the definition `compare` uses).
        let ci = &a.median_ci95;
        let f = |i: &Option<drive_sim::analysis::bootstrap::Interval>| {
            i.map_or("(none)".to_string(), |i| {
                format!("[{:.3}, {:.3}]", i.lower, i.upper)
            })
        };
        let ac = &ci.along_command;
        writeln!(
            out,
            "{:<20} 95 % CI (bootstrap by step): g_vx {} |g_vy| {} g_wz {} g_left {} g_right {} rho {}",
            "",
            f(&ac[0]),
            f(&ac[1]),
            f(&ac[2]),
            f(&ac[3]),
            f(&ac[4]),
            f(&ci.rho)
        )?;
        if let Some(w) = &ci.warning {
            writeln!(out, "{:<20} warning: {w}", "")?;
        }
        // Steps with nearly the same command against the two steady windows of one step: a
        // step-level offset that window noise does not explain (see `analysis::scatter`).
        writeln!(out, "{:<20} {}", "", a.step_scatter)?;
        writeln!(out, "{:<20} {}", "", a.turn_memory)?;
        writeln!(out, "{:<20} {}", "", a.command_mix)?;
        // A pose that repeats between samples: an odometry slower than the logger (see
        // `analysis::pose_updates`).
        if let Some(p) = &a.pose_updates {
            writeln!(out, "{:<20} {p}", "")?;
        }
    }
    Ok(())
}
