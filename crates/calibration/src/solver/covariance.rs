//! Uncertainty of fitted parameters: the covariance of the estimate with residuals clustered
//! by step (the sandwich, or robust, estimator), standard errors, 95 % intervals and
//! correlations.
//!
//! Why clustered: the samples of a step share its initial state, its command and whatever the
//! terrain did under the robot then, so they are not independent; treating 40 samples of a
//! step as 40 observations would shrink every interval by a factor of up to √40. The
//! estimating equation of the fit is `Σ_s ψ_s(θ) = 0` with `ψ_s` the step's influence on the
//! log score's gradient (through its residuals and through the channel weights its squared
//! errors set); its covariance is `(S−1)/S Σ_s d_s d_sᵀ` over the `S` steps with
//! `d_s = (A − A_s)⁻¹ ψ_s`, `A` the Gauss–Newton Hessian ([`super::weighted_normal_equations`])
//! and `A_s` the step's own share of it: the sandwich `A⁻¹ B A⁻¹` with each step's influence
//! corrected for its leverage (CR3, the one-step jackknife; see [`sandwich`] for why). It holds
//! whatever the noise's variance per channel, and does not assume the model is right.

use super::Layout;
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

/// Covariance of some fitted parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Covariance {
    /// The parameters, in order (report names).
    pub names: Vec<String>,
    /// Standard errors, in the parameters' units (infinite: the data do not constrain it).
    pub se: Vec<f64>,
    /// Correlation matrix of the estimates (sandwich), row-major (NaN where a standard error
    /// is not finite): how the estimates move together when the data are resampled.
    pub correlation: Vec<Vec<f64>>,
    /// Correlation matrix of the information (the inverse of the Gauss–Newton Hessian,
    /// normalised): how far the model itself can tell the parameters apart, whatever the noise.
    /// Two parameters that act alike on every channel are near ±1 here; identifiability is
    /// judged on it.
    #[serde(default)]
    pub information_correlation: Vec<Vec<f64>>,
    /// Steps (clusters) the estimate used.
    pub clusters: usize,
    /// How it was computed.
    pub method: String,
}

impl Covariance {
    /// The largest |information correlation| of parameter `i` with another one (0 with one
    /// parameter; a correlation with a parameter the data do not determine is skipped).
    pub fn max_abs_correlation(&self, i: usize) -> f64 {
        self.information_correlation[i]
            .iter()
            .enumerate()
            .filter(|(j, c)| *j != i && !c.is_nan())
            .map(|(_, c)| c.abs())
            .fold(0.0, f64::max)
    }
}

/// The clustered sandwich covariance of the parameters whose columns of `jacobian`
/// (residuals × parameters, in the parameters' units) are listed in `free`, at residuals `r`.
/// Parameters of a singular direction of the bread get infinite standard errors.
pub fn sandwich(
    layout: &Layout,
    r: &[f64],
    jacobian: &DMatrix<f64>,
    free: &[usize],
    names: Vec<String>,
) -> Covariance {
    let w = layout.weights(r);
    let p = free.len();
    // The bread: the Gauss–Newton Hessian of the log score with the weights at their
    // estimates (positive semi-definite; the weights' own variability is in the meat).
    let (_, h) = super::weighted_normal_equations(layout, &w, r, jacobian);
    let a = DMatrix::<f64>::from_fn(p, p, |i, j| h[(free[i], free[j])]);
    let mut clusters: Vec<u32> = layout.cluster.clone();
    clusters.sort_unstable();
    clusters.dedup();
    // Each step's influence on the log score's gradient, including through the channel
    // weights (a step that carries much of a channel's squared error also moves its weight):
    // ψ_s = Σ_c w_c (J_scᵀ r_sc − (q_sc / S_c) J_cᵀ r_c), q_sc the step's sum of squares in
    // channel c. The second term is zero with one channel at its optimum.
    let nc = layout.n_channels();
    let (s_c, _) = layout.channel_sums(r);
    let mut u = vec![vec![DVector::<f64>::zeros(p); nc]; clusters.len()];
    // Each step's own share of the bread, for the leverage correction below.
    let mut a_s = vec![DMatrix::<f64>::zeros(p, p); clusters.len()];
    let mut q = vec![vec![0.0; nc]; clusters.len()];
    let mut v = vec![DVector::<f64>::zeros(p); nc];
    for i in 0..r.len() {
        let c = layout.channel[i] as usize;
        if w[c] == 0.0 {
            continue;
        }
        let k = clusters.binary_search(&layout.cluster[i]).unwrap_or(0);
        q[k][c] += r[i] * r[i];
        for (aa, &ja) in free.iter().enumerate() {
            let t = r[i] * jacobian[(i, ja)];
            u[k][c][aa] += t;
            v[c][aa] += t;
            for (bb, &jb) in free.iter().enumerate() {
                a_s[k][(aa, bb)] += w[c] * jacobian[(i, ja)] * jacobian[(i, jb)];
            }
        }
    }
    let psi: Vec<DVector<f64>> = (0..clusters.len())
        .map(|k| {
            let mut acc = DVector::<f64>::zeros(p);
            for c in 0..nc {
                if w[c] > 0.0 && s_c[c] > 0.0 {
                    acc += (&u[k][c] - &v[c] * (q[k][c] / s_c[c])) * w[c];
                }
            }
            acc
        })
        .collect();
    let s = clusters.len() as f64;
    // Pseudo-inverse of the bread: a direction the data cannot see has no inverse.
    let svd = a.clone().svd(true, true);
    let smax = svd.singular_values.max();
    let tol = smax * 1e-10;
    let singular: Vec<bool> = svd.singular_values.iter().map(|&sv| sv <= tol).collect();
    // A parameter that loads on a null direction of the bread is not determined.
    let v_t = svd.v_t.clone().unwrap_or_else(|| DMatrix::identity(p, p));
    let ainv = svd
        .pseudo_inverse(tol)
        .unwrap_or_else(|_| DMatrix::from_element(p, p, f64::NAN));
    // Each step's shift of the estimate when it is left out, `(A − A_s)⁻¹ ψ_s` (the
    // one-step jackknife: the CR3 estimator), instead of `A⁻¹ ψ_s`. Why: an influential step
    // pulls the fit towards itself, so its own residuals understate its noise, and with a
    // few tens of clusters the plain sandwich (CR1) was a quarter narrower than the refits on
    // resampled steps for a parameter that few steps carry (the effective baseline: 0.77).
    // A step without which the bread is singular keeps the plain shift.
    let mut cov = DMatrix::<f64>::zeros(p, p);
    for (k, v) in psi.iter().enumerate() {
        let d = (&a - &a_s[k])
            .cholesky()
            .map(|c| c.solve(v))
            .unwrap_or_else(|| &ainv * v);
        cov += &d * d.transpose();
    }
    if s > 1.0 {
        cov *= (s - 1.0) / s;
    }
    let undetermined: Vec<bool> = (0..p)
        .map(|j| {
            singular
                .iter()
                .enumerate()
                .any(|(k, &sing)| sing && v_t[(k, j)].abs() > 1e-6)
        })
        .collect();
    let se: Vec<f64> = (0..p)
        .map(|j| {
            if undetermined[j] || !cov[(j, j)].is_finite() {
                f64::INFINITY
            } else {
                cov[(j, j)].max(0.0).sqrt()
            }
        })
        .collect();
    let correlation = (0..p)
        .map(|i| {
            (0..p)
                .map(|j| {
                    if i == j {
                        1.0
                    } else if undetermined[i] && undetermined[j] {
                        // Both on a null direction: indistinguishable.
                        1.0
                    } else if se[i].is_finite() && se[j].is_finite() && se[i] > 0.0 && se[j] > 0.0 {
                        (cov[(i, j)] / (se[i] * se[j])).clamp(-1.0, 1.0)
                    } else {
                        f64::NAN
                    }
                })
                .collect()
        })
        .collect();
    let info_corr = (0..p)
        .map(|i| {
            (0..p)
                .map(|j| {
                    if i == j || (undetermined[i] && undetermined[j]) {
                        1.0
                    } else if undetermined[i] || undetermined[j] {
                        f64::NAN
                    } else {
                        let d = (ainv[(i, i)] * ainv[(j, j)]).sqrt();
                        if d > 0.0 {
                            (ainv[(i, j)] / d).clamp(-1.0, 1.0)
                        } else {
                            f64::NAN
                        }
                    }
                })
                .collect()
        })
        .collect();
    Covariance {
        names,
        se,
        correlation,
        information_correlation: info_corr,
        clusters: clusters.len(),
        method: "sandwich (robust) covariance with residuals clustered by step, each step's influence leverage-corrected (CR3, the one-step jackknife), at the optimum".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linear_regression_by_hand_and_a_collinear_pair() {
        // y = b x with one entry per cluster: the leverage-corrected sandwich (CR3) is the
        // one-step jackknife, var(b) = (S − 1)/S · Σ (x e / (Σ x² − x²))².
        // Residuals at the least-squares optimum (Σ x e = 0).
        let x = [1.0, 2.0, 3.0, 4.0];
        let e = [0.1, -0.2, 0.15, -0.0375];
        let layout = Layout {
            channel: vec![0; 4],
            cluster: vec![0, 1, 2, 3],
            floor: vec![1.0],
            min_ratio: 0.0,
        };
        let j = DMatrix::from_column_slice(4, 1, &x);
        let c = sandwich(&layout, &e, &j, &[0], vec!["b".into()]);
        let sxx: f64 = x.iter().map(|v| v * v).sum();
        let jack: f64 = x
            .iter()
            .zip(&e)
            .map(|(x, e)| (x * e / (sxx - x * x)).powi(2))
            .sum();
        let expected = (jack * 3.0 / 4.0).sqrt();
        assert!((c.se[0] - expected).abs() < 1e-12 * expected.max(1.0), "{c:?}");
        // Two identical columns: not determined, perfectly correlated.
        let j2 = DMatrix::from_columns(&[DVector::from_column_slice(&x), DVector::from_column_slice(&x)]);
        let c2 = sandwich(&layout, &e, &j2, &[0, 1], vec!["a".into(), "b".into()]);
        assert!(c2.se.iter().all(|s| s.is_infinite()), "{c2:?}");
        assert_eq!(c2.max_abs_correlation(0), 1.0);
    }
}
