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
//! 3. Every term of the loss on which the calibrated model lies [`Rule::cover_beyond`]
//!    thresholds or more from the robot, and which no knob taken moves towards the robot's,
//!    gets the knob whose screening moved it there most (by at least [`MOVES_A_TERM`]), within
//!    the same numbers of knobs and coordinates (not the cosine: that knob moves a term the
//!    others do not), when that knob's best point did not raise the loss as a whole by more
//!    than [`Rule::max_cover_harm`], and when it pushes no term the calibrated model meets past
//!    [`Rule::cover_beyond`]: a knob that meets one criterion by failing another trades them,
//!    and a twin tuned on the choosing steps then carries the new failure to the steps it is
//!    judged on (the Husky's yaw-rate limit moved its ρ the right way at an eighth of its box
//!    and its body T/U area from 0.00 to 2.44 thresholds). A gain on the whole loss at one step from the calibrated
//!    value conflates the direction a knob moves a failing criterion with the size of the step:
//!    the Husky's ICR offset moved its lateral-slip map the right way and the loss the wrong
//!    way at an eighth of its box, and the search then found the value that helps. Terms are
//!    taken largest first.
//! 4. The search's budget is [`Rule::evaluations_per_coordinate`] points per coordinate plus
//!    [`Rule::base_evaluations`], times the command's budget factor.

use crate::screen::{KnobScreen, Screening};
use serde::{Deserialize, Serialize};

/// Smallest change of a loss term, in thresholds, that counts as moving it (the report's "moved
/// the right way by" uses the same).
pub const MOVES_A_TERM: f64 = 0.25;

/// The rule's settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
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
    /// A loss term this far from the robot's (thresholds) gets a knob that moves it.
    pub cover_beyond: f64,
    /// Most a knob taken for a term may have raised the whole loss at its best screening point.
    pub max_cover_harm: f64,
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
            cover_beyond: 1.0,
            max_cover_harm: 1.0,
        }
    }
}

impl Rule {
    /// The rule of the second round ([`crate::pass`]'s refinement), from the tuned twin: the
    /// same gains and tests, at most 2 knobs and 2 coordinates. Why so few: what is left after
    /// the first round is a correction of a knob or two that mattered only once the first
    /// round's were set (the Warthog's lateral friction on asphalt), and the command's time
    /// target leaves room for a short second search, not a second full one.
    pub fn refinement() -> Self {
        Self {
            max_knobs: 2,
            max_coordinates: 2,
            ..Self::default()
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
    /// Every candidate with a positive gain, largest first, then the knobs step 3 weighed for a
    /// term the calibrated model fails, with the decision.
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
            "knobs whose best screening point lowers the loss by at least {:.0} % of the calibrated model's or by {} where that is less, largest gain first, at most {} knobs and {} search coordinates (a ground's knob once per ground), none whose term changes are parallel (cosine > {}) to one taken; then each term of the loss {} thresholds or more from the robot's that no knob taken moves towards it gets the knob that moves it most (by {} threshold or more), within the same numbers of knobs and coordinates, if that knob's best screening point raised the loss by at most {} and pushed no term within {} thresholds of the robot's past them; {} search points per coordinate plus {}, times the budget factor",
            100.0 * self.min_gain_fraction,
            self.min_gain_absolute,
            self.max_knobs,
            self.max_coordinates,
            self.max_cosine,
            self.cover_beyond,
            MOVES_A_TERM,
            self.max_cover_harm,
            self.cover_beyond,
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
            let cost = coordinates_of(k, grounds);
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
            } else if let Some(full) = self.full(taken.len(), coordinates, cost) {
                full
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
        self.cover(screening, grounds, &mut taken, &mut coordinates, &mut considered);
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

impl Rule {
    /// Step 3: a knob for each term the calibrated model fails that no knob taken moves.
    fn cover<'a>(
        &self,
        screening: &'a Screening,
        grounds: usize,
        taken: &mut Vec<&'a KnobScreen>,
        coordinates: &mut usize,
        considered: &mut Vec<Considered>,
    ) {
        let l0 = screening.start.loss.unwrap_or(f64::NAN);
        let mut failing: Vec<&(String, f64)> = screening
            .start
            .terms
            .iter()
            .filter(|(_, v)| v.abs() >= self.cover_beyond)
            .collect();
        failing.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
        for (term, v) in failing {
            // How far a knob moves the term towards the robot's (positive: the right way).
            let towards = |k: &KnobScreen| towards_robot(change_of(k, term), *v);
            if taken.iter().any(|t| towards(t) >= MOVES_A_TERM) {
                continue;
            }
            let movers = || {
                screening
                    .knobs
                    .iter()
                    .filter(|k| !taken.iter().any(|t| t.knob.name == k.knob.name))
                    .filter(|k| {
                        k.gain.is_finite() && k.gain >= -self.max_cover_harm && towards(k) >= MOVES_A_TERM
                    })
            };
            let most = |a: &&KnobScreen, b: &&KnobScreen| towards(a).total_cmp(&towards(b));
            let best = movers()
                .filter(|k| breaks(k, &screening.start.terms, self.cover_beyond).is_none())
                .max_by(most);
            // The knob that moves the term most but meets it by failing another criterion is
            // passed by, and the report says so: it trades one criterion for another.
            let traded = movers()
                .max_by(most)
                .and_then(|k| breaks(k, &screening.start.terms, self.cover_beyond).map(|b| (k, b)));
            if let Some((k, (broken, from, to))) = traded {
                let why = format!(
                    "would move `{term}` {:.2} towards the robot's, but pushes `{broken}` past its threshold ({from:+.2} -> {to:+.2})",
                    towards(k)
                );
                note(considered, k, l0, false, why);
            }
            let Some(k) = best else { continue };
            // No cosine test here: however parallel its changes are to a knob taken, this knob
            // moves a term that one does not, which the search can tell them apart by.
            let cost = coordinates_of(k, grounds);
            let blocked = self.full(taken.len(), *coordinates, cost);
            let why = match &blocked {
                None => format!(
                    "moves `{term}` ({v:+.2} thresholds from the robot's) {:.2} towards it, which no knob taken does",
                    towards(k)
                ),
                Some(b) => format!("would move `{term}` {:.2} towards the robot's, but {b}", towards(k)),
            };
            if blocked.is_none() {
                taken.push(k);
                *coordinates += cost;
            }
            note(considered, k, l0, blocked.is_none(), why);
        }
    }
}

impl Rule {
    /// Why one more knob of `cost` coordinates cannot be taken beside `knobs` knobs and
    /// `coordinates` coordinates (`None`: it can).
    fn full(&self, knobs: usize, coordinates: usize, cost: usize) -> Option<String> {
        if knobs >= self.max_knobs {
            Some(format!("{} knobs taken already", self.max_knobs))
        } else if coordinates + cost > self.max_coordinates {
            Some(format!(
                "its {cost} coordinates would exceed {} with the {coordinates} taken",
                self.max_coordinates
            ))
        } else {
            None
        }
    }
}

/// Records what step 3 decided about knob `k` (`l0`: the calibrated model's loss): its entry
/// replaces the one of a knob the gains left out, and never that of a knob taken.
fn note(considered: &mut Vec<Considered>, k: &KnobScreen, l0: f64, chosen: bool, why: String) {
    let entry = Considered {
        knob: k.knob.name.clone(),
        gain: k.gain,
        relative_gain: k.gain / l0,
        chosen,
        why,
    };
    match considered.iter_mut().find(|c| c.knob == entry.knob) {
        Some(c) if !c.chosen => *c = entry,
        Some(_) => {}
        None => considered.push(entry),
    }
}

/// The first term the calibrated model meets (within `beyond` thresholds of the robot's) that
/// `k`'s best screening point pushes to `beyond` or past it, with the term before and after.
fn breaks(k: &KnobScreen, start: &[(String, f64)], beyond: f64) -> Option<(String, f64, f64)> {
    start.iter().find_map(|(name, v)| {
        let to = v + change_of(k, name);
        (v.abs() < beyond && to.abs() >= beyond).then(|| (name.clone(), *v, to))
    })
}

/// How much `k`'s best screening point changed the loss term `term` (0 when it has none).
fn change_of(k: &KnobScreen, term: &str) -> f64 {
    k.term_change
        .iter()
        .find(|(n, _)| n == term)
        .map_or(0.0, |(_, d)| *d)
}

/// The search coordinates a knob takes: a ground's knob one per ground.
fn coordinates_of(k: &KnobScreen, grounds: usize) -> usize {
    k.knob.params.len() * if k.knob.terrain_side { grounds } else { 1 }
}

/// How far a change `change` of a loss term at `term` moves it towards the robot's (positive:
/// the right way), both in thresholds.
pub(crate) fn towards_robot(change: f64, term: f64) -> f64 {
    if term > 0.0 {
        -change
    } else {
        change
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
    fn a_term_far_from_the_robot_gets_the_knob_that_moves_it_unless_that_knob_harms_the_whole() {
        let mut s = screening(vec![
            knob("scatter", 1, false, 3.0, &[("t_area", 1.3), ("slip_vy", 0.0)]),
            // Moves the lateral map most, but raised the loss by five thresholds.
            knob("kinematics", 2, false, -5.0, &[("slip_vy", -0.9)]),
            // Moves it less, and raised the loss by less than one threshold.
            knob("icr", 1, false, -0.4, &[("slip_vy", -0.31)]),
            knob("radius", 1, false, -0.2, &[("rho", 0.2)]),
            // Parallel to the scatter (cosine 0.99), but it moves ρ, which the scatter does not.
            knob("limit", 1, false, -0.3, &[("t_area", 3.0), ("rho", 0.52)]),
        ]);
        s.start.loss = Some(10.0);
        s.start.terms = vec![
            ("t_area".into(), -2.2),
            ("slip_vy".into(), 1.16),
            ("rho".into(), -1.3),
            ("vx".into(), 0.4),
        ];
        let c = Rule::default().choose(&s, 1, 1.0);
        // The area is covered by the scatter, ρ by the limit however parallel to it, the map
        // by the ICR offset; the term within its threshold asks for nothing.
        assert_eq!(c.chosen, vec!["scatter", "limit", "icr"], "{:#?}", c.considered);
        let icr = c.considered.iter().find(|k| k.knob == "icr").unwrap();
        assert!(icr.chosen && icr.why.contains("`slip_vy`"), "{}", icr.why);
        assert!(c
            .considered
            .iter()
            .all(|k| k.knob != "kinematics" && k.knob != "radius"));
        assert_eq!(c.coordinates, 3);
        assert_eq!(c.max_evaluations, 50);

        // Every term within its threshold: the rule adds nothing to the gains' choice.
        s.start.terms = vec![("t_area".into(), -0.9), ("slip_vy".into(), 0.8)];
        let c = Rule::default().choose(&s, 1, 1.0);
        assert_eq!(c.chosen, vec!["scatter"]);
    }

    #[test]
    fn a_knob_that_meets_one_criterion_by_failing_another_does_not_cover_it() {
        let mut s = screening(vec![
            knob("scatter", 1, false, 3.0, &[("wheels", 2.0)]),
            // Moves ρ most, but takes the body's area from within its threshold to 2.4 beyond.
            knob("limit", 1, false, -0.3, &[("rho", 0.52), ("body", 2.44)]),
            // Moves ρ a little less and breaks nothing.
            knob("torsion", 1, false, 0.5, &[("rho", 0.51), ("body", 0.3)]),
        ]);
        s.start.loss = Some(10.0);
        s.start.terms = vec![
            ("wheels".into(), -2.2),
            ("rho".into(), -1.33),
            ("body".into(), 0.0),
        ];
        let c = Rule::default().choose(&s, 1, 1.0);
        assert_eq!(c.chosen, vec!["scatter", "torsion"], "{:#?}", c.considered);
        let limit = c.considered.iter().find(|k| k.knob == "limit").unwrap();
        assert!(
            !limit.chosen
                && limit
                    .why
                    .contains("pushes `body` past its threshold (+0.00 -> +2.44)"),
            "{}",
            limit.why
        );
        // With no other knob that moves ρ, the term stays uncovered rather than traded.
        s.knobs.pop();
        let c = Rule::default().choose(&s, 1, 1.0);
        assert_eq!(c.chosen, vec!["scatter"], "{:#?}", c.considered);
        // A term beyond its threshold already is not one the knob can break: the limit's move
        // of the body's area from 1.2 to 3.6 is harm the loss as a whole weighs.
        s.start.terms[2].1 = 1.2;
        let c = Rule::default().choose(&s, 1, 1.0);
        assert_eq!(c.chosen, vec!["scatter", "limit"], "{:#?}", c.considered);
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
