//! Line plots with error bands (error against number of steps, residual before/after).

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::style::{
    assign_colours, canvas_height, finite_extent, padded, render, title_legend_body, xy_chart, DrawResult,
    Figure, FigureFiles, LegendEntry, Swatch,
};
use super::AxisLabel;
use crate::{Error, Result};

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

struct LinesFig<'a> {
    title: &'a str,
    x: &'a AxisLabel,
    y: &'a AxisLabel,
    series: Vec<(String, Vec<BandPoint>, RGBColor)>,
    legend: Vec<LegendEntry>,
}

const W: u32 = 860;
const H: u32 = 540;

impl Figure for LinesFig<'_> {
    fn size(&self) -> (u32, u32) {
        (W, canvas_height(H, W, &self.legend))
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult {
        let body = title_legend_body(root, self.title, &self.legend)?;
        let pts = || self.series.iter().flat_map(|s| s.1.iter());
        let xr = {
            let (lo, hi) = finite_extent(pts().map(|p| p.x)).unwrap_or((0.0, 1.0));
            let (lo, hi) = super::style::widen(lo, hi);
            let m = 0.03 * (hi - lo);
            (lo - m, hi + m)
        };
        let yr = padded(pts().flat_map(|p| [p.low, p.high, p.mean]));
        let mut ch = xy_chart(&body, "", xr, yr, &self.x.text(), &self.y.text())?;
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

/// Draws mean lines with shaded bands (one colour per series) on one chart into
/// `<dir>/<stem>.svg|png`. Errors if there is no series or a band is inverted (`low > high`).
pub fn line_bands(
    dir: &Path,
    stem: &str,
    title: &str,
    x: &AxisLabel,
    y: &AxisLabel,
    series: &[BandSeries],
) -> Result<FigureFiles> {
    if series.is_empty() {
        return Err(Error::Report(format!("{stem}: no series to draw")));
    }
    let labels: Vec<&str> = series.iter().map(|s| s.label.as_str()).collect();
    let colours = assign_colours(&labels);
    let mut skipped = 0;
    let mut prepared = vec![];
    for (s, c) in series.iter().zip(colours) {
        let mut p: Vec<BandPoint> = s.points.iter().copied().filter(finite).collect();
        skipped += s.points.len() - p.len();
        if let Some(q) = p.iter().find(|q| q.low > q.high) {
            return Err(Error::Report(format!(
                "{stem}: series `{}`: band low {} > high {} at x = {}",
                s.label, q.low, q.high, q.x
            )));
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
            x,
            y,
            series: prepared,
            legend,
        },
        skipped,
    )
}
