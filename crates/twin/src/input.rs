//! The logs a twin is made from: opened, checked before any long work, and grouped by ground.
//!
//! Runs on the same ground share one terrain: their steps are pooled into one log per ground
//! (steps renumbered by an even offset, so that each run's odd steps stay odd and a held-out
//! half of the pool is the same half of every run).

use crate::error::{Error, Result};
use crate::event::TwinEvent;
use drive_sim_analysis::bootstrap::MIN_STEPS_FOR_INTERVAL;
use drive_sim_calibration::data::MIN_STEPS_PER_SET;
use drive_sim_calibration::to_dir::StartingModels;
use drive_sim_calibration::CalibrationOptions;
use drive_sim_log::{DriveLog, OpenOptions, UseSteps};
use drive_sim_model::effects::CommandReach;
use drive_sim_model::kinematics::WheelSpeeds;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// One log given, as read.
#[derive(Debug, Clone)]
pub struct RunLog {
    /// Its file.
    pub file: PathBuf,
    /// The log.
    pub log: DriveLog,
    /// Its analysed steps (the steps with steady windows the statistics use).
    pub analysed: usize,
}

/// The runs on one ground, pooled.
#[derive(Debug, Clone)]
pub struct Ground {
    /// The ground: the logs' terrain label.
    pub name: String,
    /// Indices of its runs among the logs given.
    pub runs: Vec<usize>,
    /// Their steps in one log (one run: that run).
    pub log: DriveLog,
}

/// A log's line in `twin.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunSummary {
    /// Dataset name.
    pub dataset: String,
    /// Its file.
    pub file: PathBuf,
    /// Its ground (terrain label).
    pub ground: String,
    /// Steps in the log.
    pub steps: usize,
    /// Steps the analysis keeps (steady windows).
    pub analysed: usize,
}

impl RunLog {
    /// The log's line in `twin.json`.
    pub fn summary(&self) -> RunSummary {
        RunSummary {
            dataset: self.log.meta.name.clone(),
            file: self.file.clone(),
            ground: self.log.meta.terrain.clone(),
            steps: self.log.steps().len(),
            analysed: self.analysed,
        }
    }
}

/// Opens every log and checks what a twin needs before any long work: one robot, and in each
/// log enough analysed steps in each half for a held-out judgement (bad input naming the log
/// and what is missing).
pub fn open_logs(
    files: &[PathBuf],
    opts: &OpenOptions,
    progress: &(dyn Fn(&TwinEvent) + Sync),
) -> Result<Vec<RunLog>> {
    if files.is_empty() {
        return Err(Error::config(
            "<command line>",
            "LOG",
            "no log to make a twin from",
        ));
    }
    let mut runs: Vec<RunLog> = Vec::new();
    for file in files {
        progress(&TwinEvent::Reading { path: file });
        let opened = drive_sim_log::open(file, opts)?;
        for note in opened.notes.iter().chain(&opened.warnings) {
            progress(&TwinEvent::Note { note });
        }
        let log = opened.log;
        if let Some(first) = runs.first() {
            if first.log.meta.robot != log.meta.robot {
                return Err(Error::log(
                    file,
                    "metadata: robot",
                    format!(
                        "is of robot `{}`, `{}` of robot `{}`: a twin is of one robot",
                        log.meta.robot,
                        first.file.display(),
                        first.log.meta.robot
                    ),
                ));
            }
        }
        if runs.iter().any(|r| r.log.meta.name == log.meta.name) {
            return Err(Error::log(
                file,
                "metadata: name",
                format!("dataset `{}` is given twice", log.meta.name),
            ));
        }
        let analysed = check_splittable(file, &log)?;
        runs.push(RunLog {
            file: file.clone(),
            log,
            analysed,
        });
    }
    Ok(runs)
}

/// Fewest analysed steps in each half of a run: enough for compare's intervals and for the
/// calibration's train / validation / test split of that half (its smallest set needs
/// [`MIN_STEPS_PER_SET`] steps).
pub fn min_steps_per_half() -> usize {
    let o = CalibrationOptions::default();
    let smallest = o
        .train_fraction
        .min(o.validation_fraction)
        .min(1.0 - o.train_fraction - o.validation_fraction);
    let split = (MIN_STEPS_PER_SET as f64 / smallest).ceil() as usize;
    split.max(MIN_STEPS_FOR_INTERVAL)
}

/// The analysed steps of `log`, refused when a half of them (odd or even) has fewer than
/// [`min_steps_per_half`]: the twin is chosen on one half and judged on the other.
fn check_splittable(file: &Path, log: &DriveLog) -> Result<usize> {
    let analysed_in = |steps: UseSteps| -> Result<usize> {
        let selected = steps.select(log);
        match drive_sim_compare::analysis_of(&selected) {
            Ok(a) => Ok(a.steps.len()),
            Err(e) if e.is_bad_input() => Err(e.into()),
            Err(e) => Err(Error::log(
                file,
                format!("{} steps", steps.as_str()),
                format!("no step with steady windows to analyse ({e})"),
            )),
        }
    };
    let all = analysed_in(UseSteps::All)?;
    let need = min_steps_per_half();
    for half in [UseSteps::Odd, UseSteps::Even] {
        let n = analysed_in(half)?;
        if n < need {
            return Err(Error::log(
                file,
                format!("{} steps", half.as_str()),
                format!(
                    "{n} of its {all} analysed steps are {}: a twin is chosen on one half of a run and judged on the other, and each half needs at least {need} (a run of at least {} steps with steady windows)",
                    half.as_str(),
                    2 * need
                ),
            ));
        }
    }
    Ok(all)
}

/// The models each log's calibration starts from (`robot` / `terrain`, names or files, or the
/// log's own), with one command space for all: the robot's U widened to hold every command of
/// the logs (`Robot::cover_commands`, one note per limit changed). A twin's own DRIVE samples
/// U; a U narrower than what the operators commanded (the Husky run's metadata says 6.06 rad/s,
/// its commands reach 14.33) would make it sample other commands than the run it is judged on,
/// and so would a U of another shape (the Husky's commands fill the metadata's wheel square
/// once their turning is divided by about 2.5).
pub fn starting_models(
    logs: &[&DriveLog],
    robot: Option<&str>,
    terrain: Option<&str>,
) -> Result<(Vec<StartingModels>, Vec<String>)> {
    let mut starts = logs
        .iter()
        .map(|log| StartingModels::resolve(log, robot, terrain))
        .collect::<drive_sim_calibration::Result<Vec<_>>>()?;
    let Some(first) = starts.first() else {
        return Ok((starts, Vec::new()));
    };
    let reach = CommandReach::of_commands(
        logs.iter().flat_map(|l| l.samples.iter().map(|s| s.m.cmd)),
        &first.robot.idd(),
    );
    let configured_u = first.robot.powertrain.max_wheel_rad_s;
    let declared = first.robot.effects.get(SATURATION).is_some_and(f64::is_finite);
    // One command per step, the draw DRIVE held.
    let held: Vec<WheelSpeeds> = logs.iter().flat_map(|l| l.held_commands()).collect();
    let mut notes = Vec::new();
    for (i, m) in starts.iter_mut().enumerate() {
        let changed = m.robot.cover_commands(&held);
        if i == 0 {
            notes = changed;
        }
    }
    // Commands beyond the configured U: the configured limit may be the motor driver's, which
    // clips them. The encoders tell: when the wheels never turn much faster than some ceiling
    // whatever the command beyond it, the robot starts with that saturation declared (the
    // calibration refits it and judges it on its validation steps like any declared effect).
    if reach.wheel_rad_s > configured_u && !declared {
        if let Some(ceiling) = WheelCeiling::of(logs) {
            if ceiling.clips(reach.wheel_rad_s) {
                let at = (ceiling.rad_s * 10.0).ceil() / 10.0;
                for m in &mut starts {
                    m.robot.effects.set(SATURATION, at)?;
                }
                notes.push(format!(
                    "{SATURATION} = {at} rad/s declared: the steady wheels never exceed {:.2} rad/s while {} of {} commanded wheel speeds are above {:.2} (up to {:.2})",
                    ceiling.rad_s,
                    ceiling.beyond,
                    ceiling.sides,
                    CLIPPED_ABOVE * ceiling.rad_s,
                    reach.wheel_rad_s
                ));
            }
        }
    }
    Ok((starts, notes))
}

/// The registry's wheel-speed saturation.
const SATURATION: &str = "wheel_speed_saturation_rad_s";
/// A commanded wheel speed counts as clipped above this multiple of the wheels' ceiling.
const CLIPPED_ABOVE: f64 = 1.2;
/// Share of the steady commanded wheel speeds that must be clipped for the ceiling to be a
/// saturation (a few fast commands that the wheels did not reach may be a slow response).
const MIN_CLIPPED_SHARE: f64 = 0.1;

/// The fastest steady wheel speed of some runs (the encoders, averaged over each analysed
/// step's steady windows), and how many steady commands lie beyond it.
struct WheelCeiling {
    rad_s: f64,
    beyond: usize,
    sides: usize,
}

impl WheelCeiling {
    fn of(logs: &[&DriveLog]) -> Option<Self> {
        let mut pairs: Vec<(f64, f64)> = Vec::new();
        for log in logs {
            let a = drive_sim_compare::analysis_of(log).ok()?;
            for s in &a.steps {
                let (c, r) = (s.steady.cmd_wheels, s.steady.realized_wheels);
                pairs.push((c.left_rad_s.abs(), r.left_rad_s.abs()));
                pairs.push((c.right_rad_s.abs(), r.right_rad_s.abs()));
            }
        }
        let rad_s = pairs
            .iter()
            .map(|p| p.1)
            .filter(|v| v.is_finite())
            .fold(0.0, f64::max);
        let beyond = pairs.iter().filter(|p| p.0 > CLIPPED_ABOVE * rad_s).count();
        (rad_s > 0.0).then_some(Self {
            rad_s,
            beyond,
            sides: pairs.len(),
        })
    }

    /// The wheels are clipped: commands reach well past the ceiling, on a share of the steps.
    fn clips(&self, commanded_rad_s: f64) -> bool {
        commanded_rad_s > CLIPPED_ABOVE * self.rad_s
            && self.beyond as f64 >= MIN_CLIPPED_SHARE * self.sides as f64
    }
}

/// The runs `which` (indices into `runs`) grouped by ground, in the order the grounds first
/// appear, each ground's runs pooled.
pub fn grounds(runs: &[RunLog], which: &[usize]) -> Vec<Ground> {
    let mut out: Vec<Ground> = Vec::new();
    for &i in which {
        let name = &runs[i].log.meta.terrain;
        match out.iter_mut().find(|g| &g.name == name) {
            Some(g) => g.runs.push(i),
            None => out.push(Ground {
                name: name.clone(),
                runs: vec![i],
                log: runs[i].log.clone(),
            }),
        }
    }
    for g in &mut out {
        if g.runs.len() > 1 {
            let logs: Vec<&DriveLog> = g.runs.iter().map(|&i| &runs[i].log).collect();
            g.log = pool(&logs);
        }
    }
    out
}

/// The steps of several runs of one robot on one ground as one log: each run's steps follow
/// the previous run's, offset by an even number (odd steps stay odd), with its interruptions
/// and duration. The metadata is the first run's, named after all of them.
pub fn pool(logs: &[&DriveLog]) -> DriveLog {
    let mut pooled = logs[0].clone();
    pooled.meta.name = logs
        .iter()
        .map(|l| l.meta.name.as_str())
        .collect::<Vec<_>>()
        .join("+");
    let mut next = 0u32;
    pooled.samples.clear();
    pooled.interruptions.clear();
    pooled.duration_s = 0.0;
    for log in logs {
        let offset = next;
        pooled.samples.extend(log.samples.iter().map(|s| {
            let mut s = *s;
            s.step += offset;
            s
        }));
        pooled.interruptions.extend(log.interruptions.iter().map(|i| {
            let mut i = i.clone();
            i.step += offset;
            i
        }));
        pooled.duration_s += log.duration_s;
        let last = log.steps().last().copied().unwrap_or(0);
        // The next run starts on the even step after this one's last.
        next = offset + last + 1 + (last + 1) % 2;
    }
    pooled
}

#[cfg(test)]
mod tests {
    use super::*;
    use drive_sim_model::measurement::{LogMeta, Measurement, Nominal, Origin, Sample};

    fn log_of(name: &str, steps: &[u32]) -> DriveLog {
        let meta = LogMeta {
            name: name.into(),
            robot: "warthog".into(),
            terrain: "asphalt".into(),
            rate_hz: 20.0,
            window_s: 2.0,
            windows_per_step: 3,
            samples_per_window: 40,
            nominal: Nominal {
                wheel_radius_m: 0.3,
                baseline_m: 1.1,
                max_wheel_rad_s: 16.0,
                max_lin_m_s: 5.0,
                max_ang_rad_s: 4.0,
                mass_kg: 470.0,
                width_m: 1.5,
                length_m: 1.6,
                height_m: None,
                max_lin_acc_m_s2: None,
                command_turn_scale: None,
            },
            origin: Origin::Measured {
                file: format!("{name}.csv"),
            },
        };
        let mut log = DriveLog {
            meta,
            samples: Vec::new(),
            interruptions: Vec::new(),
            duration_s: steps.len() as f64 * 6.0,
        };
        for &step in steps {
            log.samples.push(Sample {
                step,
                window: 0,
                k: 0,
                t_in_step_s: 0.0,
                stamp_s: 0.0,
                m: Measurement::default(),
            });
        }
        log
    }

    #[test]
    fn pooled_runs_keep_each_steps_parity_and_follow_each_other() {
        let a = log_of("a", &[0, 1, 2]);
        let b = log_of("b", &[0, 1, 3]);
        let p = pool(&[&a, &b]);
        assert_eq!(p.meta.name, "a+b");
        // a ends at step 2: b starts at 4 (even), so b's odd steps 1 and 3 become 5 and 7.
        assert_eq!(p.steps(), vec![0, 1, 2, 4, 5, 7]);
        assert_eq!(p.duration_s, 36.0);
    }
}
