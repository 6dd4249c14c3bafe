//! Residual diagnosis: what the model still misses, channel by channel, and where.
//!
//! For every channel — steady vx, vy, wz, each encoder and the IMU yaw rate (window means);
//! transient vx, wz and encoders (per sample of the first window); the 2 s displacement
//! (translation, rotation) — the unexplained residual is reported as RMSE / noise floor and
//! flagged above [`STEADY_FLAG`] (steady) or [`TRANSIENT_FLAG`] (transient, pose): a model at
//! its floor scores about 1. A flagged channel says where its residual lives: in which
//! quadrant of the command space, forward or reverse, early or late in the run (step index
//! below or above the median), early or late in the step (first half of the windows or
//! samples, or the second).

use super::metrics::{NoiseFloor, StepFeatures, StepResiduals, SERIES_CHANNELS, STEADY_CHANNELS};
use drive_sim_model::kinematics::IdealDiffDrive;
use serde::{Deserialize, Serialize};

/// Flag threshold of a steady channel, RMSE / floor.
pub const STEADY_FLAG: f64 = 2.0;
/// Flag threshold of a transient or pose channel, RMSE / floor.
pub const TRANSIENT_FLAG: f64 = 3.0;

/// Which estimator a channel comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ChannelKind {
    /// Window means of the steady windows.
    Steady,
    /// Per-sample values in the transient window.
    Transient,
    /// Displacement over a window.
    Pose,
}

/// RMSE / floor of a channel over a subset of its entries.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Part {
    /// What the subset is (`reverse`, `late in the run`, `forward, turning left`, ...).
    pub part: String,
    /// RMSE / floor over it.
    pub ratio: f64,
    /// Entries in it.
    pub n: usize,
}

/// The diagnosis of one channel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ChannelDiagnosis {
    /// Channel name (`steady vy`, `transient enc_left`, `pose translation`, ...).
    pub channel: String,
    /// Estimator.
    pub kind: ChannelKind,
    /// RMSE, in the channel's unit.
    pub rmse: f64,
    /// Noise floor, same unit.
    pub floor: f64,
    /// RMSE / floor.
    pub ratio: f64,
    /// Threshold it is flagged above.
    pub threshold: f64,
    /// Above the threshold.
    pub flagged: bool,
    /// Entries (windows or samples).
    pub n: usize,
    /// Where the residual lives (flagged channels only): every part, in a fixed order.
    pub parts: Vec<Part>,
    /// The part that stands out, in words (flagged channels only).
    pub location: String,
}

/// The diagnosis of a model on a set of steps.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Diagnosis {
    /// Steps diagnosed.
    pub steps: usize,
    /// One entry per channel.
    pub channels: Vec<ChannelDiagnosis>,
}

impl Diagnosis {
    /// The flagged channels' names.
    pub fn flagged(&self) -> Vec<&str> {
        self.channels
            .iter()
            .filter(|c| c.flagged)
            .map(|c| c.channel.as_str())
            .collect()
    }

    /// The diagnosis of `channel`.
    pub fn channel(&self, channel: &str) -> Option<&ChannelDiagnosis> {
        self.channels.iter().find(|c| c.channel == channel)
    }
}

/// One residual entry with what locates it.
struct Entry {
    r: f64,
    vx: f64,
    wz: f64,
    step: u32,
    late_in_step: bool,
}

/// Diagnoses `residuals` (model − recording, as [`StepResiduals`]) against the recording's
/// features `measured` (same steps, same order) and the floor; `idd` turns the mean command
/// into a body velocity.
pub fn diagnose(
    residuals: &[StepResiduals],
    measured: &[StepFeatures],
    floor: &NoiseFloor,
    idd: &IdealDiffDrive,
) -> Diagnosis {
    let mut channels = Vec::new();
    let median_step = {
        let mut s: Vec<u32> = residuals.iter().map(|r| r.step).collect();
        s.sort_unstable();
        s.get(s.len() / 2).copied().unwrap_or(0)
    };
    let cmd = |f: &StepFeatures| idd.body_from_wheels(f.cmd);
    for (c, name) in STEADY_CHANNELS.iter().enumerate() {
        let mut e = Vec::new();
        for (r, f) in residuals.iter().zip(measured) {
            let v = cmd(f);
            let n = r.steady.len();
            for (w, x) in r.steady.iter().enumerate() {
                e.push(Entry {
                    r: x[c],
                    vx: v.vx_m_s,
                    wz: v.wz_rad_s,
                    step: r.step,
                    late_in_step: 2 * w >= n,
                });
            }
        }
        channels.push(channel(
            format!("steady {name}"),
            ChannelKind::Steady,
            &e,
            floor.steady[c],
            median_step,
        ));
    }
    for (c, name) in SERIES_CHANNELS.iter().enumerate() {
        let mut e = Vec::new();
        for (r, f) in residuals.iter().zip(measured) {
            let v = cmd(f);
            let n = r.transient.len();
            for (i, x) in r.transient.iter().enumerate() {
                e.push(Entry {
                    r: x[c],
                    vx: v.vx_m_s,
                    wz: v.wz_rad_s,
                    step: r.step,
                    late_in_step: 2 * i >= n,
                });
            }
        }
        channels.push(channel(
            format!("transient {name}"),
            ChannelKind::Transient,
            &e,
            floor.series[c],
            median_step,
        ));
    }
    for (k, name) in ["translation", "rotation"].iter().enumerate() {
        let mut e = Vec::new();
        for (r, f) in residuals.iter().zip(measured) {
            let v = cmd(f);
            let n = r.pose.len();
            for (w, x) in r.pose.iter().enumerate() {
                e.push(Entry {
                    r: if k == 0 { x[0].hypot(x[1]) } else { x[2] },
                    vx: v.vx_m_s,
                    wz: v.wz_rad_s,
                    step: r.step,
                    late_in_step: 2 * w >= n,
                });
            }
        }
        channels.push(channel(
            format!("pose {name}"),
            ChannelKind::Pose,
            &e,
            floor.pose[k],
            median_step,
        ));
    }
    Diagnosis {
        steps: residuals.len(),
        channels,
    }
}

fn channel(name: String, kind: ChannelKind, e: &[Entry], floor: f64, median_step: u32) -> ChannelDiagnosis {
    let ratio_of = |f: &dyn Fn(&Entry) -> bool| -> (f64, usize) {
        let (s, n) = e
            .iter()
            .filter(|x| f(x))
            .fold((0.0, 0usize), |(s, n), x| (s + x.r * x.r, n + 1));
        if n == 0 {
            (f64::NAN, 0)
        } else {
            ((s / n as f64).sqrt() / floor, n)
        }
    };
    let (ratio, n) = ratio_of(&|_| true);
    let threshold = match kind {
        ChannelKind::Steady => STEADY_FLAG,
        _ => TRANSIENT_FLAG,
    };
    let flagged = ratio.is_finite() && ratio > threshold;
    let mut parts = Vec::new();
    let mut location = String::new();
    if flagged {
        type Split<'a> = (&'a str, &'a str, Box<dyn Fn(&Entry) -> bool>);
        let splits: Vec<Split> = vec![
            ("forward", "reverse", Box::new(|x: &Entry| x.vx >= 0.0)),
            ("turning left", "turning right", Box::new(|x: &Entry| x.wz >= 0.0)),
            (
                "early in the run",
                "late in the run",
                Box::new(move |x: &Entry| x.step < median_step),
            ),
            (
                "early in the step",
                "late in the step",
                Box::new(|x: &Entry| !x.late_in_step),
            ),
        ];
        let mut best: Option<(f64, String)> = None;
        for (a, b, f) in &splits {
            let (ra, na) = ratio_of(&|x| f(x));
            let (rb, nb) = ratio_of(&|x| !f(x));
            parts.push(Part {
                part: a.to_string(),
                ratio: ra,
                n: na,
            });
            parts.push(Part {
                part: b.to_string(),
                ratio: rb,
                n: nb,
            });
            if na > 0 && nb > 0 {
                let (hi, lo, name) = if ra >= rb { (ra, rb, *a) } else { (rb, ra, *b) };
                let contrast = hi / lo.max(1e-12);
                if best.as_ref().is_none_or(|(c, _)| contrast > *c) {
                    best = Some((contrast, format!("{name} ({hi:.1}× vs {lo:.1}× the floor)")));
                }
            }
        }
        for (fwd, fname) in [(true, "forward"), (false, "reverse")] {
            for (left, lname) in [(true, "turning left"), (false, "turning right")] {
                let (r, n) = ratio_of(&|x| (x.vx >= 0.0) == fwd && (x.wz >= 0.0) == left);
                parts.push(Part {
                    part: format!("{fname}, {lname}"),
                    ratio: r,
                    n,
                });
            }
        }
        location = match best {
            Some((c, s)) if c >= 1.5 => format!("concentrated {s}"),
            _ => "spread over the command space, the run and the step".into(),
        };
    }
    ChannelDiagnosis {
        channel: name,
        kind,
        rmse: ratio * floor,
        floor,
        ratio,
        threshold,
        flagged,
        n,
        parts,
        location,
    }
}

/// "What the model lacks", in lines a report leads with: each channel's residual / floor on
/// the test steps before and after calibration, the equations discovery found and what it
/// added and why, and what is still above the floor (with where it lives).
pub fn lacks_summary(report: &super::CalibrationReport) -> Vec<String> {
    let mut lines = Vec::new();
    let (Some(before), Some(after)) = (&report.diagnosis_before, &report.diagnosis_after) else {
        return lines;
    };
    lines.push(format!(
        "residual / noise floor on {} test steps, declared → calibrated model (flag: > {STEADY_FLAG} steady, > {TRANSIENT_FLAG} transient and pose):",
        after.steps
    ));
    for b in &before.channels {
        if let Some(a) = after.channel(&b.channel) {
            lines.push(format!(
                "  {:<22} {:>8.2} → {:>6.2}{}",
                b.channel,
                b.ratio,
                a.ratio,
                if a.flagged { "  still flagged" } else { "" }
            ));
        }
    }
    if let Some(d) = &report.discovery {
        for round in &d.rounds {
            for e in &round.equations {
                lines.push(format!("discovered ({}): {}", e.channels.join(", "), e.text));
                for r in &e.reading {
                    lines.push(format!("  reading: {r}"));
                }
            }
            for s in &round.skipped {
                lines.push(format!("no equation for {}: {}", s.target, s.reason));
            }
            match &round.added {
                Some(a) => lines.push(format!("added {a}: {}", round.why)),
                None if !round.why.is_empty() => {
                    lines.push(format!("nothing added at the {}: {}", round.stage, round.why))
                }
                None => {}
            }
        }
        for b in d.backward.iter().filter(|b| b.dropped) {
            lines.push(format!(
                "dropped {} after discovery (validation {:.3} → {:.3} without it, ± {:.3})",
                b.effect, b.score_with, b.score_without, b.se
            ));
        }
        if let Some(c) = &d.competition {
            let list = |e: &[String]| {
                if e.is_empty() {
                    "nothing".to_string()
                } else {
                    e.join(", ")
                }
            };
            lines.push(format!(
                "discovery from the base model: {} ({} parameters) against the catalogue first: {} ({} parameters); {} kept: {}",
                list(&c.discovery_first.effects),
                c.discovery_first.parameters,
                list(&c.catalogue_first.effects),
                c.catalogue_first.parameters,
                c.kept,
                c.why
            ));
        }
    }
    let still: Vec<String> = after
        .channels
        .iter()
        .filter(|c| c.flagged)
        .map(|c| format!("{} ({:.1}×, {})", c.channel, c.ratio, c.location))
        .collect();
    lines.push(if still.is_empty() {
        "every channel within its flag threshold on the test steps".into()
    } else {
        format!("still above the floor: {}", still.join("; "))
    });
    lines
}
