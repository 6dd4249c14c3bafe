//! Bootstrap by step: the one resampling definition behind every interval the project prints
//! for a median (`analyze`) or for a difference between two runs (`compare`).
//!
//! Why by step: the samples inside a DRIVE step share one command and one transient, so they
//! are not independent; the step is the unit of replication. A resample draws as many steps as
//! the run has, with replacement, and recomputes the statistic on them. The interval is the
//! percentile interval of the resampled statistics (quantiles of type 7, the one quantile
//! definition of [`super::stats`]).
//!
//! Draws come from a ChaCha8 generator seeded with [`Bootstrap::seed`] and a stream number, so
//! the same inputs give the same interval. When the number of distinct resamples (`n^n`) is
//! no larger than the budget, all of them are enumerated instead (the exact bootstrap): tiny
//! fixtures then have intervals a person can compute by hand.

use super::stats::{quantile_of_order_statistics, quantile_sorted, sorted_finite};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// Fewer steps than this and an interval is reported with a named warning (`too_few_steps`):
/// percentile intervals of a median undercover badly on a handful of values.
pub const MIN_STEPS_FOR_INTERVAL: usize = 10;

/// How intervals are drawn.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Bootstrap {
    /// Resamples drawn.
    pub resamples: usize,
    /// Seed of the draws.
    pub seed: u64,
    /// Coverage of the intervals, e.g. 0.95.
    pub level: f64,
}

impl Default for Bootstrap {
    fn default() -> Self {
        Self {
            resamples: 2000,
            seed: 0xB007_5742,
            level: 0.95,
        }
    }
}

/// A bootstrap percentile interval.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Interval {
    /// Lower bound.
    pub lower: f64,
    /// Upper bound.
    pub upper: f64,
    /// Coverage, e.g. 0.95.
    pub level: f64,
}

impl Interval {
    /// Whether `v` lies in the interval (bounds included).
    pub fn contains(&self, v: f64) -> bool {
        v >= self.lower && v <= self.upper
    }

    /// Whether the two intervals share no value: a conservative reading of "two estimates
    /// differ" (two 95 % intervals that miss each other differ at well below 5 %), the one
    /// `compare` uses for its diagnostics beside the verdict.
    pub fn misses(&self, other: &Interval) -> bool {
        self.lower > other.upper || other.lower > self.upper
    }
}

/// `n^n`, or `None` when it exceeds `cap`.
fn exhaustive_count(n: usize, cap: usize) -> Option<usize> {
    let mut c: usize = 1;
    for _ in 0..n {
        c = c.checked_mul(n)?;
        if c > cap {
            return None;
        }
    }
    Some(c)
}

impl Bootstrap {
    /// The resamples of `n` steps, as index vectors: every one of the `n^n` when that is no more
    /// than [`Bootstrap::resamples`] (exact bootstrap), else `resamples` seeded draws.
    /// `stream` separates independent draws of one seed (the two runs of a two-sample
    /// comparison).
    pub fn draws(&self, n: usize, stream: u64) -> Vec<Vec<usize>> {
        let mut out = Vec::new();
        self.each_draw(n, stream, |idx| out.push(idx.to_vec()));
        out
    }

    /// Calls `f` with each resample of [`Bootstrap::draws`], in the same order, through one
    /// reused buffer: what a statistic computed on the fly needs, without holding every
    /// resample at once.
    pub fn each_draw(&self, n: usize, stream: u64, mut f: impl FnMut(&[usize])) {
        if n == 0 {
            return;
        }
        let mut idx = vec![0usize; n];
        if let Some(total) = exhaustive_count(n, self.resamples) {
            for mut k in 0..total {
                for slot in idx.iter_mut() {
                    *slot = k % n;
                    k /= n;
                }
                f(&idx);
            }
            return;
        }
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed ^ stream.wrapping_mul(0x9E37_79B9_7F4A_7C15));
        for _ in 0..self.resamples {
            for slot in idx.iter_mut() {
                *slot = rng.random_range(0..n);
            }
            f(&idx);
        }
    }

    /// The percentile interval of resampled statistics (non-finite ones dropped); `None`
    /// without any finite one.
    pub fn interval(&self, stats: &[f64]) -> Option<Interval> {
        let s = sorted_finite(stats);
        if s.is_empty() {
            return None;
        }
        let a = (1.0 - self.level) / 2.0;
        Some(Interval {
            lower: quantile_sorted(&s, a),
            upper: quantile_sorted(&s, 1.0 - a),
            level: self.level,
        })
    }

    /// Interval of the median of `values` (one value per step); `None` with fewer than two
    /// finite values.
    pub fn median_interval(&self, values: &[f64]) -> Option<Interval> {
        let v = sorted_finite(values);
        if v.len() < 2 {
            return None;
        }
        let mut median = ResampledMedian::new(&v);
        let mut stats = Vec::with_capacity(self.resamples);
        self.each_draw(v.len(), 0, |idx| stats.push(median.of(idx)));
        self.interval(&stats)
    }
}

/// The median of resamples of one set of values, as sorting each resample gives it (type 7,
/// the finite values only, NaN when a resample draws none), in O(n) per resample.
///
/// Why: sorting a copy of each resample was about a tenth of a twin command's CPU (`perf
/// record`), the largest cost after the physics. With the values ranked once, a resample
/// sorted is each ranked value repeated as often as it is drawn, so its middle order
/// statistics come from a walk along the counts instead of a sort of a copy.
#[derive(Debug, Clone)]
pub struct ResampledMedian {
    /// Each value's position among the finite values sorted (`None` when not finite).
    rank: Vec<Option<usize>>,
    /// The finite values, sorted.
    sorted: Vec<f64>,
    /// How many times the current resample draws each sorted value.
    count: Vec<u32>,
}

impl ResampledMedian {
    /// Ranks `values` (indexed as the resamples index them).
    pub fn new(values: &[f64]) -> Self {
        let mut order: Vec<usize> = (0..values.len()).filter(|&i| values[i].is_finite()).collect();
        order.sort_by(|&a, &b| values[a].total_cmp(&values[b]));
        let mut rank = vec![None; values.len()];
        for (r, &i) in order.iter().enumerate() {
            rank[i] = Some(r);
        }
        Self {
            rank,
            sorted: order.iter().map(|&i| values[i]).collect(),
            count: vec![0; order.len()],
        }
    }

    /// The median of the values at `idx` (a resample: indices into the values, repeats
    /// allowed).
    pub fn of(&mut self, idx: &[usize]) -> f64 {
        self.count.fill(0);
        let mut drawn = 0usize;
        for &i in idx {
            if let Some(r) = self.rank[i] {
                self.count[r] += 1;
                drawn += 1;
            }
        }
        let (sorted, count) = (&self.sorted, &self.count);
        quantile_of_order_statistics(drawn, 0.5, |k| {
            // The resample sorted is `sorted[r]` repeated `count[r]` times, in order of `r`.
            let mut seen = 0usize;
            for (r, &c) in count.iter().enumerate() {
                seen += c as usize;
                if seen > k {
                    return sorted[r];
                }
            }
            f64::NAN
        })
    }
}

/// Two-sided bootstrap p-value of "the difference is zero": twice the smaller of the shares
/// of resampled differences at or below zero and at or above zero, capped at 1. It is below
/// `1 − level` exactly when zero lies outside the percentile interval of that level (up to
/// interpolation), so Holm's correction acts on the same evidence as the intervals.
pub fn two_sided_p(diffs: &[f64]) -> f64 {
    let d: Vec<f64> = diffs.iter().copied().filter(|x| x.is_finite()).collect();
    if d.is_empty() {
        return f64::NAN;
    }
    let n = d.len() as f64;
    let below = d.iter().filter(|&&x| x <= 0.0).count() as f64 / n;
    let above = d.iter().filter(|&&x| x >= 0.0).count() as f64 / n;
    (2.0 * below.min(above)).min(1.0)
}

/// Holm's step-down adjustment of p-values (family-wise error control): sorted ascending, the
/// k-th smallest (from 0) is multiplied by `m − k`, made non-decreasing, capped at 1. NaN
/// p-values stay NaN and do not count in `m`.
pub fn holm(p: &[f64]) -> Vec<f64> {
    let mut idx: Vec<usize> = (0..p.len()).filter(|&i| p[i].is_finite()).collect();
    idx.sort_by(|&a, &b| p[a].total_cmp(&p[b]));
    let m = idx.len();
    let mut out = vec![f64::NAN; p.len()];
    let mut running: f64 = 0.0;
    for (k, &i) in idx.iter().enumerate() {
        running = running.max(((m - k) as f64 * p[i]).min(1.0));
        out[i] = running;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn three_values_enumerate_all_27_resamples() {
        // Medians of the 27 resamples of {1, 2, 3}: 7 give 1 (at least two 1s), 7 give 3, 13
        // give 2. Type-7 quantiles of the sorted 27: 2.5 % at h = 0.65 -> 1, 97.5 % at
        // h = 25.35 -> 3.
        let b = Bootstrap::default();
        assert_eq!(b.draws(3, 0).len(), 27);
        let i = b.median_interval(&[3.0, 1.0, 2.0]).unwrap();
        assert_eq!((i.lower, i.upper), (1.0, 3.0));
        // 50 % interval: quantiles 0.25 (h = 6.5: between the 7th and 8th sorted, 1 and 2)
        // and 0.75 (h = 19.5: between 2 and 3).
        let half = Bootstrap { level: 0.5, ..b };
        let i = half.median_interval(&[1.0, 2.0, 3.0]).unwrap();
        assert_eq!((i.lower, i.upper), (1.5, 2.5));
    }

    #[test]
    fn holm_by_hand() {
        // p = 0.01, 0.04, 0.03 -> sorted 0.01·3 = 0.03, 0.03·2 = 0.06, 0.04·1 -> max(0.06, 0.04)
        let a = holm(&[0.01, 0.04, 0.03]);
        assert!((a[0] - 0.03).abs() < 1e-12 && (a[2] - 0.06).abs() < 1e-12 && (a[1] - 0.06).abs() < 1e-12);
    }

    /// Finite quarters (many ties), any normal number, a negative zero or a NaN.
    fn value() -> impl Strategy<Value = f64> {
        prop_oneof![
            (-50i32..50).prop_map(|k| f64::from(k) * 0.25),
            proptest::num::f64::NORMAL,
            Just(-0.0),
            Just(f64::NAN),
        ]
    }

    proptest! {
        /// The median interval from the counts equals the one from sorting each resample (the
        /// plain definition, kept here as the oracle), ties, signed zeros and non-finite values
        /// included.
        #[test]
        fn median_interval_matches_sorting_each_resample(
            values in proptest::collection::vec(value(), 0..40),
            resamples in 1usize..300,
        ) {
            let b = Bootstrap { resamples, ..Bootstrap::default() };
            let v = sorted_finite(&values);
            let oracle = if v.len() < 2 {
                None
            } else {
                let stats: Vec<f64> = b
                    .draws(v.len(), 0)
                    .iter()
                    .map(|idx| crate::stats::median(&idx.iter().map(|&i| v[i]).collect::<Vec<_>>()))
                    .collect();
                b.interval(&stats)
            };
            let bits = |i: Option<Interval>| i.map(|i| (i.lower.to_bits(), i.upper.to_bits()));
            prop_assert_eq!(bits(b.median_interval(&values)), bits(oracle));
        }

        /// On unsorted values with NaNs, each resample's median equals sorting its finite
        /// values (NaN when it draws none).
        #[test]
        fn resampled_median_matches_sorting(
            values in proptest::collection::vec(value(), 1..40),
            resamples in 1usize..100,
        ) {
            let b = Bootstrap { resamples, ..Bootstrap::default() };
            let mut median = ResampledMedian::new(&values);
            for idx in b.draws(values.len(), 5) {
                let oracle = crate::stats::median(&idx.iter().map(|&i| values[i]).collect::<Vec<_>>());
                prop_assert_eq!(median.of(&idx).to_bits(), oracle.to_bits());
            }
        }
    }

    #[test]
    fn same_seed_same_draws() {
        let b = Bootstrap::default();
        assert_eq!(b.draws(40, 1), b.draws(40, 1));
        assert_ne!(b.draws(40, 1), b.draws(40, 2));
    }
}
