//! Error metrics between a replay and the recording, beside the two references the project
//! computes itself: the IDD prediction (a replay on the ideal plant) and a noise floor
//! estimated from the recording.
//!
//! Every quantity comes from the same estimators applied to both logs, so an estimator bias
//! cancels: body velocity from the pose stream (the analysis pipeline's per-sample local
//! least-squares slopes, [`drive_sim_analysis::velocity::window_pose_velocities`], and their window
//! means), wheel speed from the encoders, yaw rate from the IMU. Poses are only differenced
//! inside a window (measured logs restart them there).
//!
//! **Noise floor.** What no deterministic model can predict. For a steady-state channel, the
//! two steady windows of a step see the same command; if each window mean is the true steady
//! value plus an independent error of standard deviation σ, then `w1 - w2` has standard
//! deviation `√2 σ`, and σ is the RMSE of a perfect model. We estimate it robustly,
//! `σ = 1.4826 · median |w1 - w2| / √2` (the MAD estimate, exact for Gaussian errors), because
//! measured logs have a few steps where the lidar pose jumps between windows, and a mean of
//! squares would let those few set the floor of all steps. It also absorbs
//! slow real fluctuations (terrain changing under the robot), which a step-constant model cannot
//! follow either; it overstates the floor when windows 1 and 2 are not yet steady (long
//! transients on ice), which the report shows as a floor close to the errors. Per-sample
//! channels (transient) use the per-sample scatter about the window mean in steady windows; the
//! 2 s displacement uses the window-1 vs window-2 difference in the same way. With fewer than
//! two steady windows, the steady floor falls back to the per-sample scatter / √n.
//!
//! **Score.** One number per set of steps ([`score`]): for each of the 10 velocity channels the
//! pooled mean squared error over the channel's squared floor, then the geometric mean over the
//! channels (a concentrated Gaussian likelihood; see [`score`] for why not an arithmetic
//! mean). A model at the noise floor scores about 1. It is what the optimizer minimizes and
//! what the bootstrap (over steps) compares.

use super::steps::StepSlice;
use crate::error::{Error, Result};
use drive_sim_analysis::velocity::window_pose_velocities;
use drive_sim_log::{Pose, Sample};
use drive_sim_model::geometry::wrap_angle;
use drive_sim_model::kinematics::WheelSpeeds;
use serde::{Deserialize, Serialize};

/// Steady-state channels (window means of windows 1..).
pub const STEADY_CHANNELS: [&str; 6] = ["vx", "vy", "wz", "enc_left", "enc_right", "imu_wz"];
/// Per-sample channels (the transient window, and residuals over time).
pub const SERIES_CHANNELS: [&str; 4] = ["vx", "wz", "enc_left", "enc_right"];
/// Half-width of the per-sample derivative (the analysis pipeline's default: 7 points, 0.3 s).
const DERIVATIVE_HALF_WIDTH: usize = 3;
/// Floors are never taken below these (units of the channel): a noise-free log would
/// otherwise make any error infinitely significant.
const MIN_FLOOR: f64 = 1e-3;

/// What the estimators extract from one step.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StepFeatures {
    /// Step index.
    pub step: u32,
    /// Mean command of the steady windows.
    pub cmd: WheelSpeeds,
    /// Per steady window: the [`STEADY_CHANNELS`] means.
    pub steady: Vec<[f64; 6]>,
    /// Per sample: time in step, s.
    pub t_s: Vec<f64>,
    /// Per sample: window index.
    pub window: Vec<u32>,
    /// Per sample: the [`SERIES_CHANNELS`].
    pub series: Vec<[f64; 4]>,
    /// Per window (all windows): displacement over the window in its first sample's frame
    /// (dx m, dy m, dyaw rad).
    pub displacement: Vec<[f64; 3]>,
}

/// Pose of `q` in the frame of `p` (planar part).
fn relative(p: &Pose, q: &Pose) -> [f64; 3] {
    let (dx, dy) = (q.x_m - p.x_m, q.y_m - p.y_m);
    let (s, c) = p.yaw_rad.sin_cos();
    [
        c * dx + s * dy,
        -s * dx + c * dy,
        wrap_angle(q.yaw_rad - p.yaw_rad),
    ]
}

/// Extracts the features of one step.
pub fn step_features(step: u32, samples: &[Sample]) -> Result<StepFeatures> {
    if samples.is_empty() {
        return Err(Error::StepWithoutSamples { step });
    }
    let mut f = StepFeatures {
        step,
        cmd: WheelSpeeds::default(),
        steady: Vec::new(),
        t_s: Vec::with_capacity(samples.len()),
        window: Vec::with_capacity(samples.len()),
        series: Vec::with_capacity(samples.len()),
        displacement: Vec::new(),
    };
    let mut n_cmd = 0usize;
    for w in samples.chunk_by(|a, b| a.window == b.window) {
        let n = w.len();
        // The analysis pipeline's per-sample velocities (local least-squares slopes).
        let kin = window_pose_velocities(w, DERIVATIVE_HALF_WIDTH).v;
        for (s, k) in w.iter().zip(&kin) {
            f.t_s.push(s.t_in_step_s);
            f.window.push(s.window);
            f.series
                .push([k.vx_m_s, k.wz_rad_s, s.m.enc.left_rad_s, s.m.enc.right_rad_s]);
        }
        f.displacement.push(relative(&w[0].m.pose, &w[n - 1].m.pose));
        if w[0].window == 0 {
            continue;
        }
        // Steady window: window means, as the analysis pipeline takes them.
        let mut v = [0.0; 6];
        for (s, k) in w.iter().zip(&kin) {
            v[0] += k.vx_m_s / n as f64;
            v[1] += k.vy_m_s / n as f64;
            v[2] += k.wz_rad_s / n as f64;
            v[3] += s.m.enc.left_rad_s / n as f64;
            v[4] += s.m.enc.right_rad_s / n as f64;
            v[5] += s.m.imu.wz_rad_s / n as f64;
            f.cmd.left_rad_s += s.m.cmd.left_rad_s;
            f.cmd.right_rad_s += s.m.cmd.right_rad_s;
            n_cmd += 1;
        }
        f.steady.push(v);
    }
    if n_cmd > 0 {
        f.cmd.left_rad_s /= n_cmd as f64;
        f.cmd.right_rad_s /= n_cmd as f64;
    }
    Ok(f)
}

/// Features of every step of a list of slices.
pub fn features_of(steps: &[StepSlice<'_>]) -> Result<Vec<StepFeatures>> {
    steps.iter().map(|s| step_features(s.step, s.samples)).collect()
}

/// Noise floor per channel (see the module doc), estimated from the recording.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NoiseFloor {
    /// RMSE of a perfect model for each [`STEADY_CHANNELS`] window mean.
    pub steady: [f64; 6],
    /// Per-sample noise of each [`SERIES_CHANNELS`].
    pub series: [f64; 4],
    /// 2 s displacement floor: translation m, rotation rad.
    pub pose: [f64; 2],
    /// Steps with two steady windows that the estimate used.
    pub steps_used: usize,
}

impl NoiseFloor {
    /// Estimates the floor from the measured features.
    pub fn estimate(measured: &[StepFeatures]) -> Result<Self> {
        let mut steady: [Vec<f64>; 6] = Default::default();
        let mut pose: [Vec<f64>; 2] = Default::default();
        let mut n_pairs = 0usize;
        let mut scatter = [0.0; 4];
        let mut n_scatter = 0usize;
        let mut n_per_window = 0usize;
        let mut n_windows = 0usize;
        for f in measured {
            if f.steady.len() >= 2 {
                for (c, d) in steady.iter_mut().enumerate() {
                    d.push((f.steady[0][c] - f.steady[1][c]).abs());
                }
                let (d1, d2) = (f.displacement[1], f.displacement[2.min(f.displacement.len() - 1)]);
                // Translation: a 2-D difference; its norm's median relates to σ differently
                // from a 1-D one, so use each axis as a sample of the 1-D difference.
                pose[0].push((d1[0] - d2[0]).abs());
                pose[0].push((d1[1] - d2[1]).abs());
                pose[1].push(wrap_angle(d1[2] - d2[2]).abs());
                n_pairs += 1;
            }
            for w in 1..=f.steady.len() as u32 {
                let idx: Vec<usize> = (0..f.window.len()).filter(|&i| f.window[i] == w).collect();
                if idx.len() < 2 {
                    continue;
                }
                n_windows += 1;
                n_per_window += idx.len();
                for (c, sc) in scatter.iter_mut().enumerate() {
                    let mean = idx.iter().map(|&i| f.series[i][c]).sum::<f64>() / idx.len() as f64;
                    *sc += idx.iter().map(|&i| (f.series[i][c] - mean).powi(2)).sum::<f64>();
                }
                n_scatter += idx.len() - 1;
            }
        }
        if n_scatter == 0 {
            return Err(Error::NoSteadyScatter);
        }
        let series = scatter.map(|s| (s / n_scatter as f64).sqrt().max(MIN_FLOOR));
        let (steady, pose) = if n_pairs > 0 {
            let sigma = |d: &Vec<f64>| (mad_sigma(d) / std::f64::consts::SQRT_2).max(MIN_FLOOR);
            let per_axis = sigma(&pose[0]);
            (
                [0, 1, 2, 3, 4, 5].map(|c| sigma(&steady[c])),
                // A 2-D error of σ per axis has RMS norm √2 σ.
                [
                    (per_axis * std::f64::consts::SQRT_2).max(MIN_FLOOR),
                    sigma(&pose[1]),
                ],
            )
        } else {
            // White-noise fallback: a window mean of n samples.
            let n = (n_per_window as f64 / n_windows as f64).max(1.0);
            let s = |c: usize| (series[c] / n.sqrt()).max(MIN_FLOOR);
            (
                [s(0), s(0), s(1), s(2), s(3), s(1)],
                [MIN_FLOOR.max(series[0] / n.sqrt() * 2.0), MIN_FLOOR],
            )
        };
        Ok(Self {
            steady,
            series,
            pose,
            steps_used: n_pairs,
        })
    }
}

impl NoiseFloor {
    /// The floor of each score channel ([`STEADY_CHANNELS`] then [`SERIES_CHANNELS`]).
    pub fn score_channels(&self) -> [f64; SCORE_CHANNELS] {
        std::array::from_fn(|c| if c < 6 { self.steady[c] } else { self.series[c - 6] })
    }
}

/// Standard deviation from absolute deviations about zero: 1.4826 · median(|d|).
fn mad_sigma(abs_dev: &[f64]) -> f64 {
    let mut v: Vec<f64> = abs_dev.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    let med = if n % 2 == 1 {
        v[n / 2]
    } else {
        (v[n / 2 - 1] + v[n / 2]) / 2.0
    };
    1.4826 * med
}

/// Sums of squared errors of one replayed step against the recording.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StepErrors {
    /// Step index.
    pub step: u32,
    /// Σ over steady windows of the squared error of each [`STEADY_CHANNELS`].
    pub steady_sq: [f64; 6],
    /// Steady windows compared.
    pub n_steady: usize,
    /// Σ over the transient window's samples of the squared error of each [`SERIES_CHANNELS`].
    pub transient_sq: [f64; 4],
    /// Transient samples compared.
    pub n_transient: usize,
    /// Σ over windows of the squared 2 s displacement error (translation, rotation).
    pub pose_sq: [f64; 2],
    /// Windows compared.
    pub n_windows: usize,
}

/// The residuals (model − recording) of one replayed step, entry by entry: what the
/// least-squares fit works on. Each entry belongs to one of the 10 score channels
/// ([`STEADY_CHANNELS`] then [`SERIES_CHANNELS`]); the 2 s displacements are kept for the error
/// tables but are not part of the score.
#[derive(Debug, Clone, PartialEq)]
pub struct StepResiduals {
    /// Step index.
    pub step: u32,
    /// Per steady window, the [`STEADY_CHANNELS`] residuals of the window means.
    pub steady: Vec<[f64; 6]>,
    /// Per transient-window sample, the [`SERIES_CHANNELS`] residuals.
    pub transient: Vec<[f64; 4]>,
    /// Per window, the displacement residual (dx m, dy m, dyaw rad).
    pub pose: Vec<[f64; 3]>,
}

/// Index of `imu_wz` in [`STEADY_CHANNELS`]: NaN throughout when the recording has no IMU,
/// and then left out of the score.
const IMU_WZ: usize = 5;

/// Number of score channels: 6 steady, then 4 transient.
pub const SCORE_CHANNELS: usize = 10;

impl StepResiduals {
    /// Sums of squares, as [`StepErrors`].
    pub fn errors(&self) -> StepErrors {
        let mut e = StepErrors {
            step: self.step,
            steady_sq: [0.0; 6],
            n_steady: self.steady.len(),
            transient_sq: [0.0; 4],
            n_transient: self.transient.len(),
            pose_sq: [0.0; 2],
            n_windows: self.pose.len(),
        };
        for r in &self.steady {
            for (acc, v) in e.steady_sq.iter_mut().zip(r) {
                *acc += v * v;
            }
        }
        for r in &self.transient {
            for (acc, v) in e.transient_sq.iter_mut().zip(r) {
                *acc += v * v;
            }
        }
        for r in &self.pose {
            e.pose_sq[0] += r[0] * r[0] + r[1] * r[1];
            e.pose_sq[1] += r[2] * r[2];
        }
        e
    }

    /// The score-channel residuals in a fixed order (steady windows, then transient samples),
    /// appended to `values`, with each entry's channel (0..[`SCORE_CHANNELS`]) appended to
    /// `channels`.
    /// A recording without an IMU leaves its `imu_wz` entries out (they are NaN).
    pub fn flatten_into(&self, values: &mut Vec<f64>, channels: &mut Vec<u8>) {
        for r in &self.steady {
            for (c, v) in r.iter().enumerate() {
                if c == IMU_WZ && v.is_nan() {
                    continue;
                }
                values.push(*v);
                channels.push(c as u8);
            }
        }
        for r in &self.transient {
            values.extend_from_slice(r);
            channels.extend(6..10u8);
        }
    }
}

/// Compares a replayed step with the recorded one (same step, same sampling), entry by entry.
pub fn step_residuals(sim: &StepFeatures, meas: &StepFeatures) -> Result<StepResiduals> {
    if sim.step != meas.step || sim.series.len() != meas.series.len() {
        return Err(Error::ReplayMismatch {
            step: sim.step,
            replay: sim.series.len(),
            recording: meas.series.len(),
            recording_step: meas.step,
        });
    }
    let steady = sim
        .steady
        .iter()
        .zip(&meas.steady)
        .map(|(s, m)| std::array::from_fn(|c| s[c] - m[c]))
        .collect();
    let transient = (0..meas.series.len())
        .filter(|&i| meas.window[i] == 0)
        .map(|i| std::array::from_fn(|c| sim.series[i][c] - meas.series[i][c]))
        .collect();
    let pose = sim
        .displacement
        .iter()
        .zip(&meas.displacement)
        .map(|(s, m)| [s[0] - m[0], s[1] - m[1], wrap_angle(s[2] - m[2])])
        .collect();
    Ok(StepResiduals {
        step: meas.step,
        steady,
        transient,
        pose,
    })
}

/// Compares a replayed step with the recorded one (same step, same sampling).
pub fn step_errors(sim: &StepFeatures, meas: &StepFeatures) -> Result<StepErrors> {
    step_residuals(sim, meas).map(|r| r.errors())
}

impl StepErrors {
    /// This step's own score (see [`score`]), for per-step distributions.
    pub fn score(&self, floor: &NoiseFloor) -> f64 {
        score(std::iter::once(self), floor)
    }
}

/// Below this share of its squared floor a channel stops counting as better: a channel that
/// happens to match far below its noise would otherwise pull the geometric mean at will.
pub const MIN_CHANNEL_RATIO: f64 = 1e-2;

/// The score of a model over a set of steps (the same step may appear several times, as in a
/// bootstrap resample): for each of the 10 velocity channels, the mean squared error pooled
/// over the steps divided by the channel's squared floor; then the geometric mean over the
/// channels. 1 means at the noise floor.
///
/// Why a geometric mean: with Gaussian errors of an unknown variance per channel, the
/// likelihood maximised over those variances is `-Σ_c (n_c / 2) log MSE_c`, so a fit that
/// lowers it lowers every channel's error *relative to itself*. An arithmetic mean of the
/// floor-normalised errors would instead let the channels with the tightest floors (the
/// encoders) decide alone and trade body velocity for wheel speed. Channels with no sample are
/// left out, as is `imu_wz` of a recording without an IMU (NaN); no channel at all gives NaN.
pub fn score<'a>(errors: impl IntoIterator<Item = &'a StepErrors>, floor: &NoiseFloor) -> f64 {
    let mut steady = [0.0; 6];
    let mut transient = [0.0; 4];
    let (mut ns, mut nt) = (0usize, 0usize);
    for e in errors {
        for (acc, v) in steady.iter_mut().zip(&e.steady_sq) {
            *acc += v;
        }
        for (acc, v) in transient.iter_mut().zip(&e.transient_sq) {
            *acc += v;
        }
        ns += e.n_steady;
        nt += e.n_transient;
    }
    let mut log_sum = 0.0;
    let mut n = 0usize;
    let mut add = |sq: f64, count: usize, floor: f64| {
        let ratio = sq / count as f64 / floor.powi(2);
        log_sum += ratio.max(MIN_CHANNEL_RATIO).ln();
        n += 1;
    };
    if ns > 0 {
        for (c, (sq, f)) in steady.iter().zip(&floor.steady).enumerate() {
            if c == IMU_WZ && sq.is_nan() {
                continue;
            }
            add(*sq, ns, *f);
        }
    }
    if nt > 0 {
        for (sq, f) in transient.iter().zip(&floor.series) {
            add(*sq, nt, *f);
        }
    }
    if n == 0 {
        f64::NAN
    } else {
        (log_sum / n as f64).exp()
    }
}

/// One row of the before/after table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MetricRow {
    /// Metric name.
    pub metric: String,
    /// Unit.
    pub unit: String,
    /// Value.
    pub value: f64,
}

/// Pooled error metrics over a set of steps (RMSE unless said otherwise).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ErrorSummary {
    /// Steps pooled.
    pub steps: usize,
    /// Steady-state vx RMSE, m/s.
    pub steady_vx_m_s: f64,
    /// Steady-state vy RMSE, m/s.
    pub steady_vy_m_s: f64,
    /// Steady-state wz RMSE (from the pose), rad/s.
    pub steady_wz_rad_s: f64,
    /// Steady-state wheel-speed RMSE, both sides pooled, rad/s.
    pub steady_wheel_rad_s: f64,
    /// Steady-state left wheel-speed RMSE, rad/s.
    pub steady_wheel_left_rad_s: f64,
    /// Steady-state right wheel-speed RMSE, rad/s.
    pub steady_wheel_right_rad_s: f64,
    /// Steady-state IMU yaw-rate RMSE, rad/s.
    pub steady_imu_wz_rad_s: f64,
    /// Transient (first window) per-sample vx RMSE, m/s.
    pub transient_vx_m_s: f64,
    /// Transient per-sample wz RMSE, rad/s.
    pub transient_wz_rad_s: f64,
    /// Transient per-sample wheel-speed RMSE, rad/s.
    pub transient_wheel_rad_s: f64,
    /// RMS translation error of the displacement over one window (2 s), m.
    pub pose_translation_2s_m: f64,
    /// RMS rotation error of the displacement over one window (2 s), rad.
    pub pose_rotation_2s_rad: f64,
    /// Score of the steps pooled ([`score`]; 1 ≈ at the noise floor).
    pub score: f64,
}

impl ErrorSummary {
    /// Pools per-step errors.
    pub fn pool(errors: &[StepErrors], floor: &NoiseFloor) -> Self {
        let mut ss = [0.0; 6];
        let mut ts = [0.0; 4];
        let mut ps = [0.0; 2];
        let (mut ns, mut nt, mut nw) = (0usize, 0usize, 0usize);
        for e in errors {
            for (acc, v) in ss.iter_mut().zip(&e.steady_sq) {
                *acc += v;
            }
            for (acc, v) in ts.iter_mut().zip(&e.transient_sq) {
                *acc += v;
            }
            ps[0] += e.pose_sq[0];
            ps[1] += e.pose_sq[1];
            ns += e.n_steady;
            nt += e.n_transient;
            nw += e.n_windows;
        }
        let r = |s: f64, n: usize| if n == 0 { f64::NAN } else { (s / n as f64).sqrt() };
        let score = score(errors, floor);
        Self {
            steps: errors.len(),
            steady_vx_m_s: r(ss[0], ns),
            steady_vy_m_s: r(ss[1], ns),
            steady_wz_rad_s: r(ss[2], ns),
            steady_wheel_rad_s: r(ss[3] + ss[4], 2 * ns),
            steady_wheel_left_rad_s: r(ss[3], ns),
            steady_wheel_right_rad_s: r(ss[4], ns),
            steady_imu_wz_rad_s: r(ss[5], ns),
            transient_vx_m_s: r(ts[0], nt),
            transient_wz_rad_s: r(ts[1], nt),
            transient_wheel_rad_s: r(ts[2] + ts[3], 2 * nt),
            pose_translation_2s_m: r(ps[0], nw),
            pose_rotation_2s_rad: r(ps[1], nw),
            score,
        }
    }

    /// The same quantities for the noise floor itself.
    pub fn floor(floor: &NoiseFloor) -> Self {
        let f = floor;
        Self {
            steps: f.steps_used,
            steady_vx_m_s: f.steady[0],
            steady_vy_m_s: f.steady[1],
            steady_wz_rad_s: f.steady[2],
            steady_wheel_rad_s: ((f.steady[3].powi(2) + f.steady[4].powi(2)) / 2.0).sqrt(),
            steady_wheel_left_rad_s: f.steady[3],
            steady_wheel_right_rad_s: f.steady[4],
            steady_imu_wz_rad_s: f.steady[5],
            transient_vx_m_s: f.series[0],
            transient_wz_rad_s: f.series[1],
            transient_wheel_rad_s: ((f.series[2].powi(2) + f.series[3].powi(2)) / 2.0).sqrt(),
            pose_translation_2s_m: f.pose[0],
            pose_rotation_2s_rad: f.pose[1],
            score: 1.0,
        }
    }

    /// Rows (name, unit, value), in a fixed order, for tables.
    pub fn rows(&self) -> Vec<MetricRow> {
        let row = |m: &str, u: &str, v: f64| MetricRow {
            metric: m.into(),
            unit: u.into(),
            value: v,
        };
        vec![
            row("steady vx RMSE", "m/s", self.steady_vx_m_s),
            row("steady vy RMSE", "m/s", self.steady_vy_m_s),
            row("steady wz RMSE", "rad/s", self.steady_wz_rad_s),
            row("steady wheel RMSE", "rad/s", self.steady_wheel_rad_s),
            row("steady left wheel RMSE", "rad/s", self.steady_wheel_left_rad_s),
            row("steady right wheel RMSE", "rad/s", self.steady_wheel_right_rad_s),
            row("steady IMU wz RMSE", "rad/s", self.steady_imu_wz_rad_s),
            row("transient vx RMSE", "m/s", self.transient_vx_m_s),
            row("transient wz RMSE", "rad/s", self.transient_wz_rad_s),
            row("transient wheel RMSE", "rad/s", self.transient_wheel_rad_s),
            row("2 s translation error", "m", self.pose_translation_2s_m),
            row("2 s rotation error", "rad", self.pose_rotation_2s_rad),
            row("score (1 = noise floor)", "-", self.score),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use drive_sim_log::Measurement;

    /// A step of 3 windows x 40 samples at 20 Hz moving at constant (vx, wz) with wheel `w`.
    fn step(vx: f64, wz: f64, w: f64, wobble: f64) -> Vec<Sample> {
        let mut out = Vec::new();
        for window in 0..3u32 {
            for k in 0..40u32 {
                let t = window as f64 * 2.0 + k as f64 / 20.0;
                // Poses restart at each window, as in measured logs.
                let tw = k as f64 / 20.0;
                let yaw = wz * tw;
                let (x, y) = if wz.abs() < 1e-12 {
                    (vx * tw, 0.0)
                } else {
                    (vx / wz * yaw.sin(), vx / wz * (1.0 - yaw.cos()))
                };
                let mut m = Measurement::default();
                m.pose.x_m = x;
                m.pose.y_m = y;
                m.pose.yaw_rad = yaw;
                // The window-2 encoders differ by `wobble` from window 1.
                let e = w + if window == 2 { wobble } else { 0.0 };
                m.enc = WheelSpeeds::new(e, e);
                m.cmd = WheelSpeeds::new(w, w);
                out.push(Sample {
                    step: 0,
                    window,
                    k,
                    t_in_step_s: t,
                    stamp_s: t,
                    m,
                });
            }
        }
        out
    }

    #[test]
    fn features_recover_a_known_arc() {
        let f = step_features(0, &step(0.8, 0.4, 2.0, 0.0)).unwrap();
        assert_eq!(f.steady.len(), 2);
        for w in &f.steady {
            assert!((w[0] - 0.8).abs() < 1e-3, "{w:?}");
            assert!(w[1].abs() < 1e-3 && (w[2] - 0.4).abs() < 1e-9);
        }
        // Displacement over a window: 39 samples = 1.95 s of the arc.
        let yaw: f64 = 0.4 * 1.95;
        assert!((f.displacement[1][0] - 2.0 * yaw.sin()).abs() < 1e-9);
        assert!((f.displacement[1][2] - yaw).abs() < 1e-9);
        // Central differences inside the window: vx within chord error of 0.8.
        assert!(
            f.series.iter().all(|s| (s[0] - 0.8).abs() < 5e-3),
            "{:?}",
            f.series[50]
        );
    }

    #[test]
    fn floor_and_errors_by_hand() {
        // Window-2 encoders differ by 0.2 rad/s: median |d| = 0.2, σ = 1.4826 · 0.2 / √2.
        let meas = step_features(0, &step(1.0, 0.0, 3.0, 0.2)).unwrap();
        let floor = NoiseFloor::estimate(std::slice::from_ref(&meas)).unwrap();
        assert!(
            (floor.steady[3] - 1.4826 * 0.2 / 2f64.sqrt()).abs() < 1e-9,
            "{floor:?}"
        );
        // The median ignores one outlying step among three.
        let calm = step_features(0, &step(1.0, 0.0, 3.0, 0.1)).unwrap();
        let wild = step_features(0, &step(1.0, 0.0, 3.0, 5.0)).unwrap();
        let f3 = NoiseFloor::estimate(&[meas.clone(), calm, wild]).unwrap();
        assert!((f3.steady[3] - 1.4826 * 0.2 / 2f64.sqrt()).abs() < 1e-9, "{f3:?}");
        // Velocity channels are exact: clamped to the minimum floor.
        assert_eq!(floor.steady[0], MIN_FLOOR);
        // A replay 0.1 m/s slower: steady vx RMSE 0.1; wheel errors 0 in window 1, 0.2 in 2.
        let sim = step_features(0, &step(0.9, 0.0, 3.0, 0.0)).unwrap();
        let e = step_errors(&sim, &meas).unwrap();
        let s = ErrorSummary::pool(&[e], &floor);
        assert!((s.steady_vx_m_s - 0.1).abs() < 1e-3, "{s:?}");
        assert!((s.steady_wheel_left_rad_s - (0.04f64 / 2.0).sqrt()).abs() < 1e-9);
        // 2 s translation: 0.1 m/s * 1.95 s in every window.
        assert!((s.pose_translation_2s_m - 0.195).abs() < 1e-6);
        // A mismatched replay is refused.
        let mut short = sim.clone();
        short.series.pop();
        assert!(step_errors(&short, &meas).is_err());
    }
}
