//! The risk-map section of `report.html`: likelihood ρ against severity K_x per scenario.

use super::Report;
use crate::error::Result;
use crate::{risk_map, EnergyAxis, EnergyLimit, RiskEllipse, RiskScenario, CHI2_2DOF_95};
use drive_sim_analysis::risk::MotionClass;
use drive_sim_analysis::Analysis;

impl Report<'_> {
    /// The risk map, with each robot's maximum kinetic energy over U as a limit line; no
    /// figure when no scenario has a point.
    pub(super) fn risk_map(&mut self) -> Result<()> {
        self.html.section("Risk map");
        let (risk, axis) = risk_scenarios(&self.analyses, self.robots.len() > 1);
        let mut limits: Vec<EnergyLimit> = Vec::new();
        for a in &self.analyses {
            let l = format!("{} max (IDD over U)", a.robot);
            if !limits.iter().any(|x| x.label == l) {
                limits.push(EnergyLimit {
                    label: l,
                    energy_j: a.max_kinetic_energy.k_max_j,
                });
            }
        }
        if risk.is_empty() {
            return Ok(());
        }
        let f = risk_map(
            self.dir,
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
        self.add_figure(format!("Median (dot) and 95 % ellipse ({fit}) per scenario (solid: translation-dominant, dashed: rotation-dominant); horizontal lines: maximum kinetic energy of each robot over U."), f)
    }
}

/// Risk scenarios: the analysis' own (ρ, J) fits on a linear axis for one robot; for several
/// robots, fits of (ρ, log10 K_x) from the steps (same motion classes), for a log axis.
fn risk_scenarios(analyses: &[&Analysis], log: bool) -> (Vec<RiskScenario>, EnergyAxis) {
    let mut out = vec![];
    for a in analyses {
        if log {
            log_energy_scenarios(a, &mut out);
        } else {
            linear_energy_scenarios(a, &mut out);
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

/// The analysis' own (ρ, J) fits, appended to `out`.
fn linear_energy_scenarios(a: &Analysis, out: &mut Vec<RiskScenario>) {
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
}

/// Fits of (ρ, log10 K_x) from the steps of each motion class, appended to `out`.
fn log_energy_scenarios(a: &Analysis, out: &mut Vec<RiskScenario>) {
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

fn motion_name(m: MotionClass) -> &'static str {
    match m {
        MotionClass::Translation => "translation",
        MotionClass::Rotation => "rotation",
    }
}

fn median(v: impl Iterator<Item = f64>) -> f64 {
    let mut v: Vec<f64> = v.filter(|x| x.is_finite()).collect();
    v.sort_by(f64::total_cmp);
    crate::stats::quantile_sorted(&v, 0.5).unwrap_or(f64::NAN)
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
