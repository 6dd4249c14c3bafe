//! Descriptive statistics as the paper uses them: quantiles, box-plot summaries (boxes are the
//! quartiles, whiskers the central 95 %, after Cumming 2009), least-squares lines.

use serde::{Deserialize, Serialize};

/// Quantile `q` in [0, 1] of already sorted values, by linear interpolation between order
/// statistics (Hyndman & Fan type 7, the default of NumPy and R). NaN for an empty slice.
pub fn quantile_sorted(sorted: &[f64], q: f64) -> f64 {
    quantile_of_order_statistics(sorted.len(), q, |k| sorted[k])
}

/// Quantile `q` (type 7, as [`quantile_sorted`]) of `len` values given by their order
/// statistics: `at(k)` is the `k`-th smallest, from 0. For a sorted list that is never built
/// (a bootstrap resample read off counts). NaN when `len` is 0.
pub fn quantile_of_order_statistics(len: usize, q: f64, mut at: impl FnMut(usize) -> f64) -> f64 {
    if len == 0 {
        return f64::NAN;
    }
    let q = q.clamp(0.0, 1.0);
    let h = (len - 1) as f64 * q;
    let lo = h.floor() as usize;
    let hi = h.ceil() as usize;
    let low = at(lo);
    low + (h - lo as f64) * (at(hi) - low)
}

/// Finite values of `values`, sorted ascending.
pub fn sorted_finite(values: &[f64]) -> Vec<f64> {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    v.sort_by(f64::total_cmp);
    v
}

/// Quantile of the finite values (NaN if there is none).
pub fn quantile(values: &[f64], q: f64) -> f64 {
    quantile_sorted(&sorted_finite(values), q)
}

/// Median of the finite values (NaN if there is none).
pub fn median(values: &[f64]) -> f64 {
    quantile(values, 0.5)
}

/// Mean of the finite values (NaN if there is none).
pub fn mean(values: &[f64]) -> f64 {
    let v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        f64::NAN
    } else {
        v.iter().sum::<f64>() / v.len() as f64
    }
}

/// Mean and sample standard deviation (n − 1) of the finite values: (NaN, NaN) if there is
/// none, a standard deviation of 0 for one.
pub fn mean_sd(values: &[f64]) -> (f64, f64) {
    let x: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    if x.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    let n = x.len() as f64;
    let m = x.iter().sum::<f64>() / n;
    let sd = if x.len() > 1 {
        (x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
    } else {
        0.0
    };
    (m, sd)
}

/// Interquartile mean of the finite values: the mean of those between the first and third
/// quartiles (NaN if there is none). It averages noise like a mean and ignores up to a quarter
/// of wild values at either end like a median: what an estimate from a few encoder samples
/// needs when a reading can drop to zero or jump by a count.
pub fn interquartile_mean(values: &[f64]) -> f64 {
    let s = sorted_finite(values);
    if s.is_empty() {
        return f64::NAN;
    }
    let (q1, q3) = (quantile_sorted(&s, 0.25), quantile_sorted(&s, 0.75));
    let inner: Vec<f64> = s.iter().copied().filter(|v| *v >= q1 && *v <= q3).collect();
    inner.iter().sum::<f64>() / inner.len() as f64
}

/// Box-plot summary of a distribution (paper convention: whiskers at 2.5 % and 97.5 %).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BoxStats {
    /// Number of finite values summarized.
    pub n: usize,
    /// 2.5 % quantile (lower whisker).
    pub whisker_low: f64,
    /// First quartile.
    pub q1: f64,
    /// Median.
    pub median: f64,
    /// Third quartile.
    pub q3: f64,
    /// 97.5 % quantile (upper whisker).
    pub whisker_high: f64,
    /// Mean.
    pub mean: f64,
    /// Smallest value.
    pub min: f64,
    /// Largest value.
    pub max: f64,
}

impl BoxStats {
    /// Summary of the finite values; `None` if there is none.
    pub fn from_values(values: &[f64]) -> Option<Self> {
        let s = sorted_finite(values);
        if s.is_empty() {
            return None;
        }
        Some(Self {
            n: s.len(),
            whisker_low: quantile_sorted(&s, 0.025),
            q1: quantile_sorted(&s, 0.25),
            median: quantile_sorted(&s, 0.5),
            q3: quantile_sorted(&s, 0.75),
            whisker_high: quantile_sorted(&s, 0.975),
            mean: s.iter().sum::<f64>() / s.len() as f64,
            min: s[0],
            max: s[s.len() - 1],
        })
    }
    /// True if `other`'s median lies outside this interquartile range: the paper's (Cumming 2009)
    /// "beginning of a significant difference".
    pub fn median_outside_iqr(&self, other: &BoxStats) -> bool {
        other.median < self.q1 || other.median > self.q3
    }
}

/// Ratio of the medians of two distributions, `a / b` (the paper compares terrains this way,
/// e.g. "the median of ice is 1.6 times the median of grass, gravel and asphalt").
pub fn median_ratio(a: &[f64], b: &[f64]) -> f64 {
    median(a) / median(b)
}

/// Ordinary least-squares line `y = slope x + intercept` with Pearson correlation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LinearFit {
    /// Number of (x, y) pairs used (both finite).
    pub n: usize,
    /// Slope dy/dx.
    pub slope: f64,
    /// Intercept (y at x = 0).
    pub intercept: f64,
    /// Pearson correlation coefficient.
    pub correlation: f64,
}

/// Least-squares fit of `y` on `x` over the pairs where both are finite. NaN slope if x is constant.
pub fn linear_fit(x: &[f64], y: &[f64]) -> LinearFit {
    let pairs: Vec<(f64, f64)> = x
        .iter()
        .zip(y)
        .filter(|(a, b)| a.is_finite() && b.is_finite())
        .map(|(a, b)| (*a, *b))
        .collect();
    let n = pairs.len();
    if n < 2 {
        return LinearFit {
            n,
            slope: f64::NAN,
            intercept: f64::NAN,
            correlation: f64::NAN,
        };
    }
    let nf = n as f64;
    let mx = pairs.iter().map(|p| p.0).sum::<f64>() / nf;
    let my = pairs.iter().map(|p| p.1).sum::<f64>() / nf;
    let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
    for (a, b) in &pairs {
        sxx += (a - mx) * (a - mx);
        syy += (b - my) * (b - my);
        sxy += (a - mx) * (b - my);
    }
    let slope = sxy / sxx;
    LinearFit {
        n,
        slope,
        intercept: my - slope * mx,
        correlation: sxy / (sxx * syy).sqrt(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_interquartile_mean_ignores_a_dropout_and_averages_the_rest() {
        // Readings of 10 a count of ±0.5 either way, one dropped to 0 and one spike.
        let v = [10.5, 9.5, 10.0, 0.0, 10.0, 20.0, 9.5, 10.5, 10.0];
        assert!((interquartile_mean(&v) - 10.0).abs() < 1e-12);
        assert!((interquartile_mean(&[1.0, 2.0, 3.0, 4.0, 5.0]) - 3.0).abs() < 1e-12);
        assert_eq!(interquartile_mean(&[7.0]), 7.0);
        assert!(interquartile_mean(&[f64::NAN]).is_nan());
    }

    #[test]
    fn quantiles_by_hand() {
        // 1..=5: type-7 25 % quantile at h = 4 * 0.25 = 1 -> 2; 2.5 % at h = 0.1 -> 1.1.
        let v = [5.0, 1.0, 3.0, 2.0, 4.0, f64::NAN];
        let b = BoxStats::from_values(&v).unwrap();
        assert_eq!(b.n, 5);
        assert_eq!((b.q1, b.median, b.q3), (2.0, 3.0, 4.0));
        assert!((b.whisker_low - 1.1).abs() < 1e-12);
        assert!((b.whisker_high - 4.9).abs() < 1e-12);
        assert!(BoxStats::from_values(&[f64::NAN]).is_none());
        assert!((median_ratio(&[2.0, 4.0], &[1.0, 2.0]) - 2.0).abs() < 1e-12);
    }

    #[test]
    fn line_by_hand() {
        let f = linear_fit(&[0.0, 1.0, 2.0], &[1.0, 3.0, 5.0]);
        assert!((f.slope - 2.0).abs() < 1e-12 && (f.intercept - 1.0).abs() < 1e-12);
        assert!((f.correlation - 1.0).abs() < 1e-12);
        let g = linear_fit(&[0.0, 1.0, 2.0], &[5.0, 3.0, 1.0]);
        assert!((g.correlation + 1.0).abs() < 1e-12);
    }
}
