//! Grouped bar charts: one value per category and series (residual / noise floor per channel,
//! before and after), on a log axis when the values span decades, with reference lines.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::style::{
    assign_colours, axis_desc_style, canvas_height, render, tick_style, title_legend_body, DrawResult,
    Figure, FigureFiles, LegendEntry, Swatch,
};
use super::AxisLabel;
use crate::error::{Error, Result};

/// One series of bars: a value per category (`None`: no bar).
#[derive(Debug, Clone, PartialEq)]
pub struct BarSeries {
    /// Legend label.
    pub label: String,
    /// One value per category, in the chart's category order.
    pub values: Vec<Option<f64>>,
}

/// A grouped bar chart.
#[derive(Debug, Clone, PartialEq)]
pub struct BarChart {
    /// Category labels, left to right.
    pub categories: Vec<String>,
    /// Series, drawn side by side within each category.
    pub series: Vec<BarSeries>,
    /// The value axis.
    pub value: AxisLabel,
    /// Logarithmic value axis.
    pub log: bool,
    /// Horizontal reference lines (value, label), dashed.
    pub references: Vec<(f64, String)>,
}

struct BarFig<'a> {
    title: &'a str,
    chart: &'a BarChart,
    colours: Vec<RGBColor>,
    legend: Vec<LegendEntry>,
    width: u32,
}

impl BarFig<'_> {
    fn range(&self) -> (f64, f64) {
        let vals = self
            .chart
            .series
            .iter()
            .flat_map(|s| s.values.iter().flatten().copied())
            .chain(self.chart.references.iter().map(|r| r.0))
            .filter(|v| v.is_finite() && (!self.chart.log || *v > 0.0));
        let (lo, hi) = vals.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
        if !lo.is_finite() {
            return (0.0, 1.0);
        }
        if self.chart.log {
            ((lo.log10().floor() - 0.1), (hi.log10().ceil() + 0.1))
        } else {
            // All zero (nothing failed, say): a unit axis rather than an empty one.
            (0.0_f64.min(lo), if hi > 0.0 { hi * 1.1 } else { 1.0 })
        }
    }

    fn draw_body<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> DrawResult {
        let n = self.chart.categories.len();
        let (y0, y1) = self.range();
        let log = self.chart.log;
        let y_desc = if log {
            format!("log10 {}", self.chart.value.text())
        } else {
            self.chart.value.text()
        };
        let mut chart = ChartBuilder::on(area)
            .margin(12)
            .x_label_area_size(150)
            .y_label_area_size(70)
            .build_cartesian_2d(0.0..n as f64, y0..y1)?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            // Category names are drawn below each group by hand: plotters places numeric
            // ticks where its own rounding puts them, which need not be the groups' centres.
            .x_labels(0)
            .y_label_style(tick_style())
            .y_desc(y_desc)
            .axis_desc_style(axis_desc_style())
            .draw()?;
        let below = if log { y0 } else { y0.min(0.0) };
        let label_style = tick_style()
            .transform(FontTransform::Rotate90)
            .pos(Pos::new(HPos::Left, VPos::Center));
        chart.draw_series(self.chart.categories.iter().enumerate().map(|(i, c)| {
            EmptyElement::at((i as f64 + 0.5, below)) + Text::new(c.clone(), (0, 6), label_style.clone())
        }))?;
        let k = self.chart.series.len().max(1) as f64;
        let width = 0.8 / k;
        let base = if log { y0 } else { 0.0 };
        for (s, (series, colour)) in self.chart.series.iter().zip(&self.colours).enumerate() {
            chart.draw_series(series.values.iter().enumerate().filter_map(|(i, v)| {
                let v = (*v)?;
                let y = if log {
                    if v <= 0.0 {
                        return None;
                    }
                    v.log10()
                } else {
                    v
                };
                let x0 = i as f64 + 0.1 + s as f64 * width;
                Some(Rectangle::new(
                    [(x0, base), (x0 + width * 0.9, y)],
                    colour.filled(),
                ))
            }))?;
        }
        for (v, label) in &self.chart.references {
            let y = if log { v.log10() } else { *v };
            chart.draw_series(DashedLineSeries::new(
                [(0.0, y), (n as f64, y)],
                6,
                4,
                BLACK.stroke_width(1),
            ))?;
            chart.draw_series(std::iter::once(Text::new(
                label.clone(),
                (n as f64 * 0.01, y),
                tick_style(),
            )))?;
        }
        Ok(())
    }
}

impl Figure for BarFig<'_> {
    fn size(&self) -> (u32, u32) {
        (self.width, canvas_height(520, self.width, &self.legend))
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult {
        root.fill(&WHITE)?;
        let body = title_legend_body(root, self.title, &self.legend)?;
        self.draw_body(&body)
    }
}

/// Draws a grouped bar chart into `<dir>/<stem>.svg|png`. Errors if there is no category or
/// no series, or a series does not have one value per category.
pub fn bar_chart(dir: &Path, stem: &str, title: &str, chart: &BarChart) -> Result<FigureFiles> {
    if chart.categories.is_empty() || chart.series.is_empty() {
        return Err(Error::NothingToDraw {
            figure: stem.to_string(),
            what: "bar",
        });
    }
    if let Some(s) = chart
        .series
        .iter()
        .find(|s| s.values.len() != chart.categories.len())
    {
        return Err(Error::InvalidFigure {
            figure: stem.to_string(),
            message: format!(
                "series `{}` has {} values for {} categories",
                s.label,
                s.values.len(),
                chart.categories.len()
            ),
        });
    }
    let labels: Vec<String> = chart.series.iter().map(|s| s.label.clone()).collect();
    let colours = assign_colours(&labels);
    let legend = labels
        .iter()
        .zip(&colours)
        .map(|(l, c)| LegendEntry::new(l.clone(), *c, Swatch::Square))
        .collect();
    let skipped = chart
        .series
        .iter()
        .flat_map(|s| &s.values)
        .filter(|v| v.is_some_and(|x| !x.is_finite()))
        .count();
    render(
        dir,
        stem,
        &BarFig {
            title,
            chart,
            colours,
            legend,
            width: (60 * chart.categories.len() as u32 * chart.series.len() as u32 + 200).max(640),
        },
        skipped,
    )
}
