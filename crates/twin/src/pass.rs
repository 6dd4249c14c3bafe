//! One pass of the twin: from the runs' steps (one half of them, or all) to a tuned and
//! checked twin.
//!
//! 1. **Calibrate** by replay on those steps (`calibrate`'s loop on the simulator model,
//!    discovery off: its generic terms are not physical knobs and cost minutes): one ground
//!    alone, several jointly (one robot, a terrain per ground).
//! 2. **Screen** every knob of the pool in closed loop ([`crate::screen`]).
//! 3. **Choose** what to tune by the rule ([`crate::rule`]).
//! 4. **Tune** the chosen knobs and **check** the choice on fresh seeds ([`crate::tune`]).
//! 5. **Refine**: when the check accepted the tuning, screen the knobs not tuned again from the
//!    tuned twin, and tune and check the few the second round's rule
//!    ([`Rule::refinement`]) picks. Why a second round: a knob's worth depends on the others.
//!    On the Warthog's asphalt run, the lateral friction's multiplier raises the calibrated
//!    model's loss at every screening point, yet from the twin tuned for its speed loop 0.85
//!    lowers it, and brings the yaw rate of pivots and turns in place, 25 % short of the
//!    robot's, part of the way back.
//!
//! Every stage sees only the pass's steps.

use crate::closed::{Closed, ClosedGround, PointScore};
use crate::error::Result;
use crate::event::TwinEvent;
use crate::input::{starting_models, Ground};
use crate::knobs::{pool, Knob};
use crate::measured::{self, MeasuredValue};
use crate::rule::{Choice, Rule};
use crate::screen::{screen, ScreenInput, Screening};
use crate::tune::{tune, TuneInput, Tuning};
use crate::TwinOptions;
use drive_sim_calibration::joint::{calibrate_joint, JointInput, JointLog};
use drive_sim_calibration::{
    calibrate_timed, twin, CalibrationOptions, FittedParam, ModelParams, SimFactory,
};
use drive_sim_compare::real_steps::real_steps;
use drive_sim_compare::tune::search_compare_options;
use drive_sim_compare::{Input, PreparedReal, TfSmoother};
use drive_sim_log::{DriveLog, UseSteps};
use drive_sim_model::effects::CommandReach;
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// Training steps each fit evaluation of the calibration by replay replays, at most.
pub const MAX_FIT_STEPS: usize = 30;
/// Bootstrap resamples of the loss's intervals in the closed loop (`tune`'s default).
const LOSS_RESAMPLES: usize = 500;
/// Offset of the check's seeds from the pass's first seed (`tune`'s).
pub const CHECK_SEED_OFFSET: u64 = drive_sim_compare::tune::CHECK_SEED_OFFSET;
/// Fresh seeds of each check (and of the twin's score). The check accepts a tuning when its
/// mean loss reduction, paired by seed, exceeds twice its standard error: with 3 seeds that
/// error has 2 degrees of freedom, "twice" is a one-sided level of about 9 %, and a run's loss
/// moves so much from seed to seed (the Husky's held-out twin: 6.6 to 13.6 on three seeds)
/// that a second round cutting it from 10.1 to 7.3 was refused (2.74 ± 1.66). With 6 seeds it
/// has 5 (a level of about 5 %), for 6 more twin runs per check.
pub const CHECK_SEEDS: u64 = 6;

/// One ground's calibration by replay.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GroundCalibration {
    /// The ground.
    pub ground: String,
    /// Its runs (pooled when several).
    pub dataset: String,
    /// Steps calibrated on.
    pub steps: usize,
    /// Test score of the declared model (1 = noise floor; the calibration's own test steps).
    pub test_score_declared: f64,
    /// Test score of the calibrated model.
    pub test_score_calibrated: f64,
    /// Every fitted value in the calibrated model, with its standard error and interval
    /// (clustered sandwich over the training steps).
    pub fitted: Vec<FittedParam>,
    /// The calibration's notes.
    pub notes: Vec<String>,
}

/// A stage's wall time.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StageTime {
    /// The stage.
    pub stage: String,
    /// Wall time, s.
    pub seconds: f64,
}

/// What a pass did (`twin.json` → `held_out.pass`, `final.pass`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PassReport {
    /// The steps it used: `odd`, `even` or `all`.
    pub steps: String,
    /// What the start model changed from the robot file or the logs' metadata, one line each
    /// (a command space widened to the run's commands, a saturation the encoders show).
    #[serde(default)]
    pub start: Vec<String>,
    /// Each ground's calibration by replay.
    pub calibration: Vec<GroundCalibration>,
    /// The random effects the steps measure, declared on the calibrated model before the
    /// closed loop ([`crate::measured`]).
    #[serde(default)]
    pub measured: Vec<MeasuredValue>,
    /// The closed-loop screening of the pool.
    pub screening: Screening,
    /// What the rule chose.
    pub choice: Choice,
    /// The tuning (`None` when the rule chose nothing).
    pub tuning: Option<Tuning>,
    /// The second round from the tuned twin (`None` when the first tuning was not accepted:
    /// the twin is the calibrated model, which the first screening measured).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refinement: Option<Refinement>,
    /// The twin on the check's seeds: its loss and each term (the differences left).
    pub twin_score: PointScore,
    /// Each stage's wall time.
    pub times: Vec<StageTime>,
}

/// The second round of a pass: the knobs not tuned, screened again from the tuned twin, the
/// second rule's choice and its tuning.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Refinement {
    /// The screening from the tuned twin.
    pub screening: Screening,
    /// What [`Rule::refinement`] chose.
    pub choice: Choice,
    /// The tuning (`None` when the rule chose nothing).
    pub tuning: Option<Tuning>,
}

/// A pass's outcome: the report and the models.
pub(crate) struct Pass {
    pub(crate) report: PassReport,
    /// The calibrated model of each ground.
    pub(crate) calibrated: Vec<ModelParams>,
    /// The twin of each ground.
    pub(crate) twin: Vec<ModelParams>,
    /// The model each ground's calibration started from.
    pub(crate) declared: Vec<ModelParams>,
    /// The knob pool (for what a knob moves, in the report).
    pub(crate) knobs: Vec<Knob>,
}

/// What a pass works on.
pub(crate) struct PassRequest<'a> {
    pub(crate) grounds: &'a [Ground],
    pub(crate) steps: UseSteps,
    /// `--robot`, `--terrain` (the latter with one ground only).
    pub(crate) robot: Option<&'a str>,
    pub(crate) terrain: Option<&'a str>,
    pub(crate) opts: &'a TwinOptions,
    /// Only these knobs (`None`: the whole pool).
    pub(crate) knobs: Option<&'a [String]>,
    /// What the pass is, in the progress lines ("held out", "final", "without RUN").
    pub(crate) label: &'a str,
}

/// Runs a pass (see the module doc).
pub(crate) fn run_pass(req: &PassRequest, progress: &(dyn Fn(&TwinEvent) + Sync)) -> Result<Pass> {
    let mut times = Vec::new();
    let mut timed = |stage: &str, t0: Instant| {
        let seconds = t0.elapsed().as_secs_f64();
        progress(&TwinEvent::StageDone {
            pass: req.label,
            stage,
            seconds,
        });
        times.push(StageTime {
            stage: stage.to_string(),
            seconds,
        });
    };
    let names: Vec<String> = req.grounds.iter().map(|g| g.name.clone()).collect();
    let chosen: Vec<(DriveLog, usize)> = req
        .grounds
        .iter()
        .map(|g| {
            real_steps(&g.log, req.steps, "LOG", "make a twin from")
                .map(|r| (r.log, r.analysed))
                .map_err(Into::into)
        })
        .collect::<Result<_>>()?;
    progress(&TwinEvent::PassStarted {
        pass: req.label,
        steps: req.steps,
    });
    let t0 = Instant::now();
    let (start, calibration, mut calibrated, declared) = calibrate(req, &chosen, progress)?;
    timed("calibrate", t0);
    let prepared: Vec<PreparedReal> = chosen
        .iter()
        .map(|(log, _)| {
            PreparedReal::new(
                Input { log, file: None },
                &search_compare_options(LOSS_RESAMPLES, TfSmoother::Kernel),
            )
        })
        .collect::<drive_sim_compare::Result<_>>()?;
    let steps: Vec<u32> = chosen.iter().map(|(_, n)| *n as u32).collect();
    let measured = measured::declare_measured(&mut calibrated, &prepared, &steps, req.opts.seed)?;
    let closed = Closed {
        grounds: prepared
            .into_iter()
            .zip(&chosen)
            .map(|(real, (_, n))| ClosedGround {
                real,
                steps: *n as u32,
            })
            .collect(),
    };
    let reach = CommandReach::of_commands(
        chosen.iter().flat_map(|(l, _)| l.samples.iter().map(|s| s.m.cmd)),
        &calibrated[0].robot.idd(),
    );
    let knobs: Vec<Knob> = pool(&calibrated[0], &reach)
        .into_iter()
        .filter(|k| req.knobs.is_none_or(|only| only.contains(&k.name)))
        .collect();
    let seed = req.opts.seed;
    let check_seeds: Vec<u64> = (0..CHECK_SEEDS).map(|i| seed + CHECK_SEED_OFFSET + i).collect();
    let round = Round {
        closed: &closed,
        knobs: &knobs,
        names: &names,
        seed,
        check_seeds: &check_seeds,
    };
    let t0 = Instant::now();
    let screening = round.screen(&calibrated, &knobs, progress);
    timed("screen", t0);
    let choice = Rule::default().choose(&screening, req.grounds.len(), req.opts.budget);
    progress(&TwinEvent::Chosen { choice: &choice });
    let t0 = Instant::now();
    let (tuning, twin) = round.tune(&calibrated, &screening, &choice, progress);
    // The twin's score on the check's seeds belongs to the last stage that changed it.
    let score = |twin: &Vec<ModelParams>| {
        closed
            .score(std::slice::from_ref(twin), &check_seeds, &names)
            .remove(0)
    };
    let (refinement, twin, twin_score) = if tuning.as_ref().is_some_and(|t| t.accepted) {
        timed("tune", t0);
        let t0 = Instant::now();
        let (r, twin) = round.refine(&twin, &choice.chosen, req, progress);
        let twin_score = score(&twin);
        timed("refine", t0);
        (Some(r), twin, twin_score)
    } else {
        let twin_score = score(&twin);
        timed("tune", t0);
        (None, twin, twin_score)
    };
    Ok(Pass {
        report: PassReport {
            steps: req.steps.as_str().to_string(),
            start,
            calibration,
            measured,
            screening,
            choice,
            tuning,
            refinement,
            twin_score,
            times,
        },
        calibrated,
        twin,
        declared,
        knobs,
    })
}

/// What a round of screening and tuning works with.
struct Round<'a> {
    closed: &'a Closed<'a>,
    /// The pool.
    knobs: &'a [Knob],
    names: &'a [String],
    /// The pass's first seed.
    seed: u64,
    check_seeds: &'a [u64],
}

impl Round<'_> {
    /// Screens `knobs` from `starts` on the pass's two screening seeds.
    fn screen(
        &self,
        starts: &[ModelParams],
        knobs: &[Knob],
        progress: &(dyn Fn(&TwinEvent) + Sync),
    ) -> Screening {
        screen(
            &ScreenInput {
                closed: self.closed,
                starts,
                knobs,
                seeds: &[self.seed, self.seed + 1],
                names: self.names,
            },
            progress,
        )
    }

    /// Tunes `choice`'s knobs from `starts` (nothing when it chose none); the tuning and the
    /// twin (`starts` unless the check accepted the tuning).
    fn tune(
        &self,
        starts: &[ModelParams],
        screening: &Screening,
        choice: &Choice,
        progress: &(dyn Fn(&TwinEvent) + Sync),
    ) -> (Option<Tuning>, Vec<ModelParams>) {
        if choice.chosen.is_empty() {
            return (None, starts.to_vec());
        }
        let seed = self.seed;
        let (t, m) = tune(
            &TuneInput {
                closed: self.closed,
                starts,
                knobs: choice
                    .chosen
                    .iter()
                    .filter_map(|n| self.knobs.iter().find(|k| &k.name == n))
                    .collect(),
                screening,
                names: self.names,
                seeds: &[seed, seed + 1, seed + 2],
                check_seeds: self.check_seeds,
                max_evaluations: choice.max_evaluations,
            },
            progress,
        );
        (Some(t), m)
    }

    /// The second round from the tuned `twin`: the knobs not `tuned` screened again, the
    /// refinement's rule, its tuning and check; the round and the twin it leaves.
    fn refine(
        &self,
        twin: &[ModelParams],
        tuned: &[String],
        req: &PassRequest,
        progress: &(dyn Fn(&TwinEvent) + Sync),
    ) -> (Refinement, Vec<ModelParams>) {
        progress(&TwinEvent::Refining { tuned });
        let rest: Vec<Knob> = self
            .knobs
            .iter()
            .filter(|k| !tuned.contains(&k.name))
            .cloned()
            .collect();
        let screening = self.screen(twin, &rest, progress);
        let choice = Rule::refinement().choose(&screening, req.grounds.len(), req.opts.budget);
        progress(&TwinEvent::Chosen { choice: &choice });
        let (tuning, twin) = self.tune(twin, &screening, &choice, progress);
        (
            Refinement {
                screening,
                choice,
                tuning,
            },
            twin,
        )
    }
}

/// What [`calibrate`] gives: the start model's changes, each ground's calibration, its
/// calibrated model and the model it started from.
type Calibrated = (
    Vec<String>,
    Vec<GroundCalibration>,
    Vec<ModelParams>,
    Vec<ModelParams>,
);

/// Each ground's calibration by replay (jointly when several), its calibrated model and the
/// model it started from.
fn calibrate(
    req: &PassRequest,
    chosen: &[(DriveLog, usize)],
    progress: &(dyn Fn(&TwinEvent) + Sync),
) -> Result<Calibrated> {
    let opts = CalibrationOptions {
        seed: req.opts.seed,
        discover: false,
        // Each fit evaluation replays at most this many training steps (a seeded subset; the
        // floor and the command reach still use them all): the closed loop, not the replay,
        // has the last word on the twin, and a run of 100 steps then calibrates in the time
        // of one of 60.
        max_fit_steps: Some(MAX_FIT_STEPS),
        ..CalibrationOptions::default()
    };
    let on_event =
        |e: &drive_sim_calibration::CalibrationEvent| progress(&TwinEvent::Calibration { event: e });
    let factory = SimFactory::default();
    let logs: Vec<&DriveLog> = chosen.iter().map(|(log, _)| log).collect();
    let (starts, widened) = starting_models(&logs, req.robot, req.terrain)?;
    let declared = starts
        .iter()
        .map(|m| twin::lift_effects(&m.robot, &m.terrain))
        .collect::<drive_sim_calibration::Result<Vec<_>>>()?;
    if let [(log, n)] = chosen {
        let m = &starts[0];
        let (report, _) = calibrate_timed(log, &m.robot, &m.terrain, &factory, &opts, &on_event)?;
        let cal = GroundCalibration {
            ground: req.grounds[0].name.clone(),
            dataset: log.meta.name.clone(),
            steps: *n,
            test_score_declared: report.before.score,
            test_score_calibrated: report.after.score,
            fitted: twin::fitted_params(&report),
            notes: report.status.notes.clone(),
        };
        return Ok((widened, vec![cal], vec![report.model_after], declared));
    }
    let input = JointInput {
        logs: chosen
            .iter()
            .zip(&starts)
            .map(|((log, _), m)| JointLog {
                log,
                terrain: m.terrain.clone(),
            })
            .collect(),
        robot: &starts[0].robot,
        factory: &factory,
        opts: &opts,
    };
    let report = calibrate_joint(&input, &on_event)?;
    let cals = report
        .logs
        .iter()
        .zip(req.grounds)
        .zip(chosen)
        .map(|((l, g), (_, n))| GroundCalibration {
            ground: g.name.clone(),
            dataset: l.dataset.clone(),
            steps: *n,
            test_score_declared: report
                .singles
                .iter()
                .find(|s| s.dataset == l.dataset)
                .map_or(f64::NAN, |s| s.before.score),
            test_score_calibrated: l.joint.score,
            fitted: report
                .robot_params
                .iter()
                .chain(&l.terrain_params)
                .cloned()
                .collect(),
            notes: report.notes.clone(),
        })
        .collect();
    let models = report.logs.iter().map(|l| l.model.clone()).collect();
    Ok((widened, cals, models, declared))
}
