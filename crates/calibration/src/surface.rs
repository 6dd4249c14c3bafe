//! How far a tuned value can move: the profile of a quadratic fitted to a search's losses.
//!
//! It lives beside the calibration's other least-squares code (the twin's closed-loop tuning
//! uses it), so that one crate instantiates the linear algebra.
//!
//! The closed-loop search evaluates its loss at points of the knobs' unit box; each loss is a
//! mean over a few seeds, so it is noisy, and the check on fresh seeds measures that noise
//! (its standard error). Around the best point the loss surface is fitted by a full quadratic,
//! `L(z) ≈ c + gᵀd + ½ dᵀH d` with `d = z − z_best`, by least squares on the points nearest the
//! best. Where `H` is positive definite the surface has a minimum `z*`, and the values of
//! coordinate `i` whose profile loss (the surface minimised over the other coordinates) lies
//! within an allowance `a` of that minimum are `z*_i ± √(2a·(H⁻¹)ᵢᵢ)`. With `a` twice the
//! check's standard error, that is the set of values the check could not tell from the best:
//! an interval by a stated method (a response surface's profile). Where the full quadratic has
//! no minimum (a handful of points per coefficient, noisy losses), the quadratic without cross
//! terms is fitted instead ([`SurfaceFit::Separable`]); a coordinate along which even that one
//! curves down gets no interval (the value is not pinned by the closed loop).

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

/// Points used per coefficient of the quadratic (the nearest ones to the best point): enough
/// beyond the coefficients for the fit's residual to mean something.
const POINTS_PER_COEFFICIENT: usize = 2;

/// Which quadratic the intervals were read from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SurfaceFit {
    /// The full quadratic, its cross terms included: each interval is the profile (the other
    /// coordinates minimised over).
    Full,
    /// The quadratic without cross terms, used when the full one has no minimum (too few
    /// points for its coefficients, or noise that tilts it into a saddle): each coordinate with
    /// a positive curvature gets the interval of its own parabola, the others held at their
    /// minimum; narrower than the profile when values trade against each other.
    Separable,
}

/// The intervals read from the fitted surface.
#[derive(Debug, Clone, PartialEq)]
pub struct SurfaceIntervals {
    /// Which quadratic.
    pub fit: SurfaceFit,
    /// Each coordinate's interval in the unit box (clamped to it); `None`: the surface has no
    /// minimum along it (the value is not pinned).
    pub intervals: Vec<Option<[f64; 2]>>,
}

/// The interval of each coordinate in the unit box, from the search's points `(z, loss)`
/// around `z_best`, with the allowance `allowance` in loss units (see the module doc): the
/// full quadratic's profile where it has a minimum, else the separable quadratic's. `None`
/// when there are too few points for either, or the fit fails.
pub fn profile_intervals(
    points: &[(Vec<f64>, f64)],
    z_best: &[f64],
    allowance: f64,
) -> Option<SurfaceIntervals> {
    let k = z_best.len();
    if k == 0 || !(allowance.is_finite() && allowance > 0.0) {
        return None;
    }
    if let Some(intervals) = full(points, z_best, allowance) {
        return Some(SurfaceIntervals {
            fit: SurfaceFit::Full,
            intervals: intervals.into_iter().map(Some).collect(),
        });
    }
    separable(points, z_best, allowance).map(|intervals| SurfaceIntervals {
        fit: SurfaceFit::Separable,
        intervals,
    })
}

/// The `n` points nearest `z_best` as a design of `coefficients` columns (`column(d, c)` of the
/// offset `d`) and their losses; `None` with fewer than `coefficients + 2` usable points.
fn nearest_design(
    points: &[(Vec<f64>, f64)],
    z_best: &[f64],
    coefficients: usize,
    column: impl Fn(&[f64], usize) -> f64,
) -> Option<(DMatrix<f64>, DVector<f64>)> {
    let k = z_best.len();
    let mut near: Vec<(f64, &(Vec<f64>, f64))> = points
        .iter()
        .filter(|(z, l)| z.len() == k && l.is_finite())
        .map(|p| (distance(&p.0, z_best), p))
        .collect();
    if near.len() < coefficients + 2 {
        return None;
    }
    near.sort_by(|a, b| a.0.total_cmp(&b.0));
    near.truncate((POINTS_PER_COEFFICIENT * coefficients).max(coefficients + 2));
    let offsets: Vec<Vec<f64>> = near
        .iter()
        .map(|(_, p)| p.0.iter().zip(z_best).map(|(z, b)| z - b).collect())
        .collect();
    let a = DMatrix::from_fn(near.len(), coefficients, |r, c| column(&offsets[r], c));
    let b = DVector::from_fn(near.len(), |r, _| near[r].1 .1);
    Some((a, b))
}

/// The full quadratic's profile intervals; `None` when it cannot be fitted or has no minimum.
fn full(points: &[(Vec<f64>, f64)], z_best: &[f64], allowance: f64) -> Option<Vec<[f64; 2]>> {
    let k = z_best.len();
    let coefficients = 1 + k + k * (k + 1) / 2;
    let (a, b) = nearest_design(points, z_best, coefficients, |d, c| feature(d, c, k))?;
    let coef = a.svd(true, true).solve(&b, 1e-12).ok()?;
    // Gradient and Hessian at the best point.
    let g = DVector::from_fn(k, |i, _| coef[1 + i]);
    let mut h = DMatrix::zeros(k, k);
    let mut c = 1 + k;
    for i in 0..k {
        for j in i..k {
            if i == j {
                h[(i, i)] = 2.0 * coef[c];
            } else {
                h[(i, j)] = coef[c];
                h[(j, i)] = coef[c];
            }
            c += 1;
        }
    }
    let chol = h.clone().cholesky()?;
    let h_inv = chol.inverse();
    let z_min = DVector::from_column_slice(z_best) - &h_inv * g;
    let out: Vec<[f64; 2]> = (0..k)
        .map(|i| around(z_min[i], (2.0 * allowance * h_inv[(i, i)]).sqrt()))
        .collect();
    out.iter().flatten().all(|v| v.is_finite()).then_some(out)
}

/// The separable quadratic's intervals, coordinate by coordinate.
fn separable(points: &[(Vec<f64>, f64)], z_best: &[f64], allowance: f64) -> Option<Vec<Option<[f64; 2]>>> {
    let k = z_best.len();
    let coefficients = 1 + 2 * k;
    let column = |d: &[f64], c: usize| match c {
        0 => 1.0,
        c if c <= k => d[c - 1],
        c => d[c - 1 - k].powi(2),
    };
    let (a, b) = nearest_design(points, z_best, coefficients, column)?;
    let coef = a.svd(true, true).solve(&b, 1e-12).ok()?;
    Some(
        (0..k)
            .map(|i| {
                let (g, h) = (coef[1 + i], 2.0 * coef[1 + k + i]);
                (h > 0.0 && h.is_finite())
                    .then(|| around(z_best[i] - g / h, (2.0 * allowance / h).sqrt()))
                    .filter(|v| v.iter().all(|x| x.is_finite()))
            })
            .collect(),
    )
}

/// `centre ± half`, clamped to the unit box.
fn around(centre: f64, half: f64) -> [f64; 2] {
    [(centre - half).clamp(0.0, 1.0), (centre + half).clamp(0.0, 1.0)]
}

/// The quadratic's `c`-th column at `d`: 1, then `d_i`, then `d_i·d_j` for `i ≤ j`.
fn feature(d: &[f64], c: usize, k: usize) -> f64 {
    if c == 0 {
        return 1.0;
    }
    if c <= k {
        return d[c - 1];
    }
    let mut idx = 1 + k;
    for i in 0..k {
        for j in i..k {
            if idx == c {
                return d[i] * d[j];
            }
            idx += 1;
        }
    }
    0.0
}

fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>().sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Points of a known quadratic bowl (with a cross term) on a grid around its minimum.
    fn bowl(noise: impl Fn(usize) -> f64) -> Vec<(Vec<f64>, f64)> {
        let mut pts = Vec::new();
        for a in 0..7 {
            for b in 0..7 {
                let z = vec![0.1 + 0.1 * a as f64, 0.25 + 0.1 * b as f64];
                let (d1, d2) = (z[0] - 0.4, z[1] - 0.6);
                let l = 5.0 + 0.5 * (6.0 * d1 * d1 + 2.0 * 2.0 * d1 * d2 + 20.0 * d2 * d2);
                let n = pts.len();
                pts.push((z, l + noise(n)));
            }
        }
        pts
    }

    #[test]
    fn a_known_bowl_gives_the_profile_interval_by_hand() {
        // H = [[6, 2], [2, 20]]: H⁻¹ = [[20, −2], [−2, 6]] / 116; allowance 0.1:
        // half-widths √(0.2·20/116) = 0.1857 and √(0.2·6/116) = 0.1017, centred on (0.4, 0.6),
        // whichever grid point the search took as its best.
        let out = profile_intervals(&bowl(|_| 0.0), &[0.5, 0.55], 0.1).unwrap();
        assert_eq!(out.fit, SurfaceFit::Full);
        let out: Vec<[f64; 2]> = out.intervals.into_iter().map(Option::unwrap).collect();
        let want = [[0.4 - 0.1857, 0.4 + 0.1857], [0.6 - 0.1017, 0.6 + 0.1017]];
        for (o, w) in out.iter().zip(want) {
            assert!(
                (o[0] - w[0]).abs() < 1e-3 && (o[1] - w[1]).abs() < 1e-3,
                "{out:?}"
            );
        }
    }

    #[test]
    fn a_saddle_falls_back_to_the_separable_fit_and_few_points_give_nothing() {
        let flat: Vec<(Vec<f64>, f64)> = bowl(|_| 0.0)
            .into_iter()
            .map(|(z, _)| {
                let l = 1.0 + (z[0] - 0.4).powi(2) - (z[1] - 0.6).powi(2);
                (z, l)
            })
            .collect();
        // A saddle: the full quadratic has no minimum; the separable one pins the coordinate
        // that curves up (half-width √(2·0.1/2) = 0.316 around 0.4) and not the other.
        let out = profile_intervals(&flat, &[0.4, 0.6], 0.1).unwrap();
        assert_eq!(out.fit, SurfaceFit::Separable);
        let pinned = out.intervals[0].unwrap();
        assert!(
            (pinned[0] - 0.084).abs() < 1e-3 && (pinned[1] - 0.716).abs() < 1e-3,
            "{out:?}"
        );
        assert!(out.intervals[1].is_none(), "{out:?}");
        let few = &bowl(|_| 0.0)[..5];
        assert!(profile_intervals(few, &[0.4, 0.6], 0.1).is_none());
        assert!(profile_intervals(&bowl(|_| 0.0), &[0.4, 0.6], 0.0).is_none());
    }

    #[test]
    fn a_little_noise_moves_the_interval_a_little() {
        // Deterministic ±0.005 noise on a bowl whose allowance is 0.1.
        let noisy = bowl(|n| if n % 2 == 0 { 0.005 } else { -0.005 });
        let out = profile_intervals(&noisy, &[0.4, 0.6], 0.1).unwrap();
        assert_eq!(out.fit, SurfaceFit::Full);
        let out: Vec<[f64; 2]> = out.intervals.into_iter().map(Option::unwrap).collect();
        assert!(
            (out[0][0] - 0.2143).abs() < 0.02 && (out[0][1] - 0.5857).abs() < 0.02,
            "{out:?}"
        );
    }
}
