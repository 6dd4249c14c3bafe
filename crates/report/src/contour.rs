//! Values on a regular grid over the body-frame command space, and contour lines by marching
//! squares.
//!
//! Why not the `contour` crate: its `lines()` returns closed rings in the d3-contour
//! convention (rings close along the grid border, pixel-centred coordinates) and has no notion
//! of masked cells, while a transfer function over U needs open iso-lines that stop at the
//! border of U. The algorithm below is the textbook one (16 cases, saddles resolved by the cell
//! centre mean), with masked cells skipped.

use crate::error::{Error, Result};

/// Values on a rectilinear grid over the body-frame command space (e.g. a transfer function
/// or ρ smoothed onto grid points).
///
/// `values[i_wz * vx_m_s.len() + i_vx]` is the value at `(vx_m_s[i_vx], wz_rad_s[i_wz])`
/// (rows of constant yaw rate, vx fastest: the layout of
/// [`analysis::smoother::Grid`](drive_sim_analysis::smoother::Grid));
/// `None` marks a grid point without a value (outside U, or too far from any sample).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Grid2 {
    /// Longitudinal speed of each grid row, strictly increasing, m/s.
    pub vx_m_s: Vec<f64>,
    /// Yaw rate of each grid column, strictly increasing, rad/s.
    pub wz_rad_s: Vec<f64>,
    /// Values, `wz` major and `vx` minor; `None` = masked.
    pub values: Vec<Option<f64>>,
}

/// A contour segment: two points `(vx_m_s, wz_rad_s)` on the iso-line.
pub type ContourSegment = ((f64, f64), (f64, f64));

impl Grid2 {
    /// Builds a grid by evaluating `f(vx, wz)` at every grid point.
    pub fn from_fn(vx_m_s: Vec<f64>, wz_rad_s: Vec<f64>, mut f: impl FnMut(f64, f64) -> Option<f64>) -> Self {
        let mut values = Vec::with_capacity(vx_m_s.len() * wz_rad_s.len());
        for &wz in &wz_rad_s {
            for &vx in &vx_m_s {
                values.push(f(vx, wz));
            }
        }
        Self {
            vx_m_s,
            wz_rad_s,
            values,
        }
    }

    /// Builds a grid from values in the same layout where NaN marks masked points (the
    /// convention of the analysis smoother's output). Errors if the length does not match.
    pub fn from_nan_masked(vx_m_s: Vec<f64>, wz_rad_s: Vec<f64>, values: &[f64]) -> Result<Self> {
        let g = Self {
            values: values.iter().map(|v| (!v.is_nan()).then_some(*v)).collect(),
            vx_m_s,
            wz_rad_s,
        };
        g.validate()?;
        Ok(g)
    }

    /// Checks the shape: axes non-empty, finite, strictly increasing, and one value per point.
    pub fn validate(&self) -> Result<()> {
        for (name, axis) in [("vx_m_s", &self.vx_m_s), ("wz_rad_s", &self.wz_rad_s)] {
            if axis.is_empty() {
                return Err(Error::InvalidShape(format!("grid axis {name} is empty")));
            }
            if let Some(i) = axis.iter().position(|v| !v.is_finite()) {
                return Err(Error::InvalidShape(format!(
                    "grid axis {name}[{i}] is not finite ({})",
                    axis[i]
                )));
            }
            if let Some(i) = axis.windows(2).position(|w| w[1] <= w[0]) {
                return Err(Error::InvalidShape(format!(
                    "grid axis {name} is not strictly increasing at index {}: {} then {}",
                    i + 1,
                    axis[i],
                    axis[i + 1]
                )));
            }
        }
        let n = self.vx_m_s.len() * self.wz_rad_s.len();
        if self.values.len() != n {
            return Err(Error::InvalidShape(format!(
                "grid has {} values for {} x {} = {n} points",
                self.values.len(),
                self.vx_m_s.len(),
                self.wz_rad_s.len()
            )));
        }
        Ok(())
    }

    /// The finite value at `(i_vx, i_wz)`, `None` if masked, non-finite or out of range.
    pub fn get(&self, i_vx: usize, i_wz: usize) -> Option<f64> {
        if i_vx >= self.vx_m_s.len() || i_wz >= self.wz_rad_s.len() {
            return None;
        }
        self.values
            .get(i_wz * self.vx_m_s.len() + i_vx)
            .copied()
            .flatten()
            .filter(|v| v.is_finite())
    }

    /// Number of values that are `Some` but not finite (they are treated as masked).
    pub fn non_finite_count(&self) -> usize {
        self.values
            .iter()
            .filter(|v| matches!(v, Some(x) if !x.is_finite()))
            .count()
    }

    /// Min and max of the finite values, `None` if there is none.
    pub fn value_range(&self) -> Option<(f64, f64)> {
        super::style::finite_extent(self.values.iter().flatten().copied())
    }
}

/// Contour levels `k * spacing` (k integer) inside `[lo, hi]`, ascending.
///
/// Errors if the spacing is not a positive finite number or would give more than 500 levels.
pub fn contour_levels(lo: f64, hi: f64, spacing: f64) -> Result<Vec<f64>> {
    if !(spacing.is_finite() && spacing > 0.0) {
        return Err(Error::InvalidShape(format!(
            "contour spacing must be positive and finite, got {spacing}"
        )));
    }
    if !(lo.is_finite() && hi.is_finite()) || hi < lo {
        return Ok(vec![]);
    }
    let k0 = (lo / spacing).ceil();
    let k1 = (hi / spacing).floor();
    if k1 - k0 > 500.0 {
        return Err(Error::InvalidShape(format!(
            "contour spacing {spacing} gives {} levels over [{lo}, {hi}]; at most 500",
            k1 - k0 + 1.0
        )));
    }
    let mut out = vec![];
    let mut k = k0;
    while k <= k1 {
        out.push(k * spacing);
        k += 1.0;
    }
    Ok(out)
}

/// Segments of the iso-line `value = level` over the grid (marching squares with linear
/// interpolation along cell edges). Cells with a masked corner are skipped, so lines stop at
/// the mask border. Points are `(vx_m_s, wz_rad_s)`.
pub fn contour_segments(grid: &Grid2, level: f64) -> Result<Vec<ContourSegment>> {
    grid.validate()?;
    if !level.is_finite() {
        return Err(Error::InvalidShape(format!(
            "contour level {level} is not finite"
        )));
    }
    let (nx, nw) = (grid.vx_m_s.len(), grid.wz_rad_s.len());
    let mut out = vec![];
    if nx < 2 || nw < 2 {
        return Ok(out);
    }
    for i in 0..nx - 1 {
        for j in 0..nw - 1 {
            // Corners counter-clockwise in (wz, vx): c0 (i, j), c1 (i, j+1), c2 (i+1, j+1),
            // c3 (i+1, j).
            let idx = [(i, j), (i, j + 1), (i + 1, j + 1), (i + 1, j)];
            let mut vals = [0.0; 4];
            let mut masked = false;
            for (k, &(a, b)) in idx.iter().enumerate() {
                match grid.get(a, b) {
                    Some(v) => vals[k] = v,
                    None => masked = true,
                }
            }
            if masked {
                continue;
            }
            let pos = |k: usize| (grid.vx_m_s[idx[k].0], grid.wz_rad_s[idx[k].1]);
            let above = vals.map(|v| v >= level);
            // Crossing point on edge e (from corner e to corner e+1), if the edge crosses.
            let cross = |e: usize| -> Option<(f64, f64)> {
                let (a, b) = (e, (e + 1) % 4);
                if above[a] == above[b] {
                    return None;
                }
                let t = (level - vals[a]) / (vals[b] - vals[a]);
                let (pa, pb) = (pos(a), pos(b));
                Some((pa.0 + t * (pb.0 - pa.0), pa.1 + t * (pb.1 - pa.1)))
            };
            let crossings: Vec<(usize, (f64, f64))> =
                (0..4).filter_map(|e| cross(e).map(|p| (e, p))).collect();
            // A level passing exactly through a grid point gives crossings that coincide up
            // to rounding: drop such degenerate segments.
            let tiny = 1e-9
                * ((grid.vx_m_s[i + 1] - grid.vx_m_s[i]).abs()
                    + (grid.wz_rad_s[j + 1] - grid.wz_rad_s[j]).abs());
            let mut push = |a: (f64, f64), b: (f64, f64)| {
                if (a.0 - b.0).abs() + (a.1 - b.1).abs() > tiny {
                    out.push((a, b));
                }
            };
            match crossings.len() {
                2 => push(crossings[0].1, crossings[1].1),
                4 => {
                    // Saddle: the centre mean decides which diagonal pair is connected.
                    let centre_above = vals.iter().sum::<f64>() / 4.0 >= level;
                    let p = |e: usize| crossings[e].1;
                    if centre_above == above[0] {
                        // c0 and c2 joined through the centre: cut off corners c1 and c3.
                        push(p(0), p(1));
                        push(p(2), p(3));
                    } else {
                        // Cut off corners c0 and c2.
                        push(p(3), p(0));
                        push(p(1), p(2));
                    }
                }
                _ => {}
            }
        }
    }
    Ok(out)
}

/// The iso-line `value = level` as polylines: [`contour_segments`] chained end to end
/// (closed loops repeat their first point at the end). Points are `(vx_m_s, wz_rad_s)`.
pub fn contour_polylines(grid: &Grid2, level: f64) -> Result<Vec<Vec<(f64, f64)>>> {
    let segs = contour_segments(grid, level)?;
    // Neighbouring cells compute a shared crossing from the same two corner values, possibly
    // in the other order: match endpoints on a grid far finer than the cells.
    let span = grid
        .vx_m_s
        .iter()
        .chain(&grid.wz_rad_s)
        .fold(0.0f64, |m, v| m.max(v.abs()))
        .max(1.0);
    let q = 1e-9 * span;
    let key = |p: (f64, f64)| ((p.0 / q).round() as i64, (p.1 / q).round() as i64);
    let mut at: std::collections::HashMap<(i64, i64), Vec<usize>> = std::collections::HashMap::new();
    for (i, (a, b)) in segs.iter().enumerate() {
        at.entry(key(*a)).or_default().push(i);
        at.entry(key(*b)).or_default().push(i);
    }
    let mut used = vec![false; segs.len()];
    let mut lines = vec![];
    // The unused segment touching `p`, oriented to start at `p`.
    let next = |p: (f64, f64), used: &[bool]| -> Option<(usize, (f64, f64))> {
        at.get(&key(p))?.iter().find(|&&i| !used[i]).map(|&i| {
            let (a, b) = segs[i];
            (i, if key(a) == key(p) { b } else { a })
        })
    };
    for start in 0..segs.len() {
        if used[start] {
            continue;
        }
        used[start] = true;
        let (a, b) = segs[start];
        let mut fwd = vec![a, b];
        while let Some((i, p)) = next(*fwd.last().unwrap_or(&b), &used) {
            used[i] = true;
            fwd.push(p);
        }
        let mut back = vec![];
        let mut head = a;
        while let Some((i, p)) = next(head, &used) {
            used[i] = true;
            back.push(p);
            head = p;
        }
        back.reverse();
        back.extend(fwd);
        lines.push(back);
    }
    Ok(lines)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn axis(lo: f64, hi: f64, n: usize) -> Vec<f64> {
        (0..n)
            .map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64)
            .collect()
    }

    #[test]
    fn plane_contour_is_the_line() {
        // z = vx on a grid whose nodes do not fall on 0.5: linear interpolation is exact.
        let g = Grid2::from_fn(axis(0.03, 1.03, 21), axis(-1.0, 1.0, 11), |vx, _| Some(vx));
        let segs = contour_segments(&g, 0.5).unwrap();
        assert_eq!(segs.len(), 10, "one segment per cell column crossed");
        for (a, b) in segs {
            assert!((a.0 - 0.5).abs() < 1e-12 && (b.0 - 0.5).abs() < 1e-12);
        }
    }

    #[test]
    fn circle_contour_within_grid_tolerance() {
        let n = 81;
        let h = 2.0 / (n - 1) as f64;
        let g = Grid2::from_fn(axis(-1.0, 1.0, n), axis(-1.0, 1.0, n), |vx, wz| {
            Some((vx * vx + wz * wz).sqrt())
        });
        let r = 0.6;
        let segs = contour_segments(&g, r).unwrap();
        assert!(!segs.is_empty());
        let mut len = 0.0;
        for (a, b) in &segs {
            for p in [a, b] {
                let rr = (p.0 * p.0 + p.1 * p.1).sqrt();
                // Interpolating a convex function along a chord errs by at most h^2/(8 r)-ish.
                assert!((rr - r).abs() < h * h, "point {p:?} at radius {rr}");
            }
            len += ((a.0 - b.0).powi(2) + (a.1 - b.1).powi(2)).sqrt();
        }
        // Total length approximates the circumference (chords are slightly shorter).
        let c = 2.0 * std::f64::consts::PI * r;
        assert!(len < c && len > 0.99 * c, "length {len} vs {c}");
    }

    #[test]
    fn polylines_chain_the_segments() {
        // Plane: one open line through all cell columns; circle: one closed loop.
        let g = Grid2::from_fn(axis(0.03, 1.03, 21), axis(-1.0, 1.0, 11), |vx, _| Some(vx));
        let l = contour_polylines(&g, 0.5).unwrap();
        assert_eq!(l.len(), 1);
        assert_eq!(l[0].len(), 11);
        let c = Grid2::from_fn(axis(-1.0, 1.0, 41), axis(-1.0, 1.0, 41), |vx, wz| {
            Some((vx * vx + wz * wz).sqrt())
        });
        let segs = contour_segments(&c, 0.5).unwrap().len();
        let l = contour_polylines(&c, 0.5).unwrap();
        assert_eq!(l.len(), 1, "one closed loop");
        assert_eq!(l[0].len(), segs + 1);
        assert_eq!(l[0].first(), l[0].last());
    }

    #[test]
    fn masked_cells_are_skipped() {
        // Mask half of the grid (vx > 0.5): the plane contour at 0.25 survives, 0.75 vanishes.
        let g = Grid2::from_fn(axis(0.0, 1.0, 11), axis(0.0, 1.0, 11), |vx, _| {
            (vx <= 0.5 + 1e-9).then_some(vx)
        });
        assert_eq!(contour_segments(&g, 0.25).unwrap().len(), 10);
        assert!(contour_segments(&g, 0.75).unwrap().is_empty());
    }

    #[test]
    fn saddle_and_bad_inputs() {
        // z = vx * wz around 0: level 0.0 contour consists of the two axes; no panic and every
        // point lies on an axis.
        let g = Grid2::from_fn(axis(-1.0, 1.0, 5), axis(-1.0, 1.0, 5), |vx, wz| Some(vx * wz));
        let segs = contour_segments(&g, 0.1).unwrap();
        assert!(!segs.is_empty());
        for (a, b) in segs {
            for p in [a, b] {
                assert!((p.0 * p.1 - 0.1).abs() < 0.15, "{p:?}");
            }
        }
        let bad = Grid2 {
            vx_m_s: vec![0.0, 1.0],
            wz_rad_s: vec![0.0],
            values: vec![Some(1.0)],
        };
        assert!(contour_segments(&bad, 0.5).is_err());
        let unsorted = Grid2 {
            vx_m_s: vec![1.0, 0.0],
            wz_rad_s: vec![0.0],
            values: vec![Some(1.0), Some(2.0)],
        };
        assert!(unsorted.validate().is_err());
        assert!(contour_segments(&g, f64::NAN).is_err());
    }

    #[test]
    fn layout_and_nan_mask() {
        let g = Grid2::from_fn(vec![0.0, 1.0, 2.0], vec![10.0, 20.0], |vx, wz| Some(vx + wz));
        // wz major: second row (wz = 20) starts at index 3.
        assert_eq!(g.values[3], Some(20.0));
        assert_eq!(g.get(2, 1), Some(22.0));
        assert_eq!(g.get(3, 0), None);
        let m = Grid2::from_nan_masked(vec![0.0, 1.0], vec![0.0], &[f64::NAN, 1.0]).unwrap();
        assert_eq!(m.values, vec![None, Some(1.0)]);
        assert!(Grid2::from_nan_masked(vec![0.0, 1.0], vec![0.0], &[1.0]).is_err());
    }

    #[test]
    fn levels_at_spacing() {
        // Multiples of 0.2 in [-0.25, 0.45]: -0.2, 0, 0.2, 0.4.
        let l = contour_levels(-0.25, 0.45, 0.2).unwrap();
        assert_eq!(l.len(), 4);
        assert!((l[0] + 0.2).abs() < 1e-12 && l[1] == 0.0 && (l[3] - 0.4).abs() < 1e-12);
        assert!(contour_levels(0.0, 1.0, 0.0).is_err());
        assert!(contour_levels(0.0, 1.0, 1e-6).is_err());
        assert!(contour_levels(0.3, 0.35, 0.2).unwrap().is_empty());
    }
}
