//! Overlaid histograms with ± limit lines (accelerations of the first 2 s of each step).

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::stats::{finite_values, histogram, quantile_sorted};
use super::style::{
    assign_colours, canvas_height, finite_extent, no_data, note_style, padded, render, title_legend_body,
    xy_chart, DrawResult, Figure, FigureFiles, LegendEntry, Swatch,
};
use super::{AxisLabel, Samples};
use crate::error::{Error, Result};
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// One histogram panel: one quantity, one overlaid histogram per series.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct HistPanel {
    /// Panel caption, e.g. `"longitudinal"`.
    pub title: String,
    /// The quantity on the x axis and its unit, e.g. `acceleration`, `m/s²`.
    pub value: AxisLabel,
    /// Symmetric limit drawn as red dashed lines at `±limit` (e.g. the manufacturer's
    /// acceleration limit); `None` = no line.
    pub limit: Option<f64>,
    /// One histogram per series (scenario), overlaid.
    pub series: Vec<Samples>,
}

/// Colour of the limit lines (the paper's red).
const LIMIT_COLOUR: RGBColor = RGBColor(220, 20, 20);
/// Quantiles of the pooled samples that the x axis covers.
const CENTRAL: (f64, f64) = (0.005, 0.995);
const PANEL_W: u32 = 500;
const PANEL_H: u32 = 440;

struct HistFig<'a> {
    title: &'a str,
    panels: &'a [HistPanel],
    colours: Vec<(String, RGBColor)>,
    legend: Vec<LegendEntry>,
    bins: usize,
}

impl HistFig<'_> {
    fn draw_panel<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>, p: &HistPanel) -> DrawResult {
        let lim = p.limit.filter(|l| l.is_finite()).map(f64::abs);
        // Axis over the central 99 % of the pooled samples (and the limits): a few outliers
        // (e.g. from differentiating a noisy pose) would otherwise squash every bar into one.
        let (mut pooled, _) = finite_values(
            &p.series
                .iter()
                .flat_map(|s| s.values.iter().copied())
                .collect::<Vec<_>>(),
        );
        pooled.sort_by(f64::total_cmp);
        let central = [
            quantile_sorted(&pooled, CENTRAL.0),
            quantile_sorted(&pooled, CENTRAL.1),
        ];
        let (lo, hi) = padded(
            central
                .into_iter()
                .flatten()
                .chain(lim.into_iter().flat_map(|l| [-l, l])),
        );
        let outside = pooled.iter().filter(|v| **v < lo || **v > hi).count();
        let w = (hi - lo) / self.bins as f64;
        let hists: Vec<(Vec<f64>, RGBColor)> = p
            .series
            .iter()
            .map(|s| {
                let (v, _) = finite_values(&s.values);
                let n = v.len().max(1) as f64;
                let frac = histogram(&v, lo, hi, self.bins)
                    .into_iter()
                    .map(|c| c as f64 / n)
                    .collect();
                let c = self
                    .colours
                    .iter()
                    .find(|(l, _)| *l == s.label)
                    .map_or(BLACK, |x| x.1);
                (frac, c)
            })
            .collect();
        let ymax = finite_extent(hists.iter().flat_map(|h| h.0.iter().copied())).map_or(0.0, |r| r.1);
        let ytop = if ymax > 0.0 { ymax * 1.1 } else { 1.0 };
        let mut ch = xy_chart(
            area,
            &p.title,
            (lo, hi),
            (0.0, ytop),
            &p.value.text(),
            "fraction of samples",
        )?;
        for (frac, c) in &hists {
            ch.draw_series(frac.iter().enumerate().filter(|(_, f)| **f > 0.0).map(|(i, &f)| {
                let x0 = lo + i as f64 * w;
                Rectangle::new([(x0, 0.0), (x0 + w, f)], c.mix(0.3).filled())
            }))?;
            // Step outline, so that overlaid series stay distinguishable.
            let mut step = vec![(lo, 0.0)];
            for (i, &f) in frac.iter().enumerate() {
                let x0 = lo + i as f64 * w;
                step.push((x0, f));
                step.push((x0 + w, f));
            }
            step.push((hi, 0.0));
            ch.draw_series(std::iter::once(PathElement::new(step, c.stroke_width(2))))?;
        }
        if let Some(l) = lim {
            for x in [-l, l] {
                ch.draw_series(DashedLineSeries::new(
                    vec![(x, 0.0), (x, ytop)],
                    8,
                    5,
                    LIMIT_COLOUR.stroke_width(3),
                ))?;
            }
        }
        if p.series.iter().all(|s| s.values.iter().all(|v| !v.is_finite())) {
            no_data(&mut ch, "")?;
        }
        if outside > 0 {
            ch.draw_series(std::iter::once(Text::new(
                format!("{outside} samples beyond the axis"),
                (hi - 0.02 * (hi - lo), ytop * 0.98),
                note_style().pos(Pos::new(HPos::Right, VPos::Top)),
            )))?;
        }
        Ok(())
    }
}

impl Figure for HistFig<'_> {
    fn size(&self) -> (u32, u32) {
        let w = PANEL_W * self.panels.len() as u32;
        (w, canvas_height(PANEL_H, w, &self.legend))
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult {
        let body = title_legend_body(root, self.title, &self.legend)?;
        let cells = body.split_evenly((1, self.panels.len()));
        for (p, cell) in self.panels.iter().zip(&cells) {
            self.draw_panel(cell, p)?;
        }
        Ok(())
    }
}

/// Draws histogram panels side by side into `<dir>/<stem>.svg|png`.
///
/// In each panel every series is a histogram of `bins` equal bins (as a fraction of that
/// series' finite samples, so series of different sizes compare) over the central 99 % of the
/// pooled samples and the limits; samples beyond the axis are counted in a note, drawn as a light fill with a
/// step outline in the series colour; the limit, if any, is two red dashed lines at ±limit.
/// Errors if there is no panel or `bins` is 0.
pub fn histograms(
    dir: &Path,
    stem: &str,
    title: &str,
    panels: &[HistPanel],
    bins: usize,
) -> Result<FigureFiles> {
    if panels.is_empty() {
        return Err(Error::NothingToDraw {
            figure: stem.to_string(),
            what: "histogram panel",
        });
    }
    if bins == 0 || bins > 10_000 {
        return Err(Error::InvalidFigure {
            figure: stem.to_string(),
            message: format!("bin count must be in 1..=10000, got {bins}"),
        });
    }
    let mut labels: Vec<String> = vec![];
    for s in panels.iter().flat_map(|p| &p.series) {
        if !labels.contains(&s.label) {
            labels.push(s.label.clone());
        }
    }
    let colours: Vec<(String, RGBColor)> = labels.iter().cloned().zip(assign_colours(&labels)).collect();
    let mut legend: Vec<LegendEntry> = colours
        .iter()
        .map(|(l, c)| LegendEntry::new(l.clone(), *c, Swatch::Square))
        .collect();
    if panels.iter().any(|p| p.limit.is_some_and(f64::is_finite)) {
        legend.push(LegendEntry::new("limit", LIMIT_COLOUR, Swatch::Dashed));
    }
    let skipped = panels
        .iter()
        .flat_map(|p| &p.series)
        .map(|s| finite_values(&s.values).1)
        .sum();
    render(
        dir,
        stem,
        &HistFig {
            title,
            panels,
            colours,
            legend,
            bins,
        },
        skipped,
    )
}
