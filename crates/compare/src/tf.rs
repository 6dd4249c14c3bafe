//! Transfer functions of two runs on one grid, their difference maps, and the split-half
//! yardstick the RMS difference is judged against.
//!
//! Why a yardstick: a kernel-smoothed map of ~150 noisy steps differs from the same robot's
//! next run by its sampling error alone. Splitting the real run into alternate steps gives
//! two independent half-size estimates (alternate steps); their RMS difference estimates that error. With a
//! per-grid-point variance σ²/n for a map of n steps, the halves differ by
//! RMS² ≈ σ²(2/n_r + 2/n_r) = 4σ²/n_r, and two full runs of n_r and n_s steps by
//! σ²(1/n_r + 1/n_s). The yardstick is therefore the split-half RMS times
//! √((1 + n_r/n_s)/4) ([`yardstick_scale`]); √½ for runs of equal size.
//!
//! One split is one draw of a statistic with few degrees of freedom: the alternate-step split of
//! one 100-step run gave a left-wheel RMS of 0.13 rad/s, another seed's 0.42 (README, "Twins and
//! compare"), and the ratio inherited that noise in its denominator. The yardstick therefore
//! uses the quadratic mean of the split-half RMS over `tf_yardstick_splits` halvings of the real
//! run ([`SplitHalves`]): the alternate steps first, then random balanced halvings (seeded), each
//! evaluated on the comparison's own grid points. One halving is the alternate split alone.
//!
//! The yardstick is a scale, not a test: a map's RMS over a few dozen kernel footprints is a
//! statistic with few degrees of freedom, and two runs of the same model exceed 1.5× it often
//! (README, "Twins and compare"). A permutation test gives each map a calibrated p-value
//! beside it: the RMS difference against its distribution when the steps are exchanged between
//! the two runs (two-sample: the pooled steps re-split at random; paired: each step's two rows
//! swapped with probability ½), Holm-adjusted over the five maps.

use super::{CompareOptions, StepRow, TfDiff};
use drive_sim_analysis::smoother::{
    smooth, smooth_local_linear, FastParams, Grid, KernelCovariance, Smoothed,
};
use drive_sim_log::DriveLog;
use rand::seq::SliceRandom;
use rand::SeedableRng;
use serde::{Deserialize, Serialize};

/// Channels compared: the steady slips in both frames.
pub const CHANNELS: &[(&str, &str)] = &[
    ("slip_vx_m_s", "m/s"),
    ("slip_vy_m_s", "m/s"),
    ("slip_wz_rad_s", "rad/s"),
    ("slip_left_rad_s", "rad/s"),
    ("slip_right_rad_s", "rad/s"),
];

/// Factor from the split-half RMS of a run of `n_real` steps to the RMS expected between it
/// and an independent run of `n_sim` steps (module doc).
pub fn yardstick_scale(n_real: usize, n_sim: usize) -> f64 {
    ((1.0 + n_real as f64 / n_sim.max(1) as f64) / 4.0).sqrt()
}

/// The real run's halvings for the yardstick: per halving, per channel, per grid point, the
/// difference of the two halves' maps (NaN where either half lacks support). The first halving
/// is the alternate steps (`halves` of [`super::PreparedReal`]); there is always one.
#[derive(Debug, Clone)]
pub struct SplitHalves {
    diffs: Vec<Vec<Vec<f64>>>,
}

impl SplitHalves {
    /// Halvings of the real run's `rows`: the alternate-step split `halves`, then `count − 1`
    /// random balanced ones drawn with `seed`.
    pub(crate) fn new(
        setup: &TfSetup,
        rows: &[&StepRow],
        halves: &(Smoothed, Smoothed),
        count: usize,
        seed: u64,
    ) -> Self {
        let mut diffs = vec![setup.difference(&halves.0, &halves.1)];
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        for _ in 1..count {
            let mut order: Vec<&StepRow> = rows.to_vec();
            order.shuffle(&mut rng);
            let b = order.split_off(order.len() / 2);
            diffs.push(setup.difference(&setup.fields(&order), &setup.fields(&b)));
        }
        Self { diffs }
    }

    /// Halvings held.
    pub fn count(&self) -> usize {
        self.diffs.len()
    }
}

/// Difference maps `sim − real` on the real run's grid (`wz` major, `vx` minor; NaN where a
/// point is outside U or not supported by both runs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DiffMaps {
    /// Grid abscissae, m/s.
    pub vx_m_s: Vec<f64>,
    /// Grid ordinates, rad/s.
    pub wz_rad_s: Vec<f64>,
    /// Channel names, in the order of `values`.
    pub channels: Vec<String>,
    /// Per channel, per grid point.
    pub values: Vec<Vec<f64>>,
}

/// The common grid and smoother.
#[derive(Debug, Clone)]
pub struct TfSetup {
    grid: Grid,
    cov: KernelCovariance,
    fast: FastParams,
    min_weight: f64,
    tolerance: f64,
    smoother: super::TfSmoother,
}

impl TfSetup {
    /// The grid over the real log's command space and the paper's kernel for its robot.
    pub fn new(real: &DriveLog, opts: &CompareOptions) -> Self {
        let space = real.meta.nominal.command_space();
        let var = opts
            .kernel_var
            .unwrap_or_else(|| KernelCovariance::paper_variance(&real.meta.robot));
        Self {
            grid: Grid::over_space(&space, opts.grid_step, opts.grid_step),
            cov: KernelCovariance {
                var_vx: var,
                var_wz: var,
            },
            fast: FastParams::default(),
            min_weight: opts.min_weight,
            tolerance: opts.tf_tolerance,
            smoother: opts.tf_smoother,
        }
    }

    /// The smoothed slip fields of a set of steps.
    pub(crate) fn fields(&self, rows: &[&StepRow]) -> Smoothed {
        let pts: Vec<(f64, f64)> = rows.iter().map(|r| r.cmd_body).collect();
        let cols: Vec<Vec<f64>> = (1..6)
            .map(|k| rows.iter().map(|r| r.values[k]).collect())
            .collect();
        let refs: Vec<&[f64]> = cols.iter().map(|c| c.as_slice()).collect();
        match self.smoother {
            super::TfSmoother::Kernel => smooth(&self.grid, &self.cov, &self.fast, &pts, &refs).1,
            super::TfSmoother::LocalLinear => {
                smooth_local_linear(&self.grid, &self.cov, &self.fast, &pts, &refs)
            }
        }
    }

    fn supported(&self, f: &Smoothed, i: usize) -> bool {
        self.grid.inside[i] && f.weight_sum[i] >= self.min_weight
    }

    /// The points the comparison is made on: where the simulated run and both of the real
    /// run's halves support the map (`sim`'s fields with the weight of every other point set to
    /// zero; [`TfSetup::rms`] also requires the real run's support).
    fn joint_support(&self, sim: &Smoothed, halves: &(Smoothed, Smoothed)) -> Smoothed {
        let mut both = sim.clone();
        for i in 0..self.grid.len() {
            if !(self.supported(&halves.0, i) && self.supported(&halves.1, i)) {
                both.weight_sum[i] = 0.0;
            }
        }
        both
    }

    /// Permutation p-values of each channel's RMS difference between `real` and `sim` (module
    /// doc): `permutations` exchanges of the steps, seeded with `seed`, the RMS of each over
    /// the observed comparison's points; `p = (1 + #{RMS ≥ observed}) / (1 + permutations)`.
    /// `paired`: `real[i]` and `sim[i]` are the same step. `sim_fields` are the simulated run's
    /// fields the observed comparison used (they and the halves give its points). `None` where
    /// a channel has no point.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn permutation_p(
        &self,
        real: &[&StepRow],
        sim: &[&StepRow],
        paired: bool,
        sim_fields: &Smoothed,
        halves: &(Smoothed, Smoothed),
        observed: &[TfDiff],
        permutations: usize,
        seed: u64,
    ) -> Vec<Option<f64>> {
        use rand::seq::SliceRandom;
        use rand::{RngExt, SeedableRng};
        if permutations == 0 || real.is_empty() || sim.is_empty() {
            return vec![None; CHANNELS.len()];
        }
        let mask = self.joint_support(sim_fields, halves);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let mut exceed = vec![0usize; CHANNELS.len()];
        let pooled: Vec<&StepRow> = real.iter().chain(sim).copied().collect();
        for _ in 0..permutations {
            let (a, b): (Vec<&StepRow>, Vec<&StepRow>) = if paired && real.len() == sim.len() {
                real.iter()
                    .zip(sim)
                    .map(|(r, q)| if rng.random_bool(0.5) { (*q, *r) } else { (*r, *q) })
                    .unzip()
            } else {
                let mut p = pooled.clone();
                p.shuffle(&mut rng);
                let b = p.split_off(real.len());
                (p, b)
            };
            let rms = self.rms(&self.fields(&b), &self.fields(&a), &mask);
            for (c, (r, _)) in rms.iter().enumerate() {
                if r.is_finite() && *r >= observed[c].rms {
                    exceed[c] += 1;
                }
            }
        }
        observed
            .iter()
            .zip(exceed)
            .map(|(t, e)| {
                (t.points > 0 && t.rms.is_finite()).then(|| (1 + e) as f64 / (1 + permutations) as f64)
            })
            .collect()
    }

    /// `a − b` per channel and grid point, NaN where either lacks support.
    fn difference(&self, a: &Smoothed, b: &Smoothed) -> Vec<Vec<f64>> {
        (0..CHANNELS.len())
            .map(|c| {
                (0..self.grid.len())
                    .map(|i| {
                        if self.supported(a, i) && self.supported(b, i) {
                            a.values[c][i] - b.values[c][i]
                        } else {
                            f64::NAN
                        }
                    })
                    .collect()
            })
            .collect()
    }

    /// Per channel, the RMS of a difference map (from [`TfSetup::difference`]) over its
    /// finite points that `mask` supports, with their count (NaN without any).
    fn rms_on(&self, diff: &[Vec<f64>], mask: &Smoothed) -> Vec<(f64, usize)> {
        diff.iter()
            .map(|d| {
                let (mut sum, mut n) = (0.0, 0usize);
                for (i, v) in d.iter().enumerate() {
                    if v.is_finite() && self.supported(mask, i) {
                        sum += v * v;
                        n += 1;
                    }
                }
                (if n > 0 { (sum / n as f64).sqrt() } else { f64::NAN }, n)
            })
            .collect()
    }

    /// Per channel, the odd/even halving's RMS on the points `mask` supports, and the quadratic
    /// mean of every halving's RMS there (halvings with no such point are skipped; NaN without
    /// any).
    fn split_half(&self, splits: &SplitHalves, mask: &Smoothed) -> Vec<(f64, f64)> {
        let each: Vec<Vec<(f64, usize)>> = splits.diffs.iter().map(|d| self.rms_on(d, mask)).collect();
        (0..CHANNELS.len())
            .map(|c| {
                let kept: Vec<f64> = each.iter().filter(|r| r[c].1 > 0).map(|r| r[c].0).collect();
                let mean = if kept.is_empty() {
                    f64::NAN
                } else {
                    (kept.iter().map(|r| r * r).sum::<f64>() / kept.len() as f64).sqrt()
                };
                (each[0][c].0, mean)
            })
            .collect()
    }

    /// RMS of `a − b` per channel over the points both support (and `extra` supports), with
    /// the point count.
    fn rms(&self, a: &Smoothed, b: &Smoothed, extra: &Smoothed) -> Vec<(f64, usize)> {
        self.rms_on(&self.difference(a, b), extra)
    }

    /// The transfer-function differences of `sim` against `real`, judged against the
    /// split-half yardstick of `real`'s `halves` and `splits`, and the difference maps.
    pub(crate) fn compare(
        &self,
        real: &Smoothed,
        sim: &Smoothed,
        halves: &(Smoothed, Smoothed),
        splits: &SplitHalves,
        n_real: usize,
        n_sim: usize,
    ) -> (Vec<TfDiff>, DiffMaps) {
        // Both comparisons on the same points: those the real run, the simulated run and both
        // halves support.
        let both = self.joint_support(sim, halves);
        let values = self.difference(sim, real);
        let main = self.rms_on(&values, &both);
        let split = self.split_half(splits, &both);
        let scale = yardstick_scale(n_real, n_sim);
        let diffs = CHANNELS
            .iter()
            .zip(main.iter().zip(&split))
            .map(|((name, unit), (&(rms, points), &(sh, mean)))| {
                let yardstick = mean * scale;
                let ratio = if yardstick > 0.0 {
                    rms / yardstick
                } else if rms == 0.0 {
                    0.0
                } else {
                    f64::INFINITY
                };
                TfDiff {
                    channel: name.to_string(),
                    unit: unit.to_string(),
                    rms,
                    split_half_rms: sh,
                    split_half_rms_mean: Some(mean),
                    yardstick_splits: Some(splits.count()),
                    yardstick,
                    ratio,
                    within: points > 0 && ratio <= self.tolerance,
                    points,
                    p_permutation: None,
                    p_permutation_holm: None,
                }
            })
            .collect();
        (
            diffs,
            DiffMaps {
                vx_m_s: self.grid.vx_m_s.clone(),
                wz_rad_s: self.grid.wz_rad_s.clone(),
                channels: CHANNELS.iter().map(|c| c.0.to_string()).collect(),
                values,
            },
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equal_runs_scale_by_root_half() {
        assert!((yardstick_scale(150, 150) - 0.5f64.sqrt()).abs() < 1e-12);
        // A twice longer simulated run: (1 + 1/2)/4.
        assert!((yardstick_scale(150, 300) - (0.375f64).sqrt()).abs() < 1e-12);
    }

    /// Three grid points, two halvings: the yardstick's split-half RMS is the quadratic mean
    /// of each halving's RMS on the points the comparison keeps, by hand.
    #[test]
    fn the_yardstick_is_the_quadratic_mean_over_halvings_on_the_compared_points() {
        let grid = Grid {
            vx_m_s: vec![0.0, 1.0, 2.0],
            wz_rad_s: vec![0.0],
            inside: vec![true; 3],
        };
        let setup = TfSetup {
            grid,
            cov: KernelCovariance {
                var_vx: 1.0,
                var_wz: 1.0,
            },
            fast: FastParams::default(),
            min_weight: 0.5,
            tolerance: 1.5,
            smoother: super::super::TfSmoother::Kernel,
        };
        let channel = |v: [f64; 3]| vec![v.to_vec(); CHANNELS.len()];
        // Halving 1 differs by (1, 2, 100), halving 2 by (3, NaN: a half without support, 5).
        let splits = SplitHalves {
            diffs: vec![channel([1.0, 2.0, 100.0]), channel([3.0, f64::NAN, 5.0])],
        };
        // The comparison keeps the first two points only (the third lacks weight).
        let mask = Smoothed {
            values: channel([0.0; 3]),
            weight_sum: vec![1.0, 1.0, 0.1],
            error_bound: None,
        };
        let got = setup.split_half(&splits, &mask);
        // Halving 1: RMS² = (1 + 4) / 2 = 2.5; halving 2: 9 / 1 = 9; mean 5.75.
        for (first, mean) in got {
            assert!((first - 2.5f64.sqrt()).abs() < 1e-12, "{first}");
            assert!((mean - 5.75f64.sqrt()).abs() < 1e-12, "{mean}");
        }
        // No halving with a kept point: NaN, not zero.
        let none = Smoothed {
            weight_sum: vec![0.0; 3],
            ..mask
        };
        assert!(setup
            .split_half(&splits, &none)
            .iter()
            .all(|(first, mean)| first.is_nan() && mean.is_nan()));
    }
}
