//! The report of `drive-sim analyze`: one or several analysed logs turned into `summary.json`,
//! `transfer_functions.json`, the paper's figures (SVG and PNG) and one self-contained
//! `report.html`. Several logs are compared on the same figures.
//!
//! The JSON files are written by `summary`; the HTML page is built section by section by a
//! `Report`, whose methods live in `sections` (findings, command spaces, slip, ρ, transfer
//! functions, accelerations, sensor cross-check) and `risk` (the risk map).

mod risk;
mod sections;
mod summary;

use super::{FigureFiles, HtmlReport};
use crate::error::{Error, Result};
use drive_sim_analysis::{velocity, Analysis};
use drive_sim_log::DriveLog;
use std::path::{Path, PathBuf};

/// What [`write_analysis_report`] wrote.
#[derive(Debug, Clone)]
pub struct AnalysisReportFiles {
    /// `summary.json`.
    pub summary: PathBuf,
    /// `transfer_functions.json`.
    pub transfer_functions: PathBuf,
    /// `report.html`.
    pub html: PathBuf,
    /// Every figure.
    pub figures: Vec<FigureFiles>,
}

impl AnalysisReportFiles {
    /// Maps every path through `f` (from a staging folder to the final one).
    pub fn relocate(&mut self, f: &dyn Fn(&std::path::Path) -> PathBuf) {
        self.summary = f(&self.summary);
        self.transfer_functions = f(&self.transfer_functions);
        self.html = f(&self.html);
        for fig in &mut self.figures {
            fig.svg = f(&fig.svg);
            fig.png = f(&fig.png);
        }
    }
}

/// Label of an analysed log on figures: the dataset name, which says robot and terrain.
fn label(a: &Analysis) -> String {
    a.dataset.clone()
}

/// Accelerations (pose-derived, body frame) over the transient window of every step: the
/// paper's check of the first 2 s against the acceleration limit.
fn transient_accelerations(log: &DriveLog, a: &Analysis) -> (Vec<f64>, Vec<f64>) {
    let idd = log.meta.nominal.idd();
    let (mut ax, mut ay) = (Vec::new(), Vec::new());
    let mut i = 0;
    let s = &log.samples;
    while i < s.len() {
        let j = i + s[i..]
            .iter()
            .take_while(|x| x.step == s[i].step && x.window == s[i].window)
            .count();
        if s[i].window == 0 {
            for k in velocity::window_kinematics(&s[i..j], a.params.derivative_half_width, &idd) {
                ax.push(k.pose_acc_m_s2.0);
                ay.push(k.pose_acc_m_s2.1);
            }
        }
        i = j;
    }
    (ax, ay)
}

/// What the report needs of a log besides its analysis, so that a caller can drop each log as
/// soon as it is analysed (memory then grows with the analyses, not with the logs).
#[derive(Debug, Clone, PartialEq)]
pub struct LogSummary {
    /// Interrupted attempts.
    pub interruptions: usize,
    /// Productive over total time.
    pub time_efficiency: f64,
    /// Pose-derived body-frame accelerations over the transient window of every step, m/s²
    /// (longitudinal, lateral).
    pub transient_acc_m_s2: (Vec<f64>, Vec<f64>),
}

impl LogSummary {
    /// The summary of `log`, analysed as `a`.
    pub fn of(log: &DriveLog, a: &Analysis) -> Self {
        Self {
            interruptions: log.interruptions.len(),
            time_efficiency: log.time_efficiency(),
            transient_acc_m_s2: transient_accelerations(log, a),
        }
    }
}

/// Writes the whole report of `items` (each log with its analysis) into `dir`.
pub fn write_analysis_report(items: &[(&DriveLog, &Analysis)], dir: &Path) -> Result<AnalysisReportFiles> {
    let summaries: Vec<LogSummary> = items.iter().map(|(log, a)| LogSummary::of(log, a)).collect();
    let pairs: Vec<(&LogSummary, &Analysis)> = summaries.iter().zip(items.iter().map(|(_, a)| *a)).collect();
    write_analysis_report_of(&pairs, dir)
}

/// [`write_analysis_report`] from each log's [`LogSummary`] instead of the log.
pub fn write_analysis_report_of(
    items: &[(&LogSummary, &Analysis)],
    dir: &Path,
) -> Result<AnalysisReportFiles> {
    if items.is_empty() {
        return Err(Error::NothingToReport);
    }
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let analyses: Vec<&Analysis> = items.iter().map(|(_, a)| *a).collect();
    let json = summary::write_json_files(items, &analyses, dir)?;

    // The sections in the order a reader meets them: what differs first, details after.
    let mut report = Report::new(items, analyses, dir);
    report.findings()?;
    report.command_spaces()?;
    report.slip()?;
    report.rho_over_commands()?;
    report.transfer_functions()?;
    report.risk_map()?;
    report.transient_accelerations()?;
    report.sensor_crosscheck();
    let html_path = report.html.write(dir)?;
    Ok(AnalysisReportFiles {
        summary: json.summary,
        transfer_functions: json.transfer_functions,
        html: html_path,
        figures: report.figures,
    })
}

/// What every section of `report.html` shares: the analysed logs, the output folder, the page
/// being built and the figures written so far (in the order they appear on the page).
struct Report<'a> {
    /// Each log's summary with its analysis.
    items: &'a [(&'a LogSummary, &'a Analysis)],
    /// The analyses of `items`, in the same order.
    analyses: Vec<&'a Analysis>,
    /// Robots of the analyses, sorted, each once: U and the slip magnitudes differ between
    /// robots, so the command-space and transfer-function figures are per robot.
    robots: Vec<&'a str>,
    /// Where the figures are written.
    dir: &'a Path,
    /// The page.
    html: HtmlReport,
    /// Every figure written, in page order.
    figures: Vec<FigureFiles>,
}

impl<'a> Report<'a> {
    fn new(items: &'a [(&'a LogSummary, &'a Analysis)], analyses: Vec<&'a Analysis>, dir: &'a Path) -> Self {
        let html = HtmlReport::new(format!(
            "DRIVE analysis: {}",
            analyses
                .iter()
                .map(|a| a.dataset.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        ));
        let mut robots: Vec<&str> = analyses.iter().map(|a| a.robot.as_str()).collect();
        robots.sort();
        robots.dedup();
        Self {
            items,
            analyses,
            robots,
            dir,
            html,
            figures: Vec::new(),
        }
    }

    /// Embeds figure `f` under `caption` and records its files.
    fn add_figure(&mut self, caption: impl Into<String>, f: FigureFiles) -> Result<()> {
        self.html.figure(caption, &f)?;
        self.figures.push(f);
        Ok(())
    }
}
