//! The sections of `report.html` besides the risk map, each writing its figures.

use super::{label, Report};
use crate::error::Result;
use crate::findings::{self, Metric};
use crate::{
    box_plots, command_space_figure, heat_maps, histograms, value_scatter, AxisLabel, BoxPanel, ColourMap,
    ColourScale, CommandScenario, Comparison, Grid2, HeatPanel, HistPanel, KeyFigure, Samples, ScatterPanel,
    ValuePoint,
};
use drive_sim_analysis::{Analysis, StepResult};

/// The smoothed channels drawn as transfer functions: channel name in the analysis, quantity,
/// unit and contour spacing.
const TRANSFER_CHANNELS: [(&str, &str, &str, Option<f64>); 4] = [
    ("slip_vx_m_s", "longitudinal slip", "m/s", Some(0.2)),
    ("slip_vy_m_s", "lateral slip", "m/s", Some(0.1)),
    ("slip_wz_rad_s", "angular slip", "rad/s", Some(0.2)),
    ("rho", "ρ", "", Some(0.1)),
];

fn steady(a: &Analysis, f: impl Fn(&StepResult) -> f64) -> Vec<f64> {
    a.steps.iter().map(f).collect()
}

impl Report<'_> {
    /// One labelled sample set per dataset: `f` of every analysed step.
    fn groups(&self, f: &dyn Fn(&StepResult) -> f64) -> Vec<Samples> {
        self.analyses
            .iter()
            .map(|a| Samples::new(label(a), steady(a, f)))
            .collect()
    }

    /// First screen: what differs, one table with the datasets as columns, the key figure.
    pub(super) fn findings(&mut self) -> Result<()> {
        let metrics = findings::metrics(self.items);
        let datasets: Vec<String> = self.analyses.iter().map(|a| a.dataset.clone()).collect();
        let diffs = findings::differences(&metrics, &datasets);
        self.html.section("Findings");
        self.html
            .paragraph(findings::findings_paragraph(&metrics, &diffs, 4));
        self.key_figure_table(&metrics);
        self.html.paragraph(
            "Steady state = mean of the two steady windows of each step. Slip = commanded (nominal ideal \
             differential drive) minus realized, signed along the command (positive = slower than \
             commanded). Boxes: quartiles; whiskers: 2.5 and 97.5 %.",
        );
        self.html.paragraph(format!(
            "Yaw rate measured by: {}.",
            self.analyses
                .iter()
                .map(|a| format!("{} {:?}", a.dataset, a.yaw_rate_source))
                .collect::<Vec<_>>()
                .join("; ")
        ));
        self.rho_key_figure(&metrics, &datasets)
    }

    /// The headline figures, datasets as columns.
    fn key_figure_table(&mut self, metrics: &[Metric]) {
        self.html.comparison(Comparison {
            caption: "Key figures per dataset".into(),
            columns: self
                .analyses
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
    }

    /// The key figure: ρ of the steady state per dataset, with the boxes to compare named.
    fn rho_key_figure(&mut self, metrics: &[Metric], datasets: &[String]) -> Result<()> {
        let rho_panel = [BoxPanel {
            title: "steady state".into(),
            value: AxisLabel::new("ρ", ""),
            groups: self.groups(&|s| s.steady_rho.rho),
        }];
        let f = box_plots(
            self.dir,
            "rho_boxplot",
            "Unpredictability ρ per dataset",
            &rho_panel,
        )?;
        // Metric 0 is the median ρ: its two ends are the boxes to compare.
        let look = match findings::differences(&metrics[..1], datasets).first() {
            Some(d) if d.high.0 != d.low.0 => format!(
                " Compare the boxes of {} (median {:.3}, the least predictable) and {} (median {:.3}): a box high and wide means commands whose outcome cannot be told in advance.",
                d.high.0, d.high.1, d.low.0, d.low.1
            ),
            _ => String::new(),
        };
        self.add_figure(
            format!("Key figure: unpredictability ρ of the steady state of every step, per dataset (0: the robot does what the ideal differential drive predicts; 1: nothing of it).{look}"),
            f,
        )
    }

    /// Command spaces, one figure per robot (U differs).
    pub(super) fn command_spaces(&mut self) -> Result<()> {
        self.html
            .section("Command space U, sampled commands S, reached velocities T");
        for robot in self.robots.clone() {
            let of_robot: Vec<&Analysis> = self
                .analyses
                .iter()
                .copied()
                .filter(|a| a.robot == robot)
                .collect();
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
                self.dir,
                &format!("command_space_{robot}"),
                &format!("{robot}: U, S and T"),
                &space,
                &scenarios,
            )?;
            self.add_figure(format!("{robot}: command space U (outline), sampled commands S and reached steady-state velocities T, in the wheel frame W and the body frame B; lateral speed distribution."), f)?;
        }
        Ok(())
    }

    /// Slip box plots in the body and the wheel frame.
    pub(super) fn slip(&mut self) -> Result<()> {
        let panels = vec![
            BoxPanel {
                title: "longitudinal".into(),
                value: AxisLabel::new("slip vx", "m/s"),
                groups: self.groups(&|s| s.steady.slip_body.vx_m_s),
            },
            BoxPanel {
                title: "lateral".into(),
                value: AxisLabel::new("slip vy", "m/s"),
                groups: self.groups(&|s| s.steady.slip_body.vy_m_s),
            },
            BoxPanel {
                title: "angular".into(),
                value: AxisLabel::new("slip wz", "rad/s"),
                groups: self.groups(&|s| s.steady.slip_body.wz_rad_s),
            },
            BoxPanel {
                title: "left wheel".into(),
                value: AxisLabel::new("slip left", "rad/s"),
                groups: self.groups(&|s| s.steady.slip_wheels.left_rad_s),
            },
            BoxPanel {
                title: "right wheel".into(),
                value: AxisLabel::new("slip right", "rad/s"),
                groups: self.groups(&|s| s.steady.slip_wheels.right_rad_s),
            },
        ];
        self.html.section("Steady-state slip");
        let f = box_plots(
            self.dir,
            "slip_boxplots",
            "Steady-state slip (body and wheel frames)",
            &panels,
        )?;
        self.add_figure(
            "Steady-state slip per dataset in the body frame (vx, vy, wz) and the wheel frame (left, right). Look at where each dataset's boxes sit against zero: wheel slip far from zero while the body slip is large means the wheels spin without moving the body; a box that spans zero means the terrain neither slows nor speeds the robot on average.",
            f,
        )
    }

    /// ρ of every step at its commanded (vx, wz), one panel per dataset.
    pub(super) fn rho_over_commands(&mut self) -> Result<()> {
        self.html.section("Unpredictability ρ over the command space");
        let scatter: Vec<ScatterPanel> = self
            .analyses
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
            self.dir,
            "rho_command_space",
            "ρ over the command space",
            &scatter,
            &rho_scale,
        )?;
        self.add_figure("ρ of each step at its commanded (vx, wz). Look for where in the command space the colour turns yellow: the commands to avoid on that terrain (on grippy ground, turning on the spot; on ice, almost everywhere).", f)
    }

    /// Smoothed transfer functions, one figure per robot and channel: U and the slip
    /// magnitudes differ between robots.
    pub(super) fn transfer_functions(&mut self) -> Result<()> {
        self.html.section("Transfer functions (Gaussian kernel smoother)");
        for robot in self.robots.clone() {
            for channel in TRANSFER_CHANNELS {
                self.transfer_function(robot, channel)?;
            }
        }
        Ok(())
    }

    /// The figure of one channel of `robot`'s logs, if any of them has it.
    fn transfer_function(
        &mut self,
        robot: &str,
        (name, quantity, unit, spacing): (&str, &str, &str, Option<f64>),
    ) -> Result<()> {
        let panels: Vec<HeatPanel> = self
            .analyses
            .iter()
            .filter(|a| a.robot == robot)
            .filter_map(|a| heat_panel(a, name))
            .collect();
        if panels.is_empty() {
            return Ok(());
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
            self.dir,
            &stem,
            &format!("{robot}: transfer function of the {quantity}"),
            &panels,
            &scale,
            spacing,
        )?;
        let cov = panels_cov(&self.analyses, robot);
        self.add_figure(
            format!(
                "Smoothed steady-state {quantity} over U (kernel Σ = diag({}, {})), contour lines every {} {unit}.",
                cov.0,
                cov.1,
                spacing.unwrap_or(0.0)
            ),
            f,
        )
    }

    /// First-2-s accelerations against the limit.
    pub(super) fn transient_accelerations(&mut self) -> Result<()> {
        self.html.section("Accelerations in the transient window");
        let acc: Vec<(String, Vec<f64>, Vec<f64>)> = self
            .items
            .iter()
            .map(|(log, a)| {
                let (ax, ay) = log.transient_acc_m_s2.clone();
                (label(a), ax, ay)
            })
            .collect();
        let limit = self.analyses.iter().find_map(|a| a.nominal.max_lin_acc_m_s2);
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
            self.dir,
            "transient_accelerations",
            "Body accelerations in the first 2 s of each step",
            &panels,
            40,
        )?;
        self.add_figure("Pose-derived body-frame accelerations over the transient window; dashed lines: the user acceleration limit where declared.", f)
    }

    /// One table of sensor verdicts per dataset.
    pub(super) fn sensor_crosscheck(&mut self) {
        self.html.section("Sensor cross-check");
        for a in &self.analyses {
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
            self.html.table(format!("{}: sensor verdicts", a.dataset), &rows);
        }
    }
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
