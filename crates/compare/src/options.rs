//! Options of [`super::compare`]: the verdicts' thresholds, the maps' grid and smoother, and
//! how many halvings of the real run make the maps' yardstick.

use crate::error::{Error, Result};
use drive_sim_analysis::bootstrap::Bootstrap;
use serde::{Deserialize, Serialize};

/// Options of [`super::compare`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CompareOptions {
    /// Resampling of every interval.
    pub bootstrap: Bootstrap,
    /// Family-wise significance level of the Holm-corrected verdicts.
    pub alpha: f64,
    /// A transfer function reproduces the real one when its RMS difference is at most this many
    /// times the split-half yardstick.
    pub tf_tolerance: f64,
    /// T/U areas agree when they differ by at most this many percentage points.
    pub area_tolerance_pp: f64,
    /// Grid resolution of the transfer functions (m/s and rad/s; the paper's 0.1).
    pub grid_step: f64,
    /// Kernel variance; the paper's for the robot when `None`.
    pub kernel_var: Option<f64>,
    /// A grid point is compared only where both runs have at least this kernel weight (about
    /// one step within 1.2 σ): elsewhere a smoothed value is an extrapolation.
    pub min_weight: f64,
    /// Permutations of the transfer functions' test (0: not computed).
    #[serde(default)]
    pub tf_permutations: usize,
    /// How the transfer-function maps are smoothed (the paper's kernel-weighted mean, or a
    /// local-linear fit with the same kernel).
    #[serde(default)]
    pub tf_smoother: TfSmoother,
    /// Halvings of the real run behind the yardstick (the alternate steps, then random
    /// balanced ones); 1 is the alternate steps alone (the single split-half yardstick).
    #[serde(default = "default_yardstick_splits")]
    pub tf_yardstick_splits: usize,
}

/// [`CompareOptions::tf_yardstick_splits`]'s default: the quadratic mean of 64 halvings has a
/// relative standard error of a few per cent where one halving's is tens of per cent (README,
/// "Twins and compare").
pub const DEFAULT_YARDSTICK_SPLITS: usize = 64;

fn default_yardstick_splits() -> usize {
    DEFAULT_YARDSTICK_SPLITS
}

/// The smoother of the compared transfer-function maps.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TfSmoother {
    /// The paper's: the kernel-weighted mean of the steps' slips
    /// ([`drive_sim_analysis::smoother::smooth`]).
    #[default]
    Kernel,
    /// The intercept of a kernel-weighted plane
    /// ([`drive_sim_analysis::smoother::smooth_local_linear`]): no bias on a sloped map whatever
    /// commands a run drew, such as the wheel slip's ramp beyond a wheel-speed limit.
    LocalLinear,
}

impl TfSmoother {
    /// Every smoother, in the order the command line lists them.
    pub const ALL: [Self; 2] = [Self::Kernel, Self::LocalLinear];

    /// Name on the command line and in `comparison.json`.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Kernel => "kernel",
            Self::LocalLinear => "local-linear",
        }
    }

    /// What the smoother computes, in a few words.
    pub fn doc(self) -> &'static str {
        match self {
            Self::Kernel => "The paper's: the kernel-weighted mean of the steps' slips",
            Self::LocalLinear => "The intercept of a kernel-weighted plane: no bias on a sloped map",
        }
    }
}

impl Default for CompareOptions {
    fn default() -> Self {
        Self {
            bootstrap: Bootstrap::default(),
            alpha: 0.05,
            tf_tolerance: 1.5,
            area_tolerance_pp: 5.0,
            grid_step: 0.1,
            kernel_var: None,
            min_weight: 0.5,
            tf_permutations: 200,
            tf_smoother: TfSmoother::Kernel,
            tf_yardstick_splits: DEFAULT_YARDSTICK_SPLITS,
        }
    }
}

impl CompareOptions {
    /// Checks the numbers `drive-sim compare` sets, naming its options, before any log is read:
    /// at least 100 bootstrap resamples and at least one halving behind the maps' yardstick.
    /// [`super::compare`] itself refuses an unusable yardstick or level whoever calls it.
    pub fn validate(&self) -> Result<()> {
        if self.bootstrap.resamples < 100 {
            return Err(Error::config(
                "--resamples",
                "resamples",
                format!("must be at least 100, got {}", self.bootstrap.resamples),
            ));
        }
        if self.tf_yardstick_splits == 0 {
            return Err(Error::config(
                "--yardstick-splits",
                "yardstick_splits",
                "must be at least 1 (1: the odd and even steps alone), got 0",
            ));
        }
        Ok(())
    }
}

/// Refuses options no comparison can use, before any work.
pub(super) fn check_options(opts: &CompareOptions) -> Result<()> {
    if opts.tf_yardstick_splits == 0 {
        return Err(Error::config(
            "compare",
            "tf_yardstick_splits",
            "must be at least 1 (1: the odd and even steps alone), got 0",
        ));
    }
    if !(opts.alpha > 0.0 && opts.alpha < 1.0) {
        return Err(Error::config(
            "compare",
            "alpha",
            format!("must be in (0, 1), got {}", opts.alpha),
        ));
    }
    Ok(())
}
