//! Risk map: likelihood (ρ) against severity (kinetic energy), one median point and 95 %
//! ellipse per scenario, with each robot's maximum flat-ground kinetic energy.

use std::path::Path;

use plotters::coord::{CoordTranslate, Shift};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::ellipse::ellipse_points;
use super::style::{
    canvas_height, finite_extent, note_style, outline_for, render, scenario_colour, title_legend_body, widen,
    xy_chart_scaled, DrawResult, Figure, FigureFiles, LegendEntry, ScaledAxis, Swatch,
};
use crate::error::{Error, Result};

/// One navigation scenario (robot, terrain, motion) on the risk map.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RiskScenario {
    /// Legend label, e.g. `"Warthog ice, motion 1"`.
    pub label: String,
    /// Label that decides the colour (the paper colours by terrain, e.g. `"ice"`).
    pub colour_key: String,
    /// Median unpredictability ρ (likelihood), dimensionless.
    pub median_rho: f64,
    /// Median measured kinetic energy (severity), J.
    pub median_energy_j: f64,
    /// The 95 % region of the scenario's distribution; `None` draws the median alone (e.g.
    /// fewer than 3 steps).
    pub ellipse: Option<RiskEllipse>,
    /// Dashed ellipse (the paper: dashed for rotation-dominant motion, solid for forward).
    pub dashed: bool,
}

/// A bivariate normal summary of a scenario: the ellipse `(p - c)ᵀ Σ⁻¹ (p - c) = chi2`.
///
/// Both are in the space of the energy axis: (ρ, E in J) for [`EnergyAxis::Linear`],
/// (ρ, log10(E / 1 J)) for [`EnergyAxis::Log10`]. The centre is the mean of that fit (the
/// paper's dot is the median, which a skewed distribution puts elsewhere).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RiskEllipse {
    /// Centre (mean ρ, mean energy or mean log10 energy).
    pub centre: (f64, f64),
    /// Covariance `[[var ρ, cov], [cov, var E]]`.
    pub covariance: [[f64; 2]; 2],
}

/// A horizontal reference line: a robot's maximum kinetic energy on flat ground.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct EnergyLimit {
    /// Label, e.g. `"Warthog max (IDD over U)"`; decides the colour.
    pub label: String,
    /// Energy, J.
    pub energy_j: f64,
}

/// How the severity (kinetic energy) axis is scaled.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum EnergyAxis {
    /// Linear axis in J; [`RiskEllipse`] is in (ρ, E in J).
    #[default]
    Linear,
    /// Logarithmic axis (robots of very different mass on one map: Husky about 40 J, Warthog
    /// about 6 kJ); [`RiskEllipse`] is then in (ρ, log10(E / 1 J)), and is drawn as an
    /// ellipse on the log axis.
    Log10,
}

/// A scenario with its ellipse outline (in J; empty without an ellipse) and colour.
type Placed<'a> = (&'a RiskScenario, Vec<(f64, f64)>, RGBColor);

struct RiskFig<'a> {
    title: &'a str,
    ellipses: Vec<Placed<'a>>,
    limits: Vec<(&'a EnergyLimit, RGBColor)>,
    x: (f64, f64),
    y: (f64, f64),
    axis: EnergyAxis,
    legend: Vec<LegendEntry>,
}

const W: u32 = 900;
const H: u32 = 620;
const X_DESC: &str = "likelihood: unpredictability ρ [-]";
const Y_DESC: &str = "severity: kinetic energy [J]";

impl RiskFig<'_> {
    /// Draws limits, ellipses and medians on a chart of any y scale.
    fn draw_content<DB: DrawingBackend, CT: CoordTranslate<From = (f64, f64)>>(
        &self,
        ch: &mut ChartContext<'_, DB, CT>,
    ) -> DrawResult {
        for (l, c) in &self.limits {
            ch.draw_series(std::iter::once(PathElement::new(
                vec![(self.x.0, l.energy_j), (self.x.1, l.energy_j)],
                c.stroke_width(3),
            )))?;
            ch.draw_series(std::iter::once(Text::new(
                format!("{} = {:.0} J", l.label, l.energy_j),
                (self.x.1 - 0.01 * (self.x.1 - self.x.0), l.energy_j),
                note_style().pos(Pos::new(HPos::Right, VPos::Bottom)),
            )))?;
        }
        for (s, pts, c) in self.ellipses.iter().filter(|e| !e.1.is_empty()) {
            let style = c.stroke_width(2);
            if s.dashed {
                ch.draw_series(DashedLineSeries::new(pts.iter().copied(), 8, 6, style))?;
            } else {
                ch.draw_series(std::iter::once(PathElement::new(pts.clone(), style)))?;
            }
        }
        for (s, _, c) in &self.ellipses {
            let p = (s.median_rho, s.median_energy_j);
            ch.draw_series(std::iter::once(Circle::new(p, 6, c.filled())))?;
            ch.draw_series(std::iter::once(Circle::new(
                p,
                6,
                outline_for(*c).stroke_width(1),
            )))?;
        }
        Ok(())
    }
}

impl Figure for RiskFig<'_> {
    fn size(&self) -> (u32, u32) {
        (W, canvas_height(H, W, &self.legend))
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult {
        let body = title_legend_body(root, self.title, &self.legend)?;
        let y = match self.axis {
            EnergyAxis::Linear => ScaledAxis::linear(self.y.0, self.y.1),
            EnergyAxis::Log10 => ScaledAxis::log(self.y.0, self.y.1),
        };
        let mut ch = xy_chart_scaled(
            &body,
            "",
            ScaledAxis::linear(self.x.0, self.x.1),
            y,
            X_DESC,
            Y_DESC,
        )?;
        self.draw_content(&mut ch)
    }
}

/// Draws the risk map into `<dir>/<stem>.svg|png`.
///
/// Each scenario: a dot at its median (ρ, kinetic energy) and, if given, the confidence
/// ellipse `(p - c)ᵀ Σ⁻¹ (p - c) = chi2` (`chi2` = [`super::CHI2_2DOF_95`] for 95 %), solid
/// or dashed; with [`EnergyAxis::Log10`] the ellipse is in (ρ, log10 E).
/// Each limit: a horizontal line with its label. Scenarios with a non-finite median (or a
/// non-positive one on a log axis) are skipped and counted. Errors if there is nothing to
/// draw, a covariance is not a valid covariance, or `chi2` is not positive.
pub fn risk_map(
    dir: &Path,
    stem: &str,
    title: &str,
    scenarios: &[RiskScenario],
    limits: &[EnergyLimit],
    chi2: f64,
    axis: EnergyAxis,
) -> Result<FigureFiles> {
    let log = axis == EnergyAxis::Log10;
    let mut skipped = 0;
    let mut ellipses = vec![];
    for s in scenarios {
        if !(s.median_rho.is_finite() && s.median_energy_j.is_finite()) || (log && s.median_energy_j <= 0.0) {
            skipped += 1;
            continue;
        }
        let mut pts = match &s.ellipse {
            Some(e) => {
                ellipse_points(e.centre, e.covariance, chi2, 120).map_err(|err| Error::InvalidFigure {
                    figure: stem.to_string(),
                    message: format!("scenario `{}`: {err}", s.label),
                })?
            }
            None => vec![],
        };
        if log {
            for p in &mut pts {
                p.1 = 10f64.powf(p.1);
            }
        }
        ellipses.push((s, pts, scenario_colour(&s.colour_key)));
    }
    let lims: Vec<(&EnergyLimit, RGBColor)> = limits
        .iter()
        .filter(|l| {
            let ok = l.energy_j.is_finite() && (!log || l.energy_j > 0.0);
            if !ok {
                skipped += 1;
            }
            ok
        })
        .map(|l| (l, scenario_colour(&l.label)))
        .collect();
    if ellipses.is_empty() && lims.is_empty() {
        return Err(Error::NothingToDraw {
            figure: stem.to_string(),
            what: "scenario or limit",
        });
    }
    let xs = ellipses
        .iter()
        .flat_map(|e| e.1.iter().map(|p| p.0).chain([e.0.median_rho]));
    let (x0, x1) = finite_extent(xs.chain([0.0, 1.0])).unwrap_or((0.0, 1.0));
    let ys: Vec<f64> = ellipses
        .iter()
        .flat_map(|e| e.1.iter().map(|p| p.1).chain([e.0.median_energy_j]))
        .chain(lims.iter().map(|l| l.0.energy_j))
        .collect();
    let y = if log {
        let (lo, hi) = finite_extent(ys.iter().copied().filter(|v| *v > 0.0)).unwrap_or((1.0, 10.0));
        let (lo, hi) = if hi > lo { (lo, hi) } else { (lo / 10.0, hi * 10.0) };
        (lo / 1.5, hi * 1.6)
    } else {
        let (y0, y1) = finite_extent(ys.iter().copied().chain([0.0])).unwrap_or((0.0, 1.0));
        let (y0, y1) = widen(y0, y1);
        (y0 - 0.03 * (y1 - y0), y1 + 0.08 * (y1 - y0))
    };
    let pad = 0.03 * (x1 - x0);
    let mut legend: Vec<LegendEntry> = vec![];
    for (s, _, c) in &ellipses {
        let sw = if s.dashed { Swatch::Dashed } else { Swatch::Line };
        legend.push(LegendEntry::new(s.label.clone(), *c, sw));
    }
    render(
        dir,
        stem,
        &RiskFig {
            title,
            ellipses,
            limits: lims,
            x: (x0 - pad, x1 + pad),
            y,
            axis,
            legend,
        },
        skipped,
    )
}
