//! The report of `drive-sim analyze`: one or several analysed logs turned into `summary.json`,
//! `transfer_functions.json`, the paper's figures (SVG and PNG) and one self-contained
//! `report.html`. Several logs are compared on the same figures.

use super::{
    box_plots, command_space_figure, heat_maps, histograms, risk_map, value_scatter, AxisLabel, BoxPanel,
    ColourMap, ColourScale, CommandScenario, Comparison, EnergyAxis, EnergyLimit, FigureFiles, Grid2,
    HeatPanel, HistPanel, HtmlReport, KeyFigure, RiskEllipse, RiskScenario, Samples, ScatterPanel,
    ValuePoint, CHI2_2DOF_95,
};
use drive_sim_analysis::risk::MotionClass;
use drive_sim_analysis::{velocity, Analysis, StepResult};
use drive_sim_log::DriveLog;
use drive_sim_model::error::{Error, Result};
use serde::Serialize;
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

/// `summary.json`: per dataset the rows (one per step and window) and the aggregates.
#[derive(Serialize)]
struct Summary<'a> {
    tool: String,
    datasets: Vec<DatasetSummary<'a>>,
    /// Ratios of median ρ between every pair of datasets (row over column).
    median_rho_ratios: Vec<(String, String, f64)>,
}

#[derive(Serialize)]
struct DatasetSummary<'a> {
    dataset: &'a str,
    robot: &'a str,
    terrain: &'a str,
    origin: &'a drive_sim_log::Origin,
    nominal: &'a drive_sim_log::Nominal,
    steps_analysed: usize,
    steps_excluded: usize,
    interruptions: usize,
    time_efficiency: f64,
    yaw_rate_source: drive_sim_analysis::crosscheck::YawRateSource,
    crosscheck: &'a drive_sim_analysis::crosscheck::CrossCheck,
    stats: &'a drive_sim_analysis::SlipStats,
    median_ci95: &'a drive_sim_analysis::MedianIntervals,
    idd_rmse: &'a drive_sim_model::kinematics::BodyVelocity,
    commands_outside_u: usize,
    t_area_pct_body: f64,
    t_area_pct_wheels: f64,
    lateral_speed: &'a drive_sim_analysis::spaces::LateralSpeed,
    max_kinetic_energy: &'a drive_sim_analysis::risk::MaxKineticEnergy,
    risk: &'a [drive_sim_analysis::risk::RiskScenario],
    exclusions: &'a [drive_sim_analysis::segment::Exclusion],
    rows: &'a [drive_sim_analysis::SummaryRow],
    /// Step-to-step against within-step scatter of the steady wheel speeds, computed from the
    /// same analysed steps as `rows`.
    step_scatter: drive_sim_analysis::scatter::StepScatter,
    /// How loaded wheels track by the previous step's turn, from the same analysed steps.
    turn_memory: drive_sim_analysis::turn_memory::TurnMemory,
}

fn steady(a: &Analysis, f: impl Fn(&StepResult) -> f64) -> Vec<f64> {
    a.steps.iter().map(f).collect()
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
        return Err(Error::Report("nothing to report: no analysed log".into()));
    }
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let analyses: Vec<&Analysis> = items.iter().map(|(_, a)| *a).collect();

    // summary.json
    let datasets = items
        .iter()
        .map(|(log, a)| DatasetSummary {
            dataset: &a.dataset,
            robot: &a.robot,
            terrain: &a.terrain,
            origin: &a.origin,
            nominal: &a.nominal,
            steps_analysed: a.steps.len(),
            steps_excluded: a.exclusions.len(),
            interruptions: log.interruptions,
            time_efficiency: log.time_efficiency,
            yaw_rate_source: a.yaw_rate_source,
            crosscheck: &a.crosscheck,
            stats: &a.stats,
            median_ci95: &a.median_ci95,
            idd_rmse: &a.idd_rmse,
            commands_outside_u: a.commands_outside_u,
            t_area_pct_body: a.spaces.t_area_pct_body,
            t_area_pct_wheels: a.spaces.t_area_pct_wheels,
            lateral_speed: &a.spaces.lateral,
            max_kinetic_energy: &a.max_kinetic_energy,
            risk: &a.risk,
            exclusions: &a.exclusions,
            rows: &a.rows,
            step_scatter: a.step_scatter,
            turn_memory: a.turn_memory,
        })
        .collect();
    let med = |a: &Analysis| a.stats.rho.map_or(f64::NAN, |b| b.median);
    let mut median_rho_ratios = Vec::new();
    for x in &analyses {
        for y in &analyses {
            if x.dataset != y.dataset {
                median_rho_ratios.push((x.dataset.clone(), y.dataset.clone(), med(x) / med(y)));
            }
        }
    }
    let summary_path = dir.join("summary.json");
    drive_sim_model::output::write_json_atomic(
        &summary_path,
        &Summary {
            tool: format!("drive-sim {}", env!("CARGO_PKG_VERSION")),
            datasets,
            median_rho_ratios,
        },
    )?;
    let tf: Vec<_> = analyses.iter().map(|a| (&a.dataset, &a.transfer)).collect();
    let tf_path = dir.join("transfer_functions.json");
    drive_sim_model::output::write_json_atomic(&tf_path, &tf)?;

    // Figures.
    let mut figures = Vec::new();
    let mut html = HtmlReport::new(format!(
        "DRIVE analysis: {}",
        analyses
            .iter()
            .map(|a| a.dataset.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    ));
    // First screen: what differs, one table with the datasets as columns, the key figure.
    let metrics = super::findings::metrics(items);
    let datasets: Vec<String> = analyses.iter().map(|a| a.dataset.clone()).collect();
    let diffs = super::findings::differences(&metrics, &datasets);
    html.section("Findings");
    html.paragraph(super::findings::findings_paragraph(&metrics, &diffs, 4));
    html.comparison(Comparison {
        caption: "Key figures per dataset".into(),
        columns: analyses
            .iter()
            .map(|a| format!("{} ({} on {})", a.dataset, a.robot, a.terrain))
            .collect(),
        rows: metrics
            .iter()
            .map(|m| {
                (
                    m.name.to_string(),
                    m.unit.to_string(),
                    m.values.iter().map(|v| m.format(*v)).collect(),
                )
            })
            .collect(),
    });
    html.paragraph(
        "Steady state = mean of the two steady windows of each step. Slip = commanded (nominal ideal \
         differential drive) minus realized, signed along the command (positive = slower than \
         commanded). Boxes: quartiles; whiskers: 2.5 and 97.5 %.",
    );
    html.paragraph(format!(
        "Yaw rate measured by: {}.",
        analyses
            .iter()
            .map(|a| format!("{} {:?}", a.dataset, a.yaw_rate_source))
            .collect::<Vec<_>>()
            .join("; ")
    ));
    let groups = |f: &dyn Fn(&StepResult) -> f64| -> Vec<Samples> {
        analyses
            .iter()
            .map(|a| Samples::new(label(a), steady(a, f)))
            .collect()
    };
    let rho_panel = [BoxPanel {
        title: "steady state".into(),
        value: AxisLabel::new("ρ", ""),
        groups: groups(&|s| s.steady_rho.rho),
    }];
    let f = box_plots(dir, "rho_boxplot", "Unpredictability ρ per dataset", &rho_panel)?;
    // Metric 0 is the median ρ: its two ends are the boxes to compare.
    let look = match super::findings::differences(&metrics[..1], &datasets).first() {
        Some(d) if d.high.0 != d.low.0 => format!(
            " Compare the boxes of {} (median {:.3}, the least predictable) and {} (median {:.3}): a box high and wide means commands whose outcome cannot be told in advance.",
            d.high.0, d.high.1, d.low.0, d.low.1
        ),
        _ => String::new(),
    };
    html.figure(
        format!("Key figure: unpredictability ρ of the steady state of every step, per dataset (0: the robot does what the ideal differential drive predicts; 1: nothing of it).{look}"),
        &f,
    )?;
    figures.push(f);

    // Command spaces, one figure per robot (U differs).
    let mut robots: Vec<&str> = analyses.iter().map(|a| a.robot.as_str()).collect();
    robots.sort();
    robots.dedup();
    html.section("Command space U, sampled commands S, reached velocities T");
    for robot in &robots {
        let of_robot: Vec<&Analysis> = analyses.iter().copied().filter(|a| a.robot == *robot).collect();
        let space = of_robot[0].nominal.command_space();
        let scenarios: Vec<CommandScenario> = of_robot
            .iter()
            .map(|a| CommandScenario {
                label: label(a),
                commands: a.steps.iter().map(|s| s.steady.cmd_wheels).collect(),
                steady_wheels: a.steps.iter().map(|s| s.steady.realized_wheels).collect(),
                steady_body: a.steps.iter().map(|s| s.steady.realized_body).collect(),
            })
            .collect();
        let f = command_space_figure(
            dir,
            &format!("command_space_{robot}"),
            &format!("{robot}: U, S and T"),
            &space,
            &scenarios,
        )?;
        html.figure(format!("{robot}: command space U (outline), sampled commands S and reached steady-state velocities T, in the wheel frame W and the body frame B; lateral speed distribution."), &f)?;
        figures.push(f);
    }

    // Slip box plots.
    let panels = vec![
        BoxPanel {
            title: "longitudinal".into(),
            value: AxisLabel::new("slip vx", "m/s"),
            groups: groups(&|s| s.steady.slip_body.vx_m_s),
        },
        BoxPanel {
            title: "lateral".into(),
            value: AxisLabel::new("slip vy", "m/s"),
            groups: groups(&|s| s.steady.slip_body.vy_m_s),
        },
        BoxPanel {
            title: "angular".into(),
            value: AxisLabel::new("slip wz", "rad/s"),
            groups: groups(&|s| s.steady.slip_body.wz_rad_s),
        },
        BoxPanel {
            title: "left wheel".into(),
            value: AxisLabel::new("slip left", "rad/s"),
            groups: groups(&|s| s.steady.slip_wheels.left_rad_s),
        },
        BoxPanel {
            title: "right wheel".into(),
            value: AxisLabel::new("slip right", "rad/s"),
            groups: groups(&|s| s.steady.slip_wheels.right_rad_s),
        },
    ];
    html.section("Steady-state slip");
    let f = box_plots(
        dir,
        "slip_boxplots",
        "Steady-state slip (body and wheel frames)",
        &panels,
    )?;
    html.figure(
        "Steady-state slip per dataset in the body frame (vx, vy, wz) and the wheel frame (left, right). Look at where each dataset's boxes sit against zero: wheel slip far from zero while the body slip is large means the wheels spin without moving the body; a box that spans zero means the terrain neither slows nor speeds the robot on average.",
        &f,
    )?;
    figures.push(f);

    html.section("Unpredictability ρ over the command space");
    let scatter: Vec<ScatterPanel> = analyses
        .iter()
        .map(|a| ScatterPanel {
            title: label(a),
            points: a
                .steps
                .iter()
                .map(|s| ValuePoint {
                    vx_m_s: s.steady.cmd_body.vx_m_s,
                    wz_rad_s: s.steady.cmd_body.wz_rad_s,
                    value: s.steady_rho.rho,
                })
                .collect(),
            command_space: a.nominal.command_space().polygon_body(),
        })
        .collect();
    let rho_scale = ColourScale {
        value: AxisLabel::new("ρ", ""),
        map: ColourMap::Viridis,
        range: Some((0.0, 1.0)),
    };
    let f = value_scatter(
        dir,
        "rho_command_space",
        "ρ over the command space",
        &scatter,
        &rho_scale,
    )?;
    html.figure("ρ of each step at its commanded (vx, wz). Look for where in the command space the colour turns yellow: the commands to avoid on that terrain (on grippy ground, turning on the spot; on ice, almost everywhere).", &f)?;
    figures.push(f);

    // Transfer functions.
    html.section("Transfer functions (Gaussian kernel smoother)");
    let channels = [
        ("slip_vx_m_s", "longitudinal slip", "m/s", Some(0.2)),
        ("slip_vy_m_s", "lateral slip", "m/s", Some(0.1)),
        ("slip_wz_rad_s", "angular slip", "rad/s", Some(0.2)),
        ("rho", "ρ", "", Some(0.1)),
    ];
    // One figure per robot and channel: U and the slip magnitudes differ between robots.
    for (robot, (name, quantity, unit, spacing)) in
        robots.iter().flat_map(|r| channels.iter().map(move |c| (r, *c)))
    {
        let panels: Vec<HeatPanel> = analyses
            .iter()
            .filter(|a| a.robot == *robot)
            .filter_map(|a| heat_panel(a, name))
            .collect();
        if panels.is_empty() {
            continue;
        }
        let scale = ColourScale {
            value: AxisLabel::new(quantity, unit),
            map: if name == "rho" {
                ColourMap::Viridis
            } else {
                ColourMap::Diverging
            },
            range: if name == "rho" { Some((0.0, 1.0)) } else { None },
        };
        // Robot in the stem: a report of several robots writes one figure each.
        let stem = format!("tf_{name}_{robot}");
        let f = heat_maps(
            dir,
            &stem,
            &format!("{robot}: transfer function of the {quantity}"),
            &panels,
            &scale,
            spacing,
        )?;
        html.figure(
            format!("Smoothed steady-state {quantity} over U (kernel Σ = diag({}, {})), contour lines every {} {unit}.",
                panels_cov(&analyses, robot).0, panels_cov(&analyses, robot).1, spacing.unwrap_or(0.0)),
            &f,
        )?;
        figures.push(f);
    }

    // Risk map.
    html.section("Risk map");
    let n_robots = {
        let mut r: Vec<&str> = analyses.iter().map(|a| a.robot.as_str()).collect();
        r.sort_unstable();
        r.dedup();
        r.len()
    };
    let (risk, axis) = risk_scenarios(&analyses, n_robots > 1);
    let mut limits: Vec<EnergyLimit> = Vec::new();
    for a in &analyses {
        let l = format!("{} max (IDD over U)", a.robot);
        if !limits.iter().any(|x| x.label == l) {
            limits.push(EnergyLimit {
                label: l,
                energy_j: a.max_kinetic_energy.k_max_j,
            });
        }
    }
    if !risk.is_empty() {
        let f = risk_map(
            dir,
            "risk_map",
            "Risk: likelihood ρ vs severity K_x",
            &risk,
            &limits,
            CHI2_2DOF_95,
            axis,
        )?;
        let fit = if axis == EnergyAxis::Log10 {
            "bivariate normal fit of (ρ, log10 K_x), drawn on the log energy axis"
        } else {
            "bivariate normal fit of (ρ, K_x)"
        };
        html.figure(format!("Median (dot) and 95 % ellipse ({fit}) per scenario (solid: translation-dominant, dashed: rotation-dominant); horizontal lines: maximum kinetic energy of each robot over U."), &f)?;
        figures.push(f);
    }

    // First-2-s accelerations against the limit.
    html.section("Accelerations in the transient window");
    let acc: Vec<(String, Vec<f64>, Vec<f64>)> = items
        .iter()
        .map(|(log, a)| {
            let (ax, ay) = log.transient_acc_m_s2.clone();
            (label(a), ax, ay)
        })
        .collect();
    let limit = analyses.iter().find_map(|a| a.nominal.max_lin_acc_m_s2);
    let panels = vec![
        HistPanel {
            title: "longitudinal".into(),
            value: AxisLabel::new("ax", "m/s²"),
            limit,
            series: acc
                .iter()
                .map(|(l, x, _)| Samples::new(l.clone(), x.clone()))
                .collect(),
        },
        HistPanel {
            title: "lateral".into(),
            value: AxisLabel::new("ay", "m/s²"),
            limit: None,
            series: acc
                .iter()
                .map(|(l, _, y)| Samples::new(l.clone(), y.clone()))
                .collect(),
        },
    ];
    let f = histograms(
        dir,
        "transient_accelerations",
        "Body accelerations in the first 2 s of each step",
        &panels,
        40,
    )?;
    html.figure("Pose-derived body-frame accelerations over the transient window; dashed lines: the user acceleration limit where declared.", &f)?;
    figures.push(f);

    html.section("Sensor cross-check");
    for a in &analyses {
        let rows: Vec<KeyFigure> = a
            .crosscheck
            .verdicts
            .iter()
            .map(|v| KeyFigure::new(&v.sensor, verdict_text(&v.verdict), ""))
            .chain(std::iter::once(KeyFigure::new(
                "yaw-rate source used",
                format!("{:?}: {}", a.yaw_rate_source, a.crosscheck.yaw_rate_reason),
                "",
            )))
            .collect();
        html.table(format!("{}: sensor verdicts", a.dataset), &rows);
    }
    let html_path = html.write(dir)?;
    Ok(AnalysisReportFiles {
        summary: summary_path,
        transfer_functions: tf_path,
        html: html_path,
        figures,
    })
}

/// Kernel variances used for a robot's logs (the first of them).
fn panels_cov(analyses: &[&Analysis], robot: &str) -> (f64, f64) {
    analyses
        .iter()
        .find(|a| a.robot == robot)
        .map_or((f64::NAN, f64::NAN), |a| {
            (
                a.params.smoother.covariance.var_vx,
                a.params.smoother.covariance.var_wz,
            )
        })
}

fn verdict_text(v: &drive_sim_analysis::crosscheck::Verdict) -> String {
    use drive_sim_analysis::crosscheck::Verdict;
    match v {
        Verdict::Pass => "pass".into(),
        Verdict::Fault { description } => format!("FAULT: {description}"),
        Verdict::Inconclusive { description } => format!("inconclusive: {description}"),
    }
}

fn heat_panel(a: &Analysis, name: &str) -> Option<HeatPanel> {
    let tf = a.transfer.as_ref()?;
    let ch = tf.names.iter().position(|n| n == name)?;
    let g = &tf.grid;
    // The analysis grid and the figure grid share the layout (wz major, vx minor).
    let grid = Grid2 {
        vx_m_s: g.vx_m_s.clone(),
        wz_rad_s: g.wz_rad_s.clone(),
        values: tf.smoothed.values[ch]
            .iter()
            .map(|v| Some(*v).filter(|v| v.is_finite()))
            .collect(),
    };
    Some(HeatPanel {
        title: label(a),
        grid,
        command_space: a.nominal.command_space().polygon_body(),
    })
}

/// Risk scenarios: the analysis' own (ρ, J) fits on a linear axis for one robot; for several
/// robots, fits of (ρ, log10 K_x) from the steps (same motion classes), for a log axis.
fn risk_scenarios(analyses: &[&Analysis], log: bool) -> (Vec<RiskScenario>, EnergyAxis) {
    let mut out = vec![];
    for a in analyses {
        if !log {
            for r in &a.risk {
                out.push(RiskScenario {
                    label: format!("{} {}, {}", r.robot, r.terrain, motion_name(r.motion)),
                    colour_key: r.terrain.clone(),
                    median_rho: r.median_rho,
                    median_energy_j: r.median_k_x_j,
                    ellipse: r.ellipse.map(|e| RiskEllipse {
                        centre: e.center,
                        covariance: e.covariance,
                    }),
                    dashed: r.motion == MotionClass::Rotation,
                });
            }
            continue;
        }
        for class in [MotionClass::Translation, MotionClass::Rotation] {
            let pts: Vec<(f64, f64)> = a
                .steps
                .iter()
                .filter(|s| MotionClass::of(s.steady_rho.k_ut_j, s.steady_rho.k_urot_j) == Some(class))
                .map(|s| (s.steady_rho.rho, s.steady_rho.k_x_j))
                .filter(|p| p.0.is_finite() && p.1.is_finite() && p.1 > 0.0)
                .collect();
            if pts.is_empty() {
                continue;
            }
            let logs: Vec<(f64, f64)> = pts.iter().map(|p| (p.0, p.1.log10())).collect();
            out.push(RiskScenario {
                label: format!("{} {}, {}", a.robot, a.terrain, motion_name(class)),
                colour_key: a.terrain.clone(),
                median_rho: median(pts.iter().map(|p| p.0)),
                median_energy_j: 10f64.powf(median(logs.iter().map(|p| p.1))),
                ellipse: mean_cov(&logs),
                dashed: class == MotionClass::Rotation,
            });
        }
    }
    (
        out,
        if log {
            EnergyAxis::Log10
        } else {
            EnergyAxis::Linear
        },
    )
}

fn motion_name(m: MotionClass) -> &'static str {
    match m {
        MotionClass::Translation => "translation",
        MotionClass::Rotation => "rotation",
    }
}

fn median(v: impl Iterator<Item = f64>) -> f64 {
    let mut v: Vec<f64> = v.filter(|x| x.is_finite()).collect();
    v.sort_by(f64::total_cmp);
    super::stats::quantile_sorted(&v, 0.5).unwrap_or(f64::NAN)
}

/// Mean and sample covariance of 2-D points; `None` with fewer than 3.
fn mean_cov(p: &[(f64, f64)]) -> Option<RiskEllipse> {
    if p.len() < 3 {
        return None;
    }
    let n = p.len() as f64;
    let m = (
        p.iter().map(|q| q.0).sum::<f64>() / n,
        p.iter().map(|q| q.1).sum::<f64>() / n,
    );
    let (mut a, mut b, mut c) = (0.0, 0.0, 0.0);
    for q in p {
        a += (q.0 - m.0).powi(2);
        b += (q.0 - m.0) * (q.1 - m.1);
        c += (q.1 - m.1).powi(2);
    }
    let d = n - 1.0;
    Some(RiskEllipse {
        centre: m,
        covariance: [[a / d, b / d], [b / d, c / d]],
    })
}
