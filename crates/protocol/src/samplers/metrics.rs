//! Measures to compare sampling strategies without a simulator: how well a sequence of
//! commands covers the accelerations and the command space, what the protocol's interruptions
//! cost, and how much kinetic energy the commands ask for. Pure functions over commands, run
//! summaries and logs.

use super::geometry::body_bounds;
use crate::RunSummary;
use drive_sim_model::kinematics::{BodyVelocity, CommandSpace, WheelSpeeds};
use drive_sim_model::measurement::DriveLog;
use drive_sim_model::robot::Robot;
use serde::{Deserialize, Serialize};

/// A histogram with equal bins over `[lo, hi]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Histogram {
    /// Lower edge of the first bin.
    pub lo: f64,
    /// Upper edge of the last bin.
    pub hi: f64,
    /// Count per bin.
    pub counts: Vec<u32>,
}

impl Histogram {
    /// Bins `values` in `bins` equal bins over `[lo, hi]`; values beyond an edge go to the
    /// nearest end bin, non-finite values are skipped.
    pub fn new(values: impl IntoIterator<Item = f64>, lo: f64, hi: f64, bins: usize) -> Self {
        let bins = bins.max(1);
        let mut counts = vec![0u32; bins];
        let width = (hi - lo) / bins as f64;
        for v in values.into_iter().filter(|v| v.is_finite()) {
            let i = if width > 0.0 {
                ((v - lo) / width).floor().clamp(0.0, (bins - 1) as f64) as usize
            } else {
                0
            };
            counts[i] += 1;
        }
        Self { lo, hi, counts }
    }
    /// Total count.
    pub fn total(&self) -> u32 {
        self.counts.iter().sum()
    }
    /// Shannon entropy of the bin shares, bits (0 for an empty histogram).
    pub fn entropy_bits(&self) -> f64 {
        let n = self.total() as f64;
        if n == 0.0 {
            return 0.0;
        }
        self.counts
            .iter()
            .filter(|&&c| c > 0)
            .map(|&c| {
                let p = c as f64 / n;
                -p * p.log2()
            })
            .sum()
    }
    /// Entropy over its maximum log2(bins): 1 when every bin holds the same count.
    pub fn normalized_entropy(&self) -> f64 {
        let bins = self.counts.len();
        if bins < 2 {
            return 0.0;
        }
        self.entropy_bits() / (bins as f64).log2()
    }
    /// Fraction of bins holding at least one value.
    pub fn occupied_fraction(&self) -> f64 {
        self.counts.iter().filter(|&&c| c > 0).count() as f64 / self.counts.len() as f64
    }
}

/// Body-frame speed steps (Δvx m/s, Δwz rad/s) between consecutive commands, the first from rest.
pub fn speed_steps(space: &CommandSpace, cmds: &[WheelSpeeds]) -> Vec<BodyVelocity> {
    let mut prev = BodyVelocity::default();
    cmds.iter()
        .map(|c| {
            let b = space.idd.body_from_wheels(*c);
            let d = b.minus(prev);
            prev = b;
            d
        })
        .collect()
}

/// Histograms of |Δvx| and |Δwz| over their reachable ranges (0 to twice the largest |vx|,
/// |wz| of U).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AccelerationCoverage {
    /// |Δvx| histogram, m/s.
    pub linear: Histogram,
    /// |Δwz| histogram, rad/s.
    pub angular: Histogram,
}

/// Acceleration coverage of a command sequence, with `bins` bins per histogram.
pub fn acceleration_coverage(
    space: &CommandSpace,
    cmds: &[WheelSpeeds],
    bins: usize,
) -> AccelerationCoverage {
    let (vm, wm) = body_bounds(space);
    let steps = speed_steps(space, cmds);
    AccelerationCoverage {
        linear: Histogram::new(steps.iter().map(|d| d.vx_m_s.abs()), 0.0, 2.0 * vm, bins),
        angular: Histogram::new(steps.iter().map(|d| d.wz_rad_s.abs()), 0.0, 2.0 * wm, bins),
    }
}

/// Coverage of U by the sampled commands S: the fraction of the cells of a
/// `cells_per_axis`² grid over U's bounding box in normalized body coordinates
/// (vx / vx_max, wz / wz_max), whose centre lies in U, that have a command within `radius`
/// (normalized units) of their centre.
pub fn command_coverage(
    space: &CommandSpace,
    cmds: &[WheelSpeeds],
    cells_per_axis: usize,
    radius: f64,
) -> f64 {
    let (vm, wm) = body_bounds(space);
    let pts: Vec<(f64, f64)> = cmds
        .iter()
        .map(|c| {
            let b = space.idd.body_from_wheels(*c);
            (b.vx_m_s / vm, b.wz_rad_s / wm)
        })
        .collect();
    let n = cells_per_axis.max(1);
    let (mut inside, mut covered) = (0usize, 0usize);
    for i in 0..n {
        for j in 0..n {
            let x = -1.0 + (2 * i + 1) as f64 / n as f64;
            let y = -1.0 + (2 * j + 1) as f64 / n as f64;
            if !space.contains_body(BodyVelocity::new(x * vm, 0.0, y * wm)) {
                continue;
            }
            inside += 1;
            if pts
                .iter()
                .any(|p| (p.0 - x).powi(2) + (p.1 - y).powi(2) <= radius * radius)
            {
                covered += 1;
            }
        }
    }
    if inside == 0 {
        0.0
    } else {
        covered as f64 / inside as f64
    }
}

/// What the protocol's interruptions cost, per completed step.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TimeUse {
    /// Interrupted attempts per completed step.
    pub interruptions_per_step: f64,
    /// Abandoned commands per completed step.
    pub abandoned_per_step: f64,
    /// Productive over total time.
    pub time_efficiency: f64,
    /// Total protocol time per completed step, s.
    pub time_per_step_s: f64,
}

/// Time use of a run from its summary (zeros per step when no step completed).
pub fn time_use(summary: &RunSummary) -> TimeUse {
    let n = summary.steps_completed as f64;
    let per = |x: f64| if n > 0.0 { x / n } else { 0.0 };
    TimeUse {
        interruptions_per_step: per(summary.interruptions as f64),
        abandoned_per_step: per(summary.abandoned_commands as f64),
        time_efficiency: summary.time_efficiency,
        time_per_step_s: per(summary.total_time_s),
    }
}

/// Commanded kinetic energy `K_u = ½ m vx² + ½ I_zz wz²` of a wheel command under the IDD, J.
pub fn commanded_kinetic_energy_j(robot: &Robot, cmd: WheelSpeeds) -> f64 {
    let b = robot.idd().body_from_wheels(cmd);
    0.5 * robot.body.mass_kg * b.vx_m_s * b.vx_m_s + 0.5 * robot.yaw_inertia_kg_m2() * b.wz_rad_s * b.wz_rad_s
}

/// Energy use of a command sequence: Σ K_u × `step_s` over the commands, J·s.
pub fn commanded_energy_j_s(robot: &Robot, cmds: &[WheelSpeeds], step_s: f64) -> f64 {
    cmds.iter()
        .map(|c| commanded_kinetic_energy_j(robot, *c) * step_s)
        .sum()
}

/// Energy use of a log: Σ K_u × sample period over its samples (completed steps only), J·s.
pub fn log_commanded_energy_j_s(robot: &Robot, log: &DriveLog) -> f64 {
    let dt = 1.0 / log.meta.rate_hz;
    log.samples
        .iter()
        .map(|s| commanded_kinetic_energy_j(robot, s.m.cmd) * dt)
        .sum()
}

/// The command of each completed step of a log, in step order.
pub fn step_commands(log: &DriveLog) -> Vec<WheelSpeeds> {
    let mut out: Vec<WheelSpeeds> = Vec::new();
    let mut last_step = None;
    for s in &log.samples {
        if last_step != Some(s.step) {
            out.push(s.m.cmd);
            last_step = Some(s.step);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use drive_sim_model::kinematics::IdealDiffDrive;

    fn unit_space() -> CommandSpace {
        // r = 1, b = 2: vx = (wl + wr) / 2, wz = (wr - wl) / 2. Wheel limit 2, user limits 1, 1:
        // U in B is the square |vx| <= 1, |wz| <= 1 (the diamond |vx| + |wz| <= 2 contains it).
        CommandSpace {
            idd: IdealDiffDrive {
                wheel_radius_m: 1.0,
                baseline_m: 2.0,
            },
            max_wheel_rad_s: 2.0,
            max_lin_m_s: 1.0,
            max_ang_rad_s: 1.0,
            turn_scale: 1.0,
        }
    }

    #[test]
    fn histogram_entropy_by_hand() {
        // Counts 2, 1, 1, 0: shares 1/2, 1/4, 1/4: H = 0.5 + 0.5 + 0.5 = 1.5 bits; max 2 bits.
        let h = Histogram::new([0.1, 0.2, 1.5, 2.5, f64::NAN], 0.0, 4.0, 4);
        assert_eq!(h.counts, vec![2, 1, 1, 0]);
        assert!((h.entropy_bits() - 1.5).abs() < 1e-12);
        assert!((h.normalized_entropy() - 0.75).abs() < 1e-12);
        assert_eq!(h.occupied_fraction(), 0.75);
        // Out of range values go to the end bins.
        assert_eq!(Histogram::new([-1.0, 9.0], 0.0, 4.0, 4).counts, vec![1, 0, 0, 1]);
        assert_eq!(Histogram::new([], 0.0, 1.0, 3).entropy_bits(), 0.0);
    }

    #[test]
    fn acceleration_steps_by_hand() {
        let s = unit_space();
        // vx, wz: (1, 0) from rest, then (-1, 0): |Δvx| = 1, 2 (clamped to the last bin);
        // |Δwz| = 0, 0. Range [0, 2] in 4 bins.
        let cmds = [WheelSpeeds::new(1.0, 1.0), WheelSpeeds::new(-1.0, -1.0)];
        let steps = speed_steps(&s, &cmds);
        assert_eq!(steps[0].vx_m_s, 1.0);
        assert_eq!(steps[1].vx_m_s, -2.0);
        let cov = acceleration_coverage(&s, &cmds, 4);
        assert_eq!(cov.linear.counts, vec![0, 0, 1, 1]);
        assert_eq!(cov.angular.counts, vec![2, 0, 0, 0]);
    }

    #[test]
    fn command_coverage_by_hand() {
        let s = unit_space();
        // 4 x 4 cells over the square U, centres at ±0.25, ±0.75. One command at the origin
        // with radius 0.4 covers the 4 centres at (±0.25, ±0.25) (distance 0.354): 4/16.
        let origin = [WheelSpeeds::new(0.0, 0.0)];
        assert!((command_coverage(&s, &origin, 4, 0.4) - 0.25).abs() < 1e-12);
        assert_eq!(command_coverage(&s, &[], 4, 0.4), 0.0);
        // Radius 1.1 reaches (0.75, 0.75) at 1.06: all cells.
        assert_eq!(command_coverage(&s, &origin, 4, 1.1), 1.0);
    }

    #[test]
    fn energy_and_time_by_hand() {
        let (robot, _) = Robot::resolve("husky").unwrap();
        // Straight at 1 m/s (6.06 rad/s * 0.165 m = 0.9999 m/s): K = 0.5 * 75 * 0.9999² J; for
        // two 6 s steps: 2 * 6 * K.
        let w = WheelSpeeds::new(6.06, 6.06);
        let v = 6.06 * 0.165;
        let k = 0.5 * 75.0 * v * v;
        assert!((commanded_kinetic_energy_j(&robot, w) - k).abs() < 1e-9);
        assert!((commanded_energy_j_s(&robot, &[w, w], 6.0) - 12.0 * k).abs() < 1e-9);
        // Turning in place at 1 rad/s: wheels ∓ 0.555 / 2 / 0.165; K = 0.5 * I_zz.
        let t = 0.555 / 2.0 / 0.165;
        let izz = 75.0 * (0.8382f64.powi(2) + 0.6604f64.powi(2)) / 12.0;
        let kt = commanded_kinetic_energy_j(&robot, WheelSpeeds::new(-t, t));
        assert!((kt - 0.5 * izz).abs() < 1e-9, "{kt}");
        let summary = RunSummary {
            steps_completed: 4,
            interruptions: 2,
            abandoned_commands: 1,
            incomplete_reorientations: 0,
            total_time_s: 48.0,
            productive_time_s: 24.0,
            time_efficiency: 0.5,
            ..RunSummary::default()
        };
        let tu = time_use(&summary);
        assert_eq!(tu.interruptions_per_step, 0.5);
        assert_eq!(tu.abandoned_per_step, 0.25);
        assert_eq!(tu.time_per_step_s, 12.0);
        assert_eq!(time_use(&RunSummary::default()).interruptions_per_step, 0.0);
    }
}
