//! The data a calibration works on: sets of recorded steps with their measured features and
//! start states computed once, and the seeded split of a log's steps into training,
//! validation and test sets.

use super::metrics::{
    score, step_features, step_residuals, NoiseFloor, StepErrors, StepFeatures, StepResiduals,
};
use super::model::{ModelParams, PlantFactory};
use super::replay::replay_map;
use super::steps::{step_start_in, StepSlice, StepStart};
use crate::error::{Error, Result};
use drive_sim_model::kinematics::WheelSpeeds;
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// Recorded steps with what a replay needs (start states) and what it is compared with
/// (measured features), both computed once.
#[derive(Debug, Clone)]
pub struct StepSet<'a> {
    /// The recorded steps.
    pub steps: Vec<StepSlice<'a>>,
    /// The measured state each step's replay starts from.
    pub starts: Vec<StepStart>,
    /// Their measured features.
    pub features: Vec<StepFeatures>,
    /// Sample rate, Hz.
    pub rate_hz: f64,
}

impl<'a> StepSet<'a> {
    /// Selects `which` steps of `all` (in that order; a step may repeat, as in a bootstrap
    /// resample). A step's start is measured from the steps of `which` only (see
    /// [`step_start_in`]): the training set takes nothing from the sets that judge it.
    pub fn new(all: &[StepSlice<'a>], which: &[u32], rate_hz: f64) -> Result<Self> {
        Self::after(all, which, &[], rate_hz)
    }

    /// As [`StepSet::new`], with the steps' starts also measured from the `earlier` sets'
    /// steps: a validation step that follows a training step starts where that step ended,
    /// a test step where a training or validation step ended. Measurements flow from the sets
    /// that fit to those that judge, never back, so the judging sets' starts are as good as
    /// the training set's without a test step moving the fit (with their own steps only,
    /// most test steps followed a step of another set and started from the noisier estimate
    /// over their own first samples).
    pub fn after(all: &[StepSlice<'a>], which: &[u32], earlier: &[u32], rate_hz: f64) -> Result<Self> {
        let steps: Vec<StepSlice<'a>> = which
            .iter()
            .map(|w| {
                all.iter()
                    .find(|s| s.step == *w)
                    .copied()
                    .ok_or(Error::StepNotInLog { step: *w })
            })
            .collect::<Result<_>>()?;
        let features = steps
            .iter()
            .map(|s| step_features(s.step, s.samples))
            .collect::<Result<_>>()?;
        let starts = steps
            .iter()
            .map(|s| step_start_in(all, *s, |k| which.contains(&k) || earlier.contains(&k)))
            .collect::<Result<_>>()?;
        Ok(Self {
            steps,
            starts,
            features,
            rate_hz,
        })
    }

    /// The steps at positions `idx` of this set (positions may repeat).
    pub fn pick(&self, idx: &[usize]) -> Self {
        Self {
            steps: idx.iter().map(|&i| self.steps[i]).collect(),
            starts: idx.iter().map(|&i| self.starts[i]).collect(),
            features: idx.iter().map(|&i| self.features[i].clone()).collect(),
            rate_hz: self.rate_hz,
        }
    }

    /// Step indices, in set order.
    pub fn ids(&self) -> Vec<u32> {
        self.steps.iter().map(|s| s.step).collect()
    }

    /// Number of steps.
    pub fn len(&self) -> usize {
        self.steps.len()
    }

    /// No step.
    pub fn is_empty(&self) -> bool {
        self.steps.is_empty()
    }

    /// Replays every step on the model and returns its residuals against the recording.
    pub fn residuals(&self, factory: &dyn PlantFactory, params: &ModelParams) -> Result<Vec<StepResiduals>> {
        replay_map(
            &self.steps,
            &self.starts,
            factory,
            params,
            self.rate_hz,
            |i, sim| step_residuals(&step_features(self.steps[i].step, &sim)?, &self.features[i]),
        )
    }

    /// Replays every step on the model and returns the model's own features (what the
    /// estimators extract from the replay), in step order.
    pub fn replay_features(
        &self,
        factory: &dyn PlantFactory,
        params: &ModelParams,
    ) -> Result<Vec<StepFeatures>> {
        replay_map(
            &self.steps,
            &self.starts,
            factory,
            params,
            self.rate_hz,
            |i, sim| step_features(self.steps[i].step, &sim),
        )
    }

    /// Replays every step on the model and compares it with the recording.
    pub fn errors(&self, factory: &dyn PlantFactory, params: &ModelParams) -> Result<Vec<StepErrors>> {
        Ok(self
            .residuals(factory, params)?
            .iter()
            .map(StepResiduals::errors)
            .collect())
    }

    /// Score of a model on these steps ([`super::metrics::score`]).
    pub fn score(&self, factory: &dyn PlantFactory, params: &ModelParams, floor: &NoiseFloor) -> Result<f64> {
        Ok(score(&self.errors(factory, params)?, floor))
    }
}

/// Steps of a log split into the three sets of an honest calibration.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Split {
    /// Fits (terrain, effects) and every estimate from data (noise floor, command reach).
    pub train: Vec<u32>,
    /// Chooses among models (effect selection, whether a fit is kept).
    pub validation: Vec<u32>,
    /// Reports the final scores; used for nothing else.
    pub test: Vec<u32>,
}

/// Fewest steps each set of a [`Split`] may have.
pub const MIN_STEPS_PER_SET: usize = 3;

/// Splits steps into training, validation and test sets of the given fractions (the test set
/// takes the rest), spread over the command space: steps are ordered by the direction of
/// their command in the wheel plane and dealt in blocks, each block shuffled (seeded) and
/// shared by largest remainder, so every set sees every kind of motion. Each set sorted.
/// Fails, naming `dataset`, when a set would have fewer than [`MIN_STEPS_PER_SET`] steps.
pub fn split_steps(
    dataset: &str,
    commands: &[(u32, WheelSpeeds)],
    train_fraction: f64,
    validation_fraction: f64,
    seed: u64,
) -> Result<Split> {
    let test_fraction = 1.0 - train_fraction - validation_fraction;
    if !(train_fraction > 0.0 && validation_fraction > 0.0 && test_fraction > 1e-9) {
        return Err(Error::SplitFractions {
            dataset: dataset.to_string(),
            train: train_fraction,
            validation: validation_fraction,
        });
    }
    let n = commands.len();
    let need = (MIN_STEPS_PER_SET as f64 / train_fraction.min(validation_fraction).min(test_fraction)).ceil()
        as usize;
    if n < need {
        return Err(Error::TooFewSteps {
            dataset: dataset.to_string(),
            steps: n,
            need,
            min_per_set: MIN_STEPS_PER_SET,
            train: train_fraction,
            validation: validation_fraction,
        });
    }
    let mut order: Vec<(f64, f64, u32)> = commands
        .iter()
        .map(|(s, c)| {
            (
                c.right_rad_s.atan2(c.left_rad_s),
                c.left_rad_s.hypot(c.right_rad_s),
                *s,
            )
        })
        .collect();
    order.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)).then(a.2.cmp(&b.2)));
    let fractions = [train_fraction, validation_fraction, test_fraction];
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut sets: [Vec<u32>; 3] = Default::default();
    let block = 5;
    for chunk in order.chunks(block) {
        let mut ids: Vec<u32> = chunk.iter().map(|c| c.2).collect();
        ids.shuffle(&mut rng);
        for id in ids {
            // The set furthest below its share of the steps dealt so far (largest remainder).
            let dealt = sets.iter().map(Vec::len).sum::<usize>() as f64 + 1.0;
            let k = (0..3)
                .max_by(|&a, &b| {
                    let da = fractions[a] * dealt - sets[a].len() as f64;
                    let db = fractions[b] * dealt - sets[b].len() as f64;
                    da.total_cmp(&db).then(b.cmp(&a))
                })
                .unwrap_or(0);
            sets[k].push(id);
        }
    }
    for s in &mut sets {
        s.sort_unstable();
    }
    let [train, validation, test] = sets;
    Ok(Split {
        train,
        validation,
        test,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn commands(n: u32) -> Vec<(u32, WheelSpeeds)> {
        (0..n)
            .map(|i| {
                let a = i as f64 * 2.399;
                (i, WheelSpeeds::new(5.0 * a.cos(), 5.0 * a.sin()))
            })
            .collect()
    }

    #[test]
    fn a_judging_set_starts_from_the_fitting_sets_steps_and_never_the_reverse() {
        use drive_sim_log::{Measurement, Pose, Sample};
        // Two steps back to back at 20 Hz, the robot at 1.2 m/s then braking.
        let sample = |step: u32, i: u32, stamp0: f64, x: f64| Sample {
            step,
            window: i / 40,
            k: i % 40,
            t_in_step_s: f64::from(i) * 0.05,
            stamp_s: stamp0 + f64::from(i) * 0.05,
            m: Measurement {
                pose: Pose {
                    x_m: x,
                    ..Pose::default()
                },
                enc: WheelSpeeds::new(4.0, 4.0),
                ..Measurement::default()
            },
        };
        let first: Vec<Sample> = (0..120).map(|i| sample(0, i, 0.0, 0.06 * f64::from(i))).collect();
        let second: Vec<Sample> = (0..120)
            .map(|i| {
                let t = f64::from(i) * 0.05;
                sample(1, i, 6.0, 7.2 + 1.2 * t - 1.5 * t * t.min(0.4))
            })
            .collect();
        let all = [
            StepSlice {
                step: 0,
                samples: &first,
            },
            StepSlice {
                step: 1,
                samples: &second,
            },
        ];
        let judged = StepSet::after(&all, &[1], &[0], 20.0).unwrap();
        assert!((judged.starts[0].velocity.vx_m_s - 1.2).abs() < 1e-9);
        // A set on its own (the training set) reads none of the other sets' poses.
        let alone = StepSet::new(&all, &[1], 20.0).unwrap();
        assert!((alone.starts[0].velocity.vx_m_s - 1.2).abs() > 1e-3);
    }

    #[test]
    fn split_is_deterministic_disjoint_complete_and_spread() {
        let c = commands(100);
        let s = split_steps("d", &c, 0.6, 0.2, 3).unwrap();
        assert_eq!((s.train.len(), s.validation.len(), s.test.len()), (60, 20, 20));
        assert_eq!(split_steps("d", &c, 0.6, 0.2, 3).unwrap(), s);
        assert_ne!(split_steps("d", &c, 0.6, 0.2, 4).unwrap(), s);
        let mut all: Vec<u32> = s
            .train
            .iter()
            .chain(&s.validation)
            .chain(&s.test)
            .copied()
            .collect();
        all.sort_unstable();
        assert_eq!(all, (0..100).collect::<Vec<_>>());
        // Every quadrant of the wheel plane has test steps.
        for q in 0..4 {
            let in_q = |id: &u32| {
                let w = c[*id as usize].1;
                let a = w.right_rad_s.atan2(w.left_rad_s);
                ((a + std::f64::consts::PI) / std::f64::consts::FRAC_PI_2) as usize == q
            };
            assert!(s.test.iter().filter(|i| in_q(i)).count() >= 3, "quadrant {q}");
        }
    }

    #[test]
    fn too_few_steps_is_an_error_naming_the_dataset() {
        let e = split_steps("tiny", &commands(8), 0.6, 0.2, 0)
            .unwrap_err()
            .to_string();
        assert!(e.contains("tiny") && e.contains("8 completed steps"), "{e}");
        assert!(split_steps("x", &commands(100), 0.8, 0.3, 0).is_err());
    }
}
