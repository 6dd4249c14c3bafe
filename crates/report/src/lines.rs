//! Line plots with error bands (error against number of steps, residual before/after).

use std::path::Path;

use plotters::coord::{CoordTranslate, Shift};
use plotters::prelude::*;

use super::style::{
    assign_colours, canvas_height, finite_extent, padded, render, title_legend_body, xy_chart_scaled,
    DrawResult, Figure, FigureFiles, LegendEntry, ScaledAxis, Swatch,
};
use super::AxisLabel;
use crate::error::{Error, Result};

/// One point of a series: the central value and its band at `x`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct BandPoint {
    /// Abscissa (e.g. number of DRIVE steps).
    pub x: f64,
    /// Central value (mean or median).
    pub mean: f64,
    /// Lower edge of the band (e.g. mean − 1 sd, or the 2.5 % quantile).
    pub low: f64,
    /// Upper edge of the band.
    pub high: f64,
}

/// A labelled series of band points; drawn in ascending `x`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BandSeries {
    /// Series label (decides the colour).
    pub label: String,
    /// Points; those with a non-finite field are skipped and counted.
    pub points: Vec<BandPoint>,
}

fn finite(p: &BandPoint) -> bool {
    p.x.is_finite() && p.mean.is_finite() && p.low.is_finite() && p.high.is_finite()
}

/// Axis labels and scales of a line plot.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LineAxes {
    /// Abscissa quantity and unit.
    pub x: AxisLabel,
    /// Ordinate quantity and unit.
    pub y: AxisLabel,
    /// Logarithmic x axis (points with `x <= 0` are skipped and counted).
    pub log_x: bool,
    /// Logarithmic y axis (points with `low <= 0` are skipped and counted).
    pub log_y: bool,
}

struct LinesFig<'a> {
    title: &'a str,
    axes: &'a LineAxes,
    series: Vec<(String, Vec<BandPoint>, RGBColor)>,
    legend: Vec<LegendEntry>,
}

const W: u32 = 860;
const H: u32 = 540;

impl LinesFig<'_> {
    fn draw_content<DB: DrawingBackend, CT: CoordTranslate<From = (f64, f64)>>(
        &self,
        ch: &mut ChartContext<'_, DB, CT>,
    ) -> DrawResult {
        for (_, p, c) in &self.series {
            if p.len() >= 2 {
                let mut band: Vec<(f64, f64)> = p.iter().map(|q| (q.x, q.high)).collect();
                band.extend(p.iter().rev().map(|q| (q.x, q.low)));
                ch.draw_series(std::iter::once(Polygon::new(band, c.mix(0.2))))?;
            } else {
                // A single point: an error bar instead of a band.
                ch.draw_series(
                    p.iter()
                        .map(|q| PathElement::new(vec![(q.x, q.low), (q.x, q.high)], c.stroke_width(2))),
                )?;
            }
        }
        for (_, p, c) in &self.series {
            ch.draw_series(std::iter::once(PathElement::new(
                p.iter().map(|q| (q.x, q.mean)).collect::<Vec<_>>(),
                c.stroke_width(3),
            )))?;
            ch.draw_series(p.iter().map(|q| Circle::new((q.x, q.mean), 4, c.filled())))?;
        }
        Ok(())
    }
}

/// Axis range over positive finite values with a multiplicative margin (log axes).
fn log_range(values: impl IntoIterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = finite_extent(values.into_iter().filter(|v| *v > 0.0)).unwrap_or((1.0, 10.0));
    let (lo, hi) = if hi > lo { (lo, hi) } else { (lo / 2.0, hi * 2.0) };
    let m = (hi / lo).powf(0.04);
    (lo / m, hi * m)
}

impl Figure for LinesFig<'_> {
    fn size(&self) -> (u32, u32) {
        (W, canvas_height(H, W, &self.legend))
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult {
        let body = title_legend_body(root, self.title, &self.legend)?;
        let pts = || self.series.iter().flat_map(|s| s.1.iter());
        let (x0, x1) = if self.axes.log_x {
            log_range(pts().map(|p| p.x))
        } else {
            let (lo, hi) = finite_extent(pts().map(|p| p.x)).unwrap_or((0.0, 1.0));
            let (lo, hi) = super::style::widen(lo, hi);
            let m = 0.03 * (hi - lo);
            (lo - m, hi + m)
        };
        let (y0, y1) = if self.axes.log_y {
            log_range(pts().flat_map(|p| [p.low, p.high, p.mean]))
        } else {
            padded(pts().flat_map(|p| [p.low, p.high, p.mean]))
        };
        let axis = |log: bool, lo: f64, hi: f64| {
            if log {
                ScaledAxis::log(lo, hi)
            } else {
                ScaledAxis::linear(lo, hi)
            }
        };
        let mut ch = xy_chart_scaled(
            &body,
            "",
            axis(self.axes.log_x, x0, x1),
            axis(self.axes.log_y, y0, y1),
            &self.axes.x.text(),
            &self.axes.y.text(),
        )?;
        self.draw_content(&mut ch)
    }
}

/// Draws mean lines with shaded bands (one colour per series) on one chart into
/// `<dir>/<stem>.svg|png`, with linear or logarithmic axes. Points with a non-finite field, or
/// not positive on a log axis, are skipped and counted. Errors if there is no series or a
/// band is inverted (`low > high`).
pub fn line_bands(
    dir: &Path,
    stem: &str,
    title: &str,
    axes: &LineAxes,
    series: &[BandSeries],
) -> Result<FigureFiles> {
    if series.is_empty() {
        return Err(Error::NothingToDraw {
            figure: stem.to_string(),
            what: "series",
        });
    }
    let labels: Vec<&str> = series.iter().map(|s| s.label.as_str()).collect();
    let colours = assign_colours(&labels);
    let mut skipped = 0;
    let mut prepared = vec![];
    for (s, c) in series.iter().zip(colours) {
        let mut p: Vec<BandPoint> = s
            .points
            .iter()
            .copied()
            .filter(finite)
            .filter(|q| (!axes.log_x || q.x > 0.0) && (!axes.log_y || q.low > 0.0))
            .collect();
        skipped += s.points.len() - p.len();
        if let Some(q) = p.iter().find(|q| q.low > q.high) {
            return Err(Error::InvalidFigure {
                figure: stem.to_string(),
                message: format!(
                    "series `{}`: band low {} > high {} at x = {}",
                    s.label, q.low, q.high, q.x
                ),
            });
        }
        p.sort_by(|a, b| a.x.total_cmp(&b.x));
        prepared.push((s.label.clone(), p, c));
    }
    let legend = prepared
        .iter()
        .map(|(l, _, c)| LegendEntry::new(l.clone(), *c, Swatch::Line))
        .collect();
    render(
        dir,
        stem,
        &LinesFig {
            title,
            axes,
            series: prepared,
            legend,
        },
        skipped,
    )
}
