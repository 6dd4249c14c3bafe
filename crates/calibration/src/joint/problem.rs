//! The joint fit as one least-squares problem: the shared robot block, then one terrain block
//! per log, every log's residuals stacked, each log's channels scored against its own floor.

use crate::data::StepSet;
use crate::error::Result;
use crate::metrics::{NoiseFloor, MIN_CHANNEL_RATIO, SCORE_CHANNELS};
use crate::model::{ModelParams, PlantFactory};
use crate::params::ParamSpec;
use crate::solver::{Layout, LeastSquares};
use drive_sim_model::effects::CommandReach;
use std::sync::{Mutex, OnceLock};

/// One log's data for the joint fit.
pub(super) struct Prepared<'a> {
    /// Training steps of the joint fit.
    pub(super) train: StepSet<'a>,
    /// Test steps.
    pub(super) test: StepSet<'a>,
    /// The log's own noise floor.
    pub(super) floor: NoiseFloor,
    /// Its own calibrated model.
    pub(super) start: ModelParams,
}

/// The stacked problem: `x` = robot block, then each log's terrain block.
pub(super) struct JointProblem<'a, 'b> {
    /// Every log's data.
    pub(super) logs: &'b [Prepared<'a>],
    /// The plant fitted.
    pub(super) factory: &'b dyn PlantFactory,
    /// The robot block.
    pub(super) robot: Vec<ParamSpec>,
    /// Each log's terrain block.
    pub(super) terrain: Vec<Vec<ParamSpec>>,
    layout: OnceLock<Layout>,
    /// Recent residuals of each log by its own parameters: a finite difference in one log's
    /// terrain block leaves the other logs' residuals as they were.
    cache: Vec<Mutex<Vec<CacheEntry>>>,
}

const CACHE_PER_LOG: usize = 16;

/// A log's parameter values, with its residuals and their channels there.
type CacheEntry = (Vec<f64>, Vec<f64>, Vec<u8>);

impl<'a, 'b> JointProblem<'a, 'b> {
    /// The problem of `logs` with these blocks, not evaluated yet.
    pub(super) fn new(
        logs: &'b [Prepared<'a>],
        factory: &'b dyn PlantFactory,
        robot: Vec<ParamSpec>,
        terrain: Vec<Vec<ParamSpec>>,
    ) -> Self {
        Self {
            logs,
            factory,
            robot,
            terrain,
            layout: OnceLock::new(),
            cache: (0..logs.len()).map(|_| Mutex::new(Vec::new())).collect(),
        }
    }

    /// Where log `k`'s terrain block starts in `x`.
    pub(super) fn offset(&self, k: usize) -> usize {
        self.robot.len() + self.terrain[..k].iter().map(Vec::len).sum::<usize>()
    }

    /// Log `k`'s specs and values at `x`.
    fn part(&self, k: usize, x: &[f64]) -> (Vec<ParamSpec>, Vec<f64>) {
        let o = self.offset(k);
        let n = self.terrain[k].len();
        let mut specs = self.robot.clone();
        specs.extend(self.terrain[k].iter().copied());
        let mut v = x[..self.robot.len()].to_vec();
        v.extend_from_slice(&x[o..o + n]);
        (specs, v)
    }

    /// Log `k`'s model at `x`.
    pub(super) fn model(&self, k: usize, x: &[f64]) -> Result<ModelParams> {
        let (specs, v) = self.part(k, x);
        self.logs[k].start.with_values(&specs, &v)
    }

    fn log_residuals(&self, k: usize, x: &[f64]) -> Option<(Vec<f64>, Vec<u8>)> {
        let (_, v) = self.part(k, x);
        if let Some(hit) = self.cache[k]
            .lock()
            .ok()?
            .iter()
            .find(|e| e.0 == v)
            .map(|e| (e.1.clone(), e.2.clone()))
        {
            return Some(hit);
        }
        let m = self.model(k, x).ok()?;
        let res = self.logs[k].train.residuals(self.factory, &m).ok()?;
        let (mut r, mut c) = (Vec::new(), Vec::new());
        for s in &res {
            s.flatten_into(&mut r, &mut c);
        }
        let mut cache = self.cache[k].lock().ok()?;
        if cache.len() >= CACHE_PER_LOG {
            cache.remove(0);
        }
        cache.push((v, r.clone(), c.clone()));
        Some((r, c))
    }

    /// Stacked residuals, channels (log `k`'s channel `c` is `k · C + c`) and clusters.
    fn flat(&self, x: &[f64]) -> Option<(Vec<f64>, Vec<u8>, Vec<u32>)> {
        let (mut v, mut ch, mut cl) = (Vec::new(), Vec::new(), Vec::new());
        let mut cluster_base = 0u32;
        for k in 0..self.logs.len() {
            let (r, c) = self.log_residuals(k, x)?;
            // Clusters: the steps, in the order the step set replays them.
            let per_step = static_lengths(self, k, x)?;
            let mut idx = 0usize;
            for (i, n) in per_step.iter().enumerate() {
                cl.extend(std::iter::repeat_n(cluster_base + i as u32, *n));
                idx += n;
            }
            debug_assert_eq!(idx, r.len());
            cluster_base += per_step.len() as u32;
            let off = (k * SCORE_CHANNELS) as u8;
            ch.extend(c.iter().map(|c| c + off));
            v.extend(r);
        }
        Some((v, ch, cl))
    }
}

/// Entries per step of log `k`'s residuals at `x` (fixed by the recording; read once, for the
/// layout's clusters).
fn static_lengths(p: &JointProblem<'_, '_>, k: usize, x: &[f64]) -> Option<Vec<usize>> {
    let m = p.model(k, x).ok()?;
    let res = p.logs[k].train.residuals(p.factory, &m).ok()?;
    Some(
        res.iter()
            .map(|s| {
                let (mut r, mut c) = (Vec::new(), Vec::new());
                s.flatten_into(&mut r, &mut c);
                r.len()
            })
            .collect(),
    )
}

impl JointProblem<'_, '_> {
    /// Evaluates the problem once at `x` to fix its layout (channels, clusters, floors);
    /// `None` when the model cannot be evaluated there.
    pub(super) fn init_layout(&self, x: &[f64]) -> Option<()> {
        if self.layout.get().is_none() {
            let (_, channel, cluster) = self.flat(x)?;
            let mut floor = Vec::new();
            for l in self.logs {
                floor.extend(l.floor.score_channels());
            }
            let _ = self.layout.set(Layout {
                channel,
                cluster,
                floor,
                min_ratio: MIN_CHANNEL_RATIO,
            });
        }
        Some(())
    }

    fn stacked(&self, x: &[f64]) -> Option<(Vec<f64>, Vec<u8>)> {
        let (mut v, mut ch) = (Vec::new(), Vec::new());
        for k in 0..self.logs.len() {
            let (r, c) = self.log_residuals(k, x)?;
            let off = (k * SCORE_CHANNELS) as u8;
            ch.extend(c.iter().map(|c| c + off));
            v.extend(r);
        }
        Some((v, ch))
    }

    /// Every parameter's spec, in the order of `x`.
    pub(super) fn specs(&self) -> Vec<ParamSpec> {
        let mut s = self.robot.clone();
        for t in &self.terrain {
            s.extend(t.iter().copied());
        }
        s
    }
}

impl LeastSquares for JointProblem<'_, '_> {
    fn dim(&self) -> usize {
        self.robot.len() + self.terrain.iter().map(Vec::len).sum::<usize>()
    }
    fn bounds(&self) -> Vec<(f64, f64)> {
        self.specs().iter().map(|s| (s.lower, s.upper)).collect()
    }
    fn resolution(&self, j: usize) -> Option<f64> {
        self.specs()[j].param.resolution()
    }
    fn residuals(&self, x: &[f64]) -> Option<Vec<f64>> {
        let (v, c) = self.stacked(x)?;
        (c == self.layout.get()?.channel).then_some(v)
    }
    fn layout(&self) -> &Layout {
        self.layout.get().expect("layout initialised before solving")
    }
}

/// The parameter specs of the joint model for log `start` (its declared model with the union
/// of the selected effects), split into the robot's and the ground's.
pub(super) fn joint_specs(
    factory: &dyn PlantFactory,
    declared: &ModelParams,
    effects: &[(usize, usize)],
    reach: &CommandReach,
) -> (Vec<ParamSpec>, Vec<ParamSpec>) {
    let mut all = factory.base_params(declared);
    for &(e, p) in effects {
        all.push(ParamSpec::for_effect(e, p, reach));
    }
    // On/off parameters are not in the joint fit: they keep the value each log's own
    // calibration chose.
    all.retain(|s| !s.discrete);
    all.into_iter().partition(|s| !factory.on_terrain(&s.param))
}
