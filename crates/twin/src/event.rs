//! What the twin command tells its caller as it goes: one line per event, as `calibrate`
//! prints its stages.

use crate::rule::Choice;
use crate::screen::KnobScreen;
use drive_sim_calibration::CalibrationEvent;
use drive_sim_compare::judge::JudgeOutcome;
use drive_sim_compare::tune::SeedCheck;
use drive_sim_log::UseSteps;
use std::fmt;
use std::path::Path;

/// A step of the twin command.
#[derive(Debug)]
pub enum TwinEvent<'a> {
    /// A log is being read.
    Reading {
        /// Its file.
        path: &'a Path,
    },
    /// A decision or warning of the reader.
    Note {
        /// In words.
        note: &'a str,
    },
    /// The runs, grouped by ground.
    Grounds {
        /// Each ground with its runs.
        grounds: &'a [(String, Vec<String>)],
    },
    /// A pass begins.
    PassStarted {
        /// Which ("held out", "final", "without RUN").
        pass: &'a str,
        /// Its steps.
        steps: UseSteps,
    },
    /// A stage of the calibration by replay ended.
    Calibration {
        /// What it found.
        event: &'a CalibrationEvent,
    },
    /// The second round starts, from the twin tuned for these knobs.
    Refining {
        /// The first round's knobs.
        tuned: &'a [String],
    },
    /// The screening starts.
    Screening {
        /// Knobs in the pool.
        knobs: usize,
        /// DRIVE runs it takes.
        runs: usize,
    },
    /// A knob's screening.
    KnobScreened {
        /// What moving it did.
        screen: &'a KnobScreen,
    },
    /// The rule's choice.
    Chosen {
        /// What it chose.
        choice: &'a Choice,
    },
    /// A point of the search.
    Point {
        /// Its number.
        index: usize,
        /// Its mean loss.
        loss: Option<f64>,
        /// The best so far.
        best: f64,
    },
    /// The check on fresh seeds.
    Checked {
        /// Its outcome.
        check: &'a SeedCheck,
    },
    /// A judgement begins.
    Judging {
        /// What is judged against what.
        what: &'a str,
    },
    /// A judgement's outcome.
    Judged {
        /// What was judged against what.
        what: &'a str,
        /// The outcome.
        outcome: &'a JudgeOutcome,
    },
    /// A stage of a pass ended.
    StageDone {
        /// The pass.
        pass: &'a str,
        /// The stage.
        stage: &'a str,
        /// Its wall time, s.
        seconds: f64,
    },
}

impl fmt::Display for TwinEvent<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Reading { path } => write!(f, "reading {}", path.display()),
            Self::Note { note } => write!(f, "{note}"),
            Self::Grounds { grounds } => {
                let list: Vec<String> = grounds
                    .iter()
                    .map(|(g, runs)| format!("{g} ({})", runs.join(", ")))
                    .collect();
                write!(f, "grounds: {}", list.join("; "))
            }
            Self::PassStarted { pass, steps } => write!(f, "{pass}: on the {} steps", steps.as_str()),
            Self::Calibration { event } => write!(f, "calibrate: {event}"),
            Self::Refining { tuned } => write!(
                f,
                "refine: the other knobs screened again from the twin tuned for {}",
                tuned.join(", ")
            ),
            Self::Screening { knobs, runs } => write!(
                f,
                "screen: {knobs} knobs of the model, each at {} points {} and {} of its box from its calibrated value ({runs} DRIVE runs)",
                crate::screen::POINTS_PER_KNOB,
                crate::screen::SCREEN_STEP,
                crate::screen::FINE_SCREEN_STEP
            ),
            Self::KnobScreened { screen } => {
                let best = screen
                    .best
                    .map(|b| {
                        let v: Vec<String> = screen.points[b]
                            .values
                            .iter()
                            .map(|v| format!("{v:.4}"))
                            .collect();
                        v.join(", ")
                    })
                    .unwrap_or_else(|| "no point ran".into());
                write!(
                    f,
                    "screen: {:<38} gain {:>8.2} at {best}",
                    screen.knob.name, screen.gain
                )
            }
            Self::Chosen { choice } => {
                if choice.chosen.is_empty() {
                    write!(
                        f,
                        "choose: no knob lowers the loss enough: the twin stays the model it was screened from"
                    )
                } else {
                    write!(
                        f,
                        "choose: tune {} ({} coordinates, at most {} points)",
                        choice.chosen.join(", "),
                        choice.coordinates,
                        choice.max_evaluations
                    )
                }
            }
            Self::Point { index, loss, best } => write!(
                f,
                "tune: point {index}: loss {} (best {best:.3})",
                loss.map_or_else(|| "failed".to_string(), |l| format!("{l:.3}"))
            ),
            Self::Checked { check } => write!(
                f,
                "check on {} fresh seeds: loss reduction {:.2} ± {:.2} (SE): {}",
                check.seeds.len(),
                check.mean_reduction,
                check.se,
                if check.accepted {
                    "accepted"
                } else {
                    "not accepted: the twin stays the model the search started from"
                }
            ),
            Self::Judging { what } => write!(f, "judge: {what}"),
            Self::Judged { what, outcome } => write!(
                f,
                "judge: {what}: {} (p {:.3}; mean loss {:.2} against the robot){}",
                if outcome.indistinguishable {
                    "compare cannot tell the twin from the robot"
                } else {
                    "compare tells the twin from the robot"
                },
                outcome.loss.p,
                outcome.loss.real,
                if outcome.flagged.is_empty() {
                    String::new()
                } else {
                    format!("; flagged: {}", outcome.flagged.join(", "))
                }
            ),
            Self::StageDone { pass, stage, seconds } => write!(f, "{pass}: {stage} took {seconds:.1} s"),
        }
    }
}
