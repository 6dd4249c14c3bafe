//! The paper's figures and an HTML report from analysed datasets: the glue between
//! [`crate::analysis::Analysis`] and the plain-input figure builders.
//!
//! Datasets are grouped by robot for the per-robot figures (command space, slips, ρ, transfer
//! functions), since U and the energy scale differ between robots; the risk map shows every
//! dataset, on a log energy axis when several robots are present.

use std::path::{Path, PathBuf};

use super::{
    box_plots, command_space_figure, heat_maps, risk_map, value_scatter, AxisLabel, BoxPanel, ColourMap,
    ColourScale, CommandScenario, EnergyAxis, EnergyLimit, FigureFiles, Grid2, HeatPanel, HtmlReport,
    KeyFigure, RiskEllipse, RiskScenario, Samples, ScatterPanel, ValuePoint, CHI2_2DOF_95,
};
use crate::analysis::risk::MotionClass;
use crate::analysis::{Analysis, StepResult};
use crate::{Error, Result};

/// One written figure and the caption it gets in the report.
#[derive(Debug, Clone, PartialEq)]
pub struct CaptionedFigure {
    /// Section of the report it belongs to.
    pub section: String,
    /// Caption.
    pub caption: String,
    /// The files.
    pub files: FigureFiles,
}

/// Label of a dataset in legends: `"<robot> <terrain>"`, or the dataset name when the
/// terrain is empty.
fn label(a: &Analysis) -> String {
    if a.terrain.is_empty() {
        a.dataset.clone()
    } else {
        format!("{} {}", a.robot, a.terrain)
    }
}

/// File-name-safe form of a name.
fn slug(s: &str) -> String {
    let s: String = s
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() {
                c.to_ascii_lowercase()
            } else {
                '_'
            }
        })
        .collect();
    if s.is_empty() {
        "robot".into()
    } else {
        s
    }
}

fn per_step(a: &Analysis, f: impl Fn(&StepResult) -> f64) -> Vec<f64> {
    a.steps.iter().map(f).collect()
}

/// Groups of one quantity per dataset, plus the pooled `all` group when there are several.
fn groups(sets: &[&Analysis], f: &dyn Fn(&StepResult) -> f64) -> Vec<Samples> {
    let mut g: Vec<Samples> = sets
        .iter()
        .map(|a| Samples::new(a.terrain.clone(), per_step(a, f)))
        .collect();
    if sets.len() > 1 {
        g.push(Samples::new(
            "all",
            sets.iter().flat_map(|a| per_step(a, f)).collect(),
        ));
    }
    g
}

/// The grid of the transfer-function field `name` of a dataset, if it was computed.
fn field(a: &Analysis, name: &str) -> Option<Result<Grid2>> {
    let t = a.transfer.as_ref()?;
    let k = t.names.iter().position(|n| n == name)?;
    let values = t.smoothed.values.get(k)?;
    Some(Grid2::from_nan_masked(
        t.grid.vx_m_s.clone(),
        t.grid.wz_rad_s.clone(),
        values,
    ))
}

/// Writes every figure that the analyses support into `dir` and returns them with captions.
///
/// Per robot: command space (U, S, T, lateral speed), slip box plots (vx, vy, wz, left,
/// right), ρ box plot, transfer-function heat maps of the longitudinal (contours every 0.2
/// m/s) and lateral (0.1 m/s) slips and of ρ, and ρ at each sampled command. For all: the risk
/// map. Errors if `analyses` is empty or a figure cannot be drawn.
pub fn analysis_figures(dir: &Path, analyses: &[Analysis]) -> Result<Vec<CaptionedFigure>> {
    if analyses.is_empty() {
        return Err(Error::Report("no analysed dataset to report".into()));
    }
    let mut robots: Vec<&str> = vec![];
    for a in analyses {
        if !robots.contains(&a.robot.as_str()) {
            robots.push(&a.robot);
        }
    }
    let mut out = vec![];
    let mut push = |section: &str, caption: String, files: FigureFiles| {
        out.push(CaptionedFigure {
            section: section.into(),
            caption,
            files,
        })
    };
    for robot in &robots {
        let sets: Vec<&Analysis> = analyses.iter().filter(|a| a.robot == *robot).collect();
        let space = sets[0].nominal.command_space();
        let rs = slug(robot);

        let scenarios: Vec<CommandScenario> = sets
            .iter()
            .map(|a| CommandScenario {
                label: a.terrain.clone(),
                commands: a.steps.iter().map(|s| s.steady.cmd_wheels).collect(),
                steady_wheels: a.steps.iter().map(|s| s.steady.realized_wheels).collect(),
                steady_body: a.steps.iter().map(|s| s.steady.realized_body).collect(),
            })
            .collect();
        let f = command_space_figure(
            dir,
            &format!("command_space_{rs}"),
            &format!("{robot}: command space U, sampled S, steady state T"),
            &space,
            &scenarios,
        )?;
        push(
            "Command space",
            format!(
                "{robot}: U (black), sampled commands S (orange) and steady-state velocities T \
                 (mean of the steady windows) with their convex hull, in the wheel frame W and \
                 the body frame B; right: distribution of the steady-state lateral speed."
            ),
            f,
        );

        let panel = |title: &str, q: &str, unit: &str, f: &dyn Fn(&StepResult) -> f64| BoxPanel {
            title: title.into(),
            value: AxisLabel::new(q, unit),
            groups: groups(&sets, f),
        };
        let slips = [
            panel("longitudinal", "slip vx", "m/s", &|s| s.steady.slip_body.vx_m_s),
            panel("lateral", "slip vy", "m/s", &|s| s.steady.slip_body.vy_m_s),
            panel("angular", "slip ωz", "rad/s", &|s| s.steady.slip_body.wz_rad_s),
            panel("left wheel", "slip ωl", "rad/s", &|s| {
                s.steady.slip_wheels.left_rad_s
            }),
            panel("right wheel", "slip ωr", "rad/s", &|s| {
                s.steady.slip_wheels.right_rad_s
            }),
        ];
        let f = box_plots(
            dir,
            &format!("slips_{rs}"),
            &format!("{robot}: steady-state slip"),
            &slips,
        )?;
        push(
            "Slip",
            format!(
                "{robot}: steady-state slip (command minus realized) per terrain. Boxes: \
                 quartiles; thick line: median; whiskers: 2.5 % and 97.5 % quantiles."
            ),
            f,
        );
        let f = box_plots(
            dir,
            &format!("rho_{rs}"),
            &format!("{robot}: unpredictability ρ"),
            &[panel("ρ", "unpredictability ρ", "", &|s| s.steady_rho.rho)],
        )?;
        push(
            "Unpredictability",
            format!("{robot}: ρ of the steady state per terrain (same box convention)."),
            f,
        );

        let poly = space.polygon_body();
        // (analysis field, file stem part, quantity, unit, colour map, range, contour spacing)
        let fields = [
            (
                "slip_vx_m_s",
                "vx",
                "longitudinal slip",
                "m/s",
                ColourMap::Diverging,
                None,
                Some(0.2),
            ),
            (
                "slip_vy_m_s",
                "vy",
                "lateral slip",
                "m/s",
                ColourMap::Diverging,
                None,
                Some(0.1),
            ),
            (
                "rho",
                "rho",
                "unpredictability ρ",
                "",
                ColourMap::Viridis,
                Some((0.0, 1.0)),
                None,
            ),
        ];
        for (name, short, q, unit, map, range, spacing) in fields {
            let mut panels = vec![];
            for a in &sets {
                if let Some(g) = field(a, name) {
                    panels.push(HeatPanel {
                        title: a.terrain.clone(),
                        grid: g?,
                        command_space: poly.clone(),
                    });
                }
            }
            if panels.is_empty() {
                continue;
            }
            let scale = ColourScale {
                value: AxisLabel::new(q, unit),
                map,
                range,
            };
            let f = heat_maps(
                dir,
                &format!("transfer_{short}_{rs}"),
                &format!("{robot}: {q} over the command space"),
                &panels,
                &scale,
                spacing,
            )?;
            let contours = spacing.map_or(String::new(), |s| format!(" Contour lines every {s} {unit}."));
            push(
                "Transfer functions",
                format!(
                    "{robot}: {q} smoothed over U (Gaussian kernel, {} grid points).{contours}",
                    panels[0].grid.values.len()
                ),
                f,
            );
        }

        let scatter: Vec<ScatterPanel> = sets
            .iter()
            .map(|a| ScatterPanel {
                title: a.terrain.clone(),
                points: a
                    .steps
                    .iter()
                    .map(|s| ValuePoint {
                        vx_m_s: s.steady.cmd_body.vx_m_s,
                        wz_rad_s: s.steady.cmd_body.wz_rad_s,
                        value: s.steady_rho.rho,
                    })
                    .collect(),
                command_space: poly.clone(),
            })
            .collect();
        let f = value_scatter(
            dir,
            &format!("rho_commands_{rs}"),
            &format!("{robot}: ρ at each sampled command"),
            &scatter,
            &ColourScale {
                value: AxisLabel::new("unpredictability ρ", ""),
                map: ColourMap::Viridis,
                range: Some((0.0, 1.0)),
            },
        )?;
        push(
            "Unpredictability",
            format!("{robot}: ρ of each step at its command."),
            f,
        );
    }

    let (scenarios, axis) = risk_scenarios(analyses, robots.len() > 1);
    let mut limits = vec![];
    for robot in &robots {
        if let Some(a) = analyses.iter().find(|a| a.robot == *robot) {
            limits.push(EnergyLimit {
                label: format!("{robot} max"),
                energy_j: a.max_kinetic_energy.k_max_j,
            });
        }
    }
    let f = risk_map(
        dir,
        "risk_map",
        "Risk: likelihood ρ vs severity (kinetic energy)",
        &scenarios,
        &limits,
        CHI2_2DOF_95,
        axis,
    )?;
    push(
        "Risk",
        format!(
            "Median (dot) and 95 % ellipse of a bivariate normal fit per robot, terrain and \
             motion (solid: translation-dominant commands, dashed: rotation-dominant){}; \
             horizontal lines: maximum kinetic energy over U on flat ground (IDD).",
            if axis == EnergyAxis::Log10 {
                ", fitted in (ρ, log10 E) on the log axis"
            } else {
                ""
            }
        ),
        f,
    );
    Ok(out)
}

/// Risk scenarios: the analysis' own (ρ, J) fits on a linear axis for one robot; for several
/// robots, fits of (ρ, log10 K_x) from the steps (same motion classes), for a log axis.
fn risk_scenarios(analyses: &[Analysis], log: bool) -> (Vec<RiskScenario>, EnergyAxis) {
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
                label: format!("{}, {}", label(a), motion_name(class)),
                colour_key: a.terrain.clone(),
                median_rho: median(pts.iter().map(|p| p.0)),
                median_energy_j: 10f64.powf(median(logs.iter().map(|p| p.1))),
                ellipse: mean_cov(&logs).map(|(centre, covariance)| RiskEllipse { centre, covariance }),
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
fn mean_cov(p: &[(f64, f64)]) -> Option<((f64, f64), [[f64; 2]; 2])> {
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
    Some((m, [[a / d, b / d], [b / d, c / d]]))
}

/// Writes the figures and `<dir>/report.html` (figures inline, key figures per dataset).
pub fn analysis_report(dir: &Path, title: &str, analyses: &[Analysis]) -> Result<PathBuf> {
    let mut figures = analysis_figures(dir, analyses)?;
    // One section per kind, in reading order (figures come robot by robot).
    let rank = |s: &str| {
        [
            "Command space",
            "Slip",
            "Unpredictability",
            "Transfer functions",
            "Risk",
        ]
        .iter()
        .position(|k| *k == s)
        .unwrap_or(usize::MAX)
    };
    figures.sort_by_key(|f| rank(&f.section));
    let mut r = HtmlReport::new(title);
    r.section("Datasets");
    r.paragraph(
        "Steady state = mean of the steady windows of each step; slips are command minus \
         realized; ρ per the paper with alignment penalties. Excluded steps are counted, not \
         drawn.",
    );
    for a in analyses {
        let n_steps = a.steps.len();
        let med_rho = median(a.steps.iter().map(|s| s.steady_rho.rho));
        r.table(
            format!("{} ({})", a.dataset, label(a)),
            &[
                KeyFigure::new("analysed steps", n_steps, ""),
                KeyFigure::new("excluded steps", a.exclusions.len(), ""),
                KeyFigure::new("median ρ", format!("{med_rho:.3}"), ""),
                KeyFigure::new(
                    "area of T (hull ∩ U) in B",
                    format!("{:.1}", a.spaces.t_area_pct_body),
                    "% of U",
                ),
                KeyFigure::new(
                    "largest |lateral speed|",
                    format!("{:.3}", a.spaces.lateral.max_abs_m_s),
                    "m/s",
                ),
                KeyFigure::new(
                    "IDD RMSE vx / vy / ωz",
                    format!(
                        "{:.3} / {:.3} / {:.3}",
                        a.idd_rmse.vx_m_s, a.idd_rmse.vy_m_s, a.idd_rmse.wz_rad_s
                    ),
                    "m/s, m/s, rad/s",
                ),
                KeyFigure::new(
                    "maximum kinetic energy over U",
                    format!("{:.0}", a.max_kinetic_energy.k_max_j),
                    "J",
                ),
            ],
        );
    }
    let mut current = String::new();
    for f in &figures {
        if f.section != current {
            r.section(f.section.clone());
            current = f.section.clone();
        }
        r.figure(f.caption.clone(), &f.files)?;
    }
    r.write(dir)
}
