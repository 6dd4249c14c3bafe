//! Scoring the twin's runs against a candidate (the real run or one of the twin's own runs), and
//! the Monte Carlo tests of the scores.

use super::{
    CandidateScore, CriterionTest, RunScore, TermMean, TermTest, DIFFERS, STEP_SCATTER, TURN_MEMORY,
};
use crate::error::Result;
use crate::{compare_prepared_sims, CompareOptions, Input, PreparedReal, PreparedSim, SimComparison};
use drive_sim_analysis::bootstrap::holm;
use drive_sim_log::DriveLog;

/// The criteria a comparison fails, in a fixed order: the verdict, the medians, the areas,
/// the maps, then the step scatter ([`STEP_SCATTER`]) and the turn memory ([`TURN_MEMORY`]),
/// diagnostics outside the verdict and the loss (their intervals miss each other). Returns
/// (names, failed flags).
pub fn criteria_of(c: &SimComparison) -> Vec<(String, bool)> {
    let mut out = vec![(DIFFERS.to_string(), !c.verdict.reproduces)];
    for m in c.metrics.iter().filter(|m| m.tolerance.is_none()) {
        out.push((m.metric.clone(), m.significant));
    }
    for m in c.metrics.iter().filter(|m| m.tolerance.is_some()) {
        out.push((m.metric.clone(), m.within_tolerance == Some(false)));
    }
    for t in &c.transfer {
        out.push((format!("{} map", t.channel), t.points > 0 && !t.within));
    }
    out.push((
        STEP_SCATTER.to_string(),
        c.step_scatter.is_some_and(|d| d.differs),
    ));
    out.push((TURN_MEMORY.to_string(), c.turn_memory.is_some_and(|d| d.differs)));
    out
}

/// Monte Carlo p-value of an observed statistic among references drawn under the hypothesis
/// (larger is more extreme): `(1 + #{r ≥ observed}) / (n + 1)` over the finite references.
/// NaN without a finite reference or a finite observation.
pub fn monte_carlo_p(observed: f64, references: &[f64]) -> f64 {
    let finite: Vec<f64> = references.iter().copied().filter(|r| r.is_finite()).collect();
    if finite.is_empty() || !observed.is_finite() {
        return f64::NAN;
    }
    let at_least = finite.iter().filter(|&&r| r >= observed).count();
    (1 + at_least) as f64 / (finite.len() + 1) as f64
}

/// Scores the simulated runs (their seeds, and the runs analysed once) against one candidate's
/// steps.
pub(super) fn score(
    label: &str,
    seed: Option<u64>,
    candidate: &DriveLog,
    sims: (&[u64], &[PreparedSim]),
    copts: &CompareOptions,
) -> Result<(CandidateScore, Vec<String>)> {
    let prepared = PreparedReal::new(
        Input {
            log: candidate,
            file: None,
        },
        copts,
    )?;
    let (sim_seeds, sims) = sims;
    let report = compare_prepared_sims(&prepared, sims)?;
    let steps = report.real.steps;
    let mut names = Vec::new();
    let mut fails: Vec<usize> = Vec::new();
    let mut runs = Vec::new();
    // Each term's squares over the runs, in the order the first run names them.
    let mut squares: Vec<(String, Vec<f64>)> = Vec::new();
    for (sim_seed, c) in sim_seeds.iter().zip(&report.sims) {
        for t in c.loss.iter().flat_map(|l| &l.terms) {
            let k = match squares.iter().position(|(n, _)| *n == t.name) {
                Some(k) => k,
                None => {
                    squares.push((t.name.clone(), Vec::new()));
                    squares.len() - 1
                }
            };
            if let Some(v) = t.value {
                squares[k].1.push(v * v);
            }
        }
        let crit = criteria_of(c);
        if names.is_empty() {
            names = crit.iter().map(|(n, _)| n.clone()).collect();
            fails = vec![0; names.len()];
        }
        for (k, (_, failed)) in crit.iter().enumerate() {
            fails[k] += usize::from(*failed);
        }
        runs.push(RunScore {
            sim_seed: *sim_seed,
            failed: crit.into_iter().filter(|(_, f)| *f).map(|(n, _)| n).collect(),
            loss: c.loss.as_ref().map(|l| l.total),
        });
    }
    let mean_loss = drive_sim_analysis::stats::mean(
        &runs
            .iter()
            .map(|r| r.loss.unwrap_or(f64::NAN))
            .collect::<Vec<_>>(),
    );
    Ok((
        CandidateScore {
            label: label.into(),
            seed,
            steps,
            runs,
            fails,
            mean_loss,
            term_means: squares
                .into_iter()
                .map(|(name, v)| TermMean {
                    name,
                    mean_square: (!v.is_empty()).then(|| drive_sim_analysis::stats::mean(&v)),
                })
                .collect(),
        },
        names,
    ))
}

/// Each term of the loss tested as the loss is ([`TermTest`]): the real run's mean square
/// ranked among the references' ([`monte_carlo_p`]), the terms in the real run's order.
pub(super) fn term_tests(real: &CandidateScore, references: &[CandidateScore]) -> Vec<TermTest> {
    let of = |c: &CandidateScore, name: &str| {
        c.term_means
            .iter()
            .find(|t| t.name == name)
            .and_then(|t| t.mean_square)
    };
    real.term_means
        .iter()
        .map(|t| {
            let refs: Vec<f64> = references.iter().filter_map(|c| of(c, &t.name)).collect();
            TermTest {
                name: t.name.clone(),
                real: t.mean_square,
                reference_mean: (!refs.is_empty()).then(|| drive_sim_analysis::stats::mean(&refs)),
                reference_max: refs.iter().copied().reduce(f64::max),
                p: t.mean_square.map_or(f64::NAN, |r| monte_carlo_p(r, &refs)),
            }
        })
        .collect()
}

/// Each criterion's test: how many runs fail it against the real run, against each reference,
/// the Monte Carlo p-value, and Holm over the criteria other than the verdict ([`DIFFERS`],
/// first, keeps its own p).
pub(super) fn criterion_tests(
    names: &[String],
    real: &CandidateScore,
    references: &[CandidateScore],
    n_sims: usize,
) -> Vec<CriterionTest> {
    let n_sims = n_sims as f64;
    let mut criteria: Vec<CriterionTest> = names
        .iter()
        .enumerate()
        .map(|(k, name)| {
            let reference_fails: Vec<usize> = references.iter().map(|c| c.fails[k]).collect();
            let as_f = |v: &[usize]| v.iter().map(|x| *x as f64).collect::<Vec<_>>();
            CriterionTest {
                criterion: name.clone(),
                real_fails: real.fails[k],
                reference_rate: drive_sim_analysis::stats::mean(&as_f(&reference_fails)) / n_sims,
                p: monte_carlo_p(real.fails[k] as f64, &as_f(&reference_fails)),
                reference_fails,
                p_holm: f64::NAN,
            }
        })
        .collect();
    let rest: Vec<f64> = criteria.iter().skip(1).map(|c| c.p).collect();
    for (c, a) in criteria.iter_mut().skip(1).zip(holm(&rest)) {
        c.p_holm = a;
    }
    criteria[0].p_holm = criteria[0].p;
    criteria
}

/// The criteria after the verdict whose p-value (as `p` reads it) is at most `alpha`.
pub(super) fn criteria_at_most(
    criteria: &[CriterionTest],
    alpha: f64,
    p: fn(&CriterionTest) -> f64,
) -> Vec<String> {
    criteria
        .iter()
        .skip(1)
        .filter(|c| p(c) <= alpha)
        .map(|c| c.criterion.clone())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn candidate(terms: &[(&str, Option<f64>)]) -> CandidateScore {
        CandidateScore {
            label: "reference".into(),
            seed: None,
            steps: 10,
            runs: Vec::new(),
            fails: Vec::new(),
            mean_loss: 0.0,
            term_means: terms
                .iter()
                .map(|(n, v)| TermMean {
                    name: n.to_string(),
                    mean_square: *v,
                })
                .collect(),
        }
    }

    /// Each term is ranked among the references that formed it, in the real run's order; a
    /// term the real run could not form has no p.
    #[test]
    fn terms_are_ranked_as_the_loss_is() {
        let real = candidate(&[
            ("median_rho", Some(3.0)),
            ("slip_vx_m_s", Some(0.5)),
            ("step_scatter", None),
        ]);
        let refs = [
            candidate(&[("median_rho", Some(1.0)), ("slip_vx_m_s", Some(0.4))]),
            candidate(&[("median_rho", Some(4.0)), ("slip_vx_m_s", None)]),
            candidate(&[
                ("median_rho", Some(2.0)),
                ("slip_vx_m_s", Some(0.9)),
                ("step_scatter", Some(1.0)),
            ]),
            candidate(&[("median_rho", Some(0.5)), ("slip_vx_m_s", Some(0.1))]),
        ];
        let t = term_tests(&real, &refs);
        assert_eq!(t.len(), 3);
        assert_eq!(t[0].name, "median_rho");
        // One of four references at least 3.0: (1 + 1) / 5.
        assert!((t[0].p - 0.4).abs() < 1e-12);
        assert_eq!(t[0].reference_max, Some(4.0));
        assert!((t[0].reference_mean.unwrap() - 1.875).abs() < 1e-12);
        // Three references formed the map's term, one of them at least 0.5: (1 + 1) / 4.
        assert!((t[1].p - 0.5).abs() < 1e-12);
        assert!(t[2].p.is_nan() && t[2].real.is_none());
        assert_eq!(t[2].reference_max, Some(1.0));
    }

    #[test]
    fn monte_carlo_p_by_hand() {
        // 4 references, 2 of them at least 3: (1 + 2) / 5.
        assert!((monte_carlo_p(3.0, &[1.0, 3.0, 5.0, 2.0]) - 0.6).abs() < 1e-12);
        // Beyond every reference: the smallest p, 1 / 5.
        assert!((monte_carlo_p(9.0, &[1.0, 3.0, 5.0, 2.0]) - 0.2).abs() < 1e-12);
        // Below every reference: 1.
        assert_eq!(monte_carlo_p(0.0, &[1.0, 3.0, 5.0, 2.0]), 1.0);
        // Non-finite references do not count.
        assert!((monte_carlo_p(3.0, &[1.0, f64::NAN, 5.0]) - 2.0 / 3.0).abs() < 1e-12);
        assert!(monte_carlo_p(3.0, &[f64::NAN]).is_nan());
    }
}
