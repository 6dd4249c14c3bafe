//! What a judgement found (`judge.json`): each candidate's scores, each criterion's test and
//! the loss's.

use super::interval;
use super::JudgeOptions;
use drive_sim_log::UseSteps;
use serde::{Deserialize, Serialize};

/// One simulated run against one candidate (the real run or a reference): the criteria it
/// fails and its loss.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunScore {
    /// Seed of the simulated run.
    pub sim_seed: u64,
    /// Criteria failed ([`DIFFERS`](super::DIFFERS) when the verdict is not "reproduces").
    pub failed: Vec<String>,
    /// The loss of [`crate::loss`] (each term 1 at its verdict's threshold).
    pub loss: Option<f64>,
}

/// The simulated runs against one candidate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CandidateScore {
    /// `real` or `reference`.
    pub label: String,
    /// Seed of a reference run (`None` for the real run).
    pub seed: Option<u64>,
    /// Its analysed steps.
    pub steps: usize,
    /// Each simulated run against it.
    pub runs: Vec<RunScore>,
    /// Runs failing each criterion, in the order of [`JudgeOutcome::criteria`].
    pub fails: Vec<usize>,
    /// Mean loss of the runs.
    pub mean_loss: f64,
    /// Each term of the loss, its square's mean over the runs (the terms' means add up to
    /// `mean_loss` where every run forms every term), in the loss's order.
    #[serde(default)]
    pub term_means: Vec<TermMean>,
}

/// One term of the loss over a candidate's runs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TermMean {
    /// The term's name ([`crate::loss::LossTerm::name`]).
    pub name: String,
    /// Mean of its square over the runs that formed it; `None` when none did.
    pub mean_square: Option<f64>,
}

/// One term of the loss tested as the loss is: the real run's mean square among the
/// references'. Not a test of its own (the loss decides, and 14 terms at 5 % flag some of a
/// perfect twin's): it says which terms make the real run extreme when the loss does.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TermTest {
    /// The term's name.
    pub name: String,
    /// Mean square of the term over the runs against the real run.
    pub real: Option<f64>,
    /// The same against each reference, averaged over the references that formed it.
    pub reference_mean: Option<f64>,
    /// Largest of the references'.
    pub reference_max: Option<f64>,
    /// Monte Carlo p-value, as the loss's ([`super::monte_carlo_p`]); NaN without a value.
    pub p: f64,
}

/// One criterion's test.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CriterionTest {
    /// [`DIFFERS`](super::DIFFERS), a median (`median_rho`, `median_slip_vx`, ...), an area
    /// (`t_area_pct_body`), or a map (`vx map`, ...).
    pub criterion: String,
    /// Simulated runs failing it against the real run.
    pub real_fails: usize,
    /// The same against each reference run.
    pub reference_fails: Vec<usize>,
    /// Mean of `reference_fails` / runs: how often a run of the twin fails it against the twin.
    pub reference_rate: f64,
    /// Monte Carlo p-value: (1 + references failing at least as many runs) / (references + 1).
    pub p: f64,
    /// Holm-adjusted over the criteria other than [`DIFFERS`](super::DIFFERS) (for [`DIFFERS`](super::DIFFERS): `p`).
    pub p_holm: f64,
}

/// The loss's test.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LossTest {
    /// Mean loss of the simulated runs against the real run.
    pub real: f64,
    /// The same against each reference.
    pub references: Vec<f64>,
    /// Monte Carlo p-value: (1 + references with a mean loss at least the real's) /
    /// (references + 1).
    pub p: f64,
    /// The loss term by term: where the real run's mean loss comes from, against the twin's
    /// own runs in its place.
    #[serde(default)]
    pub terms: Vec<TermTest>,
}

/// Everything [`judge`](super::judge) found (`judge.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JudgeOutcome {
    /// The real log.
    pub dataset: String,
    /// Its robot.
    pub robot: String,
    /// Options.
    pub options: JudgeOptions,
    /// Analysed real steps judged against.
    pub real_steps_analysed: usize,
    /// DRIVE steps of each run.
    pub steps_per_run: u32,
    /// DRIVE steps of each reference run before its steps are chosen as the real ones were
    /// (`reference_steps`): the real log's length when a half of it is judged, else
    /// `steps_per_run`.
    #[serde(default)]
    pub reference_run_steps: u32,
    /// The steps of each reference run that take the real run's place: the same half as the
    /// judged real steps (`all` when every step is judged).
    #[serde(default)]
    pub reference_steps: UseSteps,
    /// Seeds of the simulated runs that completed.
    pub sim_seeds: Vec<u64>,
    /// Seeds of the reference runs that completed.
    pub reference_seeds: Vec<u64>,
    /// The tests, [`DIFFERS`](super::DIFFERS) first.
    pub criteria: Vec<CriterionTest>,
    /// The loss's test.
    pub loss: LossTest,
    /// The loss's p-value is above `alpha`: `compare` cannot tell the real run from the twin's
    /// own runs.
    pub indistinguishable: bool,
    /// Criteria whose Holm-adjusted p-value is at most `alpha`: where the twin falls short.
    /// (Holm over the 14 criteria, the verdict's 13 and the step scatter, needs more references
    /// than the default 19 to reach 0.05.)
    pub short_on: Vec<String>,
    /// Criteria whose own p-value is at most `alpha`, uncorrected: a diagnostic of where the
    /// real run is more extreme than (nearly) every reference, not a test (14 criteria at 5 %
    /// flag about 0.7 of them for a perfect twin).
    pub flagged: Vec<String>,
    /// The simulated runs against the real run.
    pub real: CandidateScore,
    /// The simulated runs against each reference run.
    pub references: Vec<CandidateScore>,
    /// What happened, in words (runs that failed, the p-values' resolution).
    pub notes: Vec<String>,
    /// Sets of the twin's parameters by inverting this test (`judge --interval`,
    /// [`interval`](mod@interval)); empty unless asked.
    #[serde(default)]
    pub intervals: Vec<interval::ParamInterval>,
    /// Other real runs of the same robot and ground compared with the judged steps as the
    /// twin's runs are: the robot's own difference (`judge --other-run`,
    /// [`yardsticks`](super::yardsticks)); empty unless given.
    #[serde(default)]
    pub yardsticks: Vec<super::Yardstick>,
}
