//! Gaussian kernel smoother over the command space (paper eq. 9–10, with the GUIDE's erratum:
//! `k_i ∝ exp(-½ dᵀ Σ⁻¹ d)`, `d = u_i − ū`, Σ diagonal).
//!
//! Each grid point ū of a uniform (vx, wz) grid gets `ḡ(ū) = Σ k_i g_i / Σ k_i`. Two
//! implementations:
//!
//! * [`smooth_exact`]: the definition, one kernel evaluation per (sample, grid point),
//!   O(s · grid); Σ diagonal makes each evaluation a product of two factors taken once per
//!   grid column and row, O(s · (n_vx + n_wz)) exponentials. The reference.
//! * [`smooth_fast`]: linear (bilinear) binning of the samples onto a lattice of spacing
//!   `h = σ / bins_per_sigma` (independent of the output grid), a separable Gaussian
//!   convolution truncated at `K σ` on that lattice (Σ diagonal makes the kernel separable:
//!   `k = g_x(dx) g_z(dz)`), then bilinear interpolation of the numerator and denominator at the
//!   grid points. O(s + lattice · taps + grid).
//!
//! # Error bound of the fast smoother (derivation)
//! Binning then interpolating amounts to replacing each sample's kernel `k_i(ū)` by
//! `k̂_i(ū) ≥ 0`, the bilinear interpolation (in ū, over the lattice cell of ū) of the bilinear
//! interpolation (in u, over the cell of `u_i`) of the truncated kernel. With `δ_i = k̂_i − k_i`:
//! `ĝ_fast − ĝ = Σ δ_i (g_i − ĝ) / Σ k̂_i`, hence `|ĝ_fast − ĝ| ≤ range(g) · Σ|δ_i| / D̂`
//! (`ĝ` is a convex combination of the `g_i`, so `|g_i − ĝ| ≤ range`).
//! * Each bilinear step errs by at most `h_x²/8 · max|∂²k/∂x²| + h_z²/8 · max|∂²k/∂z²|` over
//!   one cell. For the Gaussian `∂²g/∂x² = (q²−1) g / σ²` (q = x/σ); over the two cells `g`
//!   varies by at most a factor `c = exp(2η (K + 2η) + 2η²)` (η = h/σ), and
//!   `(|q|+2η)² + 1 ≤ 2 (q² + 1)`. So `|δ_i| ≤ 4 c_x² c_z² [ε_x (1 + q_x²) + ε_z (1 + q_z²)] k_i`
//!   with `ε = η² / 8`. The sums `E_x = Σ k_i (1 + q_x²)` and `E_z` come from the same
//!   convolution with the kernels `(1 + q_x²) g_x g_z` and `g_x (1 + q_z²) g_z` (×1.02 for
//!   their own approximation).
//! * Truncation: a sample farther than about `K σ` (less two cells) loses at most
//!   `exp(−(K − 2η)²/2)` of weight; at most `s` samples do.
//!
//! Bound per grid point: `range · [4c² · 1.02 (ε_x E_x + ε_z E_z) + s e^{−(K−2η)²/2}] / D̂`,
//! returned by [`smooth_fast`]. With the defaults (K = 5, 48 lattice cells per σ), `E/D̂ ≈ 2`
//! and the bound is about `1e-3 · range` inside U, up to `2.3e-3 · range` near its border where
//! `D̂` is smaller (benches/smoother.rs, s = 10⁵ on 1001²); the observed error there was
//! `3e-6 · range`: the bound is a guarantee, not an estimate.

use drive_sim_model::kinematics::{BodyVelocity, CommandSpace};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Diagonal kernel covariance Σ = diag(σ_vx², σ_wz²).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct KernelCovariance {
    /// Variance along vx, (m/s)².
    pub var_vx: f64,
    /// Variance along wz, (rad/s)².
    pub var_wz: f64,
}

impl Default for KernelCovariance {
    /// The paper's Warthog figures: Σ = 0.64 I.
    fn default() -> Self {
        Self {
            var_vx: 0.64,
            var_wz: 0.64,
        }
    }
}

impl KernelCovariance {
    /// The isotropic variance of the paper's figures for a robot: 0.25 for the Husky (its
    /// lessons learned), 0.64 for the Warthog and any other robot (the Warthog figures). The one
    /// definition the analysis and the calibration's residual maps use.
    pub fn paper_variance(robot: &str) -> f64 {
        if robot == "husky" {
            0.25
        } else {
            0.64
        }
    }
}

/// Parameters of the fast smoother.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FastParams {
    /// Kernel truncated beyond this many standard deviations along each axis.
    pub truncation_sigmas: f64,
    /// Lattice spacing is at most σ / this.
    pub bins_per_sigma: f64,
}

impl Default for FastParams {
    fn default() -> Self {
        Self {
            truncation_sigmas: 5.0,
            bins_per_sigma: 48.0,
        }
    }
}

/// A uniform grid over (vx, wz); points outside U are masked. Index = `iwz * nvx + ivx`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Grid {
    /// Grid abscissae along vx, m/s (uniform, increasing).
    pub vx_m_s: Vec<f64>,
    /// Grid ordinates along wz, rad/s (uniform, increasing).
    pub wz_rad_s: Vec<f64>,
    /// True where the grid point lies in U.
    pub inside: Vec<bool>,
}

fn axis(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    if n <= 1 {
        return vec![lo];
    }
    (0..n)
        .map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64)
        .collect()
}

/// U's bounding box in the body frame: (vx range, wz range).
fn body_box(space: &CommandSpace) -> ((f64, f64), (f64, f64)) {
    space
        .polygon_body()
        .iter()
        .fold(((f64::MAX, f64::MIN), (f64::MAX, f64::MIN)), |(v, w), p| {
            ((v.0.min(p.0), v.1.max(p.0)), (w.0.min(p.1), w.1.max(p.1)))
        })
}

impl Grid {
    /// Grid over U's bounding box (in B) with the given resolutions, starting at the box's
    /// lower corner.
    pub fn over_space(space: &CommandSpace, res_vx_m_s: f64, res_wz_rad_s: f64) -> Self {
        let ((lo_v, hi_v), (lo_w, hi_w)) = body_box(space);
        let nv = ((hi_v - lo_v) / res_vx_m_s + 1e-9).floor() as usize + 1;
        let nw = ((hi_w - lo_w) / res_wz_rad_s + 1e-9).floor() as usize + 1;
        let vx: Vec<f64> = (0..nv).map(|i| lo_v + i as f64 * res_vx_m_s).collect();
        let wz: Vec<f64> = (0..nw).map(|i| lo_w + i as f64 * res_wz_rad_s).collect();
        Self::with_axes(space, vx, wz)
    }
    /// `nvx × nwz` grid spanning U's bounding box (used by the benches: 101², 1001²).
    pub fn with_counts(space: &CommandSpace, nvx: usize, nwz: usize) -> Self {
        let ((lo_v, hi_v), (lo_w, hi_w)) = body_box(space);
        Self::with_axes(space, axis(lo_v, hi_v, nvx), axis(lo_w, hi_w, nwz))
    }
    /// Grid on given axes, masked by U.
    pub fn with_axes(space: &CommandSpace, vx_m_s: Vec<f64>, wz_rad_s: Vec<f64>) -> Self {
        let mut inside = Vec::with_capacity(vx_m_s.len() * wz_rad_s.len());
        for &w in &wz_rad_s {
            for &v in &vx_m_s {
                inside.push(space.contains_body(BodyVelocity::new(v, 0.0, w)));
            }
        }
        Self {
            vx_m_s,
            wz_rad_s,
            inside,
        }
    }
    /// The rows `rows` (along wz) of this grid: a slab with the same spacing, for timing the
    /// exact smoother on a part of a large grid.
    pub fn slab(&self, rows: std::ops::Range<usize>) -> Self {
        let n = self.vx_m_s.len();
        Self {
            vx_m_s: self.vx_m_s.clone(),
            wz_rad_s: self.wz_rad_s[rows.clone()].to_vec(),
            inside: self.inside[rows.start * n..rows.end * n].to_vec(),
        }
    }
    /// Number of grid points.
    pub fn len(&self) -> usize {
        self.inside.len()
    }
    /// True if the grid has no point.
    pub fn is_empty(&self) -> bool {
        self.inside.is_empty()
    }
}

/// Smoothed values of one or several channels on a grid.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Smoothed {
    /// Per channel, per grid point: the smoothed value (NaN outside U or with no weight).
    pub values: Vec<Vec<f64>>,
    /// Per grid point: Σ k_i (kernel without its normalization constant, which cancels).
    pub weight_sum: Vec<f64>,
    /// Fast smoother only: per channel, per grid point, the guaranteed bound on
    /// |fast − exact| (see the module doc).
    pub error_bound: Option<Vec<Vec<f64>>>,
}

fn check_inputs(points: &[(f64, f64)], channels: &[&[f64]]) {
    for c in channels {
        assert_eq!(c.len(), points.len(), "every channel needs one value per point");
    }
}

/// Reference smoother: `Σ k_i g_i / Σ k_i` by direct summation at every grid point in U.
/// Points whose value is not finite are skipped (in every channel).
///
/// Σ is diagonal, so the kernel is the product of one factor per axis:
/// `k_i(ū) = exp(−Δv²/2σ_v²) · exp(−Δw²/2σ_w²)`. Each factor depends on one grid coordinate
/// only, so the `exp`s are taken once per (sample, grid column) and (sample, grid row), and a
/// kernel evaluation is one product: the sum is the definition's, with `s · (n_vx + n_wz)`
/// exponentials instead of `s · grid`, which made them most of the cost (an `exp` costs
/// [`EXP_COST_IN_MACS`] multiply-adds). The product differs from the exponential of the sum
/// by a few units in the last place.
pub fn smooth_exact(
    grid: &Grid,
    cov: &KernelCovariance,
    points: &[(f64, f64)],
    channels: &[&[f64]],
) -> Smoothed {
    check_inputs(points, channels);
    let keep: Vec<usize> = (0..points.len())
        .filter(|&i| {
            points[i].0.is_finite() && points[i].1.is_finite() && channels.iter().all(|c| c[i].is_finite())
        })
        .collect();
    let (ivx, iwz) = (0.5 / cov.var_vx, 0.5 / cov.var_wz);
    let nv = grid.vx_m_s.len();
    let nc = channels.len();
    // Per grid point: Σ k_i and, per channel, Σ k_i g_i, summed block of samples after block
    // (so that the factors of a block, `(n_vx + n_wz) · EXACT_BLOCK` values, bound the memory).
    let mut sums: Vec<(f64, Vec<f64>)> = (0..grid.len()).map(|_| (0.0, vec![0.0; nc])).collect();
    for block in keep.chunks(EXACT_BLOCK) {
        let m = block.len();
        // The kernel's factor along each axis: one row of `m` per grid abscissa (ordinate).
        let factors = |axis: &[f64], coordinate: fn(&(f64, f64)) -> f64, inv: f64| -> Vec<f64> {
            axis.iter()
                .flat_map(|&g| {
                    block.iter().map(move |&i| {
                        let d = coordinate(&points[i]) - g;
                        (-(d * d * inv)).exp()
                    })
                })
                .collect()
        };
        let along_vx = factors(&grid.vx_m_s, |p| p.0, ivx);
        let along_wz = factors(&grid.wz_rad_s, |p| p.1, iwz);
        let values: Vec<Vec<f64>> = channels
            .iter()
            .map(|c| block.iter().map(|&i| c[i]).collect())
            .collect();
        // One buffer of kernel weights per worker, refilled at each grid point.
        sums.par_iter_mut()
            .enumerate()
            .filter(|(g, _)| grid.inside[*g])
            .for_each_init(
                || Vec::with_capacity(m),
                |weights, (g, (d, n))| {
                    let (j, k) = (g % nv, g / nv);
                    let kv = &along_vx[j * m..(j + 1) * m];
                    let kw = &along_wz[k * m..(k + 1) * m];
                    weights.clear();
                    weights.extend(kv.iter().zip(kw).map(|(a, b)| a * b));
                    *d += weights.iter().sum::<f64>();
                    for (n, ch) in n.iter_mut().zip(&values) {
                        *n += dot(weights, ch);
                    }
                },
            );
    }
    let mut values = vec![Vec::with_capacity(grid.len()); nc];
    let mut weight_sum = Vec::with_capacity(grid.len());
    for (g, (d, n)) in sums.into_iter().enumerate() {
        weight_sum.push(d);
        for (c, n) in n.into_iter().enumerate() {
            values[c].push(if grid.inside[g] && d > 0.0 {
                n / d
            } else {
                f64::NAN
            });
        }
    }
    Smoothed {
        values,
        weight_sum,
        error_bound: None,
    }
}

/// Samples per block of [`smooth_exact`]: its factors take `(n_vx + n_wz) · 2048 · 8` bytes
/// (32 MiB on a 1001² grid), and a run's steps or samples fit in one or a few blocks.
const EXACT_BLOCK: usize = 2048;

/// One lattice axis: spacing `h = σ / bins_per_sigma`, `n` nodes from `origin`; the output
/// region (covering the grid's range) is nodes `half .. half + n_out`, `half` = the kernel's
/// half width in nodes.
struct LatticeAxis {
    origin: f64,
    h: f64,
    n: usize,
    n_out: usize,
    half: usize,
    taps: Vec<f64>,
    taps_q2: Vec<f64>,
}

impl LatticeAxis {
    fn new(grid_axis: &[f64], sigma: f64, fast: &FastParams) -> Self {
        let h = sigma / fast.bins_per_sigma;
        let half = (fast.truncation_sigmas * sigma / h).floor() as usize;
        let lo = grid_axis[0];
        let hi = grid_axis[grid_axis.len() - 1];
        let n_out = ((hi - lo) / h).ceil() as usize + 2;
        let n = n_out + 2 * half;
        let origin = lo - half as f64 * h;
        let q = |k: usize| (k as f64 - half as f64) * h / sigma;
        let taps: Vec<f64> = (0..=2 * half).map(|k| (-0.5 * q(k) * q(k)).exp()).collect();
        let taps_q2 = (0..=2 * half).map(|k| (1.0 + q(k) * q(k)) * taps[k]).collect();
        Self {
            origin,
            h,
            n,
            n_out,
            half,
            taps,
            taps_q2,
        }
    }
    /// Lower node and fractional position of `u` on the whole lattice, or None if off it.
    fn locate(&self, u: f64) -> Option<(usize, f64)> {
        let f = (u - self.origin) / self.h;
        if f.is_nan() || f < 0.0 || f >= (self.n - 1) as f64 {
            return None;
        }
        let i = f.floor() as usize;
        Some((i, f - i as f64))
    }
    /// Lower output-region node and fraction of a grid coordinate.
    fn locate_out(&self, g: f64) -> (usize, f64) {
        let f = ((g - self.origin) / self.h - self.half as f64).clamp(0.0, (self.n_out - 1) as f64);
        let j = (f.floor() as usize).min(self.n_out - 2);
        (j, f - j as f64)
    }
}

/// Dot product with eight independent accumulators, so that the compiler can vectorize it
/// (a single running sum is a serial chain of dependent additions).
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut acc = [0.0f64; 8];
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for k in 0..8 {
            acc[k] += x[k] * y[k];
        }
    }
    let mut s: f64 = acc.iter().sum();
    for (x, y) in ra.iter().zip(rb) {
        s += x * y;
    }
    s
}

/// Fast smoother: bilinear binning onto a lattice of spacing σ / `bins_per_sigma`, truncated
/// separable Gaussian convolution on the lattice, bilinear interpolation at the grid points;
/// with a per-point error bound against [`smooth_exact`] (derivation in the module doc).
pub fn smooth_fast(
    grid: &Grid,
    cov: &KernelCovariance,
    fast: &FastParams,
    points: &[(f64, f64)],
    channels: &[&[f64]],
) -> Smoothed {
    check_inputs(points, channels);
    let (sx, sz) = (cov.var_vx.sqrt(), cov.var_wz.sqrt());
    let ax = LatticeAxis::new(&grid.vx_m_s, sx, fast);
    let az = LatticeAxis::new(&grid.wz_rad_s, sz, fast);
    let nc = channels.len();
    // Lattice layers: 0 = weight, 1..=nc = weighted values.
    let mut lat = vec![vec![0.0f64; ax.n * az.n]; nc + 1];
    let mut ranges = vec![(f64::MAX, f64::MIN); nc];
    let mut s_total = 0usize;
    for (i, p) in points.iter().enumerate() {
        if !(p.0.is_finite() && p.1.is_finite() && channels.iter().all(|c| c[i].is_finite())) {
            continue;
        }
        s_total += 1;
        for c in 0..nc {
            let v = channels[c][i];
            ranges[c] = (ranges[c].0.min(v), ranges[c].1.max(v));
        }
        // Samples off the lattice are farther than K σ from every grid point: dropped, and
        // covered by the truncation term of the bound.
        let (Some((ix, tx)), Some((iz, tz))) = (ax.locate(p.0), az.locate(p.1)) else {
            continue;
        };
        let w = [
            (iz * ax.n + ix, (1.0 - tx) * (1.0 - tz)),
            (iz * ax.n + ix + 1, tx * (1.0 - tz)),
            ((iz + 1) * ax.n + ix, (1.0 - tx) * tz),
            ((iz + 1) * ax.n + ix + 1, tx * tz),
        ];
        for (node, wt) in w {
            lat[0][node] += wt;
            for c in 0..nc {
                lat[c + 1][node] += wt * channels[c][i];
            }
        }
    }
    let row_has_mass: Vec<bool> = (0..az.n)
        .map(|r| lat[0][r * ax.n..(r + 1) * ax.n].iter().any(|&v| v != 0.0))
        .collect();
    let nxo = ax.n_out;
    // Along x, at the output-region columns: A[r][j] = Σ_k taps[k] L[r][j + k].
    let pass_x = |layer: &[f64], taps: &[f64]| -> Vec<f64> {
        let mut out = vec![0.0; az.n * nxo];
        out.par_chunks_mut(nxo).enumerate().for_each(|(r, orow)| {
            if !row_has_mass[r] {
                return;
            }
            let row = &layer[r * ax.n..(r + 1) * ax.n];
            for (j, o) in orow.iter_mut().enumerate() {
                *o = dot(&row[j..j + taps.len()], taps);
            }
        });
        out
    };
    // Along z, at the output-region rows: C[j][i] = Σ_k taps[k] A[j + k][i].
    let pass_z = |a: &[f64], taps: &[f64]| -> Vec<f64> {
        let mut out = vec![0.0; az.n_out * nxo];
        out.par_chunks_mut(nxo).enumerate().for_each(|(j, orow)| {
            for (k, &t) in taps.iter().enumerate() {
                let r = j + k;
                if !row_has_mass[r] {
                    continue;
                }
                for (o, v) in orow.iter_mut().zip(&a[r * nxo..(r + 1) * nxo]) {
                    *o += t * v;
                }
            }
        });
        out
    };
    let nvx = grid.vx_m_s.len();
    // Bilinear interpolation of a lattice field at every grid point.
    let interp = |c: &[f64]| -> Vec<f64> {
        (0..grid.len())
            .map(|g| {
                let (j, tx) = ax.locate_out(grid.vx_m_s[g % nvx]);
                let (r, tz) = az.locate_out(grid.wz_rad_s[g / nvx]);
                let at = |r: usize, j: usize| c[r * nxo + j];
                (1.0 - tz) * ((1.0 - tx) * at(r, j) + tx * at(r, j + 1))
                    + tz * ((1.0 - tx) * at(r + 1, j) + tx * at(r + 1, j + 1))
            })
            .collect()
    };
    let d_x = pass_x(&lat[0], &ax.taps);
    let d = interp(&pass_z(&d_x, &az.taps));
    let e_x = interp(&pass_z(&pass_x(&lat[0], &ax.taps_q2), &az.taps));
    let e_z = interp(&pass_z(&d_x, &az.taps_q2));
    // Bound (module doc): two bilinear steps (binning, interpolation), each within one cell.
    let eta_x = ax.h / sx;
    let eta_z = az.h / sz;
    let k = fast.truncation_sigmas;
    let c_of = |eta: f64| (2.0 * eta * (k + 2.0 * eta) + 2.0 * eta * eta).exp();
    let c2 = (c_of(eta_x) * c_of(eta_z)).powi(2);
    let (eps_x, eps_z) = (eta_x * eta_x / 8.0, eta_z * eta_z / 8.0);
    let trunc = s_total as f64 * (-0.5 * (k - 2.0 * eta_x.max(eta_z)).powi(2)).exp();
    let rel: Vec<f64> = (0..grid.len())
        .map(|g| {
            if d[g] > 0.0 {
                (4.0 * c2 * 1.02 * (eps_x * e_x[g] + eps_z * e_z[g]) + trunc) / d[g]
            } else {
                f64::INFINITY
            }
        })
        .collect();
    let mut values = Vec::with_capacity(nc);
    let mut bounds = Vec::with_capacity(nc);
    for c in 0..nc {
        let n = interp(&pass_z(&pass_x(&lat[c + 1], &ax.taps), &az.taps));
        let range = if ranges[c].1 >= ranges[c].0 {
            ranges[c].1 - ranges[c].0
        } else {
            0.0
        };
        values.push(
            (0..grid.len())
                .map(|g| {
                    if grid.inside[g] && d[g] > 0.0 {
                        n[g] / d[g]
                    } else {
                        f64::NAN
                    }
                })
                .collect::<Vec<f64>>(),
        );
        bounds.push((0..grid.len()).map(|g| range * rel[g]).collect::<Vec<f64>>());
    }
    Smoothed {
        values,
        weight_sum: d,
        error_bound: Some(bounds),
    }
}

/// Which implementation [`smooth`] used.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SmootherMethod {
    /// [`smooth_exact`].
    Exact,
    /// [`smooth_fast`].
    Fast,
}

/// Cost model of the choice in [`smooth`]: one `exp` of the exact smoother's kernel factors
/// costs about this many multiply-adds of the fast one's convolution (measured by
/// `benches/smoother.rs` when each kernel evaluation was an `exp`: ~14 ns per evaluation vs
/// ~0.3 ns per multiply-add on the 2-core development machine).
pub const EXP_COST_IN_MACS: f64 = 40.0;

/// Smooths with whichever implementation is cheaper: the fast smoother's cost depends on its
/// lattice (about `(3 + channels) · lattice · taps` multiply-adds, independent of `s` and of
/// the grid), the exact one's on `s · grid points in U` (`2 + channels` multiply-adds each)
/// and `s · (n_vx + n_wz)` exponentials. With the paper's settings (a few
/// hundred samples on a 0.1 grid) the exact smoother wins; with 10⁵ samples or a fine grid the
/// fast one does.
pub fn smooth(
    grid: &Grid,
    cov: &KernelCovariance,
    fast: &FastParams,
    points: &[(f64, f64)],
    channels: &[&[f64]],
) -> (SmootherMethod, Smoothed) {
    match choose_method(grid, cov, fast, points.len(), channels.len()) {
        SmootherMethod::Exact => (SmootherMethod::Exact, smooth_exact(grid, cov, points, channels)),
        SmootherMethod::Fast => (
            SmootherMethod::Fast,
            smooth_fast(grid, cov, fast, points, channels),
        ),
    }
}

/// Local-linear kernel regression: at each grid point, the intercept of the kernel-weighted
/// least-squares plane through the points (the same Gaussian kernel as [`smooth`]), instead of
/// the kernel-weighted mean.
///
/// Why: the weighted mean of a sloped surface is biased by the slope times the weighted mean
/// offset of the points from the grid point, and that offset depends on which commands a run
/// drew. Beyond a wheel-speed limit the wheel slip is a ramp (command − limit); two runs of one
/// exact model then differ there by their designs, not by noise. A plane is unbiased on a plane
/// whatever the design; what is left is the curvature's bias (at the limit's kink).
///
/// Computed from kernel-weighted moments, each a channel of [`smooth`]: with `E` the
/// kernel-weighted mean at the grid point `g`, `x` the point, `y` a channel, the value is
/// `E[y] + βᵀ(g − E[x])` with `Cov(x) β = Cov(x, y)`. Where the points are nearly collinear
/// under the kernel (the smaller eigenvalue of `Cov(x)`, in units of the kernel's variances,
/// below 1e-6) the plane is not determined and the weighted mean is kept. `error_bound` is
/// `None`.
pub fn smooth_local_linear(
    grid: &Grid,
    cov: &KernelCovariance,
    fast: &FastParams,
    points: &[(f64, f64)],
    channels: &[&[f64]],
) -> Smoothed {
    check_inputs(points, channels);
    // Moments in kernel-variance units (so that the collinearity threshold is scale-free).
    let (sv, sw) = (cov.var_vx.sqrt(), cov.var_wz.sqrt());
    let u: Vec<f64> = points.iter().map(|p| p.0 / sv).collect();
    let w: Vec<f64> = points.iter().map(|p| p.1 / sw).collect();
    let uu: Vec<f64> = u.iter().map(|a| a * a).collect();
    let uw: Vec<f64> = u.iter().zip(&w).map(|(a, b)| a * b).collect();
    let ww: Vec<f64> = w.iter().map(|b| b * b).collect();
    let mut derived: Vec<Vec<f64>> = vec![u.clone(), w.clone(), uu, uw, ww];
    for c in channels {
        derived.push(c.iter().zip(&u).map(|(y, a)| y * a).collect());
        derived.push(c.iter().zip(&w).map(|(y, b)| y * b).collect());
    }
    let mut refs: Vec<&[f64]> = derived.iter().map(|c| c.as_slice()).collect();
    refs.extend_from_slice(channels);
    let (_, m) = smooth(grid, cov, fast, points, &refs);
    let nv = grid.vx_m_s.len();
    let nc = channels.len();
    let first_y = 5 + 2 * nc;
    let mut values = vec![vec![f64::NAN; grid.len()]; nc];
    let supported = |g: usize| grid.inside[g] && m.weight_sum[g] > 0.0;
    for g in (0..grid.len()).filter(|&g| supported(g)) {
        let at = |k: usize| m.values[k][g];
        let (eu, ew) = (at(0), at(1));
        let (cuu, cuw, cww) = (at(2) - eu * eu, at(3) - eu * ew, at(4) - ew * ew);
        let det = cuu * cww - cuw * cuw;
        let half_trace = 0.5 * (cuu + cww);
        let smallest = half_trace - (half_trace * half_trace - det).max(0.0).sqrt();
        let plane = smallest > 1e-6 && det > 0.0;
        let (gu, gw) = (grid.vx_m_s[g % nv] / sv, grid.wz_rad_s[g / nv] / sw);
        for (c, out) in values.iter_mut().enumerate() {
            let ey = at(first_y + c);
            out[g] = if plane {
                let cuy = at(5 + 2 * c) - eu * ey;
                let cwy = at(6 + 2 * c) - ew * ey;
                let bu = (cww * cuy - cuw * cwy) / det;
                let bw = (cuu * cwy - cuw * cuy) / det;
                ey + bu * (gu - eu) + bw * (gw - ew)
            } else {
                ey
            };
        }
    }
    Smoothed {
        values,
        weight_sum: m.weight_sum,
        error_bound: None,
    }
}

/// The cheaper implementation for `s` samples and `n_channels` channels (cost model of [`smooth`]).
pub fn choose_method(
    grid: &Grid,
    cov: &KernelCovariance,
    fast: &FastParams,
    s: usize,
    n_channels: usize,
) -> SmootherMethod {
    let inside = grid.inside.iter().filter(|&&b| b).count() as f64;
    // The exact smoother: the kernel's factors (an `exp` per sample and grid column or row),
    // then per (sample, grid point) their product, its sum and one multiply-add per channel.
    let axes = (grid.vx_m_s.len() + grid.wz_rad_s.len()) as f64;
    let exact_cost = s as f64 * (axes * EXP_COST_IN_MACS + inside * (2.0 + n_channels as f64));
    let axis = |v: &[f64], var: f64| {
        let h = var.sqrt() / fast.bins_per_sigma;
        let taps = 2.0 * fast.truncation_sigmas * fast.bins_per_sigma + 1.0;
        ((v[v.len() - 1] - v[0]) / h + 2.0, taps)
    };
    let (nx, tx) = axis(&grid.vx_m_s, cov.var_vx);
    let (nz, tz) = axis(&grid.wz_rad_s, cov.var_wz);
    let fast_cost = (3.0 + n_channels as f64) * (nz * nx * tx + nz * tz * nx);
    if exact_cost <= fast_cost {
        SmootherMethod::Exact
    } else {
        SmootherMethod::Fast
    }
}

/// Grid and smoothed fields of the slip dimensions and ρ (the paper's transfer functions).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TransferFunctions {
    /// The grid (over U's bounding box in B, masked by U).
    pub grid: Grid,
    /// Kernel covariance used.
    pub covariance: KernelCovariance,
    /// Names of the fields, in the order of `smoothed.values`.
    pub names: Vec<String>,
    /// Implementation used.
    pub method: SmootherMethod,
    /// The fields (and, for the fast smoother, their error bounds).
    pub smoothed: Smoothed,
}

#[cfg(test)]
mod tests {
    use super::*;
    use drive_sim_model::kinematics::IdealDiffDrive;
    use rand::{RngExt, SeedableRng};

    fn space() -> CommandSpace {
        CommandSpace {
            idd: IdealDiffDrive {
                wheel_radius_m: 0.3,
                baseline_m: 1.08,
            },
            max_wheel_rad_s: 16.6667,
            max_lin_m_s: 5.0,
            max_ang_rad_s: 4.0,
            turn_scale: 1.0,
        }
    }

    fn samples(n: usize, seed: u64) -> Vec<(f64, f64)> {
        let s = space();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let mut out = Vec::new();
        while out.len() < n {
            let p = (rng.random_range(-5.0..5.0), rng.random_range(-4.0..4.0));
            if s.contains_body(BodyVelocity::new(p.0, 0.0, p.1)) {
                out.push(p);
            }
        }
        out
    }

    #[test]
    fn method_choice_follows_the_cost_model() {
        let cov = KernelCovariance::default();
        let fast = FastParams::default();
        // The paper's setting (100 steps, 0.1 grid, 6 fields): exact. 10^5 samples on 1001^2: fast.
        let coarse = Grid::over_space(&space(), 0.1, 0.1);
        assert_eq!(choose_method(&coarse, &cov, &fast, 100, 6), SmootherMethod::Exact);
        let fine = Grid::with_counts(&space(), 1001, 1001);
        assert_eq!(
            choose_method(&fine, &cov, &fast, 100_000, 1),
            SmootherMethod::Fast
        );
    }

    /// The definition summed directly, one `exp` per (sample, grid point): the oracle of
    /// [`smooth_exact`]'s factored kernel.
    fn smooth_by_definition(
        grid: &Grid,
        cov: &KernelCovariance,
        points: &[(f64, f64)],
        channel: &[f64],
    ) -> (Vec<f64>, Vec<f64>) {
        let nv = grid.vx_m_s.len();
        (0..grid.len())
            .map(|g| {
                if !grid.inside[g] {
                    return (0.0, f64::NAN);
                }
                let (gv, gw) = (grid.vx_m_s[g % nv], grid.wz_rad_s[g / nv]);
                let (mut d, mut n) = (0.0, 0.0);
                for (p, y) in points.iter().zip(channel) {
                    if !(p.0.is_finite() && p.1.is_finite() && y.is_finite()) {
                        continue;
                    }
                    let (dv, dw) = (p.0 - gv, p.1 - gw);
                    let k = (-0.5 * (dv * dv / cov.var_vx + dw * dw / cov.var_wz)).exp();
                    d += k;
                    n += k * y;
                }
                (d, if d > 0.0 { n / d } else { f64::NAN })
            })
            .unzip()
    }

    /// The factored kernel sums what the definition sums, over several blocks of samples, with
    /// samples of non-finite values skipped and grid points outside U left empty.
    #[test]
    fn exact_is_the_definition_over_several_blocks() {
        let grid = Grid::over_space(&space(), 0.5, 0.5);
        let cov = KernelCovariance {
            var_vx: 0.64,
            var_wz: 0.25,
        };
        let mut pts = samples(2 * EXACT_BLOCK + 17, 5);
        let mut y: Vec<f64> = pts.iter().map(|p| (p.0 * 1.3).sin() + p.1 * p.1).collect();
        pts[3].0 = f64::NAN;
        y[EXACT_BLOCK + 1] = f64::INFINITY;
        let got = smooth_exact(&grid, &cov, &pts, &[&y]);
        let (d, v) = smooth_by_definition(&grid, &cov, &pts, &y);
        assert!(grid.inside.iter().any(|&i| !i));
        for g in 0..grid.len() {
            if !grid.inside[g] {
                assert_eq!(got.weight_sum[g], 0.0);
                assert!(got.values[0][g].is_nan());
                continue;
            }
            assert!((got.weight_sum[g] - d[g]).abs() <= 1e-12 * d[g], "{g}");
            assert!(
                (got.values[0][g] - v[g]).abs() <= 1e-10,
                "{g}: {} {}",
                got.values[0][g],
                v[g]
            );
        }
    }

    #[test]
    fn constant_is_reproduced_exactly() {
        let grid = Grid::over_space(&space(), 0.1, 0.1);
        let pts = samples(200, 1);
        let c = vec![0.7; pts.len()];
        let cov = KernelCovariance::default();
        for sm in [
            smooth_exact(&grid, &cov, &pts, &[&c]),
            smooth_fast(&grid, &cov, &FastParams::default(), &pts, &[&c]),
        ] {
            for (g, v) in sm.values[0].iter().enumerate() {
                if grid.inside[g] {
                    assert!((v - 0.7).abs() < 1e-12, "{v}");
                } else {
                    assert!(v.is_nan());
                }
            }
        }
    }

    /// A plane is reproduced exactly by the local-linear smoother wherever the points
    /// determine it, however one-sided they are; the kernel-weighted mean of the same points is
    /// off by the slope times their mean offset. Collinear points fall back to the mean.
    #[test]
    fn local_linear_reproduces_a_plane_whatever_the_design() {
        let grid = Grid::over_space(&space(), 0.1, 0.1);
        let cov = KernelCovariance::default();
        // One-sided design: only points with vx > 1 (the grid's points below are extrapolated
        // from one side).
        let pts: Vec<(f64, f64)> = samples(400, 4).into_iter().filter(|p| p.0 > 1.0).collect();
        let plane = |p: &(f64, f64)| 2.0 + 3.0 * p.0 - 0.5 * p.1;
        let y: Vec<f64> = pts.iter().map(plane).collect();
        let ll = smooth_local_linear(&grid, &cov, &FastParams::default(), &pts, &[&y]);
        let nw = smooth_exact(&grid, &cov, &pts, &[&y]);
        let nv = grid.vx_m_s.len();
        let (mut worst_ll, mut worst_nw, mut n) = (0.0f64, 0.0f64, 0);
        for g in 0..grid.len() {
            if !grid.inside[g] || nw.weight_sum[g] < 0.5 {
                continue;
            }
            let truth = plane(&(grid.vx_m_s[g % nv], grid.wz_rad_s[g / nv]));
            worst_ll = worst_ll.max((ll.values[0][g] - truth).abs());
            worst_nw = worst_nw.max((nw.values[0][g] - truth).abs());
            n += 1;
        }
        assert!(n > 100, "{n}");
        assert!(worst_ll < 1e-8, "local-linear off a plane by {worst_ll}");
        assert!(
            worst_nw > 0.1,
            "the weighted mean was expected off by the slope: {worst_nw}"
        );
        // Every point on the vx axis: the plane's wz slope is not determined; the mean is kept.
        let line: Vec<(f64, f64)> = (0..50).map(|i| (-2.0 + 0.08 * i as f64, 0.0)).collect();
        let y: Vec<f64> = line.iter().map(plane).collect();
        let ll = smooth_local_linear(&grid, &cov, &FastParams::default(), &line, &[&y]);
        let nw = smooth_exact(&grid, &cov, &line, &[&y]);
        for g in 0..grid.len() {
            if grid.inside[g] && nw.weight_sum[g] > 0.5 {
                assert!(ll.values[0][g].is_finite());
                assert!((ll.values[0][g] - nw.values[0][g]).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn linear_is_nearly_linear_inside_and_fast_matches_exact() {
        // g = 0.3 vx - 0.2 wz + 1. A kernel smoother reproduces a linear function exactly where
        // the samples are symmetric about the grid point; with uniform samples in U the bias
        // is the local asymmetry times the slope. Check it is small deep inside U.
        let space = space();
        let grid = Grid::over_space(&space, 0.1, 0.1);
        for (n, seed) in [(3000, 2), (300, 3)] {
            check_linear(&grid, &samples(n, seed), n == 3000);
        }
    }

    fn check_linear(grid: &Grid, pts: &[(f64, f64)], dense: bool) {
        let g: Vec<f64> = pts.iter().map(|p| 0.3 * p.0 - 0.2 * p.1 + 1.0).collect();
        let cov = KernelCovariance::default();
        let ex = smooth_exact(grid, &cov, pts, &[&g]);
        let fa = smooth_fast(grid, &cov, &FastParams::default(), pts, &[&g]);
        let nv = grid.vx_m_s.len();
        let range = g.iter().cloned().fold(f64::MIN, f64::max) - g.iter().cloned().fold(f64::MAX, f64::min);
        let mut max_diff: f64 = 0.0;
        for i in 0..grid.len() {
            if !grid.inside[i] {
                continue;
            }
            let (v, w) = (grid.vx_m_s[i % nv], grid.wz_rad_s[i / nv]);
            let diff = (ex.values[0][i] - fa.values[0][i]).abs();
            let bound = fa.error_bound.as_ref().unwrap()[0][i];
            assert!(diff <= bound, "diff {diff} above bound {bound} at ({v}, {w})");
            max_diff = max_diff.max(diff);
            if dense && v.abs() < 1.5 && w.abs() < 1.5 {
                let truth = 0.3 * v - 0.2 * w + 1.0;
                assert!(
                    (ex.values[0][i] - truth).abs() < 0.1,
                    "{} vs {truth}",
                    ex.values[0][i]
                );
            }
        }
        assert!(max_diff <= 1e-3 * range, "{max_diff}");
        // Weight sums agree too.
        let i0 = grid.inside.iter().position(|&b| b).unwrap();
        assert!((ex.weight_sum[i0] - fa.weight_sum[i0]).abs() / ex.weight_sum[i0] < 1e-3);
    }
}
