//! One competition between the catalogue and discovery, as two orders: the catalogue's
//! selection with discovery on top, and discovery from the base model alone (its terms and the
//! named effects its equations read). When the first order still leaves a channel flagged on
//! the training steps, the second runs, and the order whose final model scores better on the
//! validation steps is kept; within one bootstrap standard error (by step) of each other, the
//! one with fewer parameters, the catalogue's on a tie.
//!
//! Why two orders: the catalogue's stand-ins enter first and can absorb part of an effect they
//! do not describe (a controller's kinematics for a gain curve), leaving a residual that mixes
//! model state with the command's nonlinearity, which no sparse equation reads; from the base
//! model the same curve is one term in the command.

use super::candidates::Candidate;
use super::discovery::DiscoveryRound;
use super::Context;
use crate::metrics::StepErrors;
use serde::{Deserialize, Serialize};

/// One order of the competition: the model it ends with.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Contender {
    /// Validation score of its model.
    pub validation_score: f64,
    /// Continuous parameters of its effects and terms (the base parameters are common).
    pub parameters: usize,
    /// Its effects and terms.
    pub effects: Vec<String>,
}

/// The two orders compared (see the module doc).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Competition {
    /// The catalogue's selection, then discovery.
    pub catalogue_first: Contender,
    /// Discovery from the base model.
    pub discovery_first: Contender,
    /// Bootstrap standard error (by step) of the difference of their validation scores.
    pub se: f64,
    /// The order kept: `catalogue first` or `discovery first`.
    pub kept: String,
    /// Why, in words.
    pub why: String,
    /// Discovery's rounds from the base model.
    pub rounds: Vec<DiscoveryRound>,
    /// Its backward pass.
    #[serde(default)]
    pub backward: Vec<super::selection::BackwardStep>,
}

/// The competition's rule on two contenders whose validation scores differ with standard
/// error `se`: whether discovery first (`b`) wins, and why.
fn decide(a: &Contender, b: &Contender, se: f64) -> (bool, String) {
    let d = a.validation_score - b.validation_score;
    if d > se {
        (
            true,
            format!(
                "discovery from the base model scores {:.3} on validation against {:.3} (± {se:.3})",
                b.validation_score, a.validation_score
            ),
        )
    } else if d < -se {
        (
            false,
            format!(
                "the catalogue's selection scores {:.3} on validation against {:.3} (± {se:.3})",
                a.validation_score, b.validation_score
            ),
        )
    } else {
        let fewer = b.parameters < a.parameters;
        (
            fewer,
            format!(
                "within one standard error ({:.3} against {:.3}, ± {se:.3}): the fewer parameters win ({} against {})",
                a.validation_score,
                b.validation_score,
                if fewer { b.parameters } else { a.parameters },
                if fewer { a.parameters } else { b.parameters }
            ),
        )
    }
}

/// What [`compete`] compares of an order's final model: its validation errors and its effects.
pub struct Order<'a> {
    /// Its validation errors.
    pub validation: &'a [StepErrors],
    /// Its effects and terms.
    pub selected: &'a [Candidate],
}

/// Which order wins ([`Competition`]): the lower validation score, unless the two lie within
/// one bootstrap standard error of each other, where the fewer parameters win (the
/// catalogue's order on a tie). Returns the competition without its rounds, and whether
/// discovery first won.
pub fn compete(ctx: &Context<'_>, catalogue: &Order, discovery: &Order) -> (Competition, bool) {
    let contender = |o: &Order| Contender {
        validation_score: crate::metrics::score(o.validation, &ctx.floor),
        parameters: o
            .selected
            .iter()
            .map(|c| c.params.iter().filter(|p| !p.discrete).count())
            .sum(),
        effects: o.selected.iter().map(|c| c.name.clone()).collect(),
    };
    let (a, b) = (contender(catalogue), contender(discovery));
    let se = super::candidates::bootstrap_reduction_se(
        catalogue.validation,
        discovery.validation,
        &ctx.floor,
        ctx.opts.rule.bootstrap_samples,
        ctx.opts.seed ^ 0xc0e7,
    );
    let (discovery_wins, why) = decide(&a, &b, se);
    (
        Competition {
            catalogue_first: a,
            discovery_first: b,
            se,
            kept: if discovery_wins {
                "discovery first"
            } else {
                "catalogue first"
            }
            .into(),
            why,
            rounds: Vec::new(),
            backward: Vec::new(),
        },
        discovery_wins,
    )
}

#[cfg(test)]
mod competition_tests {
    use super::*;

    fn contender(score: f64, parameters: usize) -> Contender {
        Contender {
            validation_score: score,
            parameters,
            effects: Vec::new(),
        }
    }

    #[test]
    fn the_lower_score_wins_beyond_one_standard_error_else_the_fewer_parameters() {
        // Discovery first clearly better, though with more parameters.
        assert!(decide(&contender(10.0, 2), &contender(4.0, 9), 1.0).0);
        // The catalogue clearly better.
        assert!(!decide(&contender(4.0, 9), &contender(10.0, 2), 1.0).0);
        // Within one SE: the fewer parameters, whichever order has them.
        let (wins, why) = decide(&contender(5.0, 4), &contender(4.5, 2), 1.0);
        assert!(
            wins && why.contains("fewer parameters win (2 against 4)"),
            "{why}"
        );
        assert!(!decide(&contender(4.5, 2), &contender(5.0, 4), 1.0).0);
        // A tie in parameters keeps the catalogue's order.
        assert!(!decide(&contender(5.0, 3), &contender(4.5, 3), 1.0).0);
    }
}
