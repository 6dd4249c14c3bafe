//! The rule that picks what to tune from the screening: how many knobs, which, and the
//! search's budget. It sees only the screening, which ran on the choosing steps.
//!
//! 1. A knob is a candidate when its best screening point lowers the loss by at least
//!    [`Rule::min_gain_fraction`] of the calibrated model's loss, or by
//!    [`Rule::min_gain_absolute`] (one criterion's threshold: the loss is a sum of squared
//!    terms, each 1 at its verdict's threshold) where that is less: a smaller gain is within
//!    what a few seeds' paths move the loss by, and a twin far from its robot (a loss of tens)
//!    must not hide every knob but the largest behind a tenth of it.
//! 2. Candidates are taken by gain, largest first, up to [`Rule::max_knobs`] knobs and
//!    [`Rule::max_coordinates`] coordinates of the search (a ground's knob counts once per
//!    ground). A knob whose term changes are nearly parallel to a knob already taken (cosine
//!    above [`Rule::max_cosine`]) is left out: it explains the same difference the same way,
//!    and two such knobs make a ridge the search cannot resolve.
//! 3. The search's budget is [`Rule::evaluations_per_coordinate`] points per coordinate plus
//!    [`Rule::base_evaluations`], times the command's budget factor.

use crate::screen::{KnobScreen, Screening};
use serde::{Deserialize, Serialize};

/// The rule's settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Rule {
    /// Smallest gain a candidate knob shows, as a fraction of the calibrated model's loss...
    pub min_gain_fraction: f64,
    /// ... or in loss units, where that is less.
    pub min_gain_absolute: f64,
    /// Most knobs tuned.
    pub max_knobs: usize,
    /// Most coordinates of the search (the design has one Halton base per coordinate).
    pub max_coordinates: usize,
    /// Largest cosine between the term changes of two knobs both tuned.
    pub max_cosine: f64,
    /// Search points per coordinate.
    pub evaluations_per_coordinate: usize,
    /// Search points besides.
    pub base_evaluations: usize,
}

impl Default for Rule {
    fn default() -> Self {
        Self {
            min_gain_fraction: 0.10,
            min_gain_absolute: 1.0,
            max_knobs: 4,
            max_coordinates: 5,
            max_cosine: 0.95,
            evaluations_per_coordinate: 10,
            base_evaluations: 20,
        }
    }
}

/// What the rule decided about one knob.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Considered {
    /// The knob.
    pub knob: String,
    /// Its screening gain.
    pub gain: f64,
    /// The gain over the calibrated model's loss.
    pub relative_gain: f64,
    /// Tuned.
    pub chosen: bool,
    /// Why, in words.
    pub why: String,
}

/// The knobs tuned and the budget.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Choice {
    /// The rule's settings.
    pub rule: Rule,
    /// The rule in words.
    pub rule_text: String,
    /// The knobs tuned, in the order taken.
    pub chosen: Vec<String>,
    /// Every candidate with a positive gain, largest first, with the decision.
    pub considered: Vec<Considered>,
    /// Coordinates of the search.
    pub coordinates: usize,
    /// Most points the search evaluates.
    pub max_evaluations: usize,
}

impl Rule {
    /// The rule in words (`twin.json`, the report).
    pub fn text(&self) -> String {
        format!(
            "knobs whose best screening point lowers the loss by at least {:.0} % of the calibrated model's or by {} where that is less, largest gain first, at most {} knobs and {} search coordinates (a ground's knob once per ground), none whose term changes are parallel (cosine > {}) to one taken; {} search points per coordinate plus {}, times the budget factor",
            100.0 * self.min_gain_fraction,
            self.min_gain_absolute,
            self.max_knobs,
            self.max_coordinates,
            self.max_cosine,
            self.evaluations_per_coordinate,
            self.base_evaluations
        )
    }

    /// Applies the rule to `screening` for `grounds` grounds with the budget factor `budget`.
    pub fn choose(&self, screening: &Screening, grounds: usize, budget: f64) -> Choice {
        let l0 = screening.start.loss.unwrap_or(f64::NAN);
        let min_gain = (self.min_gain_fraction * l0).min(self.min_gain_absolute);
        let mut order: Vec<&KnobScreen> = screening.knobs.iter().filter(|k| k.gain > 0.0).collect();
        order.sort_by(|a, b| b.gain.total_cmp(&a.gain));
        let mut taken: Vec<&KnobScreen> = Vec::new();
        let mut coordinates = 0;
        let mut considered = Vec::new();
        for k in order {
            let relative = k.gain / l0;
            let cost = k.knob.params.len() * if k.knob.terrain_side { grounds } else { 1 };
            let parallel = taken
                .iter()
                .find(|t| cosine(&t.term_change, &k.term_change) > self.max_cosine);
            // A NaN gain (no calibrated loss) is below any threshold.
            let why = if relative.is_nan() || k.gain < min_gain {
                format!(
                    "gain {:.2} ({:.1} % of the loss), below {min_gain:.2}",
                    k.gain,
                    100.0 * relative
                )
            } else if taken.len() >= self.max_knobs {
                format!("{} knobs taken already", self.max_knobs)
            } else if coordinates + cost > self.max_coordinates {
                format!(
                    "its {cost} coordinates would exceed {} with the {coordinates} taken",
                    self.max_coordinates
                )
            } else if let Some(t) = parallel {
                format!(
                    "moves the loss's terms as `{}` does (cosine > {})",
                    t.knob.name, self.max_cosine
                )
            } else {
                String::new()
            };
            let chosen = why.is_empty();
            if chosen {
                taken.push(k);
                coordinates += cost;
            }
            considered.push(Considered {
                knob: k.knob.name.clone(),
                gain: k.gain,
                relative_gain: relative,
                chosen,
                why: if chosen {
                    format!("gain {:.1} % of the loss", 100.0 * relative)
                } else {
                    why
                },
            });
        }
        let budget_points =
            (self.evaluations_per_coordinate * coordinates + self.base_evaluations) as f64 * budget;
        Choice {
            rule: *self,
            rule_text: self.text(),
            chosen: taken.iter().map(|k| k.knob.name.clone()).collect(),
            considered,
            coordinates,
            max_evaluations: (budget_points.round() as usize).max(coordinates + 2),
        }
    }
}

/// Cosine between two term-change vectors (matched by name; 0 when either is zero).
fn cosine(a: &[(String, f64)], b: &[(String, f64)]) -> f64 {
    let dot: f64 = a
        .iter()
        .filter_map(|(n, x)| b.iter().find(|(m, _)| m == n).map(|(_, y)| x * y))
        .sum();
    let norm = |v: &[(String, f64)]| v.iter().map(|(_, x)| x * x).sum::<f64>().sqrt();
    let d = norm(a) * norm(b);
    if d > 0.0 {
        dot / d
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::closed::PointScore;
    use crate::knobs::KnobInfo;

    fn knob(name: &str, params: usize, terrain: bool, gain: f64, change: &[(&str, f64)]) -> KnobScreen {
        KnobScreen {
            knob: KnobInfo {
                name: name.into(),
                params: (0..params).map(|i| format!("{name}_{i}")).collect(),
                terrain_side: terrain,
            },
            points: Vec::new(),
            best: Some(0),
            gain,
            term_change: change.iter().map(|(n, v)| (n.to_string(), *v)).collect(),
        }
    }

    fn screening(knobs: Vec<KnobScreen>) -> Screening {
        Screening {
            seeds: vec![0, 1],
            start: PointScore {
                loss: Some(20.0),
                seed_losses: vec![Some(20.0), Some(20.0)],
                terms: Vec::new(),
                error: None,
            },
            knobs,
            runs: 0,
        }
    }

    #[test]
    fn takes_large_gains_first_and_leaves_out_small_parallel_and_excess_knobs() {
        let s = screening(vec![
            knob("small", 1, false, 0.5, &[("a", -1.0)]),
            knob("line", 2, false, 10.0, &[("a", -3.0), ("b", 0.5)]),
            knob("twin_of_line", 1, false, 8.0, &[("a", -6.0), ("b", 1.0)]),
            knob("lateral", 1, true, 6.0, &[("c", -2.0)]),
            knob("droop", 1, false, 5.0, &[("b", -2.0)]),
            knob("lag", 1, false, 4.0, &[("d", -2.0)]),
            knob("fifth", 1, false, 3.0, &[("e", -2.0)]),
        ]);
        let c = Rule::default().choose(&s, 1, 1.0);
        assert_eq!(
            c.chosen,
            vec!["line", "lateral", "droop", "lag"],
            "{:#?}",
            c.considered
        );
        let why = |c: &Choice, n: &str| c.considered.iter().find(|k| k.knob == n).unwrap().why.clone();
        assert!(
            why(&c, "twin_of_line").contains("as `line` does"),
            "{}",
            why(&c, "twin_of_line")
        );
        assert!(why(&c, "fifth").contains("4 knobs taken"), "{}", why(&c, "fifth"));
        assert!(why(&c, "small").contains("below 1.00"), "{}", why(&c, "small"));
        assert_eq!(c.coordinates, 5);
        assert_eq!(c.max_evaluations, 70);
        // Two grounds: the ground's knob counts twice, the budget scales.
        let c2 = Rule::default().choose(&s, 2, 2.0);
        assert_eq!(
            c2.chosen,
            vec!["line", "lateral", "droop"],
            "{:#?}",
            c2.considered
        );
        assert!(why(&c2, "lag").contains("exceed 5"), "{}", why(&c2, "lag"));
        assert_eq!(c2.max_evaluations, 2 * (10 * 5 + 20));
    }

    #[test]
    fn far_from_its_robot_a_gain_of_one_threshold_is_enough() {
        // A loss of 80: a tenth of it (8) would leave every knob but the first out.
        let mut s = screening(vec![
            knob("scatter", 1, false, 45.0, &[("a", -6.0)]),
            knob("radius", 1, false, 4.0, &[("b", -2.0)]),
            knob("limit", 1, false, 0.8, &[("c", -1.0)]),
        ]);
        s.start.loss = Some(80.0);
        let c = Rule::default().choose(&s, 1, 1.0);
        assert_eq!(c.chosen, vec!["scatter", "radius"], "{:#?}", c.considered);
    }

    #[test]
    fn nothing_helps_nothing_is_tuned() {
        let s = screening(vec![
            knob("a", 1, false, -3.0, &[]),
            knob("b", 1, false, 0.5, &[]),
        ]);
        let c = Rule::default().choose(&s, 1, 1.0);
        assert!(c.chosen.is_empty());
        assert_eq!(c.coordinates, 0);
    }
}
