//! One seeded DRIVE run of a model against real steps: the twin's run, compare, the loss.

use super::*;
use drive_sim_model::kinematics::WheelSpeeds;

/// The loss of one seeded DRIVE run of a model against the real steps.
pub(super) struct SeedRun {
    pub(super) outcome: std::result::Result<Loss, String>,
}

/// The protocol run of `drive-sim run --robot twin/robot.toml --terrain twin/terrain.toml
/// --steps N --seed S`, in memory.
pub fn twin_run(model: &ModelParams, steps: u32, seed: u64) -> Result<DriveLog> {
    let (robot, terrain) = twin::twin_models(model)?;
    Ok(drive_sim_harness::simulate(&robot, &terrain, SAMPLER, steps, seed, SensorNoise::typical())?.log)
}

/// [`twin_run`] drawn as a real run was, to be compared with it: step `i` draws uniformly in U
/// in the quadrant (forward or backward, turning left or right) of `like[i]`, the real run's
/// command of its step `i` ([`Matched`](drive_sim_protocol::samplers::matched::Matched) says
/// why: the medians of a run are its quadrants' mix).
pub fn twin_run_matched(
    model: &ModelParams,
    like: &[WheelSpeeds],
    steps: u32,
    seed: u64,
) -> Result<DriveLog> {
    let (robot, terrain) = twin::twin_models(model)?;
    Ok(drive_sim_harness::simulate_matched(&robot, &terrain, like, steps, seed, SensorNoise::typical())?.log)
}

/// Compare's options for the loss of the search and the check: `resamples` bootstrap draws,
/// the maps smoothed by `smoother`, and no permutation test of the maps (the loss does not use
/// it, and it would cost every run a few hundred smoothings). The judgement uses compare's
/// defaults with the same smoother.
pub(super) fn loss_opts(resamples: usize, smoother: TfSmoother) -> CompareOptions {
    CompareOptions {
        bootstrap: Bootstrap {
            resamples,
            ..Bootstrap::default()
        },
        tf_permutations: 0,
        tf_smoother: smoother,
        ..CompareOptions::default()
    }
}

/// DRIVE runs of `models` with `seed`, drawn as the real steps were (their commands'
/// quadrants), compared with the real steps prepared once.
pub(super) fn run_against(
    real: &PreparedReal,
    models: &[&ModelParams],
    steps: u32,
    seed: u64,
) -> Result<ComparisonReport> {
    let logs = models
        .iter()
        .map(|m| twin_run_matched(m, real.commands(), steps, seed))
        .collect::<Result<Vec<_>>>()?;
    let inputs: Vec<Input> = logs.iter().map(|log| Input { log, file: None }).collect();
    compare_prepared(real, &inputs)
}

/// The loss of one seeded run of `model` against `real` (prepared with [`loss_opts`]).
pub(super) fn seed_run(real: &PreparedReal, model: &ModelParams, steps: u32, seed: u64) -> SeedRun {
    SeedRun {
        outcome: run_loss(real, model, steps, seed),
    }
}

/// The loss of one seeded DRIVE run of `model` (`steps` steps) against the real steps
/// `real` (prepared once with compare's options for a search: no permutation test of the
/// maps); the error in words when the run or the comparison failed (a model that cannot run
/// its protocol is a point of the search, not an error of the search).
pub fn run_loss(
    real: &PreparedReal,
    model: &ModelParams,
    steps: u32,
    seed: u64,
) -> std::result::Result<Loss, String> {
    run_against(real, &[model], steps, seed)
        .map_err(|e| e.to_string())
        .and_then(|r| {
            r.sims[0]
                .loss
                .clone()
                .ok_or_else(|| "compare gave no loss".to_string())
        })
}

/// Compare's options for a closed-loop search's loss: `resamples` bootstrap draws, the maps
/// smoothed by `smoother`, no permutation test of the maps.
pub fn search_compare_options(resamples: usize, smoother: TfSmoother) -> CompareOptions {
    loss_opts(resamples, smoother)
}

/// Mean of the seeds' losses; `None` when one failed.
pub(super) fn mean_loss(runs: &[SeedRun]) -> Option<f64> {
    let mut sum = 0.0;
    for r in runs {
        sum += r.outcome.as_ref().ok()?.total;
    }
    Some(sum / runs.len().max(1) as f64)
}

pub(super) fn evaluation(values: Vec<f64>, runs: &[SeedRun]) -> PointEvaluation {
    PointEvaluation {
        values,
        loss: mean_loss(runs),
        seed_losses: runs
            .iter()
            .map(|r| r.outcome.as_ref().ok().map(|o| o.total))
            .collect(),
        error: runs.iter().find_map(|r| r.outcome.as_ref().err().cloned()),
    }
}

pub(super) fn judged(r: std::result::Result<&ComparisonReport, &String>, i: usize, seed: u64) -> JudgedRun {
    match r {
        Ok(rep) => {
            let c = &rep.sims[i];
            JudgedRun {
                seed,
                loss: c.loss.clone(),
                metrics: c.metrics.clone(),
                transfer: c.transfer.clone(),
                verdict: Some(c.verdict.clone()),
                error: None,
            }
        }
        Err(e) => JudgedRun {
            seed,
            loss: None,
            metrics: vec![],
            transfer: vec![],
            verdict: None,
            error: Some(e.clone()),
        },
    }
}
