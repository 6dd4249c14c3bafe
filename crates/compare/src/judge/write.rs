//! A judgement's files: `judge.json` (every run's score against the real run and against each
//! reference), `judge.md` (the table `drive-sim judge` prints) and `judge_rates.svg|png` (how
//! often the twin's runs fail each criterion against the real run, beside how often they fail
//! it against the twin's own runs).

use super::interval::{short as short_number, ParamInterval};
use super::{JudgeOutcome, DIFFERS};
use crate::error::{Error, Result};
use drive_sim_calibration::twin::annotate_value;
use drive_sim_log::UseSteps;
use drive_sim_model::provenance::Provenance;
use drive_sim_report::{bar_chart, AxisLabel, BarChart, BarSeries};
use std::path::{Path, PathBuf};

/// The other real runs' comparisons beside the twin's mean loss (empty without any).
fn yardsticks_table(o: &JudgeOutcome) -> String {
    if o.yardsticks.is_empty() {
        return String::new();
    }
    let mut s = String::from(
        "\nThe robot against itself (another real run of the same robot and ground, compared with the judged steps as each twin run is; the yardstick test ranks its loss among the losses of the twin's runs as long as it, and its p is small when the robot's own run is closer than the twin's runs):\n\n| other real run | its loss | twin's mean loss | twin as close as the robot to itself | yardstick test: p (twin runs) | verdict on the other run | differs on | ρ difference (p Holm) |\n|---|---|---|---|---|---|---|---|\n",
    );
    for y in &o.yardsticks {
        let rho = y
            .medians
            .iter()
            .find(|m| m.metric == "median_rho")
            .map_or("-".to_string(), |m| {
                format!("{:+.3} ({:.3})", m.difference, m.p_holm)
            });
        s.push_str(&format!(
            "| {} | {} | {:.2} | {} | {} | {} | {} | {rho} |\n",
            y.other,
            y.loss.map_or("-".to_string(), |l| format!("{l:.2}")),
            y.twin_mean_loss,
            if y.twin_within { "yes" } else { "no" },
            yardstick_test_words(y),
            if y.reproduces { "reproduces" } else { "differs" },
            if y.differs_on.is_empty() {
                "-".to_string()
            } else {
                y.differs_on.join(", ")
            },
        ));
    }
    s
}

/// The yardstick test's outcome in a table cell: "as close, p 0.350 (19 runs of 100 steps)".
fn yardstick_test_words(y: &super::Yardstick) -> String {
    if !y.p_twin_farther.is_finite() {
        return "-".to_string();
    }
    format!(
        "{}, p {:.3} ({} runs of {} steps{})",
        if y.twin_as_close {
            "as close"
        } else {
            "**farther**"
        },
        y.p_twin_farther,
        y.twin_run_losses.len(),
        y.twin_run_steps,
        if y.twin_runs_failed > 0 {
            format!(", {} failed", y.twin_runs_failed)
        } else {
            String::new()
        }
    )
}

/// The table: one row per criterion, the verdict first; then the other real runs, if any.
pub fn table(o: &JudgeOutcome) -> String {
    let n = o.sim_seeds.len();
    let m = o.references.len();
    // A half of the real run is stood in for by the same half of the twin's runs as long.
    let references = match o.reference_steps {
        UseSteps::All => format!("{m} runs of its own"),
        half => format!(
            "the {} steps of {m} runs of its own as long as the real run ({} DRIVE steps)",
            half.as_str(),
            o.reference_run_steps
        ),
    };
    let mut s = format!(
        "{}: the twin's {n} runs ({} DRIVE steps each) against the {} {} real steps, and against {references}\n\n",
        o.dataset,
        o.steps_per_run,
        o.real_steps_analysed,
        o.options.real_steps.as_str(),
    );
    s.push_str(&format!(
        "**{}**: the loss's Monte Carlo p {:.3} (mean loss {:.2} against the real run, {:.2} against the twin's runs; alpha {}); the verdict's {:.3}\n\n",
        if o.indistinguishable {
            "indistinguishable"
        } else {
            "distinguishable"
        },
        o.loss.p,
        o.loss.real,
        drive_sim_analysis::stats::mean(&o.loss.references),
        o.options.alpha,
        o.criteria[0].p
    ));
    s.push_str("| criterion | runs failing it against the real run | against the twin's own runs (mean, range) | p | p (Holm) |\n|---|---|---|---|---|\n");
    for c in &o.criteria {
        let lo = c.reference_fails.iter().min().copied().unwrap_or(0);
        let hi = c.reference_fails.iter().max().copied().unwrap_or(0);
        s.push_str(&format!(
            "| {}{} | {} of {n} | {:.1} of {n} ({lo}–{hi}) | {:.3} | {} |\n",
            c.criterion,
            if c.criterion == DIFFERS {
                " (the verdict)"
            } else {
                ""
            },
            c.real_fails,
            c.reference_rate * n as f64,
            c.p,
            if c.criterion == DIFFERS {
                "-".to_string()
            } else {
                format!("{:.3}", c.p_holm)
            }
        ));
    }
    s.push_str(&terms_table(o));
    if !o.short_on.is_empty() {
        s.push_str(&format!(
            "\nShort on (Holm-adjusted p ≤ {}): {}\n",
            o.options.alpha,
            o.short_on.join(", ")
        ));
    }
    if !o.flagged.is_empty() {
        s.push_str(&format!(
            "\nFlagged (own p ≤ {}, uncorrected: a diagnostic, not a test): {}\n",
            o.options.alpha,
            o.flagged.join(", ")
        ));
    }
    s.push_str(&yardsticks_table(o));
    for note in &o.notes {
        s.push_str(&format!("\nNote: {note}\n"));
    }
    if !o.intervals.is_empty() {
        s.push_str(&intervals_table(o));
    }
    s
}

/// The loss term by term: where the real run's mean loss comes from (empty for a judgement
/// written before the terms were).
pub fn terms_table(o: &JudgeOutcome) -> String {
    if o.loss.terms.is_empty() {
        return String::new();
    }
    let n = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.2}"));
    let mut s = String::from(
        "\nThe loss term by term (each term's square, its mean over the twin's runs; p: the real run's ranked among the twin's own runs as the loss's is, a diagnostic of where the loss comes from, not a test):\n\n| term | against the real run | against the twin's runs: mean (largest) | p |\n|---|---|---|---|\n",
    );
    for t in &o.loss.terms {
        s.push_str(&format!(
            "| {} | {} | {} ({}) | {} |\n",
            t.name,
            n(t.real),
            n(t.reference_mean),
            n(t.reference_max),
            if t.p.is_finite() {
                format!("{:.3}", t.p)
            } else {
                "-".into()
            }
        ));
    }
    s
}

/// The parameters' sets (`judge --interval`): one row per parameter, then every judged value.
pub fn intervals_table(o: &JudgeOutcome) -> String {
    let level = 100.0 * (1.0 - o.options.alpha);
    let mut s = format!(
        "\n**{level:.0} % sets by inverting this test** (one parameter moves, the others stay at the twin's values; the same seeds at every value):\n\n| parameter | twin's value | set | box | judged values (p) |\n|---|---|---|---|---|\n"
    );
    for i in &o.intervals {
        let unit = if i.unit == "-" {
            String::new()
        } else {
            format!(" {}", i.unit)
        };
        let set = match (&i.lower, &i.upper) {
            (Some(lo), Some(hi)) => {
                let end = |b: &super::interval::Bound| match b.rejected_at {
                    None => format!("{:.4} (box)", b.value),
                    Some(r) => format!("{:.4} (rejected at {:.4})", b.value, r),
                };
                format!("[{}, {}]", end(lo), end(hi))
            }
            _ => "empty: the twin's own value is rejected".into(),
        };
        let mut judged = i.evaluations.clone();
        judged.sort_by(|a, b| a.value.total_cmp(&b.value));
        let judged: Vec<String> = judged
            .iter()
            .map(|e| {
                format!(
                    "{:.4} ({:.2}{})",
                    e.value,
                    e.p,
                    if e.accepted { "" } else { ", out" }
                )
            })
            .collect();
        s.push_str(&format!(
            "| {} | {}{unit} | {set} | [{}, {}] | {} |\n",
            i.name,
            short_number(i.value),
            short_number(i.box_lower),
            short_number(i.box_upper),
            judged.join(", ")
        ));
    }
    s
}

/// The twin's two files (`robot.toml`, `terrain.toml` as text) with each set of `intervals` in
/// the comment of the line that sets its value, in whichever file sets it
/// ([`drive_sim_calibration::twin::annotate_value`]); and the keys neither file sets.
pub fn annotated_twin(
    texts: [&str; 2],
    intervals: &[ParamInterval],
    dataset: &str,
    steps: &str,
) -> ([String; 2], Vec<String>) {
    let mut texts = texts.map(str::to_string);
    let mut unplaced = Vec::new();
    for i in intervals {
        // A base parameter's report name is dotted (`terrain.friction.peak_longitudinal`); its
        // file sets the last part.
        let key = i.name.rsplit('.').next().unwrap_or(&i.name);
        let note = i.comment(dataset, steps);
        let placed = texts.iter_mut().any(|t| match annotate_value(t, key, &note) {
            Some(new) => {
                *t = new;
                true
            }
            None => false,
        });
        if !placed {
            unplaced.push(key.to_string());
        }
    }
    (texts, unplaced)
}

/// The twin's two files and their text, when `robot` and `terrain` (as `--robot` and
/// `--terrain` give them: names or paths) both name files; `None` otherwise. Read before any
/// run, so that a file that vanished is an error before the long work.
pub fn read_twin_files(robot: Option<&str>, terrain: Option<&str>) -> Result<Option<[(PathBuf, String); 2]>> {
    let file = |arg: Option<&str>| arg.map(Path::new).filter(|p| p.is_file()).map(Path::to_path_buf);
    let (Some(robot), Some(terrain)) = (file(robot), file(terrain)) else {
        return Ok(None);
    };
    let read = |p: &Path| std::fs::read_to_string(p).map_err(|e| Error::io(p, e));
    Ok(Some([
        (robot.clone(), read(&robot)?),
        (terrain.clone(), read(&terrain)?),
    ]))
}

/// The twin's files written with each set of `intervals` in its value's comment.
#[derive(Debug, Clone, PartialEq)]
pub struct AnnotatedTwin {
    /// `robot.toml` and `terrain.toml` as written.
    pub files: Vec<PathBuf>,
    /// The keys neither file sets: their sets are in `judge.json` only.
    pub unplaced: Vec<String>,
}

/// Writes `dir/robot.toml` and `dir/terrain.toml`: the twin's files (`texts`: robot, terrain)
/// with each set in its value's comment ([`annotated_twin`]).
pub fn write_annotated_twin(
    texts: [&str; 2],
    intervals: &[ParamInterval],
    dataset: &str,
    steps: &str,
    dir: &Path,
) -> Result<AnnotatedTwin> {
    let (texts, unplaced) = annotated_twin(texts, intervals, dataset, steps);
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let mut files = Vec::new();
    for (name, text) in ["robot.toml", "terrain.toml"].iter().zip(&texts) {
        let p = dir.join(name);
        drive_sim_model::output::write_atomic(&p, text.as_bytes())?;
        files.push(p);
    }
    Ok(AnnotatedTwin { files, unplaced })
}

/// Writes `judge.json` (stamped with `provenance`), `judge.md` and the rates' figure into
/// `dir`; returns their paths.
pub fn write_judge(o: &JudgeOutcome, provenance: &Provenance, dir: &Path) -> Result<Vec<PathBuf>> {
    let json = dir.join("judge.json");
    drive_sim_model::output::write_json_atomic(&json, o)?;
    drive_sim_model::provenance::stamp_json_file(&json, provenance)?;
    let md = dir.join("judge.md");
    drive_sim_model::output::write_atomic(&md, table(o).as_bytes())?;
    let n = o.sim_seeds.len() as f64;
    let quantile = |k: usize, q: f64| {
        drive_sim_analysis::stats::quantile(
            &o.criteria[k]
                .reference_fails
                .iter()
                .map(|x| *x as f64 / n)
                .collect::<Vec<_>>(),
            q,
        )
    };
    let chart = BarChart {
        categories: o.criteria.iter().map(|c| short(&c.criterion)).collect(),
        series: vec![
            BarSeries {
                label: "against the real run".into(),
                values: o.criteria.iter().map(|c| Some(c.real_fails as f64 / n)).collect(),
            },
            BarSeries {
                label: "against the twin's own runs (mean)".into(),
                values: o.criteria.iter().map(|c| Some(c.reference_rate)).collect(),
            },
            BarSeries {
                label: format!("(its {:.0}th percentile)", 100.0 * (1.0 - o.options.alpha)),
                values: (0..o.criteria.len())
                    .map(|k| Some(quantile(k, 1.0 - o.options.alpha)))
                    .collect(),
            },
        ],
        value: AxisLabel::new("share of the twin's runs failing", ""),
        log: false,
        references: vec![],
    };
    let fig = bar_chart(
        dir,
        "judge_rates",
        &format!(
            "{} ({} steps): how often compare fails the twin's runs, by criterion",
            o.dataset,
            o.options.real_steps.as_str()
        ),
        &chart,
    )?;
    Ok(vec![json, md, fig.svg, fig.png])
}

/// A criterion's name on the figure's axis: `slip vx`, `T/U body`, `vx map`.
fn short(criterion: &str) -> String {
    let unitless = |c: &str| {
        c.trim_start_matches("slip_")
            .trim_end_matches("_m_s")
            .trim_end_matches("_rad_s")
            .to_string()
    };
    if let Some(channel) = criterion.strip_suffix(" map") {
        format!("{} map", unitless(channel))
    } else if let Some(frame) = criterion.strip_prefix("t_area_pct_") {
        format!("T/U {frame}")
    } else if criterion == super::STEP_SCATTER {
        "step scatter".into()
    } else if criterion == super::TURN_MEMORY {
        "turn memory".into()
    } else if let Some(m) = criterion.strip_prefix("median_slip_") {
        format!("slip {m}")
    } else {
        criterion.trim_start_matches("median_").to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::super::interval::{Bound, ParamInterval};

    /// Each set goes into whichever file sets its value; a key neither sets is returned.
    #[test]
    fn annotated_twin_places_each_set_in_its_file() {
        let set = |name: &str| ParamInterval {
            name: name.into(),
            unit: "-".into(),
            value: 1.0,
            box_lower: 0.0,
            box_upper: 2.0,
            level: 0.95,
            lower: Some(Bound {
                value: 0.5,
                rejected_at: Some(0.4),
            }),
            upper: Some(Bound {
                value: 1.5,
                rejected_at: Some(1.6),
            }),
            evaluations: Vec::new(),
            method: String::new(),
        };
        let robot = "[effects]\nspeed_droop_rad_s_per_knm = 1.0  # [tune] no interval\n";
        let terrain = "[friction]\npeak_longitudinal = 0.9\n";
        let (texts, unplaced) = super::annotated_twin(
            [robot, terrain],
            &[
                set("speed_droop_rad_s_per_knm"),
                set("terrain.friction.peak_longitudinal"),
                set("dead_time_s"),
            ],
            "d",
            "all",
        );
        assert!(
            texts[0].contains("# [tune] 95 % set [0.5000, 1.500]"),
            "{}",
            texts[0]
        );
        assert!(
            texts[1].contains("peak_longitudinal = 0.9  # 95 % set"),
            "{}",
            texts[1]
        );
        assert_eq!(unplaced, vec!["dead_time_s".to_string()]);
    }

    #[test]
    fn short_names() {
        for (long, s) in [
            ("differs", "differs"),
            ("median_rho", "rho"),
            ("median_slip_vx", "slip vx"),
            ("t_area_pct_wheels", "T/U wheels"),
            ("slip_wz_rad_s map", "wz map"),
            ("slip_vx_m_s map", "vx map"),
        ] {
            assert_eq!(super::short(long), s);
        }
    }
}
