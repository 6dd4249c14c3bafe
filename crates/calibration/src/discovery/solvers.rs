//! The sparse regressions discovery chooses between, and the least squares they share.
//!
//! Both read a design whose columns have unit root mean square, so one threshold means the
//! same in both: a coefficient below it is zero.
//!
//! - **STLSQ** (sequentially thresholded least squares; Brunton, Proctor and Kutz 2016): least
//!   squares, zero every coefficient below the threshold, refit on the rest, until the support
//!   stops changing. It decides each term from the full least-squares fit, so of two
//!   correlated columns it keeps whichever that fit happens to weigh more.
//! - **SR3** (sparse relaxed regularized regression; Zheng, Askham, Brunton, Kutz and Aravkin
//!   2019, as PySINDy's `SR3` with the ℓ0 penalty): the coefficients `ξ` fit the data and stay
//!   close to a relaxed copy `w` that carries the penalty,
//!   `½‖Aξ − b‖² + (λ²/2ν)‖w‖₀ + (1/2ν)‖ξ − w‖²`. Alternating the two minimizations, `ξ` is a
//!   ridge fit pulled towards `w`, and `w` is `ξ` hard-thresholded at `λ`. The pull lets a
//!   term that least squares splits with a correlated neighbour gather its weight before it
//!   is judged, so SR3 can reach a support STLSQ's first fit closes off. The support is then
//!   refitted by least squares (PySINDy's `unbias`), as STLSQ's last step is.
//!
//! Which of the two an equation uses is chosen on validation (`super::choose_threshold`).

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

/// SR3's relaxation: the pull `1/ν` towards the relaxed copy, per row of the design (the
/// design's columns have unit RMS, so `AᵀA / rows` has a unit diagonal and the pull weighs
/// like one more column's worth of data). PySINDy's default `ν = 1` on an unscaled design of
/// thousands of rows would make the pull vanish and SR3 one hard threshold of least squares.
pub const SR3_PULL_PER_ROW: f64 = 1.0;
/// SR3 iterations at most; it stops earlier when the relaxed copy moves less than
/// [`SR3_TOLERANCE`] of its size.
pub const SR3_MAX_ITER: usize = 200;
/// SR3's stopping tolerance on the relaxed copy's relative change.
pub const SR3_TOLERANCE: f64 = 1e-8;

/// A sparse regression discovery can use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SparseSolver {
    /// Sequentially thresholded least squares.
    #[default]
    Stlsq,
    /// Sparse relaxed regularized regression with the ℓ0 penalty.
    Sr3,
}

impl SparseSolver {
    /// Every solver, the incumbent first (a tie goes to it).
    pub const ALL: [Self; 2] = [Self::Stlsq, Self::Sr3];

    /// The name reports give it.
    pub fn name(self) -> &'static str {
        match self {
            Self::Stlsq => "STLSQ",
            Self::Sr3 => "SR3",
        }
    }

    /// Coefficients of `a` for `b` with every coefficient below `lambda` zero.
    pub fn fit(self, a: &DMatrix<f64>, b: &DVector<f64>, lambda: f64, max_iter: usize) -> DVector<f64> {
        match self {
            Self::Stlsq => stlsq(a, b, lambda, max_iter),
            Self::Sr3 => Sr3::new(a, b).map_or_else(|| stlsq(a, b, lambda, max_iter), |s| s.fit(lambda)),
        }
    }
}

/// Sequentially thresholded least squares: least squares, zero every coefficient below
/// `lambda` in magnitude, refit on the rest, until the support stops changing.
pub fn stlsq(a: &DMatrix<f64>, b: &DVector<f64>, lambda: f64, max_iter: usize) -> DVector<f64> {
    let p = a.ncols();
    let support: Vec<usize> = (0..p).collect();
    let mut xi = DVector::zeros(p);
    let mut support = support;
    for _ in 0..max_iter.max(1) {
        xi = DVector::zeros(p);
        if support.is_empty() {
            break;
        }
        let sub = a.select_columns(support.iter());
        let Some(x) = least_squares(&sub, b) else {
            break;
        };
        for (k, &j) in support.iter().enumerate() {
            xi[j] = x[k];
        }
        let next: Vec<usize> = support
            .iter()
            .copied()
            .filter(|&j| xi[j].abs() >= lambda)
            .collect();
        if next.len() == support.len() {
            break;
        }
        support = next;
    }
    threshold(&mut xi, lambda);
    xi
}

/// One design's SR3: the factor of the relaxed normal equations, computed once for every
/// threshold.
pub struct Sr3<'a> {
    a: &'a DMatrix<f64>,
    b: &'a DVector<f64>,
    /// Cholesky factor of `AᵀA + I/ν`.
    relaxed: nalgebra::Cholesky<f64, nalgebra::Dyn>,
    /// `Aᵀb`.
    atb: DVector<f64>,
    /// `1/ν`.
    pull: f64,
    /// The least-squares start (minimum norm when the design is rank-deficient).
    start: DVector<f64>,
}

impl<'a> Sr3<'a> {
    /// `None` for an empty design or one whose relaxed normal equations do not factor.
    pub fn new(a: &'a DMatrix<f64>, b: &'a DVector<f64>) -> Option<Self> {
        if a.ncols() == 0 || a.nrows() == 0 {
            return None;
        }
        let pull = SR3_PULL_PER_ROW * a.nrows() as f64;
        let ata = a.transpose() * a;
        let relaxed = (ata + DMatrix::identity(a.ncols(), a.ncols()) * pull).cholesky()?;
        let atb = a.transpose() * b;
        let start = minimum_norm_least_squares(a, b)?;
        Some(Self {
            a,
            b,
            relaxed,
            atb,
            pull,
            start,
        })
    }

    /// The sparse fit at `lambda`: alternate the ridge step and the hard threshold from the
    /// thresholded least-squares start, then least squares on the support.
    pub fn fit(&self, lambda: f64) -> DVector<f64> {
        let mut w = self.start.clone();
        threshold(&mut w, lambda);
        for _ in 0..SR3_MAX_ITER {
            let xi = self.relaxed.solve(&(&self.atb + &w * self.pull));
            let mut next = xi;
            threshold(&mut next, lambda);
            let moved = (&next - &w).norm();
            let size = next.norm().max(f64::MIN_POSITIVE);
            w = next;
            if moved <= SR3_TOLERANCE * size {
                break;
            }
        }
        let support: Vec<usize> = (0..w.len()).filter(|&j| w[j] != 0.0).collect();
        if support.is_empty() {
            return w;
        }
        match least_squares(&self.a.select_columns(support.iter()), self.b) {
            Some(x) => {
                let mut out = DVector::zeros(w.len());
                for (k, &j) in support.iter().enumerate() {
                    out[j] = x[k];
                }
                threshold(&mut out, lambda);
                out
            }
            None => w,
        }
    }
}

/// Zeroes every entry of `x` below `lambda` in magnitude.
fn threshold(x: &mut DVector<f64>, lambda: f64) {
    for v in x.iter_mut() {
        if v.abs() < lambda {
            *v = 0.0;
        }
    }
}

/// Least squares by SVD; `None` when the matrix is rank-deficient (a singular design), has
/// no row, or gives a non-finite solution.
pub fn least_squares(a: &DMatrix<f64>, b: &DVector<f64>) -> Option<DVector<f64>> {
    if a.nrows() < a.ncols() || a.ncols() == 0 {
        return None;
    }
    let svd = a.clone().svd(true, true);
    let smax = svd.singular_values.max();
    let smin = svd.singular_values.min();
    if smax.is_nan() || smax <= 0.0 || smin <= smax * 1e-10 {
        return None;
    }
    let x = svd.solve(b, 0.0).ok()?;
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// Least squares by SVD with singular values below 1e-10 of the largest treated as zero (the
/// minimum-norm solution of a rank-deficient system).
pub(super) fn minimum_norm_least_squares(a: &DMatrix<f64>, b: &DVector<f64>) -> Option<DVector<f64>> {
    if a.ncols() == 0 || a.nrows() == 0 {
        return None;
    }
    let svd = a.clone().svd(true, true);
    let eps = svd.singular_values.max() * 1e-10;
    let x = svd.solve(b, eps).ok()?;
    x.iter().all(|v| v.is_finite()).then_some(x)
}
