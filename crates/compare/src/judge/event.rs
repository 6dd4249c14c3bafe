//! What [`super::judge`] tells its caller as it goes: one event per phase, each displayed as the
//! line `drive-sim judge` prints for it.

use super::{CandidateScore, JudgeOutcome};
use drive_sim_log::UseSteps;
use std::fmt;

/// What [`judge`](super::judge) tells its caller as it goes. `Display` gives the line
/// `drive-sim judge` prints (after its clock).
#[derive(Debug, Clone, Copy)]
pub enum JudgeEvent<'a> {
    /// Every input is checked: the twin's runs start.
    Started {
        /// The real log's name.
        dataset: &'a str,
        /// Which of its steps are judged against.
        real_steps: UseSteps,
        /// How many of them the analysis keeps.
        real_steps_analysed: usize,
        /// Runs of the twin compared with the real run and with each reference.
        sims: u32,
        /// Runs of the twin in the real run's place.
        references: u32,
        /// DRIVE steps of each run.
        steps_per_run: u32,
    },
    /// The twin's runs scored against the real run.
    AgainstReal {
        /// Their scores.
        score: &'a CandidateScore,
    },
    /// One more reference scored (references complete in any order).
    Reference {
        /// References scored so far, this one included.
        done: usize,
        /// References in all.
        of: usize,
        /// Its seed.
        seed: u64,
        /// The twin's runs against it.
        score: &'a CandidateScore,
    },
    /// The judgement is made.
    Decided {
        /// What it found.
        outcome: &'a JudgeOutcome,
    },
}

impl fmt::Display for JudgeEvent<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            JudgeEvent::Started {
                dataset,
                real_steps,
                real_steps_analysed,
                sims,
                references,
                steps_per_run,
            } => write!(
                f,
                "judge: {sims} runs of the twin against the {real_steps_analysed} {} steps of `{dataset}` and against {references} runs of its own, {steps_per_run} DRIVE steps each",
                real_steps.as_str()
            ),
            JudgeEvent::AgainstReal { score } => write!(
                f,
                "judge: against the real run: {} of {} runs differ, mean loss {:.2}",
                score.fails[0],
                score.runs.len(),
                score.mean_loss
            ),
            JudgeEvent::Reference {
                done,
                of,
                seed,
                score,
            } => write!(
                f,
                "judge: reference {done}/{of} (seed {seed}): {} of {} runs differ, mean loss {:.2}",
                score.fails[0],
                score.runs.len(),
                score.mean_loss
            ),
            JudgeEvent::Decided { outcome } => write!(
                f,
                "judge: {} (the loss's p {:.3}, the verdict's {:.3})",
                if outcome.indistinguishable {
                    "indistinguishable from the twin's own runs"
                } else {
                    "distinguishable from the twin's own runs"
                },
                outcome.loss.p,
                outcome.criteria[0].p
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The lines are the ones `drive-sim judge` has always printed for these phases.
    #[test]
    fn events_display_as_the_printed_lines() {
        let started = JudgeEvent::Started {
            dataset: "warthog_gravel",
            real_steps: UseSteps::Even,
            real_steps_analysed: 50,
            sims: 2,
            references: 4,
            steps_per_run: 20,
        };
        assert_eq!(
            started.to_string(),
            "judge: 2 runs of the twin against the 50 even steps of `warthog_gravel` and against 4 runs of its own, 20 DRIVE steps each"
        );
        let score = CandidateScore {
            label: "reference".into(),
            seed: Some(5002),
            steps: 20,
            runs: Vec::new(),
            fails: vec![0],
            mean_loss: 2740.678,
            term_means: Vec::new(),
        };
        let reference = JudgeEvent::Reference {
            done: 2,
            of: 4,
            seed: 5002,
            score: &score,
        };
        assert_eq!(
            reference.to_string(),
            "judge: reference 2/4 (seed 5002): 0 of 0 runs differ, mean loss 2740.68"
        );
    }
}
