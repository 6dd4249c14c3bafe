//! Cross-check of the redundant sensors: IMU yaw rate, pose (ICP) yaw rate, encoder (IDD) yaw
//! rate; IMU acceleration against the pose-derived body acceleration; encoder vs pose speed.
//!
//! For each comparison (a "measured" signal against a "reference"):
//! * sign, scale and bias from the least-squares line through the per-window means
//!   (measured = slope · reference + intercept); window means average the sample noise away,
//!   so the slope is not attenuated by noise in the reference. For the accelerometer, through
//!   the half-window accelerations of the transient windows instead (see [`cross_check`]);
//! * latency from the cross-correlation of the sample series, centred per window over the pairs
//!   that overlap at each lag (only the variation inside a window carries timing information),
//!   pooled over the transient windows (where the signals move), using only samples whose pose
//!   derivative is centred, searched over
//!   ±`max_lag_search_s`, refined by a parabola through the peak; positive = the measured signal
//!   is late.
//!
//! The pose is the exteroceptive reference the paper requires for realized velocities. It is
//! itself checked by majority: when the IMU and the pose disagree in sign, the encoders (whose
//! yaw-rate scale is off on a skid-steer, but whose sign is not) decide which one is inverted.

use super::stats::{linear_fit, LinearFit};
use super::velocity::SampleKinematics;
use serde::{Deserialize, Serialize};

/// Tolerances of the verdicts.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CrossCheckParams {
    /// Below this |correlation| of the window means a comparison is inconclusive.
    pub min_correlation: f64,
    /// Allowed |slope − 1| for the IMU yaw rate against the pose.
    pub yaw_scale_tolerance: f64,
    /// Allowed |slope − 1| for the IMU acceleration against the pose-derived one (wider: a
    /// second derivative of ICP positions is a weak reference).
    pub acc_scale_tolerance: f64,
    /// Allowed |intercept| of the IMU yaw rate, rad/s.
    pub max_yaw_bias_rad_s: f64,
    /// Allowed |latency|, s.
    pub max_latency_s: f64,
    /// Lag search range, s.
    pub max_lag_search_s: f64,
    /// Below this |correlation| at the peak the latency is undetermined and not judged.
    pub min_latency_correlation: f64,
}

impl Default for CrossCheckParams {
    fn default() -> Self {
        Self {
            min_correlation: 0.7,
            yaw_scale_tolerance: 0.15,
            acc_scale_tolerance: 0.35,
            max_yaw_bias_rad_s: 0.05,
            max_latency_s: 0.1,
            max_lag_search_s: 0.5,
            min_latency_correlation: 0.5,
        }
    }
}

/// One sensor compared with a reference.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Comparison {
    /// Measured signal, e.g. `imu_wz`.
    pub measured: String,
    /// Reference signal, e.g. `pose_wz`.
    pub reference: String,
    /// Line through the window means (measured on reference).
    pub fit: LinearFit,
    /// Estimated latency of the measured signal, s (positive = late).
    pub latency_s: f64,
    /// Correlation of the (per-window centred) sample series at that latency.
    pub latency_correlation: f64,
}

/// Outcome for one sensor.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "status", rename_all = "snake_case")]
pub enum Verdict {
    /// Consistent with the references.
    Pass,
    /// Inconsistent: what is wrong.
    Fault {
        /// Description with the evidence numbers.
        description: String,
    },
    /// Not enough signal to decide.
    Inconclusive {
        /// Why.
        description: String,
    },
}

impl Verdict {
    /// True for [`Verdict::Pass`].
    pub fn passed(&self) -> bool {
        matches!(self, Verdict::Pass)
    }
}

/// Verdict on one sensor channel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SensorVerdict {
    /// Sensor channel, e.g. `imu_yaw_rate`.
    pub sensor: String,
    /// The verdict.
    pub verdict: Verdict,
}

/// Which measurement the pipeline uses for the realized yaw rate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum YawRateSource {
    /// The IMU gyro (less noisy; the source's own choice).
    Imu,
    /// The derivative of the ICP yaw.
    Pose,
}

/// Result of the cross-check of one dataset.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CrossCheck {
    /// All comparisons, with their evidence numbers.
    pub comparisons: Vec<Comparison>,
    /// One verdict per sensor channel.
    pub verdicts: Vec<SensorVerdict>,
    /// The yaw-rate measurement used downstream.
    pub yaw_rate_source: YawRateSource,
    /// Why that source.
    pub yaw_rate_reason: String,
    /// Whether the log has an IMU (some finite IMU yaw rate); without one the IMU channels are
    /// inconclusive and the yaw rate comes from the pose.
    #[serde(default = "has_imu_by_default", skip_serializing_if = "is_true")]
    pub imu: bool,
}

/// A cross-check that does not say otherwise had an IMU.
fn has_imu_by_default() -> bool {
    true
}

/// Only the absence of an IMU is written out.
fn is_true(b: &bool) -> bool {
    *b
}

impl CrossCheck {
    /// The verdict on a channel, if checked.
    pub fn verdict(&self, sensor: &str) -> Option<&Verdict> {
        self.verdicts
            .iter()
            .find(|v| v.sensor == sensor)
            .map(|v| &v.verdict)
    }
    /// The comparison of `measured` against `reference`, if made.
    pub fn comparison(&self, measured: &str, reference: &str) -> Option<&Comparison> {
        self.comparisons
            .iter()
            .find(|c| c.measured == measured && c.reference == reference)
    }
}

type Getter = fn(&SampleKinematics) -> f64;

fn compare(
    windows: &[Vec<SampleKinematics>],
    measured: (&str, Getter),
    reference: (&str, Getter),
    rate_hz: f64,
    params: &CrossCheckParams,
) -> Comparison {
    let mut mx = Vec::new();
    let mut my = Vec::new();
    // Per-window sample series, NaN where unusable for timing (non-finite or one-sided
    // derivative at the window's ends).
    let mut series: Vec<(Vec<f64>, Vec<f64>)> = Vec::new();
    for w in windows {
        let a: Vec<f64> = w.iter().map(measured.1).collect();
        let b: Vec<f64> = w.iter().map(reference.1).collect();
        let ok: Vec<bool> = a
            .iter()
            .zip(&b)
            .map(|(x, y)| x.is_finite() && y.is_finite())
            .collect();
        let n = ok.iter().filter(|&&o| o).count();
        if n == 0 {
            continue;
        }
        my.push(a.iter().zip(&ok).filter(|p| *p.1).map(|p| p.0).sum::<f64>() / n as f64);
        mx.push(b.iter().zip(&ok).filter(|p| *p.1).map(|p| p.0).sum::<f64>() / n as f64);
        let timing = |v: &[f64]| -> Vec<f64> {
            v.iter()
                .zip(w)
                .map(|(x, s)| if x.is_finite() && s.centered { *x } else { f64::NAN })
                .collect()
        };
        // Timing from the transient windows only: in steady windows the signals are flat and
        // their within-window variation is sensor noise, which dilutes the correlation peak.
        if w.first().is_some_and(|s| s.window == 0) {
            series.push((timing(&a), timing(&b)));
        }
    }
    let fit = linear_fit(&mx, &my);
    let max_lag = (params.max_lag_search_s * rate_hz).round() as i64;
    // Pearson correlation at `lag`, each window centred over its own overlapping pairs (so a
    // shift does not leave a constant offset that biases the peak), pooled over windows.
    let corr_at = |lag: i64| -> f64 {
        let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
        for (a, b) in &series {
            let pairs: Vec<(f64, f64)> = (0..b.len() as i64)
                .filter_map(|i| {
                    let j = i + lag;
                    if j < 0 || j >= a.len() as i64 {
                        return None;
                    }
                    let (x, y) = (a[j as usize], b[i as usize]);
                    (x.is_finite() && y.is_finite()).then_some((x, y))
                })
                .collect();
            if pairs.len() < 3 {
                continue;
            }
            let n = pairs.len() as f64;
            let ma = pairs.iter().map(|p| p.0).sum::<f64>() / n;
            let mb = pairs.iter().map(|p| p.1).sum::<f64>() / n;
            for (x, y) in pairs {
                sab += (x - ma) * (y - mb);
                saa += (x - ma) * (x - ma);
                sbb += (y - mb) * (y - mb);
            }
        }
        if saa > 0.0 && sbb > 0.0 {
            sab / (saa * sbb).sqrt()
        } else {
            0.0
        }
    };
    let corrs: Vec<(i64, f64)> = (-max_lag..=max_lag).map(|l| (l, corr_at(l))).collect();
    let (best_i, &(best_lag, best_c)) = corrs
        .iter()
        .enumerate()
        .max_by(|a, b| a.1 .1.abs().total_cmp(&b.1 .1.abs()))
        .unwrap_or((0, &(0, 0.0)));
    // Parabolic refinement of |corr| around the peak.
    let mut lag = best_lag as f64;
    if best_i > 0 && best_i + 1 < corrs.len() {
        let (y0, y1, y2) = (corrs[best_i - 1].1.abs(), best_c.abs(), corrs[best_i + 1].1.abs());
        let den = y0 - 2.0 * y1 + y2;
        if den < 0.0 {
            lag += (0.5 * (y0 - y2) / den).clamp(-0.5, 0.5);
        }
    }
    Comparison {
        measured: measured.0.to_string(),
        reference: reference.0.to_string(),
        fit,
        latency_s: lag / rate_hz,
        latency_correlation: best_c,
    }
}

fn describe(c: &Comparison) -> String {
    format!(
        "{} = {:.3} x {} {:+.4} (r = {:.3}, {} windows), latency {:+.3} s (r = {:.3})",
        c.measured,
        c.fit.slope,
        c.reference,
        c.fit.intercept,
        c.fit.correlation,
        c.fit.n,
        c.latency_s,
        c.latency_correlation
    )
}

/// Verdict on a signal that should equal its reference (slope 1, no bias, no latency).
fn identity_verdict(
    c: &Comparison,
    scale_tol: f64,
    max_bias: Option<f64>,
    params: &CrossCheckParams,
) -> Verdict {
    if !c.fit.correlation.is_finite() || c.fit.correlation.abs() < params.min_correlation {
        return Verdict::Inconclusive {
            description: format!("|r| below {}: {}", params.min_correlation, describe(c)),
        };
    }
    let mut faults = Vec::new();
    if c.fit.slope < 0.0 {
        faults.push("sign inverted".to_string());
    }
    if (c.fit.slope.abs() - 1.0).abs() > scale_tol {
        faults.push(format!("scale {:.3} (tolerance ±{scale_tol})", c.fit.slope.abs()));
    }
    if let Some(b) = max_bias {
        if c.fit.intercept.abs() > b {
            faults.push(format!("bias {:+.4} (tolerance ±{b})", c.fit.intercept));
        }
    }
    if c.latency_correlation.abs() >= params.min_latency_correlation
        && c.latency_s.abs() > params.max_latency_s
    {
        faults.push(format!(
            "latency {:+.3} s (tolerance ±{} s)",
            c.latency_s, params.max_latency_s
        ));
    }
    if faults.is_empty() {
        Verdict::Pass
    } else {
        Verdict::Fault {
            description: format!("{}: {}", faults.join(", "), describe(c)),
        }
    }
}

/// Cross-checks the sensors over the given windows (each a time-ordered sample series).
///
/// `accelerations` holds, per transient window, `[imu_ax, imu_ay, pose_ax, pose_ay]` from
/// [`super::velocity::half_window_acceleration`]: sign, scale and bias of the accelerometer come
/// from them (window means of steady windows carry no acceleration, only the gravity
/// projection of the terrain's slope); its latency still comes from the sample series.
pub fn cross_check(
    windows: &[Vec<SampleKinematics>],
    accelerations: &[[f64; 4]],
    rate_hz: f64,
    params: &CrossCheckParams,
) -> CrossCheck {
    let imu_wz: (&str, Getter) = ("imu_wz", |s| s.imu_wz_rad_s);
    let pose_wz: (&str, Getter) = ("pose_wz", |s| s.pose.wz_rad_s);
    let enc_wz: (&str, Getter) = ("encoder_idd_wz", |s| s.enc_body.wz_rad_s);
    let pose_vx: (&str, Getter) = ("pose_vx", |s| s.pose.vx_m_s);
    let enc_vx: (&str, Getter) = ("encoder_idd_vx", |s| s.enc_body.vx_m_s);
    let imu_ax: (&str, Getter) = ("imu_ax", |s| s.imu_acc_m_s2.0);
    let pose_ax: (&str, Getter) = ("pose_ax", |s| s.pose_acc_m_s2.0);
    let imu_ay: (&str, Getter) = ("imu_ay", |s| s.imu_acc_m_s2.1);
    let pose_ay: (&str, Getter) = ("pose_ay", |s| s.pose_acc_m_s2.1);
    let c_imu = compare(windows, imu_wz, pose_wz, rate_hz, params);
    let c_enc = compare(windows, enc_wz, pose_wz, rate_hz, params);
    let c_imu_enc = compare(windows, imu_wz, enc_wz, rate_hz, params);
    let c_vx = compare(windows, enc_vx, pose_vx, rate_hz, params);
    let mut c_ax = compare(windows, imu_ax, pose_ax, rate_hz, params);
    let mut c_ay = compare(windows, imu_ay, pose_ay, rate_hz, params);
    let col = |i: usize| accelerations.iter().map(|a| a[i]).collect::<Vec<f64>>();
    c_ax.fit = linear_fit(&col(2), &col(0));
    c_ay.fit = linear_fit(&col(3), &col(1));

    let sign = |c: &Comparison| c.fit.slope.signum();
    let mut verdicts = Vec::new();
    // Who is inverted when the IMU and the pose disagree: the encoders break the tie.
    let pose_inverted = sign(&c_imu) < 0.0 && sign(&c_enc) < 0.0 && sign(&c_imu_enc) > 0.0;
    let pose_yaw = if pose_inverted {
        Verdict::Fault {
            description: format!(
                "pose yaw rate disagrees in sign with both the IMU and the encoders: {}; {}",
                describe(&c_imu),
                describe(&c_enc)
            ),
        }
    } else if !c_enc.fit.correlation.is_finite() || c_enc.fit.correlation.abs() < params.min_correlation {
        Verdict::Inconclusive {
            description: format!(
                "pose yaw rate weakly correlated with the encoders: {}",
                describe(&c_enc)
            ),
        }
    } else {
        Verdict::Pass
    };
    let imu_yaw = if pose_inverted {
        Verdict::Inconclusive {
            description: "reference (pose) yaw rate is itself inverted".to_string(),
        }
    } else {
        identity_verdict(
            &c_imu,
            params.yaw_scale_tolerance,
            Some(params.max_yaw_bias_rad_s),
            params,
        )
    };
    // Encoders: IDD scale on a skid-steer is legitimately off (effective baseline), only the
    // sign and the correlation are checked.
    let encoders = {
        let mut faults = Vec::new();
        if sign(&c_vx) < 0.0 {
            faults.push(format!("forward speed sign inverted: {}", describe(&c_vx)));
        }
        if sign(&c_enc) < 0.0 && sign(&c_imu) > 0.0 {
            faults.push(format!(
                "yaw sign inverted (left/right swapped?): {}",
                describe(&c_enc)
            ));
        }
        if !faults.is_empty() {
            Verdict::Fault {
                description: faults.join("; "),
            }
        } else if !c_vx.fit.correlation.is_finite() || c_vx.fit.correlation.abs() < params.min_correlation {
            Verdict::Inconclusive {
                description: format!(
                    "encoder speed weakly correlated with the pose: {}",
                    describe(&c_vx)
                ),
            }
        } else {
            Verdict::Pass
        }
    };
    // A log without an IMU has no finite IMU reading: its channels are not judged.
    let imu = windows.iter().flatten().any(|s| s.imu_wz_rad_s.is_finite());
    let no_imu = || Verdict::Inconclusive {
        description: NO_IMU.to_string(),
    };
    let acc = |c: &Comparison| {
        if imu {
            identity_verdict(c, params.acc_scale_tolerance, None, params)
        } else {
            no_imu()
        }
    };
    let imu_yaw = if imu { imu_yaw } else { no_imu() };
    verdicts.push(SensorVerdict {
        sensor: "imu_yaw_rate".into(),
        verdict: imu_yaw.clone(),
    });
    verdicts.push(SensorVerdict {
        sensor: "pose_yaw_rate".into(),
        verdict: pose_yaw.clone(),
    });
    verdicts.push(SensorVerdict {
        sensor: "encoders".into(),
        verdict: encoders,
    });
    verdicts.push(SensorVerdict {
        sensor: "imu_accel_x".into(),
        verdict: acc(&c_ax),
    });
    verdicts.push(SensorVerdict {
        sensor: "imu_accel_y".into(),
        verdict: acc(&c_ay),
    });
    let (yaw_rate_source, yaw_rate_reason) = match (&imu_yaw, &pose_yaw) {
        _ if !imu => (YawRateSource::Pose, "no IMU in the log; using the pose".to_string()),
        (Verdict::Pass, _) => (YawRateSource::Imu, "IMU yaw rate passes the cross-check".to_string()),
        (_, Verdict::Pass) => (YawRateSource::Pose, "IMU yaw rate fails the cross-check; using the pose".to_string()),
        _ => (
            YawRateSource::Pose,
            "neither the IMU nor the pose yaw rate passes; using the pose (exteroceptive, as the paper requires)"
                .to_string(),
        ),
    };
    CrossCheck {
        comparisons: vec![c_imu, c_enc, c_imu_enc, c_vx, c_ax, c_ay],
        verdicts,
        yaw_rate_source,
        yaw_rate_reason,
        imu,
    }
}

/// The verdict's description on the IMU channels of a log without an IMU.
const NO_IMU: &str = "no IMU in the log";
