//! Box-and-whisker panels (slips and ρ per terrain / dataset).

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::stats::{finite_values, BoxStats};
use super::style::{
    assign_colours, axis_desc_style, canvas_height, caption_style, fmt_tick, note_style, padded, render,
    tick_style, title_legend_body, DrawResult, Figure, FigureFiles, LegendEntry, Swatch,
};
use super::{AxisLabel, BoxGroup};
use crate::error::{Error, Result};

/// One panel of box plots: one quantity, one box per group.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BoxPanel {
    /// Panel caption, e.g. `"longitudinal"`.
    pub title: String,
    /// The quantity on the y axis and its unit.
    pub value: AxisLabel,
    /// One box per group, drawn left to right in this order.
    pub groups: Vec<BoxGroup>,
}

const MAX_COLS: usize = 3;

struct BoxFig<'a> {
    title: &'a str,
    panels: &'a [BoxPanel],
    colours: Vec<(String, RGBColor)>,
    legend: Vec<LegendEntry>,
    panel_w: u32,
    panel_h: u32,
}

impl BoxFig<'_> {
    fn colour(&self, label: &str) -> RGBColor {
        self.colours
            .iter()
            .find(|(l, _)| l == label)
            .map(|(_, c)| *c)
            .unwrap_or(BLACK)
    }

    fn draw_panel<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>, panel: &BoxPanel) -> DrawResult {
        let stats: Vec<Option<BoxStats>> = panel
            .groups
            .iter()
            .map(|g| BoxStats::from_values(&g.values))
            .collect();
        let (y0, y1) = padded(
            stats
                .iter()
                .flatten()
                .flat_map(|s| [s.whisker_low, s.whisker_high]),
        );
        // Room above the upper whiskers for the sample counts.
        let y1 = y1 + 0.06 * (y1 - y0);
        let n = panel.groups.len().max(1);
        let mut chart = ChartBuilder::on(area)
            .margin(12)
            .margin_right(20)
            .caption(&panel.title, caption_style())
            .x_label_area_size(40)
            .y_label_area_size(66)
            .build_cartesian_2d(-0.6..n as f64 - 0.4, y0..y1)?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(0)
            .light_line_style(WHITE.mix(0.0))
            .bold_line_style(BLACK.mix(0.08))
            .label_style(tick_style())
            .axis_desc_style(axis_desc_style())
            .y_desc(panel.value.text())
            .y_labels(7)
            .y_label_formatter(&fmt_tick)
            .draw()?;
        // Categorical x axis: group labels under each box (plotters' key-point axes cannot
        // take a label formatter).
        let base = area.get_base_pixel();
        for (i, g) in panel.groups.iter().enumerate() {
            let (px, py) = chart.backend_coord(&(i as f64, y0));
            let (px, py) = (px - base.0, py - base.1);
            area.draw(&PathElement::new(vec![(px, py), (px, py + 5)], BLACK))?;
            area.draw(&Text::new(
                g.label.clone(),
                (px, py + 9),
                tick_style().pos(Pos::new(HPos::Center, VPos::Top)),
            ))?;
        }
        // Zero line: slips and residuals are judged against it.
        if y0 < 0.0 && y1 > 0.0 {
            chart.draw_series(std::iter::once(PathElement::new(
                vec![(-0.6, 0.0), (n as f64 - 0.4, 0.0)],
                BLACK.mix(0.35).stroke_width(1),
            )))?;
        }
        let half = 0.3;
        for (i, (g, s)) in panel.groups.iter().zip(&stats).enumerate() {
            let x = i as f64;
            let Some(s) = s else {
                chart.draw_series(std::iter::once(Text::new(
                    "no data",
                    (x, (y0 + y1) / 2.0),
                    note_style().pos(Pos::new(HPos::Center, VPos::Center)),
                )))?;
                continue;
            };
            let fill = self.colour(&g.label);
            let line = BLACK.stroke_width(2);
            // Whiskers with caps.
            for (a, b) in [(s.whisker_low, s.q1), (s.q3, s.whisker_high)] {
                chart.draw_series(std::iter::once(PathElement::new(vec![(x, a), (x, b)], line)))?;
            }
            for w in [s.whisker_low, s.whisker_high] {
                chart.draw_series(std::iter::once(PathElement::new(
                    vec![(x - half / 2.0, w), (x + half / 2.0, w)],
                    line,
                )))?;
            }
            chart.draw_series(std::iter::once(Rectangle::new(
                [(x - half, s.q1), (x + half, s.q3)],
                fill.filled(),
            )))?;
            chart.draw_series(std::iter::once(Rectangle::new(
                [(x - half, s.q1), (x + half, s.q3)],
                line,
            )))?;
            // Thick black median: readable on the terrain colours and on the white "all" box.
            chart.draw_series(std::iter::once(PathElement::new(
                vec![(x - half, s.median), (x + half, s.median)],
                BLACK.stroke_width(4),
            )))?;
            chart.draw_series(std::iter::once(Text::new(
                format!("n={}", s.n),
                (x, s.whisker_high),
                note_style().pos(Pos::new(HPos::Center, VPos::Bottom)),
            )))?;
        }
        Ok(())
    }
}

impl Figure for BoxFig<'_> {
    fn size(&self) -> (u32, u32) {
        let cols = self.panels.len().min(MAX_COLS) as u32;
        let rows = self.panels.len().div_ceil(MAX_COLS) as u32;
        let w = cols * self.panel_w;
        (w, canvas_height(rows * self.panel_h, w, &self.legend))
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult {
        let body = title_legend_body(root, self.title, &self.legend)?;
        let cols = self.panels.len().min(MAX_COLS);
        let rows = self.panels.len().div_ceil(MAX_COLS);
        let cells = body.split_evenly((rows, cols));
        for (p, cell) in self.panels.iter().zip(&cells) {
            self.draw_panel(cell, p)?;
        }
        Ok(())
    }
}

/// Draws box-and-whisker panels (up to three per row) into `<dir>/<stem>.svg|png`.
///
/// Boxes span the quartiles, the thick line is the median, whiskers reach the 2.5 % and
/// 97.5 % quantiles (the paper's convention, after Cumming 2009), and `n=` gives the number of
/// finite samples. Groups are coloured by label ([`super::scenario_colour`]); a group labelled
/// `all` is white. Errors if there is no panel or no group at all.
pub fn box_plots(dir: &Path, stem: &str, title: &str, panels: &[BoxPanel]) -> Result<FigureFiles> {
    if panels.iter().all(|p| p.groups.is_empty()) {
        return Err(Error::NothingToDraw {
            figure: stem.to_string(),
            what: "box",
        });
    }
    let mut labels: Vec<String> = vec![];
    for g in panels.iter().flat_map(|p| &p.groups) {
        if !labels.contains(&g.label) {
            labels.push(g.label.clone());
        }
    }
    let colours: Vec<(String, RGBColor)> = labels.iter().cloned().zip(assign_colours(&labels)).collect();
    let legend = colours
        .iter()
        .map(|(l, c)| LegendEntry::new(l.clone(), *c, Swatch::Square))
        .collect();
    let max_groups = panels.iter().map(|p| p.groups.len()).max().unwrap_or(1) as u32;
    let skipped = panels
        .iter()
        .flat_map(|p| &p.groups)
        .map(|g| finite_values(&g.values).1)
        .sum();
    render(
        dir,
        stem,
        &BoxFig {
            title,
            panels,
            colours,
            legend,
            panel_w: (90 * max_groups + 110).max(420),
            panel_h: 460,
        },
        skipped,
    )
}
