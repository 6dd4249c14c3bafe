//! Figures and the HTML page of a calibration report (built with [`drive_sim_report`]).

use super::residual::{ResidualAnalysis, ResidualMap};
use super::stages::selection::SelectionRound;
use super::CalibrationReport;
use crate::error::Result;
use drive_sim_report::{
    bar_chart, box_plots, heat_maps, line_bands, AxisLabel, BandPoint, BandSeries, BarChart, BarSeries,
    BoxGroup, BoxPanel, ColourMap, ColourScale, FigureFiles, Grid2, HeatPanel, HtmlReport, KeyFigure,
    LineAxes,
};
use std::path::{Path, PathBuf};

/// Converts a residual map (rows = wz) to the report's grid (wz major, vx minor).
fn grid2(m: &ResidualMap) -> Grid2 {
    let mut values = Vec::with_capacity(m.vx_m_s.len() * m.wz_rad_s.len());
    for j in 0..m.wz_rad_s.len() {
        for i in 0..m.vx_m_s.len() {
            values.push(m.values.get(j).and_then(|row| row.get(i)).copied().flatten());
        }
    }
    Grid2 {
        vx_m_s: m.vx_m_s.clone(),
        wz_rad_s: m.wz_rad_s.clone(),
        values,
    }
}

fn time_series(label: &str, a: &ResidualAnalysis, c: usize) -> BandSeries {
    BandSeries {
        label: label.to_string(),
        points: a
            .time
            .t_s
            .iter()
            .zip(a.time.mean.iter().zip(&a.time.rms))
            .map(|(&t, (m, r))| {
                // Band: mean ± the standard deviation over steps (from mean and RMS).
                let sd = (r[c] * r[c] - m[c] * m[c]).max(0.0).sqrt();
                BandPoint {
                    x: t,
                    mean: m[c],
                    low: m[c] - sd,
                    high: m[c] + sd,
                }
            })
            .collect(),
    }
}

/// Draws the figures of a report into `dir`: residual maps over the command space (before and
/// after effects), residual over time in step, and per-step held-out scores.
pub fn write_figures(report: &CalibrationReport, dir: &Path) -> Result<Vec<(String, FigureFiles)>> {
    let mut out = Vec::new();
    // What the model lacks first: residual / floor per channel, declared and calibrated.
    if let (Some(b), Some(a)) = (&report.diagnosis_before, &report.diagnosis_after) {
        let chart = BarChart {
            categories: b.channels.iter().map(|c| c.channel.clone()).collect(),
            series: vec![
                BarSeries {
                    label: "declared model".into(),
                    values: b.channels.iter().map(|c| Some(c.ratio)).collect(),
                },
                BarSeries {
                    label: "calibrated model".into(),
                    values: b
                        .channels
                        .iter()
                        .map(|c| a.channel(&c.channel).map(|x| x.ratio))
                        .collect(),
                },
            ],
            value: AxisLabel::new("RMSE / noise floor", ""),
            log: true,
            references: vec![
                (super::diagnosis::STEADY_FLAG, "steady flag (2×)".into()),
                (
                    super::diagnosis::TRANSIENT_FLAG,
                    "transient / pose flag (3×)".into(),
                ),
            ],
        };
        let files = bar_chart(
            dir,
            "residual_vs_floor",
            &format!(
                "{}: residual / noise floor per channel, test steps",
                report.dataset
            ),
            &chart,
        )?;
        out.push((
            "What the model lacks: RMSE / noise floor per channel on the test steps, declared and calibrated model (1 = at the floor; flagged above 2 steady, 3 transient and pose).".into(),
            files,
        ));
    }
    let poly = report.model_before.robot.command_space().polygon_body();
    let units = ["m/s", "m/s", "rad/s"];
    let quantity = [
        "longitudinal velocity residual",
        "lateral velocity residual",
        "yaw-rate residual",
    ];
    for c in 0..3 {
        let (b, a) = (&report.residual_before.maps[c], &report.residual_after.maps[c]);
        let panels = [
            HeatPanel {
                title: "terrain-calibrated model".into(),
                grid: grid2(b),
                command_space: poly.clone(),
            },
            HeatPanel {
                title: "final model (with effects)".into(),
                grid: grid2(a),
                command_space: poly.clone(),
            },
        ];
        let scale = ColourScale {
            value: AxisLabel::new(format!("{} (measured − model)", quantity[c]), units[c]),
            map: ColourMap::Diverging,
            range: None,
        };
        let stem = format!("residual_map_{}", b.channel);
        let files = heat_maps(
            dir,
            &stem,
            &format!(
                "{}: steady-state {} over the command space, held-out steps",
                report.dataset, quantity[c]
            ),
            &panels,
            &scale,
            None,
        )?;
        out.push((
            format!(
                "Steady-state {} over the command space (kernel smoother, held-out steps).",
                quantity[c]
            ),
            files,
        ));
    }
    let names = ["vx", "wz", "left wheel", "right wheel"];
    let units = ["m/s", "rad/s", "rad/s", "rad/s"];
    for c in 0..4 {
        let series = [
            time_series("terrain-calibrated model", &report.residual_before, c),
            time_series("final model", &report.residual_after, c),
        ];
        let stem = format!("residual_time_{}", report.residual_before.time.channels[c]);
        let files = line_bands(
            dir,
            &stem,
            &format!(
                "{}: {} residual over the step (mean ± sd over held-out steps)",
                report.dataset, names[c]
            ),
            &LineAxes {
                x: AxisLabel::new("time in step", "s"),
                y: AxisLabel::new(format!("{} residual (measured − model)", names[c]), units[c]),
                log_x: false,
                log_y: false,
            },
            &series,
        )?;
        out.push((format!("{} residual against time in step.", names[c]), files));
    }
    let log_scores = |v: &[f64]| v.iter().map(|s| s.max(1e-6).log10()).collect::<Vec<f64>>();
    let files = box_plots(
        dir,
        "heldout_scores",
        &format!("{}: per-step held-out score (1 = noise floor)", report.dataset),
        &[BoxPanel {
            title: "held-out steps".into(),
            value: AxisLabel::new("log10 score", ""),
            groups: vec![
                BoxGroup::new("IDD", log_scores(&report.step_scores.idd)),
                BoxGroup::new("model before", log_scores(&report.step_scores.before)),
                BoxGroup::new("model after", log_scores(&report.step_scores.after)),
            ],
        }],
    )?;
    out.push((
        "Per-step held-out score, log10 (0 = at the noise floor).".into(),
        files,
    ));
    Ok(out)
}

/// Builds the HTML page of a report around already drawn figures and writes `report.html`.
pub fn write_html(
    report: &CalibrationReport,
    figures: &[(String, FigureFiles)],
    dir: &Path,
) -> Result<PathBuf> {
    let mut h = HtmlReport::new(format!("drive-sim calibrate: {}", report.dataset));
    let lacks = super::diagnosis::lacks_summary(report);
    if !lacks.is_empty() {
        let section = h.section("What the model lacks");
        for line in lacks {
            section.paragraph(line);
        }
    }
    summary_section(&mut h, report);
    let declared: Vec<String> = report
        .declared_effects
        .iter()
        .map(|d| {
            format!(
                "Declared effect `{}` (robot or terrain file), refit on this log — {}.",
                d.effect, d.verdict
            )
        })
        .collect();
    if !declared.is_empty() {
        let section = h.section("Declared effects");
        for line in declared {
            section.paragraph(line);
        }
    }
    let rows: Vec<KeyFigure> = report
        .table
        .iter()
        .map(|r| {
            KeyFigure::new(
                r.metric.clone(),
                format!(
                    "IDD {:.4} | before {:.4} | after {:.4} | floor {:.4}",
                    r.idd, r.sim_before, r.sim_after, r.floor
                ),
                r.unit.clone(),
            )
        })
        .collect();
    h.section("Before / after, held-out steps")
        .table("Errors against the recording", &rows);
    h.section("Fitted parameters")
        .table("Terrain / robot parameters and effects", &fitted_rows(report));
    for round in &report.rounds {
        round_section(&mut h, round);
    }
    h.section("Figures");
    for (caption, files) in figures {
        h.figure(caption.clone(), files)?;
    }
    h.section("Reproduce").paragraph(report.reproduce.clone());
    Ok(h.write(dir)?)
}

/// The summary: status, notes and the held-out scores.
fn summary_section(h: &mut HtmlReport, report: &CalibrationReport) {
    let effects = if report.effects.is_empty() {
        "none".to_string()
    } else {
        report
            .effects
            .iter()
            .map(|e| format!("{} = {:.4}", e.name.trim_start_matches("effect."), e.value))
            .collect::<Vec<_>>()
            .join(", ")
    };
    h.section("Summary")
        .paragraph(format!(
            "Model `{}` calibrated on {} training steps, every figure below on {} held-out steps \
             the fit never saw. Status: {}. {}",
            report.model_kind,
            report.train_steps.len(),
            report.heldout_steps.len(),
            if report.status.converged {
                "all optimizations converged"
            } else {
                "NOT all optimizations converged"
            },
            report.status.notes.join("; ")
        ))
        .table(
            "Held-out score (geometric mean over the 10 velocity channels of the pooled squared \
             error / noise floor²; 1 = noise floor)",
            &[
                KeyFigure::new("IDD", format!("{:.3}", report.idd.score), ""),
                KeyFigure::new("model before", format!("{:.3}", report.before.score), ""),
                KeyFigure::new(
                    "model after terrain fit",
                    format!("{:.3}", report.after_terrain.score),
                    "",
                ),
                KeyFigure::new("model after", format!("{:.3}", report.after.score), ""),
                KeyFigure::new(
                    "reduction before → after",
                    format!(
                        "{:.3} ± {:.3} (bootstrap SE)",
                        report.total_reduction, report.total_reduction_se
                    ),
                    "",
                ),
                KeyFigure::new("effects in the model", effects, ""),
            ],
        );
}

/// The base fit's parameters, then the effects'.
fn fitted_rows(report: &CalibrationReport) -> Vec<KeyFigure> {
    let mut fitted: Vec<KeyFigure> = report
        .terrain_fit
        .iter()
        .flat_map(|f| &f.params)
        .map(|p| {
            KeyFigure::new(
                p.name.clone(),
                format!(
                    "{:.4} (declared {}){}",
                    p.value,
                    p.initial.map_or("-".into(), |v| format!("{v:.4}")),
                    if p.at_bound { ", AT SEARCH BOUND" } else { "" }
                ),
                "",
            )
        })
        .collect();
    fitted.extend(report.effects.iter().map(|p| {
        KeyFigure::new(
            p.name.clone(),
            format!(
                "{:.4}{}",
                p.value,
                if p.at_bound { ", AT SEARCH BOUND" } else { "" }
            ),
            "",
        )
    }));
    fitted
}

/// One forward round's ranking of the candidates.
fn round_section(h: &mut HtmlReport, round: &SelectionRound) {
    let rows: Vec<KeyFigure> = round
        .ranking
        .iter()
        .map(|e| {
            KeyFigure::new(
                e.effect.clone(),
                format!(
                    "held-out reduction {:.3} ± {:.3}, share {:.2}{}; fitted {}",
                    e.reduction,
                    e.reduction_se,
                    e.share,
                    if e.significant { ", significant" } else { "" },
                    e.params
                        .iter()
                        .map(|p| format!("{}={:.4}", p.name.trim_start_matches("effect."), p.value))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
                "",
            )
        })
        .collect();
    h.section(format!(
        "Candidate effects, round {} (added: {})",
        round.round + 1,
        round.added.as_deref().unwrap_or("none")
    ))
    .table(
        "Each fitted alone on the training steps, judged on the held-out steps",
        &rows,
    );
}
