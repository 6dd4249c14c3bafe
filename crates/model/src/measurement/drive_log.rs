//! The common in-memory DRIVE log and its metadata.
//!
//! A log is built from a stream of [`Frame`]s, one per 20 Hz tick, by [`DriveLog::from_frames`];
//! that one function decides which samples belong to which step and which attempts were
//! interrupted.

use super::{Frame, Phase, Sample};
use serde::{Deserialize, Serialize};

/// An interrupted attempt: the robot was about to leave the safe area.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Interruption {
    /// Step whose attempt was interrupted.
    pub step: u32,
    /// The attempt that was interrupted.
    pub attempt: u32,
    /// Time into the attempt at the interruption, s.
    pub t_in_step_s: f64,
    /// Log time of the interruption, s.
    pub stamp_s: f64,
    /// Time spent on the interrupted attempt and the re-orientation, s.
    pub time_lost_s: f64,
}

/// Robot parameters the log declares (the operators' configuration for measured data).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Nominal {
    /// Wheel radius, m.
    pub wheel_radius_m: f64,
    /// Baseline, m.
    pub baseline_m: f64,
    /// Wheel speed limit, rad/s.
    pub max_wheel_rad_s: f64,
    /// User limit on |vx|, m/s.
    pub max_lin_m_s: f64,
    /// User limit on |wz|, rad/s.
    pub max_ang_rad_s: f64,
    /// Mass, kg.
    pub mass_kg: f64,
    /// Footprint width, m.
    pub width_m: f64,
    /// Footprint length, m.
    pub length_m: f64,
    /// Height, m, when declared.
    #[serde(default)]
    pub height_m: Option<f64>,
    /// User linear acceleration limit, m/s², when declared.
    #[serde(default)]
    pub max_lin_acc_m_s2: Option<f64>,
    /// How much more the commands turn than the wheel square they were drawn in
    /// ([`CommandSpace::turn_scale`](crate::kinematics::CommandSpace::turn_scale)), when not 1.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub command_turn_scale: Option<f64>,
}

impl Nominal {
    /// The declared ideal differential drive.
    pub fn idd(&self) -> crate::kinematics::IdealDiffDrive {
        crate::kinematics::IdealDiffDrive {
            wheel_radius_m: self.wheel_radius_m,
            baseline_m: self.baseline_m,
        }
    }
    /// The declared command space.
    pub fn command_space(&self) -> crate::kinematics::CommandSpace {
        crate::kinematics::CommandSpace {
            idd: self.idd(),
            max_wheel_rad_s: self.max_wheel_rad_s,
            max_lin_m_s: self.max_lin_m_s,
            max_ang_rad_s: self.max_ang_rad_s,
            turn_scale: self.command_turn_scale.unwrap_or(1.0),
        }
    }
}

/// Where a log comes from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Origin {
    /// Written by this simulator.
    Simulated {
        /// Seed of every random draw.
        seed: u64,
        /// Robot file used.
        robot_file: String,
        /// Terrain file used.
        terrain_file: String,
        /// Sampler name.
        sampler: String,
        /// Effects injected without being declared (`--inject`), as `name=value` strings.
        /// Kept for the test harness; analysis must not read it.
        #[serde(default)]
        injected: Vec<String>,
    },
    /// Recorded on a real robot.
    Measured {
        /// The file it was read from.
        file: String,
    },
    /// The commands of another log replayed on a model, step for step (`drive-sim replay`):
    /// each step pairs with the step of the same number in that log (what `compare` uses to
    /// pair differences by step).
    Replayed {
        /// Name of the log whose commands were replayed.
        of: String,
        /// Plant replayed (`simulator`, `kinematic`).
        model: String,
        /// Robot model (name or file) replayed.
        robot_file: String,
        /// Terrain model (name or file) replayed.
        terrain_file: String,
        /// The model's effects, as `name=value` strings.
        #[serde(default)]
        effects: Vec<String>,
    },
}

/// Metadata of a log.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LogMeta {
    /// Dataset name, e.g. `warthog_ice`.
    pub name: String,
    /// Robot name.
    pub robot: String,
    /// Terrain name (`unlabelled` when unknown).
    pub terrain: String,
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// Window duration, s.
    pub window_s: f64,
    /// Windows per step (1 transient + steady ones).
    pub windows_per_step: u32,
    /// Samples per window.
    pub samples_per_window: u32,
    /// Declared robot parameters.
    pub nominal: Nominal,
    /// Where the log comes from.
    pub origin: Origin,
}

impl LogMeta {
    /// The validation pass of a log's metadata, whatever the format it came from: physical
    /// ranges with units, and the sampling it declares being consistent. Returns the field and
    /// the reason. Checked by every reader before the samples are used, so that a typo (a rate
    /// of `1e12` Hz) is an error naming the field, not an allocation of terabytes.
    pub fn validate(&self) -> std::result::Result<(), (String, String)> {
        let range = |field: &str, v: f64, lo: f64, hi: f64, unit: &str| {
            if v.is_finite() && v >= lo && v <= hi {
                Ok(())
            } else {
                Err((
                    field.to_string(),
                    format!("must be in [{lo}, {hi}] {unit}, got {v}"),
                ))
            }
        };
        range("rate_hz", self.rate_hz, 1.0, 1_000.0, "Hz")?;
        range("window_s", self.window_s, 0.05, 60.0, "s")?;
        range(
            "windows_per_step",
            self.windows_per_step as f64,
            2.0,
            20.0,
            "windows",
        )?;
        range(
            "samples_per_window",
            self.samples_per_window as f64,
            1.0,
            10_000.0,
            "samples",
        )?;
        let expected = self.rate_hz * self.window_s;
        if (self.samples_per_window as f64 - expected).abs() > 1.0 {
            return Err((
                "samples_per_window".into(),
                format!(
                    "{} does not match rate_hz x window_s = {} x {} = {expected}",
                    self.samples_per_window, self.rate_hz, self.window_s
                ),
            ));
        }
        let n = &self.nominal;
        for (field, v, lo, hi, unit) in [
            ("nominal.wheel_radius_m", n.wheel_radius_m, 0.02, 2.0, "m"),
            ("nominal.baseline_m", n.baseline_m, 0.05, 10.0, "m"),
            ("nominal.max_wheel_rad_s", n.max_wheel_rad_s, 0.1, 200.0, "rad/s"),
            ("nominal.max_lin_m_s", n.max_lin_m_s, 0.01, 30.0, "m/s"),
            ("nominal.max_ang_rad_s", n.max_ang_rad_s, 0.01, 20.0, "rad/s"),
            ("nominal.mass_kg", n.mass_kg, 1.0, 20_000.0, "kg"),
            ("nominal.width_m", n.width_m, 0.1, 10.0, "m"),
            ("nominal.length_m", n.length_m, 0.1, 20.0, "m"),
        ] {
            range(field, v, lo, hi, unit)?;
        }
        if let Some(h) = n.height_m {
            range("nominal.height_m", h, 0.05, 10.0, "m")?;
        }
        if let Some(a) = n.max_lin_acc_m_s2 {
            range("nominal.max_lin_acc_m_s2", a, 0.01, 50.0, "m/s²")?;
        }
        if let Some(k) = n.command_turn_scale {
            let (lo, hi) = crate::kinematics::TURN_SCALE;
            range("nominal.command_turn_scale", k, lo, hi, "-")?;
        }
        Ok(())
    }

    /// Duration of one step, s.
    pub fn step_s(&self) -> f64 {
        self.window_s * self.windows_per_step as f64
    }
}

/// Which steps of a log to use: a twin calibrated on one half of a run is judged on the other.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum UseSteps {
    /// Every step.
    #[default]
    All,
    /// Steps with an odd number.
    Odd,
    /// Steps with an even number.
    Even,
}

impl UseSteps {
    /// Every choice, in the order the command line lists them.
    pub const ALL: [Self; 3] = [Self::All, Self::Odd, Self::Even];

    /// What the choice keeps, in a few words.
    pub fn doc(self) -> &'static str {
        match self {
            Self::All => "Every step",
            Self::Odd => "Steps with an odd number",
            Self::Even => "Steps with an even number",
        }
    }

    /// Name on the command line.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::All => "all",
            Self::Odd => "odd",
            Self::Even => "even",
        }
    }

    /// The steps these leave out: the other half (`None` for `All`), where what was chosen on
    /// these steps can be judged.
    pub fn other_half(self) -> Option<Self> {
        match self {
            Self::All => None,
            Self::Odd => Some(Self::Even),
            Self::Even => Some(Self::Odd),
        }
    }

    /// The log restricted to these steps (itself for `All`), named `<name>_odd` / `_even`.
    pub fn select(self, log: &DriveLog) -> DriveLog {
        match self {
            Self::All => log.clone(),
            Self::Odd => log.with_steps("odd", |s| s % 2 == 1),
            Self::Even => log.with_steps("even", |s| s % 2 == 0),
        }
    }
}

/// A DRIVE log: metadata, the samples of completed steps (in order), and the interruptions.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DriveLog {
    /// Metadata.
    pub meta: LogMeta,
    /// Samples of completed step attempts, ordered by step then time.
    pub samples: Vec<Sample>,
    /// Interrupted attempts.
    pub interruptions: Vec<Interruption>,
    /// Total log duration, s (protocol time including interruptions and re-orientation).
    pub duration_s: f64,
}

impl DriveLog {
    /// Builds a log from a frame stream: keeps, for each step, the samples of its last attempt;
    /// earlier attempts of a step become [`Interruption`]s whose lost time runs until the next
    /// attempt starts.
    pub fn from_frames(meta: LogMeta, frames: &[Frame]) -> Self {
        use std::collections::BTreeMap;
        // Last attempt seen per step.
        let mut last_attempt: BTreeMap<u32, u32> = BTreeMap::new();
        for f in frames {
            if let Phase::Step { step, attempt, .. } = f.phase {
                let e = last_attempt.entry(step).or_insert(attempt);
                *e = (*e).max(attempt);
            }
        }
        let mut samples = Vec::new();
        // (step, attempt) -> (first stamp, last stamp, last t_in_step)
        let mut aborted: BTreeMap<(u32, u32), (f64, f64, f64)> = BTreeMap::new();
        // First stamp of each (step, attempt), to close the lost time of the previous attempt.
        let mut attempt_start: BTreeMap<(u32, u32), f64> = BTreeMap::new();
        for f in frames {
            if let Phase::Step {
                step,
                attempt,
                window,
                k,
                t_in_step_s,
            } = f.phase
            {
                attempt_start.entry((step, attempt)).or_insert(f.stamp_s);
                if attempt == last_attempt[&step] {
                    samples.push(Sample {
                        step,
                        window,
                        k,
                        t_in_step_s,
                        stamp_s: f.stamp_s,
                        m: f.m,
                    });
                } else {
                    let e = aborted
                        .entry((step, attempt))
                        .or_insert((f.stamp_s, f.stamp_s, t_in_step_s));
                    e.1 = f.stamp_s;
                    e.2 = t_in_step_s;
                }
            }
        }
        let interruptions = aborted
            .into_iter()
            .map(|((step, attempt), (start, end, t))| {
                let next = attempt_start.get(&(step, attempt + 1)).copied().unwrap_or(end);
                Interruption {
                    step,
                    attempt,
                    t_in_step_s: t,
                    stamp_s: end,
                    time_lost_s: next - start,
                }
            })
            .collect();
        let duration_s = match (frames.first(), frames.last()) {
            (Some(a), Some(b)) => b.stamp_s - a.stamp_s + 1.0 / meta.rate_hz,
            _ => 0.0,
        };
        Self {
            meta,
            samples,
            interruptions,
            duration_s,
        }
    }

    /// The log restricted to the steps `keep` accepts (their samples and interruptions; the
    /// duration shrinks in proportion to the productive time kept, so time efficiency stays
    /// comparable), named `<name>_<label>`.
    pub fn with_steps(&self, label: &str, keep: impl Fn(u32) -> bool) -> DriveLog {
        let before = self.steps().len().max(1) as f64;
        let samples: Vec<Sample> = self.samples.iter().filter(|s| keep(s.step)).cloned().collect();
        let mut out = DriveLog {
            meta: LogMeta {
                name: format!("{}_{label}", self.meta.name),
                ..self.meta.clone()
            },
            samples,
            interruptions: self
                .interruptions
                .iter()
                .filter(|i| keep(i.step))
                .cloned()
                .collect(),
            duration_s: self.duration_s,
        };
        out.duration_s = self.duration_s * out.steps().len() as f64 / before;
        out
    }

    /// Indices of the completed steps, in order.
    pub fn steps(&self) -> Vec<u32> {
        let mut s: Vec<u32> = self.samples.iter().map(|s| s.step).collect();
        s.dedup();
        s
    }

    /// The command each completed step holds ([`held_command`](super::held_command)), in step
    /// order.
    pub fn held_commands(&self) -> Vec<crate::kinematics::WheelSpeeds> {
        // A step's samples are contiguous, as in `steps`.
        self.samples
            .chunk_by(|a, b| a.step == b.step)
            .filter_map(|samples| super::held_command(samples).map(|h| h.cmd))
            .collect()
    }

    /// Fraction of protocol time spent on completed steps (the paper's time-efficiency ratio).
    pub fn time_efficiency(&self) -> f64 {
        if self.duration_s <= 0.0 {
            return 0.0;
        }
        let productive = self.steps().len() as f64 * self.meta.step_s();
        (productive / self.duration_s).min(1.0)
    }
}
