//! What a calibration tells its caller as it goes: one typed event per kind of message, with
//! the values as fields, displayed as the line the command line prints.

use std::fmt;
use std::path::PathBuf;

/// How a forward round of the selection ended ([`CalibrationEvent::Round`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RoundOutcome {
    /// The round's best candidate passed the selection rule and was added.
    Added,
    /// The best candidate's parameters are not identifiable: the selection stops.
    NotIdentifiable,
    /// The best candidate's reduction is within its bootstrap error: the selection stops.
    NotSignificant,
}

/// What [`crate::calibrate_timed`], [`crate::joint::calibrate_joint`] and
/// [`crate::calibrate_logs`] tell their caller as they go. `Display` gives the line the command
/// line prints for it (without the `drive-sim:` prefix and the clock).
#[derive(Debug, Clone, PartialEq)]
pub enum CalibrationEvent {
    /// Reading this log.
    Reading {
        /// Its file.
        path: PathBuf,
    },
    /// A decision made while reading a log or resolving its models.
    Note {
        /// The note.
        note: String,
    },
    /// Data reading a log left out.
    Warning {
        /// The warning.
        warning: String,
    },
    /// What resolving the terrain of one log of a joint calibration noted.
    LogNote {
        /// The log's dataset name.
        dataset: String,
        /// The note.
        note: String,
    },
    /// The calibration of one log starts (every input is read and resolved).
    Calibrating {
        /// The model as named on the command line.
        model: String,
        /// The robot's name.
        robot: String,
        /// The terrain's name.
        terrain: String,
        /// Steps of the log.
        steps: usize,
        /// Fraction of the steps fitted on.
        train_fraction: f64,
        /// Fraction of the steps chosen on.
        validation_fraction: f64,
        /// The local solver as named on the command line.
        optimizer: String,
    },
    /// A joint calibration of several logs starts.
    CalibratingJointly {
        /// The model as named on the command line.
        model: String,
        /// The robot's name.
        robot: String,
        /// Logs.
        logs: usize,
    },
    /// A step the analysis excludes is left out of every set.
    StepExcluded {
        /// The step.
        step: u32,
        /// Why.
        reason: String,
    },
    /// The steps are split into training, validation and test sets.
    Split {
        /// Usable steps.
        steps: usize,
        /// Training steps.
        train: usize,
        /// Validation steps.
        validation: usize,
        /// Test steps.
        test: usize,
        /// Seed of the split.
        seed: u64,
    },
    /// The declared model's validation score.
    Baseline {
        /// Its validation score (1 = noise floor).
        validation_score: f64,
        /// Validation steps.
        steps: usize,
    },
    /// The base parameters were fitted on the training steps.
    BaseFit {
        /// Parameters fitted.
        params: usize,
        /// Model evaluations.
        evaluations: u64,
        /// How the fit stopped.
        status: String,
        /// Training score before the fit.
        training_before: f64,
        /// Training score after it.
        training_after: f64,
        /// Validation score of the declared model.
        validation_before: f64,
        /// Validation score of the fitted model.
        validation_after: f64,
        /// The fit lowered the validation score and is kept.
        kept: bool,
    },
    /// The kinematic model screened the candidates for the simulator.
    Screening {
        /// Candidates screened.
        candidates: usize,
        /// Pairs screened.
        pairs: usize,
        /// The kinematic model's validation score.
        validation_score: f64,
        /// Candidates passed on to the simulator.
        shortlist: Vec<String>,
        /// Pairs passed on to the simulator.
        pair_shortlist: Vec<String>,
    },
    /// Pairs tried in the first forward round, against its best single candidate.
    FirstRoundPairs {
        /// Pairs tried.
        tried: usize,
        /// The best pair.
        best: String,
        /// Validation score before it.
        validation_before: f64,
        /// Validation score with it.
        validation_after: f64,
        /// How far the pair's validation score is below the best single's.
        gain: f64,
        /// Bootstrap standard error of `gain`.
        se: f64,
        /// The pair beats the single by the selection rule and replaces it.
        preferred: bool,
    },
    /// One forward round of the selection.
    Round {
        /// Round index, from 0.
        round: usize,
        /// Candidates evaluated.
        candidates: usize,
        /// The best one.
        best: String,
        /// Validation score before it.
        validation_before: f64,
        /// Validation score with it.
        validation_after: f64,
        /// Bootstrap standard error of the reduction.
        se: f64,
        /// Whether it was added.
        outcome: RoundOutcome,
    },
    /// Pairs tried after the forward pass.
    Pairs {
        /// Pairs tried.
        tried: usize,
        /// The best pair.
        best: String,
        /// Validation score before it.
        validation_before: f64,
        /// Validation score with it.
        validation_after: f64,
        /// Bootstrap standard error of the reduction.
        se: f64,
        /// It passed the selection rule and was added.
        added: bool,
    },
    /// One selected effect tried out of the model in the backward pass.
    Backward {
        /// The effect.
        effect: String,
        /// Validation score with it.
        with: f64,
        /// Validation score without it.
        without: f64,
        /// Bootstrap standard error of the difference.
        se: f64,
        /// It was dropped.
        dropped: bool,
    },
    /// A discovery round tries candidates at one stage of the model.
    DiscoveryRound {
        /// Round, from 1.
        round: usize,
        /// Channels flagged above their noise floor.
        flagged: Vec<String>,
        /// The stage the candidates act at.
        stage: String,
        /// Candidates tried.
        trying: Vec<String>,
    },
    /// Discovery added a candidate to the model.
    DiscoveryAdded {
        /// The candidate.
        effect: String,
    },
    /// The two orders of the competition between the catalogue and discovery were compared.
    Competition {
        /// The order kept (`catalogue first`, `discovery first`).
        kept: String,
        /// Why, in words.
        why: String,
    },
    /// The base and effect parameters were refitted together.
    FinalFit {
        /// Parameters fitted.
        params: usize,
        /// Model evaluations.
        evaluations: u64,
        /// How the fit stopped.
        status: String,
        /// Validation score before the fit.
        validation_before: f64,
        /// Validation score after it.
        validation_after: f64,
        /// The fit is kept.
        kept: bool,
    },
    /// The verdict on an effect the starting model declared.
    Declared {
        /// The effect.
        effect: String,
        /// The verdict, in words.
        verdict: String,
    },
    /// One log of a joint calibration is calibrated on its own.
    JointLogStarted {
        /// Its position, from 1.
        index: usize,
        /// Logs in the joint calibration.
        logs: usize,
        /// Its dataset name.
        dataset: String,
    },
    /// One log of a joint calibration was calibrated on its own.
    JointLogCalibrated {
        /// Its dataset name.
        dataset: String,
        /// Its calibrated test score.
        test_score: f64,
        /// Its declared model's test score.
        declared_score: f64,
        /// The effect parameters it selected, with their values.
        effects: Vec<(String, f64)>,
    },
    /// The joint fit starts.
    JointFitStarted {
        /// Parameters shared by every log (the robot's).
        robot_params: Vec<String>,
        /// Parameters fitted once per log (the ground's).
        terrain_params: Vec<String>,
        /// Logs.
        logs: usize,
    },
    /// The joint fit ended.
    JointFitDone {
        /// Training score at its start.
        initial_score: f64,
        /// Training score at its end.
        score: f64,
        /// How it stopped.
        status: String,
        /// Model evaluations.
        evaluations: u64,
    },
}

/// `", "`-joined names, or `none`.
fn list_or_none(names: &[String]) -> String {
    if names.is_empty() {
        "none".to_string()
    } else {
        names.join(", ")
    }
}

impl fmt::Display for CalibrationEvent {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Reading { .. }
            | Self::Note { .. }
            | Self::Warning { .. }
            | Self::LogNote { .. }
            | Self::Calibrating { .. }
            | Self::CalibratingJointly { .. } => self.fmt_setup(f),
            Self::StepExcluded { .. }
            | Self::Split { .. }
            | Self::Baseline { .. }
            | Self::BaseFit { .. }
            | Self::Screening { .. } => self.fmt_start(f),
            Self::FirstRoundPairs { .. }
            | Self::Round { .. }
            | Self::Pairs { .. }
            | Self::Backward { .. }
            | Self::DiscoveryRound { .. }
            | Self::DiscoveryAdded { .. }
            | Self::Competition { .. } => self.fmt_selection(f),
            Self::FinalFit { .. } | Self::Declared { .. } => self.fmt_end(f),
            Self::JointLogStarted { .. }
            | Self::JointLogCalibrated { .. }
            | Self::JointFitStarted { .. }
            | Self::JointFitDone { .. } => self.fmt_joint(f),
        }
    }
}

impl CalibrationEvent {
    /// Reading the logs and resolving their models.
    fn fmt_setup(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Reading { path } => write!(f, "reading {}", path.display()),
            Self::Note { note } => write!(f, "{note}"),
            Self::Warning { warning } => write!(f, "warning: {warning}"),
            Self::LogNote { dataset, note } => write!(f, "{dataset}: {note}"),
            Self::Calibrating {
                model,
                robot,
                terrain,
                steps,
                train_fraction,
                validation_fraction,
                optimizer,
            } => write!(
                f,
                "calibrating the {model} model of {robot} on {terrain} ({steps} steps: fit on {:.0} %, choose on {:.0} %, report on the rest), {optimizer}",
                100.0 * train_fraction,
                100.0 * validation_fraction,
            ),
            Self::CalibratingJointly { model, robot, logs } => {
                write!(f, "calibrating the {model} model of {robot} jointly on {logs} logs")
            }
            _ => unreachable!("not a set-up event"),
        }
    }

    /// The split, the baseline and the screening.
    fn fmt_start(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::StepExcluded { step, reason } => write!(f, "step {step} excluded: {reason}"),
            Self::Split {
                steps,
                train,
                validation,
                test,
                seed,
            } => write!(
                f,
                "split of {steps} steps: {train} train, {validation} validation, {test} test (seed {seed})"
            ),
            Self::Baseline {
                validation_score,
                steps,
            } => write!(
                f,
                "baseline: validation score of the declared model {validation_score:.2} on {steps} steps (1 = noise floor)"
            ),
            Self::BaseFit {
                params,
                evaluations,
                status,
                training_before,
                training_after,
                validation_before,
                validation_after,
                kept,
            } => write!(
                f,
                "base fit ({params} parameters, {evaluations} evaluations, {status}): training {training_before:.2} -> {training_after:.2}, validation {validation_before:.2} -> {validation_after:.2}, {}",
                if *kept { "kept" } else { "not kept" }
            ),
            Self::Screening {
                candidates,
                pairs,
                validation_score,
                shortlist,
                pair_shortlist,
            } => write!(
                f,
                "screening with the kinematic model ({candidates} candidates, {pairs} pairs, its validation score {validation_score:.2}): passing on {}; pairs {}",
                shortlist.join(", "),
                list_or_none(pair_shortlist)
            ),
            _ => unreachable!("not an event of the start"),
        }
    }

    /// The forward rounds, the pairs, the backward pass and discovery.
    fn fmt_selection(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::FirstRoundPairs {
                tried,
                best,
                validation_before,
                validation_after,
                gain,
                se,
                preferred,
            } => write!(
                f,
                "round 0 pairs: {tried} tried, best {best} (validation {validation_before:.2} -> {validation_after:.2}; {gain:.2} ± {se:.2} below the best single){}",
                if *preferred { ", preferred" } else { "" }
            ),
            Self::Round {
                round,
                candidates,
                best,
                validation_before,
                validation_after,
                se,
                outcome,
            } => write!(
                f,
                "round {round}: {candidates} candidates, best {best} (validation {validation_before:.2} -> {validation_after:.2}, ± {se:.2}){}",
                match outcome {
                    RoundOutcome::Added => ", added",
                    RoundOutcome::NotIdentifiable => ", not identifiable: stop",
                    RoundOutcome::NotSignificant => ", not significant: stop",
                }
            ),
            Self::Pairs {
                tried,
                best,
                validation_before,
                validation_after,
                se,
                added,
            } => write!(
                f,
                "pairs: {tried} tried, best {best} (validation {validation_before:.2} -> {validation_after:.2}, ± {se:.2}){}",
                if *added { ", added" } else { ", not significant" }
            ),
            Self::Backward {
                effect,
                with,
                without,
                se,
                dropped,
            } => write!(
                f,
                "backward: without {effect} validation {with:.2} -> {without:.2} (± {se:.2}){}",
                if *dropped { ", dropped" } else { ", kept" }
            ),
            Self::DiscoveryRound {
                round,
                flagged,
                stage,
                trying,
            } => write!(
                f,
                "discovery round {round}: {} flagged ({}); at the {stage}, trying {}",
                flagged.len(),
                flagged.join(", "),
                trying.join(", ")
            ),
            Self::DiscoveryAdded { effect } => write!(f, "discovery: added {effect}"),
            Self::Competition { kept, why } => write!(f, "competition: {kept} kept: {why}"),
            _ => unreachable!("not an event of the selection"),
        }
    }

    /// The final fit and the verdicts on the declared effects.
    fn fmt_end(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::FinalFit {
                params,
                evaluations,
                status,
                validation_before,
                validation_after,
                kept,
            } => write!(
                f,
                "final fit ({params} parameters, {evaluations} evaluations, {status}): validation {validation_before:.2} -> {validation_after:.2}{}",
                if *kept { "" } else { ", not kept" }
            ),
            Self::Declared { effect, verdict } => write!(f, "declared {effect}: {verdict}"),
            _ => unreachable!("not an event of the end"),
        }
    }

    /// A joint calibration's own stages.
    fn fmt_joint(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::JointLogStarted {
                index,
                logs,
                dataset,
            } => write!(f, "log {index}/{logs} `{dataset}`: its own calibration"),
            Self::JointLogCalibrated {
                dataset,
                test_score,
                declared_score,
                effects,
            } => write!(
                f,
                "log `{dataset}`: test score {test_score:.3} (declared {declared_score:.3}); effects: {}",
                list_or_none(
                    &effects
                        .iter()
                        .map(|(name, value)| format!("{name}={value:.4}"))
                        .collect::<Vec<_>>()
                )
            ),
            Self::JointFitStarted {
                robot_params,
                terrain_params,
                logs,
            } => write!(
                f,
                "joint fit: {} robot parameters ({}), {} per log ({}), {logs} logs",
                robot_params.len(),
                robot_params.join(", "),
                terrain_params.len(),
                terrain_params.join(", ")
            ),
            Self::JointFitDone {
                initial_score,
                score,
                status,
                evaluations,
            } => write!(
                f,
                "joint fit: training score {initial_score:.3} → {score:.3} ({status}, {evaluations} evaluations)"
            ),
            _ => unreachable!("not an event of a joint calibration"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn events_read_as_the_lines_the_command_line_prints() {
        let round = CalibrationEvent::Round {
            round: 1,
            candidates: 6,
            best: "dead_time_s".into(),
            validation_before: 7.104,
            validation_after: 6.1,
            se: 0.321,
            outcome: RoundOutcome::Added,
        };
        assert_eq!(
            round.to_string(),
            "round 1: 6 candidates, best dead_time_s (validation 7.10 -> 6.10, ± 0.32), added"
        );
        let calibrating = CalibrationEvent::Calibrating {
            model: "kinematic".into(),
            robot: "warthog".into(),
            terrain: "gravel".into(),
            steps: 100,
            train_fraction: 0.6,
            validation_fraction: 0.2,
            optimizer: "levenberg-marquardt".into(),
        };
        assert_eq!(
            calibrating.to_string(),
            "calibrating the kinematic model of warthog on gravel (100 steps: fit on 60 %, choose on 20 %, report on the rest), levenberg-marquardt"
        );
        let screening = CalibrationEvent::Screening {
            candidates: 20,
            pairs: 0,
            validation_score: 3.456,
            shortlist: vec!["a".into(), "b".into()],
            pair_shortlist: Vec::new(),
        };
        assert!(screening.to_string().ends_with("passing on a, b; pairs none"));
        let joint = CalibrationEvent::JointLogCalibrated {
            dataset: "x".into(),
            test_score: 1.0,
            declared_score: 2.0,
            effects: Vec::new(),
        };
        assert_eq!(
            joint.to_string(),
            "log `x`: test score 1.000 (declared 2.000); effects: none"
        );
    }
}
