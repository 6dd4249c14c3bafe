//! Values over the body-frame command space: heat maps with contour lines (transfer
//! functions, ρ on a grid) and coloured scatter of per-command values.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::contour::{contour_levels, contour_polylines, Grid2};
use super::style::{
    axis_desc_style, closed, finite_extent, fmt_tick, render, tick_style, title_legend_body, xy_chart,
    ColourMap, DrawResult, Figure, FigureFiles, LegendEntry, Swatch, XyChart,
};
use super::AxisLabel;
use crate::error::{Error, Result};

/// How values become colours, shared by all panels of a figure (so panels compare).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ColourScale {
    /// The quantity shown by colour and its unit (colour bar label).
    pub value: AxisLabel,
    /// Colour map.
    pub map: ColourMap,
    /// Value range mapped onto the colour map; `None` = from the data (symmetric about zero
    /// for [`ColourMap::Diverging`]). Values outside are clamped to the end colours.
    pub range: Option<(f64, f64)>,
}

/// One heat-map panel: a grid of values over (vx, wz), e.g. one terrain's transfer function.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct HeatPanel {
    /// Panel caption, e.g. `"ice"`.
    pub title: String,
    /// The values; `None` grid points are left blank.
    pub grid: Grid2,
    /// U in the body frame as `(vx_m_s, wz_rad_s)` vertices (as
    /// [`CommandSpace::polygon_body`](drive_sim_model::kinematics::CommandSpace::polygon_body) gives
    /// them); drawn as an outline, and grid points outside it are blanked. Empty = none.
    pub command_space: Vec<(f64, f64)>,
}

/// A value at one command (e.g. ρ of one DRIVE step at its commanded body velocity).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ValuePoint {
    /// Commanded longitudinal speed, m/s.
    pub vx_m_s: f64,
    /// Commanded yaw rate, rad/s.
    pub wz_rad_s: f64,
    /// The value shown by colour.
    pub value: f64,
}

/// One coloured-scatter panel.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ScatterPanel {
    /// Panel caption.
    pub title: String,
    /// The points; non-finite ones are skipped and counted.
    pub points: Vec<ValuePoint>,
    /// U in the body frame as `(vx_m_s, wz_rad_s)` vertices; empty = none.
    pub command_space: Vec<(f64, f64)>,
}

const PANEL_W: u32 = 500;
const PANEL_H: u32 = 480;
const BAR_W: u32 = 180;

/// True if `p = (vx, wz)` is inside the polygon or on its border (relative tolerance 1e-9).
fn in_polygon(poly: &[(f64, f64)], p: (f64, f64)) -> bool {
    let n = poly.len();
    if n < 3 {
        return true;
    }
    let scale = poly
        .iter()
        .fold(0.0f64, |m, q| m.max(q.0.abs()).max(q.1.abs()))
        .max(1.0);
    let tol = 1e-9 * scale;
    let mut inside = false;
    for i in 0..n {
        let (a, b) = (poly[i], poly[(i + 1) % n]);
        // On the edge: distance from p to segment ab below tolerance.
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        let len2 = dx * dx + dy * dy;
        let t = if len2 > 0.0 {
            (((p.0 - a.0) * dx + (p.1 - a.1) * dy) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let (cx, cy) = (a.0 + t * dx - p.0, a.1 + t * dy - p.1);
        if (cx * cx + cy * cy).sqrt() <= tol {
            return true;
        }
        if (a.1 > p.1) != (b.1 > p.1) {
            let x = a.0 + (p.1 - a.1) / (b.1 - a.1) * (b.0 - a.0);
            if p.0 < x {
                inside = !inside;
            }
        }
    }
    inside
}

/// True if the polygon is convex (all turns the same way), so that it can clip cells.
fn is_convex(poly: &[(f64, f64)]) -> bool {
    let n = poly.len();
    if n < 3 {
        return false;
    }
    let mut sign = 0.0f64;
    for i in 0..n {
        let (a, b, c) = (poly[i], poly[(i + 1) % n], poly[(i + 2) % n]);
        let cross = (b.0 - a.0) * (c.1 - b.1) - (b.1 - a.1) * (c.0 - b.0);
        if cross.abs() < 1e-15 {
            continue;
        }
        if sign == 0.0 {
            sign = cross.signum();
        } else if cross.signum() != sign {
            return false;
        }
    }
    sign != 0.0
}

/// The grid with points outside `poly` masked.
fn masked(grid: &Grid2, poly: &[(f64, f64)]) -> Grid2 {
    let mut g = grid.clone();
    let nv = g.vx_m_s.len();
    for (k, v) in g.values.iter_mut().enumerate() {
        let (i, j) = (k % nv, k / nv);
        let inside = match (grid.vx_m_s.get(i), grid.wz_rad_s.get(j)) {
            (Some(&vx), Some(&wz)) => in_polygon(poly, (vx, wz)),
            _ => false,
        };
        if !inside || !v.is_some_and(f64::is_finite) {
            *v = None;
        }
    }
    g
}

/// Cell edges around each node of an axis: midpoints between nodes, half a step beyond the
/// ends (±0.05 for a single node).
fn cell_edges(axis: &[f64]) -> Vec<(f64, f64)> {
    let n = axis.len();
    (0..n)
        .map(|i| {
            let lo = if i > 0 {
                (axis[i - 1] + axis[i]) / 2.0
            } else if n > 1 {
                axis[0] - (axis[1] - axis[0]) / 2.0
            } else {
                axis[0] - 0.05
            };
            let hi = if i + 1 < n {
                (axis[i] + axis[i + 1]) / 2.0
            } else if n > 1 {
                axis[n - 1] + (axis[n - 1] - axis[n - 2]) / 2.0
            } else {
                axis[0] + 0.05
            };
            (lo, hi)
        })
        .collect()
}

/// Colour-map position rounded to one of 96 levels: invisible banding, and runs of equal
/// colour that merge into one SVG rectangle.
fn quantize(t: f64) -> f64 {
    (t.clamp(0.0, 1.0) * 95.0).round() / 95.0
}

/// Normalized position of `v` in `range`.
fn norm(v: f64, range: (f64, f64)) -> f64 {
    (v - range.0) / (range.1 - range.0)
}

/// Draws the colour bar (with optional tick lines at the contour levels) in `area`.
fn colour_bar<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    scale: &ColourScale,
    range: (f64, f64),
    levels: &[f64],
) -> DrawResult {
    let (_, h) = area.dim_in_pixel();
    let mut chart = ChartBuilder::on(area)
        .margin_top(50)
        .margin_bottom(((h as f64) * 0.12) as u32)
        .margin_left(8)
        .margin_right(36)
        .right_y_label_area_size(96)
        .build_cartesian_2d(0.0..1.0, range.0..range.1)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .label_style(tick_style())
        .axis_desc_style(axis_desc_style())
        .y_desc(scale.value.text())
        .y_labels(7)
        .y_label_formatter(&fmt_tick)
        .draw()?;
    let steps = 128;
    let d = (range.1 - range.0) / steps as f64;
    chart.draw_series((0..steps).map(|k| {
        let v0 = range.0 + k as f64 * d;
        Rectangle::new(
            [(0.0, v0), (1.0, v0 + d)],
            scale.map.at((k as f64 + 0.5) / steps as f64).filled(),
        )
    }))?;
    chart.draw_series(
        levels
            .iter()
            .map(|&l| PathElement::new(vec![(0.0, l), (1.0, l)], BLACK.stroke_width(1))),
    )?;
    chart.draw_series(std::iter::once(Rectangle::new(
        [(0.0, range.0), (1.0, range.1)],
        BLACK.stroke_width(1),
    )))?;
    Ok(())
}

/// Axis ranges (wz, vx) covering the polygons and the points given, with a margin.
fn body_ranges(
    polys: impl Iterator<Item = (f64, f64)> + Clone,
    pts: impl Iterator<Item = (f64, f64)> + Clone,
) -> ((f64, f64), (f64, f64)) {
    let pad = |r: Option<(f64, f64)>| {
        let (lo, hi) = super::style::widen(r.map_or(-1.0, |r| r.0), r.map_or(1.0, |r| r.1));
        let m = 0.05 * (hi - lo);
        (lo - m, hi + m)
    };
    let all = polys.chain(pts);
    let vx = pad(finite_extent(all.clone().map(|p| p.0)));
    let wz = pad(finite_extent(all.map(|p| p.1)));
    (wz, vx)
}

fn u_outline<DB: DrawingBackend>(ch: &mut XyChart<'_, DB>, poly: &[(f64, f64)]) -> DrawResult {
    if poly.len() >= 3 {
        let pts: Vec<(f64, f64)> = closed(poly).into_iter().map(|(vx, wz)| (wz, vx)).collect();
        ch.draw_series(std::iter::once(PathElement::new(pts, BLACK.stroke_width(2))))?;
    }
    Ok(())
}

/// Panel title, masked grid and U outline.
type PreparedPanel = (String, Grid2, Vec<(f64, f64)>);

struct HeatFig<'a> {
    title: &'a str,
    panels: Vec<PreparedPanel>,
    scale: &'a ColourScale,
    range: (f64, f64),
    levels: Vec<f64>,
    legend: Vec<LegendEntry>,
}

impl Figure for HeatFig<'_> {
    fn size(&self) -> (u32, u32) {
        let w = PANEL_W * self.panels.len() as u32 + BAR_W;
        (w, super::style::canvas_height(PANEL_H, w, &self.legend))
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult {
        let body = title_legend_body(root, self.title, &self.legend)?;
        let (plots, bar) = body.split_horizontally(PANEL_W * self.panels.len() as u32);
        let cells = plots.split_evenly((1, self.panels.len()));
        for ((title, grid, poly), cell) in self.panels.iter().zip(&cells) {
            let (xr, yr) = body_ranges(
                poly.iter().copied(),
                grid.vx_m_s
                    .iter()
                    .flat_map(|&vx| grid.wz_rad_s.iter().map(move |&wz| (vx, wz))),
            );
            let mut ch = xy_chart(
                cell,
                title,
                xr,
                yr,
                "commanded yaw rate ωz [rad/s]",
                "commanded longitudinal speed vx [m/s]",
            )?;
            let ex = cell_edges(&grid.wz_rad_s);
            let ey = cell_edges(&grid.vx_m_s);
            let nv = grid.vx_m_s.len();
            // U in plot coordinates (wz, vx): cells are clipped to it when it is convex, so
            // that no colour leaks outside the outline.
            let clip: Option<Vec<(f64, f64)>> =
                is_convex(poly).then(|| poly.iter().map(|&(vx, wz)| (wz, vx)).collect());
            let mut rects = vec![];
            let mut clipped = vec![];
            // Rows of constant vx run along the x (wz) axis: consecutive cells of the same
            // (quantized) colour become one rectangle, which keeps the SVG small.
            for (i, &(y0, y1)) in ey.iter().enumerate() {
                let mut run: Option<(usize, usize, RGBColor)> = None;
                let flush = |run: &mut Option<(usize, usize, RGBColor)>, rects: &mut Vec<_>| {
                    if let Some((j0, j1, c)) = run.take() {
                        rects.push(Rectangle::new([(ex[j0].0, y0), (ex[j1].1, y1)], c.filled()));
                    }
                };
                for (j, &(x0, x1)) in ex.iter().enumerate() {
                    let Some(v) = grid.values[j * nv + i] else {
                        flush(&mut run, &mut rects);
                        continue;
                    };
                    let colour = self.scale.map.at(quantize(norm(v, self.range)));
                    let corners = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)];
                    if let Some(c) = &clip {
                        if !corners.iter().all(|&(x, y)| in_polygon(poly, (y, x))) {
                            flush(&mut run, &mut rects);
                            let p = drive_sim_model::geometry::clip_convex(&corners, c);
                            if p.len() >= 3 {
                                clipped.push(Polygon::new(p, colour.filled()));
                            }
                            continue;
                        }
                    }
                    match &mut run {
                        Some((_, j1, c)) if *c == colour && *j1 + 1 == j => *j1 = j,
                        _ => {
                            flush(&mut run, &mut rects);
                            run = Some((j, j, colour));
                        }
                    }
                }
                flush(&mut run, &mut rects);
            }
            ch.draw_series(rects)?;
            ch.draw_series(clipped)?;
            for &level in &self.levels {
                let lines =
                    contour_polylines(grid, level).map_err(|e| super::style::DrawError(e.to_string()))?;
                let style = if level == 0.0 {
                    BLACK.stroke_width(2)
                } else {
                    BLACK.mix(0.85).stroke_width(1)
                };
                ch.draw_series(lines.into_iter().map(|l| {
                    PathElement::new(l.into_iter().map(|(vx, wz)| (wz, vx)).collect::<Vec<_>>(), style)
                }))?;
            }
            u_outline(&mut ch, poly)?;
            if grid.values.iter().all(Option::is_none) {
                super::style::no_data(&mut ch, " inside U")?;
            }
        }
        colour_bar(&bar, self.scale, self.range, &self.levels)
    }
}

/// Resolves the colour range from the option or the data.
fn resolve_range(scale: &ColourScale, data: Option<(f64, f64)>) -> Result<(f64, f64)> {
    match scale.range {
        Some((lo, hi)) => {
            if lo.is_finite() && hi.is_finite() && hi > lo {
                Ok((lo, hi))
            } else {
                Err(Error::InvalidShape(format!(
                    "colour range ({lo}, {hi}) must be finite and increasing"
                )))
            }
        }
        None => {
            let (lo, hi) = data.unwrap_or((0.0, 1.0));
            Ok(scale.map.default_range(lo, hi))
        }
    }
}

/// Draws heat maps of grids over the body-frame command space into `<dir>/<stem>.svg|png`.
///
/// Panels side by side, yaw rate on x and longitudinal speed on y, one colour scale for all
/// (colour bar on the right). Grid points that are `None`, non-finite or outside the panel's U
/// outline are left blank. With `contour_spacing = Some(s)`, black contour lines are drawn at
/// every multiple of `s` (the paper: 0.2 m/s longitudinal, 0.1 m/s lateral), thicker at zero,
/// and marked on the colour bar. Errors if there is no panel, a grid is malformed, or the
/// spacing or range is impossible.
pub fn heat_maps(
    dir: &Path,
    stem: &str,
    title: &str,
    panels: &[HeatPanel],
    scale: &ColourScale,
    contour_spacing: Option<f64>,
) -> Result<FigureFiles> {
    if panels.is_empty() {
        return Err(Error::NothingToDraw {
            figure: stem.to_string(),
            what: "heat-map panel",
        });
    }
    let mut skipped = 0;
    let mut prepared = vec![];
    for p in panels {
        p.grid.validate().map_err(|e| Error::InvalidFigure {
            figure: stem.to_string(),
            message: format!("panel `{}`: {e}", p.title),
        })?;
        skipped += p.grid.non_finite_count();
        prepared.push((
            p.title.clone(),
            masked(&p.grid, &p.command_space),
            p.command_space.clone(),
        ));
    }
    let data = finite_extent(prepared.iter().flat_map(|p| p.1.values.iter().flatten().copied()));
    let range = resolve_range(scale, data)?;
    let levels = match contour_spacing {
        Some(s) => {
            let (lo, hi) = data.unwrap_or((0.0, 0.0));
            contour_levels(lo, hi, s)?
        }
        None => vec![],
    };
    let legend = if levels.is_empty() {
        vec![]
    } else {
        vec![
            LegendEntry::new("U (command space)", BLACK, Swatch::Line),
            LegendEntry::new(
                format!(
                    "contours every {} {}",
                    fmt_tick(&contour_spacing.unwrap_or(0.0)),
                    scale.value.unit
                ),
                RGBColor(90, 90, 90),
                Swatch::Line,
            ),
        ]
    };
    render(
        dir,
        stem,
        &HeatFig {
            title,
            panels: prepared,
            scale,
            range,
            levels,
            legend,
        },
        skipped,
    )
}

struct ScatterFig<'a> {
    title: &'a str,
    panels: &'a [ScatterPanel],
    scale: &'a ColourScale,
    range: (f64, f64),
}

impl Figure for ScatterFig<'_> {
    fn size(&self) -> (u32, u32) {
        let w = PANEL_W * self.panels.len() as u32 + BAR_W;
        (w, super::style::canvas_height(PANEL_H, w, &[]))
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult {
        let body = title_legend_body(root, self.title, &[])?;
        let (plots, bar) = body.split_horizontally(PANEL_W * self.panels.len() as u32);
        let cells = plots.split_evenly((1, self.panels.len()));
        for (p, cell) in self.panels.iter().zip(&cells) {
            let pts: Vec<&ValuePoint> = p
                .points
                .iter()
                .filter(|q| q.vx_m_s.is_finite() && q.wz_rad_s.is_finite() && q.value.is_finite())
                .collect();
            let (xr, yr) = body_ranges(
                p.command_space.iter().copied(),
                pts.iter().map(|q| (q.vx_m_s, q.wz_rad_s)),
            );
            let mut ch = xy_chart(
                cell,
                &p.title,
                xr,
                yr,
                "commanded yaw rate ωz [rad/s]",
                "commanded longitudinal speed vx [m/s]",
            )?;
            u_outline(&mut ch, &p.command_space)?;
            ch.draw_series(pts.iter().map(|q| {
                Circle::new(
                    (q.wz_rad_s, q.vx_m_s),
                    5,
                    self.scale.map.at(norm(q.value, self.range)).filled(),
                )
            }))?;
            ch.draw_series(
                pts.iter()
                    .map(|q| Circle::new((q.wz_rad_s, q.vx_m_s), 5, BLACK.mix(0.4).stroke_width(1))),
            )?;
            if pts.is_empty() {
                super::style::no_data(&mut ch, "")?;
            }
        }
        colour_bar(&bar, self.scale, self.range, &[])
    }
}

/// Draws values at commands (e.g. ρ per DRIVE step) as coloured dots over the body-frame
/// command space, panels side by side with one colour bar, into `<dir>/<stem>.svg|png`.
/// For ρ use `range: Some((0.0, 1.0))`. Errors if there is no panel or the range is impossible.
pub fn value_scatter(
    dir: &Path,
    stem: &str,
    title: &str,
    panels: &[ScatterPanel],
    scale: &ColourScale,
) -> Result<FigureFiles> {
    if panels.is_empty() {
        return Err(Error::NothingToDraw {
            figure: stem.to_string(),
            what: "scatter panel",
        });
    }
    let finite = |q: &&ValuePoint| q.vx_m_s.is_finite() && q.wz_rad_s.is_finite() && q.value.is_finite();
    let skipped = panels
        .iter()
        .flat_map(|p| &p.points)
        .filter(|q| !finite(q))
        .count();
    let data = finite_extent(
        panels
            .iter()
            .flat_map(|p| &p.points)
            .filter(finite)
            .map(|q| q.value),
    );
    let range = resolve_range(scale, data)?;
    render(
        dir,
        stem,
        &ScatterFig {
            title,
            panels,
            scale,
            range,
        },
        skipped,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn polygon_membership_with_border() {
        let sq = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)];
        assert!(in_polygon(&sq, (0.5, 0.5)));
        assert!(in_polygon(&sq, (1.0, 0.5)));
        assert!(in_polygon(&sq, (0.0, 0.0)));
        assert!(!in_polygon(&sq, (1.01, 0.5)));
        assert!(!in_polygon(&sq, (-0.5, -0.5)));
    }

    #[test]
    fn convex_clipping_by_hand() {
        let tri = [(0.0, 0.0), (2.0, 0.0), (0.0, 2.0)];
        assert!(is_convex(&tri));
        let sq = vec![(0.5, 0.5), (1.5, 0.5), (1.5, 1.5), (0.5, 1.5)];
        let p = drive_sim_model::geometry::clip_convex(&sq, &tri);
        // The triangle's hypotenuse x + y = 2 cuts the square [0.5, 1.5]² along its
        // diagonal (1.5, 0.5)-(0.5, 1.5), leaving a right triangle of area 0.5.
        let area: f64 = (0..p.len())
            .map(|i| {
                let (a, b) = (p[i], p[(i + 1) % p.len()]);
                a.0 * b.1 - b.0 * a.1
            })
            .sum::<f64>()
            / 2.0;
        assert!((area.abs() - 0.5).abs() < 1e-12, "area {area}, {p:?}");
        // Clockwise clip polygon gives the same result.
        let cw: Vec<(f64, f64)> = tri.iter().rev().copied().collect();
        let q =
            drive_sim_model::geometry::clip_convex(&[(0.5, 0.5), (1.5, 0.5), (1.5, 1.5), (0.5, 1.5)], &cw);
        assert_eq!(q.len(), p.len());
        assert!(!is_convex(&[
            (0.0, 0.0),
            (2.0, 0.0),
            (1.0, 0.5),
            (2.0, 2.0),
            (0.0, 2.0)
        ]));
    }

    #[test]
    fn cell_edges_midpoints() {
        assert_eq!(
            cell_edges(&[0.0, 1.0, 3.0]),
            vec![(-0.5, 0.5), (0.5, 2.0), (2.0, 4.0)]
        );
        assert_eq!(cell_edges(&[2.0]), vec![(1.95, 2.05)]);
    }
}
