//! Command space figure: U, S and T in the wheel frame W and the body frame B, and the
//! distribution of lateral speed (one row per scenario).

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::stats::histogram;
use super::style::{
    assign_colours, canvas_height, closed, no_data, render, title_legend_body, xy_chart, DrawResult, Figure,
    FigureFiles, LegendEntry, Swatch,
};
use crate::error::{Error, Result};
use drive_sim_model::geometry::convex_hull;
use drive_sim_model::kinematics::{BodyVelocity, CommandSpace, WheelSpeeds};

/// One scenario (robot on a terrain, one dataset) of the command-space figure.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CommandScenario {
    /// Scenario label; decides the colour of T.
    pub label: String,
    /// The sampled commands S (wheel speeds).
    pub commands: Vec<WheelSpeeds>,
    /// Measured steady-state wheel speeds T in W (one per step).
    pub steady_wheels: Vec<WheelSpeeds>,
    /// Measured steady-state body velocities T in B (one per step); `vy` feeds the lateral
    /// speed histogram.
    pub steady_body: Vec<BodyVelocity>,
}

/// Colour of the sampled commands S (the paper's orange).
const S_COLOUR: RGBColor = RGBColor(255, 140, 0);
const PANEL_W: u32 = 470;
const PANEL_H: u32 = 440;

struct CommandSpaceFig<'a> {
    title: &'a str,
    space: &'a CommandSpace,
    scenarios: &'a [CommandScenario],
    colours: Vec<RGBColor>,
    legend: Vec<LegendEntry>,
}

/// Symmetric range covering the values, at least `min_half` on each side of zero, +8 %.
fn symmetric(values: impl IntoIterator<Item = f64>, min_half: f64) -> (f64, f64) {
    let m = values
        .into_iter()
        .filter(|v| v.is_finite())
        .fold(min_half, |m, v| m.max(v.abs()));
    let m = if m > 0.0 { m * 1.08 } else { 1.0 };
    (-m, m)
}

impl CommandSpaceFig<'_> {
    fn draw_row<DB: DrawingBackend>(
        &self,
        cells: &[DrawingArea<DB, Shift>],
        sc: &CommandScenario,
        colour: RGBColor,
    ) -> DrawResult {
        let t_style = colour.mix(0.85).filled();
        // Wheel frame W: x = left, y = right.
        let u_w = self.space.polygon_wheels();
        let s_w: Vec<(f64, f64)> = sc
            .commands
            .iter()
            .filter(|w| w.is_finite())
            .map(|w| (w.left_rad_s, w.right_rad_s))
            .collect();
        let t_w: Vec<(f64, f64)> = sc
            .steady_wheels
            .iter()
            .filter(|w| w.is_finite())
            .map(|w| (w.left_rad_s, w.right_rad_s))
            .collect();
        let r = symmetric(u_w.iter().chain(&s_w).chain(&t_w).flat_map(|p| [p.0, p.1]), 0.0);
        let mut ch = xy_chart(
            &cells[0],
            &format!("{}: wheel frame W", sc.label),
            r,
            r,
            "left wheel speed ωl [rad/s]",
            "right wheel speed ωr [rad/s]",
        )?;
        self.draw_space(&mut ch, &u_w, &s_w, &t_w, colour, t_style)?;

        // Body frame B: x = wz, y = vx.
        let u_b: Vec<(f64, f64)> = self
            .space
            .polygon_body()
            .into_iter()
            .map(|(vx, wz)| (wz, vx))
            .collect();
        let s_b: Vec<(f64, f64)> = sc
            .commands
            .iter()
            .filter(|w| w.is_finite())
            .map(|&w| {
                let b = self.space.idd.body_from_wheels(w);
                (b.wz_rad_s, b.vx_m_s)
            })
            .collect();
        let t_b: Vec<(f64, f64)> = sc
            .steady_body
            .iter()
            .filter(|b| b.is_finite())
            .map(|b| (b.wz_rad_s, b.vx_m_s))
            .collect();
        let xr = symmetric(u_b.iter().chain(&s_b).chain(&t_b).map(|p| p.0), 0.0);
        let yr = symmetric(u_b.iter().chain(&s_b).chain(&t_b).map(|p| p.1), 0.0);
        let mut ch = xy_chart(
            &cells[1],
            &format!("{}: body frame B", sc.label),
            xr,
            yr,
            "yaw rate ωz [rad/s]",
            "longitudinal speed vx [m/s]",
        )?;
        self.draw_space(&mut ch, &u_b, &s_b, &t_b, colour, t_style)?;

        // Lateral speed distribution.
        let vy: Vec<f64> = sc
            .steady_body
            .iter()
            .map(|b| b.vy_m_s)
            .filter(|v| v.is_finite())
            .collect();
        let xr = symmetric(vy.iter().copied(), 0.1);
        let bins = 31;
        let counts = histogram(&vy, xr.0, xr.1, bins);
        let n = vy.len().max(1) as f64;
        let ymax = counts.iter().copied().max().unwrap_or(0) as f64 / n;
        let mut ch = xy_chart(
            &cells[2],
            &format!("{}: lateral speed", sc.label),
            xr,
            (0.0, if ymax > 0.0 { ymax * 1.1 } else { 1.0 }),
            "lateral speed vy [m/s]",
            "fraction of steps",
        )?;
        if vy.is_empty() {
            no_data(&mut ch, "")?;
        } else {
            let w = (xr.1 - xr.0) / bins as f64;
            ch.draw_series(counts.iter().enumerate().filter(|(_, c)| **c > 0).map(|(i, &c)| {
                let x0 = xr.0 + i as f64 * w;
                Rectangle::new([(x0, 0.0), (x0 + w, c as f64 / n)], colour.mix(0.7).filled())
            }))?;
            ch.draw_series(counts.iter().enumerate().filter(|(_, c)| **c > 0).map(|(i, &c)| {
                let x0 = xr.0 + i as f64 * w;
                Rectangle::new([(x0, 0.0), (x0 + w, c as f64 / n)], BLACK.stroke_width(1))
            }))?;
        }
        Ok(())
    }

    fn draw_space<DB: DrawingBackend>(
        &self,
        ch: &mut super::style::XyChart<'_, DB>,
        u: &[(f64, f64)],
        s: &[(f64, f64)],
        t: &[(f64, f64)],
        colour: RGBColor,
        t_style: ShapeStyle,
    ) -> DrawResult {
        // T's convex hull as a light fill: the visual approximation of the continuous T.
        let hull = convex_hull(t);
        if hull.len() >= 3 {
            ch.draw_series(std::iter::once(Polygon::new(hull.clone(), colour.mix(0.15))))?;
            ch.draw_series(std::iter::once(PathElement::new(
                closed(&hull),
                colour.stroke_width(2),
            )))?;
        }
        ch.draw_series(s.iter().map(|&p| Circle::new(p, 3, S_COLOUR.mix(0.9).filled())))?;
        ch.draw_series(t.iter().map(|&p| Circle::new(p, 3, t_style)))?;
        ch.draw_series(std::iter::once(PathElement::new(
            closed(u),
            BLACK.stroke_width(2),
        )))?;
        if s.is_empty() && t.is_empty() {
            no_data(ch, "")?;
        }
        Ok(())
    }
}

impl Figure for CommandSpaceFig<'_> {
    fn size(&self) -> (u32, u32) {
        let w = 3 * PANEL_W;
        (
            w,
            canvas_height(PANEL_H * self.scenarios.len() as u32, w, &self.legend),
        )
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult {
        let body = title_legend_body(root, self.title, &self.legend)?;
        let cells = body.split_evenly((self.scenarios.len(), 3));
        for (k, sc) in self.scenarios.iter().enumerate() {
            self.draw_row(&cells[3 * k..3 * k + 3], sc, self.colours[k])?;
        }
        Ok(())
    }
}

/// Draws the command space figure into `<dir>/<stem>.svg|png`.
///
/// One row per scenario: (1) W: U outline (black), sampled commands S (orange), steady-state
/// wheel speeds T (scenario colour, with its convex hull); (2) B, yaw rate on x and
/// longitudinal speed on y, with S mapped through the IDD of `space`; (3) histogram of the
/// steady-state lateral speed (fraction of steps). Errors if there is no scenario.
pub fn command_space_figure(
    dir: &Path,
    stem: &str,
    title: &str,
    space: &CommandSpace,
    scenarios: &[CommandScenario],
) -> Result<FigureFiles> {
    if scenarios.is_empty() {
        return Err(Error::NothingToDraw {
            figure: stem.to_string(),
            what: "scenario",
        });
    }
    let labels: Vec<&str> = scenarios.iter().map(|s| s.label.as_str()).collect();
    let colours = assign_colours(&labels);
    let mut legend = vec![
        LegendEntry::new("U (command space)", BLACK, Swatch::Line),
        LegendEntry::new("S (sampled commands)", S_COLOUR, Swatch::Dot),
    ];
    for (s, c) in scenarios.iter().zip(&colours) {
        legend.push(LegendEntry::new(
            format!("T (steady state), {}", s.label),
            *c,
            Swatch::Dot,
        ));
    }
    let skipped = scenarios
        .iter()
        .map(|s| {
            s.commands.iter().filter(|w| !w.is_finite()).count()
                + s.steady_wheels.iter().filter(|w| !w.is_finite()).count()
                + s.steady_body.iter().filter(|b| !b.is_finite()).count()
        })
        .sum();
    render(
        dir,
        stem,
        &CommandSpaceFig {
            title,
            space,
            scenarios,
            colours,
            legend,
        },
        skipped,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hull_of_square_with_inner_points() {
        let pts = [
            (0.0, 0.0),
            (1.0, 0.0),
            (1.0, 1.0),
            (0.0, 1.0),
            (0.5, 0.5),
            (0.2, 0.7),
        ];
        let h = convex_hull(&pts);
        assert_eq!(h.len(), 4);
        assert!(!h.contains(&(0.5, 0.5)));
        assert!(convex_hull(&[(1.0, 1.0)]).len() == 1);
    }
}
