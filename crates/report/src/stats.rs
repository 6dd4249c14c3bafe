//! The few statistics the figures draw: quantiles, box-plot summaries, histograms.

/// Splits `values` into its finite values and the count of non-finite ones (NaN, ±inf).
pub fn finite_values(values: &[f64]) -> (Vec<f64>, usize) {
    let finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    let skipped = values.len() - finite.len();
    (finite, skipped)
}

/// Quantile `p` in [0, 1] of sorted finite values, by linear interpolation between order
/// statistics (Hyndman & Fan type 7, the default of R and NumPy). `None` if empty.
pub fn quantile_sorted(sorted: &[f64], p: f64) -> Option<f64> {
    if sorted.is_empty() || !p.is_finite() {
        return None;
    }
    let p = p.clamp(0.0, 1.0);
    let h = (sorted.len() - 1) as f64 * p;
    let lo = h.floor() as usize;
    let hi = (lo + 1).min(sorted.len() - 1);
    Some(sorted[lo] + (h - lo as f64) * (sorted[hi] - sorted[lo]))
}

/// Box-and-whisker summary following the paper (after Cumming 2009): box = quartiles,
/// line = median, whiskers = 2.5 % and 97.5 % quantiles (95 % of the distribution).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoxStats {
    /// 2.5 % quantile (lower whisker end).
    pub whisker_low: f64,
    /// First quartile.
    pub q1: f64,
    /// Median.
    pub median: f64,
    /// Third quartile.
    pub q3: f64,
    /// 97.5 % quantile (upper whisker end).
    pub whisker_high: f64,
    /// Number of finite values summarized.
    pub n: usize,
}

impl BoxStats {
    /// Summary of the finite values in `values`; `None` if there is none.
    pub fn from_values(values: &[f64]) -> Option<Self> {
        let (mut v, _) = finite_values(values);
        v.sort_by(f64::total_cmp);
        Some(Self {
            whisker_low: quantile_sorted(&v, 0.025)?,
            q1: quantile_sorted(&v, 0.25)?,
            median: quantile_sorted(&v, 0.5)?,
            q3: quantile_sorted(&v, 0.75)?,
            whisker_high: quantile_sorted(&v, 0.975)?,
            n: v.len(),
        })
    }
}

/// Equal-width histogram of finite values over `[lo, hi]` with `bins` bins; values outside
/// the range are not counted. Returns the counts.
pub fn histogram(values: &[f64], lo: f64, hi: f64, bins: usize) -> Vec<usize> {
    let mut counts = vec![0usize; bins];
    if bins == 0 || !(lo.is_finite() && hi.is_finite()) || hi <= lo {
        return counts;
    }
    let w = (hi - lo) / bins as f64;
    for &v in values.iter().filter(|v| v.is_finite()) {
        if v < lo || v > hi {
            continue;
        }
        let i = (((v - lo) / w).floor() as usize).min(bins - 1);
        counts[i] += 1;
    }
    counts
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_by_hand() {
        // 1..=5: type 7 quartiles are 2 and 4, median 3; p = 0.025 -> h = 0.1 -> 1.1.
        let s = BoxStats::from_values(&[5.0, 1.0, f64::NAN, 3.0, 2.0, 4.0]).unwrap();
        assert_eq!((s.q1, s.median, s.q3), (2.0, 3.0, 4.0));
        assert!((s.whisker_low - 1.1).abs() < 1e-12);
        assert!((s.whisker_high - 4.9).abs() < 1e-12);
        assert_eq!(s.n, 5);
        assert!(BoxStats::from_values(&[f64::NAN]).is_none());
        let one = BoxStats::from_values(&[2.5]).unwrap();
        assert_eq!((one.whisker_low, one.whisker_high), (2.5, 2.5));
    }

    #[test]
    fn histogram_counts() {
        let c = histogram(&[0.0, 0.1, 0.5, 0.99, 1.0, 2.0, f64::NAN], 0.0, 1.0, 2);
        assert_eq!(c, vec![2, 3]);
        assert_eq!(histogram(&[1.0], 1.0, 1.0, 3), vec![0, 0, 0]);
    }
}
