//! The step scatter of both runs side by side (not part of the verdict; a term of the loss,
//! [`ScatterDiff::scaled_difference`]): how far apart two steps with nearly the same command
//! land in each ([`drive_sim_analysis::scatter`]).
//!
//! Why beside the verdict: the verdict's statistics are medians, hull areas and smoothed maps,
//! which a step-level offset barely moves (it is zero-mean, and a smoother averages it out),
//! yet a twin without one has steps that land where they are told while the real robot's do
//! not. The measured Warthog runs scatter 0.46–0.48 rad/s per wheel on asphalt and gravel; the
//! simulator, without `wheel_speed_scatter`, 0.05–0.12.

use drive_sim_analysis::scatter::StepScatter;
use serde::{Deserialize, Serialize};

/// Smallest difference in step scatter that counts, rad/s per wheel: below it two runs are
/// alike whatever their intervals say. 0.1 rad/s is 3 cm/s at the Warthog's wheel, half the
/// smallest within-step scatter of the measured Warthog runs (ice, 0.11 rad/s) and well below
/// the step scatter of any of them (0.22–0.48); a generator whose encoders are noisier than the
/// simulator's differs from it by 0.03 rad/s, with intervals that miss each other.
pub const SCATTER_TOLERANCE_RAD_S: f64 = 0.1;

/// Both runs' step scatter and what the simulated one lacks.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ScatterDiff {
    /// The real run's.
    pub real: StepScatter,
    /// The simulated run's.
    pub sim: StepScatter,
    /// The two intervals do not overlap (a conservative reading of "they differ": two 95 %
    /// intervals that miss each other differ at well below 5 %) and the estimates are at least
    /// [`SCATTER_TOLERANCE_RAD_S`] apart.
    pub differs: bool,
    /// `√(real² − sim²)` when the real run scatters more: the per-step offset (rad/s per
    /// wheel) that, added independently, brings the simulated run's scatter to the real one's,
    /// the value of `wheel_speed_scatter_rad_s` to try. `None` otherwise or without both
    /// estimates.
    pub offset_to_add_rad_s: Option<f64>,
}

impl ScatterDiff {
    /// The two runs' scatters compared.
    pub fn new(real: StepScatter, sim: StepScatter) -> Self {
        let differs = match (real.ci95, sim.ci95, real.wheel_rad_s, sim.wheel_rad_s) {
            (Some(r), Some(s), Some(a), Some(b)) => r.misses(&s) && (a - b).abs() >= SCATTER_TOLERANCE_RAD_S,
            _ => false,
        };
        let offset_to_add_rad_s = match (real.wheel_rad_s, sim.wheel_rad_s) {
            (Some(r), Some(s)) if r > s => Some((r * r - s * s).sqrt()),
            _ => None,
        };
        Self {
            real,
            sim,
            differs,
            offset_to_add_rad_s,
        }
    }

    /// The difference in scatter (simulated − real) over the real interval's width, at least
    /// [`SCATTER_TOLERANCE_RAD_S`]: 1 where the intervals of two runs as uncertain as the real
    /// one would stop overlapping (if the twin were the robot, its estimate would carry the
    /// robot's interval). `None` without both estimates and the real interval. The term of
    /// `compare`'s loss for the step scatter.
    ///
    /// Why not the simulated run's own interval: a bootstrap interval of a scatter widens with
    /// the scatter, so a twin that scattered more would be held to a looser scale, and a search
    /// minimising the loss would buy the other terms with scatter the robot does not have.
    pub fn scaled_difference(&self) -> Option<f64> {
        let (Some(r), Some(s), Some(ri)) = (self.real.wheel_rad_s, self.sim.wheel_rad_s, self.real.ci95)
        else {
            return None;
        };
        let scale = (ri.upper - ri.lower).max(SCATTER_TOLERANCE_RAD_S);
        ((s - r).is_finite() && scale.is_finite()).then(|| (s - r) / scale)
    }

    /// One line for the verdict's text.
    pub fn line(&self) -> String {
        let est = |s: &StepScatter| match (s.wheel_rad_s, s.ci95) {
            (Some(v), Some(i)) => format!("{v:.2} [{:.2}, {:.2}] ({} pairs)", i.lower, i.upper, s.pairs),
            (Some(v), None) => format!("{v:.2} ({} pairs)", s.pairs),
            _ => format!("- ({} pairs: too few)", s.pairs),
        };
        let tail = match (self.differs, self.offset_to_add_rad_s) {
            (true, Some(o)) => format!(
                ": the simulated run lacks a step-level offset of about {o:.2} rad/s (`wheel_speed_scatter_rad_s`)"
            ),
            (true, None) => ": the simulated run scatters more".into(),
            (false, _) => format!(": alike (intervals overlap or within {SCATTER_TOLERANCE_RAD_S} rad/s)"),
        };
        format!(
            "step scatter (rad/s per wheel, a diagnostic): real {}, sim {}{tail}",
            est(&self.real),
            est(&self.sim)
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use drive_sim_analysis::bootstrap::Interval;

    fn scatter(v: f64, lo: f64, hi: f64) -> StepScatter {
        StepScatter {
            pairs: 12,
            radius_rad_s: 1.0,
            wheel_rad_s: Some(v),
            ci95: Some(Interval {
                lower: lo,
                upper: hi,
                level: 0.95,
            }),
            within_step_rad_s: Some(0.25),
            steps_with_two_windows: 90,
        }
    }

    #[test]
    fn offset_adds_in_quadrature_and_overlap_is_no_difference() {
        let d = ScatterDiff::new(scatter(0.5, 0.35, 0.65), scatter(0.3, 0.2, 0.34));
        assert!(d.differs);
        assert!((d.offset_to_add_rad_s.unwrap() - 0.4).abs() < 1e-12);
        assert!(
            d.line().contains("lacks a step-level offset of about 0.40"),
            "{}",
            d.line()
        );
        let same = ScatterDiff::new(scatter(0.5, 0.35, 0.65), scatter(0.45, 0.3, 0.6));
        assert!(!same.differs);
        assert!(same.line().contains("alike"));
        // Apart, but by less than the tolerance: alike.
        let close = ScatterDiff::new(scatter(0.10, 0.09, 0.11), scatter(0.03, 0.02, 0.04));
        assert!(!close.differs);
        let more = ScatterDiff::new(scatter(0.3, 0.2, 0.34), scatter(0.5, 0.35, 0.65));
        assert!(more.differs && more.offset_to_add_rad_s.is_none());
    }
}
