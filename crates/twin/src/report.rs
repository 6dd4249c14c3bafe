//! What the twin command found (`twin.json`) and the report that opens on the answer
//! (`twin.md`): can `compare` tell the twin from the robot, criterion by criterion, and what
//! was changed to get there.

use crate::input::{Ground, RunLog, RunSummary};
use crate::judging::{shortfalls, Judgement, LeftOut, Shortfall};
use crate::knobs::KnobInfo;
use crate::pass::{Pass, PassReport, StageTime};
use crate::TwinOptions;
use drive_sim_calibration::twin::TwinCheck;
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;

/// A ground of the twin.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GroundInfo {
    /// Its name (the runs' terrain label).
    pub name: String,
    /// Its runs.
    pub runs: Vec<String>,
    /// Its terrain file in `twin/`.
    pub terrain_file: String,
}

/// A pass and the judgements of its twin.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PassJudged {
    /// What the pass did.
    pub pass: PassReport,
    /// Each ground's twin judged.
    pub judgements: Vec<Judgement>,
}

/// The closed-loop check of a ground's twin as written.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GroundCheck {
    /// The ground.
    pub ground: String,
    /// Which model the files hold: `tuned` (the final pass's twin) or `calibrated` (its
    /// calibrated model, when the tuned one did not run).
    pub written: String,
    /// The check's run.
    pub check: TwinCheck,
}

/// Everything the twin command found (`twin.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TwinReport {
    /// The robot.
    pub robot: String,
    /// The runs given.
    pub runs: Vec<RunSummary>,
    /// Their grounds.
    pub grounds: Vec<GroundInfo>,
    /// The answer in words: can compare tell the twin from the robot (the report's opening).
    pub answer: String,
    /// Chosen on the odd steps, judged on the even ones.
    pub held_out: PassJudged,
    /// Chosen on every step: the twin written, judged on the same steps with fresh runs.
    #[serde(rename = "final")]
    pub final_twin: PassJudged,
    /// Each run left out (several runs).
    pub leave_one_out: Vec<LeftOut>,
    /// Every criterion a judgement flags, and why.
    pub cannot: Vec<Shortfall>,
    /// The twin files' closed-loop check, per ground.
    pub twin_checks: Vec<GroundCheck>,
    /// The knob pool the screening measured.
    pub knobs: Vec<KnobInfo>,
    /// Every stage's wall time, in order.
    pub times: Vec<StageTime>,
    /// The whole command's wall time, s.
    pub seconds: f64,
    /// Options.
    pub options: TwinOptions,
}

/// What [`assemble`] puts together.
pub(crate) struct Parts<'a> {
    pub(crate) runs: &'a [RunLog],
    pub(crate) grounds: &'a [Ground],
    pub(crate) held: (&'a Pass, Vec<Judgement>),
    pub(crate) fin: (&'a Pass, Vec<Judgement>),
    pub(crate) left_out: Vec<LeftOut>,
    pub(crate) checks: Vec<(drive_sim_calibration::twin::TwinCheck, bool)>,
    pub(crate) times: Vec<StageTime>,
    pub(crate) options: TwinOptions,
    pub(crate) seconds: f64,
}

/// The terrain file of a ground in `twin/`: `terrain.toml` for one ground, else
/// `terrain_<ground>.toml`.
pub fn terrain_file(ground: &str, grounds: usize) -> String {
    if grounds == 1 {
        "terrain.toml".into()
    } else {
        format!("terrain_{ground}.toml")
    }
}

/// The report from the passes, judgements and checks.
pub(crate) fn assemble(p: Parts) -> TwinReport {
    let n = p.grounds.len();
    let (held, held_j) = p.held;
    let (fin, fin_j) = p.fin;
    let mut cannot = Vec::new();
    for (label, pass, judgements) in [("held out", held, &held_j), ("final", fin, &fin_j)] {
        for j in judgements {
            cannot.extend(shortfalls(j, label, &pass.report, n));
        }
    }
    let mut times: Vec<StageTime> = Vec::new();
    for (label, pass) in [("held out", held), ("final", fin)] {
        times.extend(pass.report.times.iter().map(|t| StageTime {
            stage: format!("{label}: {}", t.stage),
            seconds: t.seconds,
        }));
    }
    times.extend(p.times);
    let mut report = TwinReport {
        robot: p.runs[0].log.meta.robot.clone(),
        runs: p.runs.iter().map(RunLog::summary).collect(),
        grounds: p
            .grounds
            .iter()
            .map(|g| GroundInfo {
                name: g.name.clone(),
                runs: g.runs.iter().map(|&i| p.runs[i].log.meta.name.clone()).collect(),
                terrain_file: terrain_file(&g.name, n),
            })
            .collect(),
        answer: String::new(),
        held_out: PassJudged {
            pass: held.report.clone(),
            judgements: held_j,
        },
        final_twin: PassJudged {
            pass: fin.report.clone(),
            judgements: fin_j,
        },
        leave_one_out: p.left_out,
        cannot,
        twin_checks: p
            .grounds
            .iter()
            .zip(p.checks)
            .map(|(g, (check, tuned))| GroundCheck {
                ground: g.name.clone(),
                written: if tuned { "tuned" } else { "calibrated" }.into(),
                check,
            })
            .collect(),
        knobs: fin.knobs.iter().map(|k| k.info()).collect(),
        times,
        seconds: p.seconds,
        options: p.options,
    };
    report.answer = answer(&report);
    report
}

/// One judgement in words.
fn verdict_line(j: &Judgement) -> String {
    let o = &j.outcome;
    format!(
        "compare **{}** tell the twin from the robot (p {:.3} with {} references; mean loss {:.2} against the robot, {:.2} against the twin's own runs)",
        if o.indistinguishable { "cannot" } else { "can" },
        o.loss.p,
        o.references.len(),
        o.loss.real,
        drive_sim_analysis::stats::mean(&o.loss.references)
    )
}

/// The answer: every judgement, one line each.
fn answer(r: &TwinReport) -> String {
    let mut s = String::new();
    for j in &r.held_out.judgements {
        let _ = writeln!(
            s,
            "- Held out ({}: chosen on the odd steps, judged on the {} even steps it never saw): {}{}.",
            j.ground,
            j.outcome.real_steps_analysed,
            verdict_line(j),
            yardstick_words(j, "steps the twin was chosen on")
        );
    }
    for j in &r.final_twin.judgements {
        let _ = writeln!(
            s,
            "- The twin written ({}: chosen on every step, judged on the same {} steps with fresh runs, not held out): {}.",
            j.ground, j.outcome.real_steps_analysed, verdict_line(j)
        );
    }
    for l in &r.leave_one_out {
        match &l.judgement {
            Some(j) => {
                let _ = writeln!(
                    s,
                    "- Made without `{}` (from {}), judged on it: {}{}.",
                    l.run,
                    l.made_from.join(", "),
                    verdict_line(j),
                    yardstick_words(j, "other run")
                );
            }
            None => {
                let _ = writeln!(
                    s,
                    "- `{}` left out: {}.",
                    l.run,
                    l.note.clone().unwrap_or_default()
                );
            }
        }
    }
    s
}

/// The robot's own difference beside a judgement, in words; `what` names the robot's own
/// steps compared (`other run`, `steps the twin was chosen on`).
fn yardstick_words(j: &Judgement, what: &str) -> String {
    j.outcome
        .yardsticks
        .iter()
        .map(|y| {
            format!(
                "; the robot's own {what} (`{}`): loss {} against it ({}), the twin's runs {:.2}; the yardstick test (that loss ranked among {} runs of the twin drawn as those steps were): {} p {:.3}",
                y.other,
                y.loss.map_or("-".into(), |l| format!("{l:.2}")),
                if y.reproduces {
                    "compare's verdict: reproduces"
                } else {
                    "compare's verdict: differs"
                },
                y.twin_mean_loss,
                y.twin_run_losses.len(),
                if y.twin_as_close {
                    "no farther than the robot's own steps,"
                } else {
                    "farther than the robot's own steps,"
                },
                y.p_twin_farther
            )
        })
        .collect()
}

/// `twin.md`.
pub fn markdown(r: &TwinReport) -> String {
    let mut s = format!(
        "# Twin of the {} from {}\n\n",
        r.robot,
        r.runs
            .iter()
            .map(|x| x.dataset.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    );
    s.push_str("## Can compare tell the twin from the robot?\n\n");
    s.push_str(&r.answer);
    criteria_table(&mut s, r);
    changed(&mut s, r);
    choice(&mut s, r);
    if !r.cannot.is_empty() {
        s.push_str("\n## What it cannot do (yet)\n\nEvery criterion a judgement flags (its own p ≤ 0.05, uncorrected), with the twin's difference and what moves it:\n\n| judgement | ground | criterion | p | twin − robot (thresholds) | why |\n|---|---|---|---|---|---|\n");
        for c in &r.cannot {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {:.3} | {} | {} |",
                c.judgement,
                c.ground,
                c.criterion,
                c.p,
                c.term.map_or("-".into(), |v| format!("{v:+.2}")),
                c.why
            );
        }
    }
    s.push_str("\n## Stages and times\n\n| stage | wall time |\n|---|---|\n");
    for t in &r.times {
        let _ = writeln!(s, "| {} | {:.1} s |", t.stage, t.seconds);
    }
    let _ = writeln!(s, "| **total** | **{:.1} s** |", r.seconds);
    s.push_str("\n(The held-out judgement runs beside the final pass's calibration, which keeps mostly one core busy: the stages' times add up to more than the total.)\n");
    s.push_str("\n## The twin's files\n\n");
    for c in &r.twin_checks {
        let g = r.grounds.iter().find(|g| g.name == c.ground);
        let _ = writeln!(
            s,
            "- `twin/robot.toml` + `twin/{}` ({}, the {} model): a {}-step DRIVE {}.",
            g.map_or("terrain.toml", |g| g.terrain_file.as_str()),
            c.ground,
            c.written,
            c.check.steps,
            if c.check.ran {
                format!("completed ({} interruptions)", c.check.interruptions.unwrap_or(0))
            } else {
                format!("stopped: {}", c.check.error.clone().unwrap_or_default())
            }
        );
    }
    let terrains: Vec<String> = r
        .grounds
        .iter()
        .map(|g| format!("`held_out/{}`", g.terrain_file))
        .collect();
    let _ = writeln!(
        s,
        "- `held_out/robot.toml` + {}: the held-out twin, chosen on the odd steps, as judged on the even ones{} (`drive-sim judge RUN --real-steps even --robot held_out/robot.toml --terrain held_out/{} --seed S` judges it again).",
        terrains.join(", "),
        r.held_out
            .judgements
            .first()
            .map_or(String::new(), |j| format!(" with seed {}", j.outcome.options.seed)),
        r.grounds
            .first()
            .map_or("terrain.toml", |g| g.terrain_file.as_str()),
    );
    s
}

/// The criteria of every judgement side by side.
fn criteria_table(s: &mut String, r: &TwinReport) {
    let all: Vec<(&str, &Judgement)> = r
        .held_out
        .judgements
        .iter()
        .map(|j| ("held out", j))
        .chain(r.final_twin.judgements.iter().map(|j| ("final", j)))
        .chain(
            r.leave_one_out
                .iter()
                .filter_map(|l| l.judgement.as_ref().map(|j| ("left out", j))),
        )
        .collect();
    let Some((_, first)) = all.first() else {
        return;
    };
    s.push_str("\n## Criterion by criterion\n\nRuns of the twin failing each criterion against the robot, and the Monte Carlo p-value of that count among the twin's runs in the robot's place (`judge`):\n\n| criterion |");
    for (label, j) in &all {
        let _ = write!(s, " {label}: {} ({}) |", j.against, j.steps);
    }
    s.push_str("\n|---|");
    s.push_str(&"---|".repeat(all.len()));
    s.push('\n');
    for (i, c) in first.outcome.criteria.iter().enumerate() {
        let _ = write!(s, "| {} |", c.criterion);
        for (_, j) in &all {
            match j.outcome.criteria.get(i) {
                Some(d) => {
                    let _ = write!(
                        s,
                        " {} of {}, p {:.2} |",
                        d.real_fails,
                        j.outcome.sim_seeds.len(),
                        d.p
                    );
                }
                None => s.push_str(" - |"),
            }
        }
        s.push('\n');
    }
    s.push_str("| **loss (decides)** |");
    for (_, j) in &all {
        let _ = write!(s, " **p {:.3}** |", j.outcome.loss.p);
    }
    s.push('\n');
}

/// What the final pass changed: the calibration's fitted values and the tuned ones.
fn changed(s: &mut String, r: &TwinReport) {
    let p = &r.final_twin.pass;
    s.push_str("\n## What was changed to get there (the twin written)\n\n");
    if !p.start.is_empty() {
        s.push_str("The start model, from the robot's file and the logs' metadata:\n\n");
        for line in &p.start {
            let _ = writeln!(s, "- {line}");
        }
        s.push('\n');
    }
    for c in &p.calibration {
        let _ = writeln!(
            s,
            "Calibrated by replay on `{}` ({} steps): test score {:.2} → {:.2} (1 = noise floor). Fitted values (± SE, 95 % interval; clustered sandwich over the training steps):\n",
            c.dataset, c.steps, c.test_score_declared, c.test_score_calibrated
        );
        for f in &c.fitted {
            let interval = match (f.se, f.ci95) {
                (Some(se), Some(ci)) if se.is_finite() => format!("± {se:.3} [{:.4}, {:.4}]", ci[0], ci[1]),
                _ => "no interval".into(),
            };
            let _ = writeln!(s, "- `{}` = {:.4} {} {interval}", f.name, f.value, f.unit);
        }
        s.push('\n');
    }
    match &p.tuning {
        Some(t) => tuning_table(s, t, "calibrated model"),
        None => s.push_str("Nothing tuned: no knob lowered the loss enough in the screening (below).\n"),
    }
    if let Some(rf) = &p.refinement {
        let chosen = &rf.choice.chosen;
        let _ = writeln!(
            s,
            "\nThen a second round from the tuned twin (how, below): {}.\n",
            if chosen.is_empty() {
                "no knob lowered its loss enough".to_string()
            } else {
                format!("tuned {}", chosen.join(", "))
            }
        );
        if let Some(t) = &rf.tuning {
            tuning_table(s, t, "first round's twin");
        }
    }
}

/// One round's tuning: its search, its check and each value; `start` names the model it
/// started from.
fn tuning_table(s: &mut String, t: &crate::tune::Tuning, start: &str) {
    let _ = writeln!(
        s,
        "Tuned in closed loop ({} points; loss {} → {:.2} on seeds {:?}); check on fresh seeds: reduction {:.2} ± {:.2} (SE), **{}**:\n",
        t.evaluated.len(),
        t.start_loss.map_or("-".into(), |l| format!("{l:.2}")),
        t.chosen_loss,
        t.seeds,
        t.check.mean_reduction,
        t.check.se,
        if t.accepted { "accepted".to_string() } else { format!("not accepted: the twin is the {start}") }
    );
    s.push_str("| value | ground | calibrated | chosen | box | profile interval | near-best range | on a bound |\n|---|---|---|---|---|---|---|---|\n");
    for v in &t.values {
        let _ = writeln!(
            s,
            "| `{}` ({}) | {} | {} | {:.4} | [{:.4}, {:.4}] | {} | {} | {} |",
            v.name,
            v.unit,
            v.ground.as_deref().unwrap_or("all"),
            if v.calibrated.is_finite() {
                format!("{:.4}", v.calibrated)
            } else {
                "off".into()
            },
            v.chosen,
            v.lower,
            v.upper,
            v.interval.map_or("not pinned".into(), |[a, b]| {
                let mark = match v.interval_fit {
                    Some(drive_sim_calibration::surface::SurfaceFit::Separable) => " ¹",
                    _ => "",
                };
                format!("[{a:.4}, {b:.4}]{mark}")
            }),
            v.near_best
                .map_or("-".into(), |[a, b]| format!("[{a:.4}, {b:.4}]")),
            if v.at_bound { "yes" } else { "no" }
        );
    }
    s.push_str("\n(profile interval: the values whose loss, on a quadratic fitted to the search's points nearest the best and minimised over the other tuned values, lies within twice the check's standard error of its minimum; marked ¹ where the full quadratic had no minimum and the one without cross terms was used, the others held at their minimum; \"not pinned\": the fitted surface has no minimum along it. Near-best range: the values of the search's points whose loss lies within twice the check's standard error of the best, a set of evaluated points.)\n");
}

/// How the knobs were chosen.
fn choice(s: &mut String, r: &TwinReport) {
    let c = &r.final_twin.pass.choice;
    let sc = &r.final_twin.pass.screening;
    let _ = writeln!(
        s,
        "\n## How the knobs were chosen (the twin written)\n\nEach of the {} knobs of the model was set at {} points, each parameter moved by {} and by {} of its box either side of its calibrated value (the box's quarters and two of its eighths where that value is off or outside the box), and run in closed loop on seeds {:?} ({} DRIVE runs); the calibrated model's loss there: {}. The rule: {}.\n",
        sc.knobs.len(),
        crate::screen::POINTS_PER_KNOB,
        crate::screen::SCREEN_STEP,
        crate::screen::FINE_SCREEN_STEP,
        sc.seeds,
        sc.runs,
        sc.start.loss.map_or("-".into(), |l| format!("{l:.2}")),
        c.rule_text
    );
    considered_table(s, c);
    if let Some(rf) = &r.final_twin.pass.refinement {
        let _ = writeln!(
            s,
            "\nThe second round, from the twin the first round tuned: the {} other knobs screened the same way on the same seeds ({} DRIVE runs); the tuned twin's loss there: {}. The same rule with at most {} knobs and {} coordinates, the gains over the tuned twin's loss.\n",
            rf.screening.knobs.len(),
            rf.screening.runs,
            rf.screening.start.loss.map_or("-".into(), |l| format!("{l:.2}")),
            rf.choice.rule.max_knobs,
            rf.choice.rule.max_coordinates
        );
        considered_table(s, &rf.choice);
    }
}

/// One round's knobs with a gain, and what the rule decided of each.
fn considered_table(s: &mut String, c: &crate::rule::Choice) {
    if c.considered.is_empty() {
        s.push_str("No knob lowered the loss at its screening points.\n");
        return;
    }
    s.push_str("| knob | gain | of the loss | decision |\n|---|---|---|---|\n");
    for k in &c.considered {
        let _ = writeln!(
            s,
            "| {} | {:.2} | {:.1} % | {} |",
            k.knob,
            k.gain,
            100.0 * k.relative_gain,
            if k.chosen {
                "tuned".to_string()
            } else {
                k.why.clone()
            }
        );
    }
}
