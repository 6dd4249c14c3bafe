//! A twin of a robot from its DRIVE runs, in one call: `drive-sim twin LOG... --out DIR`.
//!
//! A roboticist brings runs of their robot and wants a simulated robot that behaves like it,
//! to try protocols, samplers and smoothers on. This crate goes the whole way, with no recipe
//! picked by hand:
//!
//! 1. **Held-out pass** ([`pass`]): on the odd steps of every run, calibrate by replay, declare
//!    the random effects the steps measure directly ([`measured`]), screen
//!    every knob of the model in closed loop ([`screen`]), choose what to tune by a stated rule
//!    ([`rule`]), tune it and check the choice on fresh seeds ([`mod@tune`]). Then `judge` the
//!    twin on the even steps, which played no part in any of it ([`judging`]).
//! 2. **Final pass**: the same on every step; the twin written is this one, judged on the
//!    same steps with fresh runs (not held out, and said so).
//! 3. **Leave one run out** (several runs): a twin made without each run, judged on it, with the
//!    other runs of its ground as the robot's own difference (`judge`'s yardstick).
//! 4. **What it cannot do**: every criterion a judgement flags, with the twin's difference,
//!    the knobs that move it the right way, the values on their bound, and when no knob does,
//!    that the model lacks an effect there.
//!
//! The twin's files are `DIR/twin/robot.toml` and `DIR/twin/terrain.toml` (one ground) or
//! `DIR/twin/terrain_<ground>.toml` (several), with every tuned value written in them:
//! `drive-sim run --robot DIR/twin/robot.toml --terrain DIR/twin/terrain.toml` runs it.
//! The held-out twin, as judged on the even steps, is in `DIR/held_out/` in the same form, so
//! that its verdict can be judged again with other seeds. `DIR/twin.json` holds every stage's
//! outcome and time; `DIR/twin.md` opens on the answer.
//!
//! ```no_run
//! use drive_sim_twin::{make_twin, TwinOptions, TwinRequest};
//!
//! let req = TwinRequest {
//!     logs: vec!["warthog_gravel.csv".into()],
//!     out: "out/twin".into(),
//!     input: Default::default(),
//!     options: TwinOptions::default(),
//!     knobs: None,
//! };
//! let twin = make_twin(&req, &|event| eprintln!("{event}"))?;
//! println!("{}", twin.report.answer);
//! # Ok::<(), drive_sim_twin::Error>(())
//! ```

#![warn(missing_docs, unreachable_pub)]

pub mod closed;
pub mod error;
pub mod event;
pub mod input;
pub mod judging;
pub mod knobs;
pub mod measured;
pub mod pass;
pub mod report;
pub mod rule;
pub mod screen;
pub mod tune;
mod write;

pub use error::{Error, Result};
pub use event::TwinEvent;
pub use report::TwinReport;

use drive_sim_compare::judge::JudgeOptions;
use drive_sim_log::{DriveLog, OpenOptions, UseSteps};
use drive_sim_model::output::StagedDir;
use input::{grounds, open_logs, Ground, RunLog};
use judging::{judge_left_out, judge_own_grounds, LeftOut};
use pass::{run_pass, Pass, PassRequest, StageTime};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;
use std::time::Instant;

/// Bootstrap resamples of each comparison in a judgement: enough for the medians' tests at
/// the 5 % level, half `judge`'s default (a twin is judged three times or more).
pub const JUDGE_RESAMPLES: usize = 1000;

/// Options of [`make_twin`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TwinOptions {
    /// First seed of every closed-loop run (the calibration's split, the screening and the
    /// search use `seed..`, the check `seed + 1000..`, the judgements `seed + 2000..`).
    pub seed: u64,
    /// Factor on the search's budget (1: the rule's; larger for a longer search).
    pub budget: f64,
    /// With several runs, make a twin without each and judge it on it.
    pub leave_one_out: bool,
    /// Runs of the twin in each judgement (`judge --sims`).
    pub judge_sims: u32,
    /// Reference runs in each judgement (`judge --references`: the smallest p-value is
    /// 1 / (references + 1)).
    pub judge_references: u32,
}

impl Default for TwinOptions {
    fn default() -> Self {
        Self {
            seed: 0,
            budget: 1.0,
            leave_one_out: true,
            judge_sims: JudgeOptions::default().sims,
            judge_references: JudgeOptions::default().references,
        }
    }
}

impl TwinOptions {
    /// Checks the numbers before any work (bad input names the option).
    pub fn validate(&self) -> Result<()> {
        if !(self.budget >= 0.25 && self.budget <= 20.0) {
            return Err(Error::config(
                "<command line>",
                "--budget",
                format!(
                    "must be in [0.25, 20] (a factor on the search's points), got {}",
                    self.budget
                ),
            ));
        }
        self.judge_options(UseSteps::All).validate()?;
        Ok(())
    }

    /// The options of a judgement of the steps `steps` (seeds `seed + 2000..`, so that the
    /// twin's runs judged are not those its choice was made on).
    pub fn judge_options(&self, steps: UseSteps) -> JudgeOptions {
        JudgeOptions {
            real_steps: steps,
            seed: self.seed + judging::JUDGE_SEED_OFFSET,
            sims: self.judge_sims,
            references: self.judge_references,
            resamples: JUDGE_RESAMPLES,
            ..JudgeOptions::default()
        }
    }
}

/// What to make a twin from, and where to write it.
#[derive(Debug, Clone, PartialEq)]
pub struct TwinRequest {
    /// The runs: measured `.csv`, `.mcap` or bags, all of one robot.
    pub logs: Vec<PathBuf>,
    /// Output directory (appears whole, or not at all).
    pub out: PathBuf,
    /// How to read the logs, and the robot and terrain to start from (names or files).
    pub input: OpenOptions,
    /// Options.
    pub options: TwinOptions,
    /// Only these knobs may be tuned (effect names or base parameter names; `None`: the whole
    /// pool, [`knobs::pool`]).
    pub knobs: Option<Vec<String>>,
}

/// What [`make_twin`] made.
#[derive(Debug)]
pub struct Twin {
    /// The report (`twin.json`).
    pub report: TwinReport,
    /// Every file written.
    pub files: Vec<PathBuf>,
}

/// Makes the twin (see the crate doc) and writes it into `req.out`. Bad input (logs of two
/// robots, a run too short to split, a run without steady windows, a `--terrain` for several
/// grounds) is refused before any long work; an interrupt leaves no half-written twin.
pub fn make_twin(req: &TwinRequest, progress: &(dyn Fn(&TwinEvent) + Sync)) -> Result<Twin> {
    req.options.validate()?;
    let t_all = Instant::now();
    let runs = open_logs(&req.logs, &req.input, progress)?;
    let all: Vec<usize> = (0..runs.len()).collect();
    let grounds = grounds(&runs, &all);
    if grounds.len() > 1 && req.input.terrain.is_some() {
        return Err(Error::config(
            "--terrain",
            req.input.terrain.clone().unwrap_or_default(),
            "the runs are on several grounds, each starts from its own terrain: `--terrain` names one for all",
        ));
    }
    let listed: Vec<(String, Vec<String>)> = grounds
        .iter()
        .map(|g| {
            (
                g.name.clone(),
                g.runs.iter().map(|&i| runs[i].log.meta.name.clone()).collect(),
            )
        })
        .collect();
    progress(&TwinEvent::Grounds { grounds: &listed });
    let logs: Vec<&DriveLog> = runs.iter().map(|r| &r.log).collect();
    let (_, widened) =
        input::starting_models(&logs, req.input.robot.as_deref(), req.input.terrain.as_deref())?;
    for note in &widened {
        progress(&TwinEvent::Note { note });
    }
    if let Some(only) = &req.knobs {
        check_knobs(only, &runs[0], &req.input)?;
    }
    let staged = StagedDir::begin(&req.out, "--out")?;
    let mut times = Vec::new();
    let pass_of = |grounds: &[Ground], steps: UseSteps, label: &str| {
        run_pass(
            &PassRequest {
                grounds,
                steps,
                robot: req.input.robot.as_deref(),
                terrain: req.input.terrain.as_deref(),
                opts: &req.options,
                knobs: req.knobs.as_deref(),
                label,
            },
            progress,
        )
    };
    let seed = req.options.seed;
    // 1. Chosen on the odd steps, judged on the even ones.
    let held = pass_of(&grounds, UseSteps::Odd, "held out")?;
    // 2. The twin written: chosen on every step. Its calibration by replay runs mostly on one
    // core: the held-out judgement's parallel runs take the other meanwhile.
    let t0 = Instant::now();
    let (held_judged, fin) = rayon::join(
        || {
            let j = judge_own_grounds(
                &grounds,
                &held.twin,
                &req.options.judge_options(UseSteps::Even),
                progress,
            );
            (j, stage_time("judge", t0, "held out", progress))
        },
        || pass_of(&grounds, UseSteps::All, "final"),
    );
    let (held_judged, held_time) = held_judged;
    let held_judged = held_judged?;
    let fin = fin?;
    times.push(held_time);
    let t0 = Instant::now();
    let fin_judged = judge_own_grounds(
        &grounds,
        &fin.twin,
        &req.options.judge_options(UseSteps::All),
        progress,
    )?;
    times.push(stage_time("judge", t0, "final", progress));
    let checks = write::check_runs(&fin.twin, &fin.calibrated, seed)?;
    // 3. Each run left out.
    let left_out = if req.options.leave_one_out && runs.len() > 1 {
        leave_one_out(
            &runs,
            &pass_of,
            &req.options.judge_options(UseSteps::All),
            progress,
        )?
    } else {
        Vec::new()
    };
    let report = report::assemble(report::Parts {
        runs: &runs,
        grounds: &grounds,
        held: (&held, held_judged),
        fin: (&fin, fin_judged),
        left_out,
        checks,
        times,
        options: req.options,
        seconds: t_all.elapsed().as_secs_f64(),
    });
    let written = write::write_twin(
        &write::Written {
            report: &report,
            held: &held,
            fin: &fin,
            logs: &req.logs,
        },
        staged.path(),
    )?;
    staged.commit()?;
    let files = written.into_iter().map(|name| req.out.join(name)).collect();
    Ok(Twin { report, files })
}

/// Refuses knob names the pool does not hold (bad input naming the first, with the pool).
fn check_knobs(only: &[String], first: &RunLog, input: &OpenOptions) -> Result<()> {
    let (starts, _) =
        input::starting_models(&[&first.log], input.robot.as_deref(), input.terrain.as_deref())?;
    let m = &starts[0];
    let start = drive_sim_calibration::twin::lift_effects(&m.robot, &m.terrain)?;
    let reach = drive_sim_model::effects::CommandReach::of_commands(
        first.log.samples.iter().map(|s| s.m.cmd),
        &start.robot.idd(),
    );
    let pool: Vec<String> = knobs::pool(&start, &reach).into_iter().map(|k| k.name).collect();
    if only.is_empty() {
        return Err(Error::config(
            "<command line>",
            "--knobs",
            "name at least one knob",
        ));
    }
    match only.iter().find(|n| !pool.contains(n)) {
        Some(bad) => Err(Error::config(
            "--knobs",
            bad.as_str(),
            format!("not a knob of the model; the knobs: {}", pool.join(", ")),
        )),
        None => Ok(()),
    }
}

/// A stage's time, told and recorded as `PASS: STAGE`.
fn stage_time(stage: &str, t0: Instant, pass: &str, progress: &(dyn Fn(&TwinEvent) + Sync)) -> StageTime {
    let seconds = t0.elapsed().as_secs_f64();
    progress(&TwinEvent::StageDone { pass, stage, seconds });
    StageTime {
        stage: format!("{pass}: {stage}"),
        seconds,
    }
}

/// A pass on some grounds' steps, labelled.
type PassOf<'a> = dyn Fn(&[Ground], UseSteps, &str) -> Result<Pass> + 'a;

/// For each run: a twin made from the others (every step), judged on it.
fn leave_one_out(
    runs: &[RunLog],
    pass_of: &PassOf<'_>,
    judge: &JudgeOptions,
    progress: &(dyn Fn(&TwinEvent) + Sync),
) -> Result<Vec<LeftOut>> {
    let mut out = Vec::new();
    for k in 0..runs.len() {
        let rest: Vec<usize> = (0..runs.len()).filter(|&i| i != k).collect();
        let rest_grounds = grounds(runs, &rest);
        let name = &runs[k].log.meta.name;
        let made_from: Vec<String> = rest.iter().map(|&i| runs[i].log.meta.name.clone()).collect();
        if !rest_grounds.iter().any(|g| g.name == runs[k].log.meta.terrain) {
            out.push(LeftOut {
                run: name.clone(),
                made_from,
                judgement: None,
                note: Some(format!(
                    "no other run is on `{}`: a twin made without `{name}` has no terrain for it",
                    runs[k].log.meta.terrain
                )),
            });
            continue;
        }
        let label = format!("without {name}");
        let pass = pass_of(&rest_grounds, UseSteps::All, &label)?;
        let judgement = judge_left_out(runs, k, (&rest_grounds, &pass.twin), judge, progress)?;
        out.push(LeftOut {
            run: name.clone(),
            made_from,
            judgement,
            note: None,
        });
    }
    Ok(out)
}
