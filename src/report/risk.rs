//! Risk map: likelihood (ρ) against severity (kinetic energy), one median point and 95 %
//! ellipse per scenario, with each robot's maximum flat-ground kinetic energy.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::ellipse::ellipse_points;
use super::style::{
    canvas_height, finite_extent, note_style, outline_for, render, scenario_colour, title_legend_body, widen,
    xy_chart, DrawResult, Figure, FigureFiles, LegendEntry, Swatch,
};
use crate::{Error, Result};

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
    /// Covariance of (ρ, energy J): `[[var ρ, cov], [cov, var E]]`.
    pub covariance: [[f64; 2]; 2],
    /// Dashed ellipse (the paper: dashed for rotation-dominant motion, solid for forward).
    pub dashed: bool,
}

/// A horizontal reference line: a robot's maximum kinetic energy on flat ground.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct EnergyLimit {
    /// Label, e.g. `"Warthog max (IDD over U)"`; decides the colour.
    pub label: String,
    /// Energy, J.
    pub energy_j: f64,
}

struct RiskFig<'a> {
    title: &'a str,
    ellipses: Vec<(&'a RiskScenario, Vec<(f64, f64)>, RGBColor)>,
    limits: Vec<(&'a EnergyLimit, RGBColor)>,
    x: (f64, f64),
    y: (f64, f64),
    legend: Vec<LegendEntry>,
}

const W: u32 = 900;
const H: u32 = 620;

impl Figure for RiskFig<'_> {
    fn size(&self) -> (u32, u32) {
        (W, canvas_height(H, W, &self.legend))
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult {
        let body = title_legend_body(root, self.title, &self.legend)?;
        let mut ch = xy_chart(
            &body,
            "",
            self.x,
            self.y,
            "likelihood: unpredictability ρ [-]",
            "severity: kinetic energy [J]",
        )?;
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
        for (s, pts, c) in &self.ellipses {
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

/// Draws the risk map into `<dir>/<stem>.svg|png`.
///
/// Each scenario: a dot at its median (ρ, kinetic energy) and the confidence ellipse
/// `(p - m)ᵀ Σ⁻¹ (p - m) = chi2` of its covariance (`chi2` = [`super::CHI2_2DOF_95`] for
/// 95 %), solid or dashed. Each limit: a horizontal line with its label. Scenarios with a
/// non-finite median are skipped and counted. Errors if there is nothing to draw, a covariance
/// is not a valid covariance, or `chi2` is not positive.
pub fn risk_map(
    dir: &Path,
    stem: &str,
    title: &str,
    scenarios: &[RiskScenario],
    limits: &[EnergyLimit],
    chi2: f64,
) -> Result<FigureFiles> {
    let mut skipped = 0;
    let mut ellipses = vec![];
    for s in scenarios {
        if !(s.median_rho.is_finite() && s.median_energy_j.is_finite()) {
            skipped += 1;
            continue;
        }
        let pts = ellipse_points((s.median_rho, s.median_energy_j), s.covariance, chi2, 120)
            .map_err(|e| Error::Report(format!("{stem}: scenario `{}`: {e}", s.label)))?;
        ellipses.push((s, pts, scenario_colour(&s.colour_key)));
    }
    let lims: Vec<(&EnergyLimit, RGBColor)> = limits
        .iter()
        .filter(|l| {
            let ok = l.energy_j.is_finite();
            if !ok {
                skipped += 1;
            }
            ok
        })
        .map(|l| (l, scenario_colour(&l.label)))
        .collect();
    if ellipses.is_empty() && lims.is_empty() {
        return Err(Error::Report(format!("{stem}: no scenario or limit to draw")));
    }
    let xs = ellipses.iter().flat_map(|e| e.1.iter().map(|p| p.0));
    let (x0, x1) = finite_extent(xs.chain([0.0, 1.0])).unwrap_or((0.0, 1.0));
    let ys = ellipses
        .iter()
        .flat_map(|e| e.1.iter().map(|p| p.1))
        .chain(lims.iter().map(|l| l.0.energy_j));
    let (y0, y1) = finite_extent(ys.chain([0.0])).unwrap_or((0.0, 1.0));
    let (y0, y1) = widen(y0, y1);
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
            y: (y0 - 0.03 * (y1 - y0), y1 + 0.08 * (y1 - y0)),
            legend,
        },
        skipped,
    )
}
