//! The closed loop of a pass: the real steps of each ground prepared once, and the twin's own
//! seeded DRIVE runs scored against them by `compare`'s loss.
//!
//! A point is one model per ground (the robot shared, a terrain per ground); its score is the
//! mean over the seeds of the mean over the grounds of compare's loss, the same loss `tune`
//! minimises (each term 1 at its verdict's threshold). Every point of a pass is run with the
//! same seeds (common random numbers: two points differ by their parameters, not by their
//! draws).

use drive_sim_calibration::ModelParams;
use drive_sim_compare::loss::Loss;
use drive_sim_compare::tune::run_loss;
use drive_sim_compare::PreparedReal;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// One ground's real steps, prepared for comparisons.
pub(crate) struct ClosedGround<'a> {
    /// The prepared real steps.
    pub(crate) real: PreparedReal<'a>,
    /// DRIVE steps of each of the twin's runs: as many as the analysed real steps (a T/U
    /// area is a hull, which grows with the number of steps).
    pub(crate) steps: u32,
}

/// The grounds of a pass.
pub(crate) struct Closed<'a> {
    pub(crate) grounds: Vec<ClosedGround<'a>>,
}

/// A point's score over its seeds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PointScore {
    /// Mean loss over the seeds (`None`: a run failed).
    pub loss: Option<f64>,
    /// Each seed's loss (mean over the grounds).
    pub seed_losses: Vec<Option<f64>>,
    /// Each loss term's mean over the seeds, named `term` (one ground) or `ground: term`.
    pub terms: Vec<(String, f64)>,
    /// The first failure, in words.
    pub error: Option<String>,
}

impl Closed<'_> {
    /// The losses of `models` (one per ground) on one seed.
    fn run(&self, models: &[ModelParams], seed: u64, names: &[String]) -> Result<Vec<Loss>, String> {
        self.grounds
            .iter()
            .zip(models)
            .zip(names)
            .map(|((g, m), name)| run_loss(&g.real, m, g.steps, seed).map_err(|e| format!("{name}: {e}")))
            .collect()
    }

    /// The score of every point (each one model per ground) on every seed, run in parallel.
    pub(crate) fn score(
        &self,
        points: &[Vec<ModelParams>],
        seeds: &[u64],
        names: &[String],
    ) -> Vec<PointScore> {
        let jobs: Vec<(usize, u64)> = (0..points.len())
            .flat_map(|i| seeds.iter().map(move |s| (i, *s)))
            .collect();
        let runs: Vec<Result<Vec<Loss>, String>> = jobs
            .par_iter()
            .map(|&(i, seed)| self.run(&points[i], seed, names))
            .collect();
        runs.chunks(seeds.len().max(1))
            .map(|mine| point_score(mine, names))
            .collect()
    }
}

/// The mean over seeds of the mean over grounds, and each term's mean.
fn point_score(runs: &[Result<Vec<Loss>, String>], names: &[String]) -> PointScore {
    let seed_losses: Vec<Option<f64>> = runs
        .iter()
        .map(|r| {
            r.as_ref()
                .ok()
                .map(|ls| ls.iter().map(|l| l.total).sum::<f64>() / ls.len().max(1) as f64)
        })
        .collect();
    let loss = seed_losses
        .iter()
        .copied()
        .collect::<Option<Vec<f64>>>()
        .map(|v| v.iter().sum::<f64>() / v.len().max(1) as f64);
    let mut terms: Vec<(String, f64, usize)> = Vec::new();
    for ls in runs.iter().filter_map(|r| r.as_ref().ok()) {
        for (l, ground) in ls.iter().zip(names) {
            for t in &l.terms {
                let Some(v) = t.value else { continue };
                let name = if names.len() > 1 {
                    format!("{ground}: {}", t.name)
                } else {
                    t.name.clone()
                };
                match terms.iter_mut().find(|(n, _, _)| *n == name) {
                    Some(e) => {
                        e.1 += v;
                        e.2 += 1;
                    }
                    None => terms.push((name, v, 1)),
                }
            }
        }
    }
    PointScore {
        loss,
        seed_losses,
        terms: terms.into_iter().map(|(n, s, k)| (n, s / k as f64)).collect(),
        error: runs.iter().find_map(|r| r.as_ref().err().cloned()),
    }
}

/// The term `name` of a score (0 when it could not be formed).
pub(crate) fn term(score: &PointScore, name: &str) -> f64 {
    score
        .terms
        .iter()
        .find(|(n, _)| n == name)
        .map_or(0.0, |(_, v)| *v)
}
