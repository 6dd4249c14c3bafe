//! Step 3 of a tuning (module doc of [`super`]): the start and the chosen model judged on real
//! steps with fresh seeds, in compare's full terms.

use super::runs::{judged, run_against};
use super::{HeldOut, TuneEvent};
use crate::real_steps::RealSteps;
use crate::{compare_prepared, CompareOptions, ComparisonReport, Input, PreparedReal, TfSmoother};
use drive_sim_calibration::ModelParams;
use drive_sim_log::DriveLog;
use rayon::prelude::*;

/// The judgement of the start and the chosen model on real steps, with compare's default
/// options but the tuning's smoother, one run of each per seed.
pub(super) struct Judging<'a> {
    pub(super) smoother: TfSmoother,
    pub(super) seeds: Vec<u64>,
    /// The start and the chosen model, in that order.
    pub(super) models: [&'a ModelParams; 2],
    /// DRIVE steps of each run.
    pub(super) steps: u32,
}

impl Judging<'_> {
    /// Both models judged on the real steps `on`; with `halves` (the choosing half, when `on` is
    /// the other one) that half too, compared with `on` as a simulated run would be.
    pub(super) fn on(
        &self,
        on: &RealSteps,
        halves: Option<&DriveLog>,
        progress: &(dyn Fn(&TuneEvent) + Sync),
    ) -> HeldOut {
        let judging = CompareOptions {
            tf_smoother: self.smoother,
            ..CompareOptions::default()
        };
        let prepared = PreparedReal::new(
            Input {
                log: &on.log,
                file: None,
            },
            &judging,
        )
        .map_err(|e| e.to_string());
        let reps: Vec<(u64, std::result::Result<ComparisonReport, String>)> = self
            .seeds
            .par_iter()
            .map(|&s| {
                let r = prepared
                    .as_ref()
                    .map_err(Clone::clone)
                    .and_then(|p| run_against(p, &self.models, self.steps, s).map_err(|e| e.to_string()));
                (s, r)
            })
            .collect();
        let real_halves = halves.map(|other| {
            let c = prepared.as_ref().map_err(Clone::clone).and_then(|p| {
                compare_prepared(
                    p,
                    &[Input {
                        log: other,
                        file: None,
                    }],
                )
                .map_err(|e| e.to_string())
            });
            judged(c.as_ref(), 0, 0)
        });
        let h = HeldOut {
            real_halves,
            steps: on.steps,
            real_steps: on.analysed,
            start: reps.iter().map(|(s, r)| judged(r.as_ref(), 0, *s)).collect(),
            chosen: reps.iter().map(|(s, r)| judged(r.as_ref(), 1, *s)).collect(),
            reports: reps.into_iter().filter_map(|(_, r)| r.ok()).collect(),
        };
        progress(&TuneEvent::Judged { judgement: &h });
        h
    }
}
