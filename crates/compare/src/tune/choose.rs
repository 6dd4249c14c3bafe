//! Steps 1 and 2 of a tuning (module doc of [`super`]): the search over the parameters' box on
//! the choosing seeds, and the check of its choice on fresh seeds, every run scored by the loss
//! against the choosing steps.

use super::outcome::check_rule;
use super::runs::{evaluation, seed_run, SeedRun};
use super::search::{self, SearchOptions, SearchSummary};
use super::{apply_boxes, tuned_specs, PointEvaluation, SeedCheck, TuneEvent, TuneRequest};
use crate::error::Result;
use crate::PreparedReal;
use drive_sim_calibration::params::ParamSpec;
use drive_sim_calibration::ModelParams;
use drive_sim_log::DriveLog;
use drive_sim_model::effects::CommandReach;
use rayon::prelude::*;
use std::cell::RefCell;

/// The tuned parameters and the unit box the search works in: each parameter's box mapped
/// onto [0, 1].
pub(super) struct Space<'a> {
    /// The model tuning starts from.
    pub(super) start: &'a ModelParams,
    pub(super) specs: Vec<ParamSpec>,
    /// The parameters' keys, in the order of `specs`.
    keys: Vec<String>,
    lower: Vec<f64>,
    width: Vec<f64>,
    /// Where the search starts, in the parameters' units (the start model's values when inside
    /// the box).
    pub(super) x0: Vec<f64>,
}

impl<'a> Space<'a> {
    /// The parameters `req.tune` names, with the registry's boxes for the commands of the
    /// choosing steps and the boxes `req.boxes` gives.
    pub(super) fn new(req: &TuneRequest<'a>, choosing: &DriveLog) -> Result<Self> {
        let reach =
            CommandReach::of_commands(choosing.samples.iter().map(|s| s.m.cmd), &req.start.robot.idd());
        let mut specs = tuned_specs(req.tune, req.start, &reach)?;
        apply_boxes(&mut specs, req.boxes)?;
        Ok(Self {
            start: req.start,
            keys: specs.iter().map(|s| s.param.key()).collect(),
            lower: specs.iter().map(|s| s.lower).collect(),
            width: specs.iter().map(|s| s.upper - s.lower).collect(),
            x0: specs.iter().map(|s| s.start_in(req.start)).collect(),
            specs,
        })
    }

    /// A point of the unit box in the parameters' units.
    fn to_x(&self, z: &[f64]) -> Vec<f64> {
        z.iter()
            .zip(self.lower.iter().zip(&self.width))
            .map(|(z, (l, w))| l + z * w)
            .collect()
    }

    /// Where the search starts, in the unit box.
    fn z0(&self) -> Vec<f64> {
        self.x0
            .iter()
            .zip(self.lower.iter().zip(&self.width))
            .map(|(x, (l, w))| (x - l) / w)
            .collect()
    }

    /// The start model with the parameters at `x`.
    fn model_at(&self, x: &[f64]) -> Result<ModelParams> {
        Ok(self.start.with_values(&self.specs, x)?)
    }
}

/// Seeded DRIVE runs of models, each scored by the loss against the choosing steps (prepared
/// once).
pub(super) struct LossRuns<'a> {
    pub(super) real: &'a PreparedReal<'a>,
    /// DRIVE steps of each run.
    pub(super) steps: u32,
}

impl LossRuns<'_> {
    fn run(&self, model: &ModelParams, seed: u64) -> SeedRun {
        seed_run(self.real, model, self.steps, seed)
    }

    /// The check: the start and the chosen model on fresh seeds, paired by seed.
    pub(super) fn check(
        &self,
        seeds: Vec<u64>,
        start: &ModelParams,
        chosen: &ModelParams,
        progress: &(dyn Fn(&TuneEvent) + Sync),
    ) -> SeedCheck {
        let pairs: Vec<(SeedRun, SeedRun)> = seeds
            .par_iter()
            .map(|&s| (self.run(start, s), self.run(chosen, s)))
            .collect();
        let total = |r: &SeedRun| r.outcome.as_ref().ok().map(|o| o.total);
        let check = check_rule(
            seeds,
            pairs.iter().map(|p| total(&p.0)).collect(),
            pairs.iter().map(|p| total(&p.1)).collect(),
            chosen == start,
        );
        progress(&TuneEvent::Checked { check: &check });
        check
    }
}

/// What the search found.
pub(super) struct Choice {
    /// Every point evaluated, in order.
    pub(super) evaluations: Vec<PointEvaluation>,
    /// The start model on the search's seeds.
    pub(super) start: PointEvaluation,
    /// The best point, in the parameters' units.
    pub(super) x_best: Vec<f64>,
    /// Its mean loss.
    pub(super) loss: f64,
    pub(super) summary: SearchSummary,
    /// The start model with the best point's values.
    pub(super) model: ModelParams,
}

/// The search: the start model on the search's seeds (the baseline its losses compare with),
/// then the design and the simplex over the unit box.
pub(super) fn choose(
    space: &Space,
    runs: &LossRuns,
    seeds: &[u64],
    opts: &SearchOptions,
    progress: &(dyn Fn(&TuneEvent) + Sync),
) -> Result<Choice> {
    let points = Points {
        space,
        runs,
        seeds,
        evaluations: RefCell::new(Vec::new()),
        progress,
    };
    let cost_many = |zs: &[Vec<f64>]| points.cost_many(zs);
    let start_runs: Vec<SeedRun> = seeds.par_iter().map(|&s| runs.run(space.start, s)).collect();
    let start = evaluation(space.start.values_of(&space.specs), &start_runs);
    progress(&TuneEvent::StartModel { point: &start });
    let (z_best, loss, summary) = search::minimise(&space.z0(), opts, &cost_many);
    let x_best = space.to_x(&z_best);
    let model = space.model_at(&x_best)?;
    progress(&TuneEvent::SearchDone {
        summary: &summary,
        keys: &space.keys,
        best: &x_best,
        loss,
        start_loss: start.loss,
    });
    Ok(Choice {
        evaluations: points.evaluations.into_inner(),
        start,
        x_best,
        loss,
        summary,
        model,
    })
}

/// The search's cost: every point on every seed.
struct Points<'a> {
    space: &'a Space<'a>,
    runs: &'a LossRuns<'a>,
    seeds: &'a [u64],
    /// Every point evaluated, in order (the search asks for points from one thread at a time;
    /// each request runs its points' seeds in parallel).
    evaluations: RefCell<Vec<PointEvaluation>>,
    progress: &'a (dyn Fn(&TuneEvent) + Sync),
}

impl Points<'_> {
    /// The mean loss of each point `zs` of the unit box (`None` where a run failed).
    fn cost_many(&self, zs: &[Vec<f64>]) -> Vec<Option<f64>> {
        let jobs: Vec<(usize, u64)> = (0..zs.len())
            .flat_map(|i| self.seeds.iter().map(move |s| (i, *s)))
            .collect();
        // In the order of `jobs`: each point's seeds side by side.
        let runs: Vec<SeedRun> = jobs
            .par_iter()
            .map(|&(i, seed)| match self.space.model_at(&self.space.to_x(&zs[i])) {
                Ok(m) => self.runs.run(&m, seed),
                Err(e) => SeedRun {
                    outcome: Err(e.to_string()),
                },
            })
            .collect();
        let mut evals = self.evaluations.borrow_mut();
        let mut out = Vec::new();
        for (z, mine) in zs.iter().zip(runs.chunks(self.seeds.len())) {
            let e = evaluation(self.space.to_x(z), mine);
            let best = evals
                .iter()
                .chain(std::iter::once(&e))
                .filter_map(|p| p.loss)
                .fold(f64::INFINITY, f64::min);
            (self.progress)(&TuneEvent::Point {
                index: evals.len() + 1,
                keys: &self.space.keys,
                point: &e,
                best,
            });
            out.push(e.loss);
            evals.push(e);
        }
        out
    }
}
