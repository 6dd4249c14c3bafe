//! Writing a comparison: `comparison.json`, the difference-map figures, and `report.html`
//! whose first screen is the verdict table.

use super::{ComparisonReport, MetricDiff, SimComparison, TfDiff};
use crate::error::{Error, Result};
use drive_sim_analysis::bootstrap::Interval;
use drive_sim_report::{
    heat_maps, AxisLabel, ColourMap, ColourScale, Comparison, FigureFiles, Grid2, HeatPanel, HtmlReport,
};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

fn ci(i: &Option<Interval>) -> String {
    match i {
        Some(i) => format!("[{:.4}, {:.4}]", i.lower, i.upper),
        None => "(no interval)".into(),
    }
}

fn verdict_word(m: &MetricDiff) -> &'static str {
    match (m.significant, m.within_tolerance) {
        (_, Some(true)) => "within tolerance",
        (_, Some(false)) => "beyond tolerance",
        (true, None) => "differs",
        (false, None) => "no difference",
    }
}

/// The verdict table as plain text (what the CLI prints): one block per simulated log.
pub fn verdict_text(r: &ComparisonReport) -> String {
    let mut s = String::new();
    for c in &r.sims {
        sim_block(&mut s, r, c);
    }
    for w in &r.warnings {
        let _ = writeln!(s, "warning [{}]: {}", w.name, w.message);
    }
    s
}

/// One simulated log's block of [`verdict_text`].
fn sim_block(s: &mut String, r: &ComparisonReport, c: &SimComparison) {
    let _ = writeln!(
        s,
        "{} vs {} ({} bootstrap, {} resamples, Holm over {} medians at {}; T/U areas within {} pp): {}",
        c.sim.name,
        r.real.name,
        match c.pairing {
            super::Pairing::Paired => "paired-by-step",
            super::Pairing::TwoSample => "two-sample",
        },
        r.options.bootstrap.resamples,
        c.metrics.iter().filter(|m| m.tolerance.is_none()).count(),
        r.options.alpha,
        r.options.area_tolerance_pp,
        if c.verdict.reproduces {
            "REPRODUCES"
        } else {
            "DIFFERS"
        }
    );
    let _ = writeln!(
        s,
        "  {:<26} {:>10} {:>10} {:>10} {:>24} {:>8}  verdict",
        "metric", "real", "sim", "sim-real", "95 % interval", "p Holm"
    );
    for m in &c.metrics {
        let _ = writeln!(
            s,
            "  {:<26} {:>10.4} {:>10.4} {:>10.4} {:>24} {:>8.4}  {}",
            format!("{} [{}]", m.metric, m.unit),
            m.real,
            m.sim,
            m.difference,
            ci(&m.difference_ci95),
            m.p_holm,
            verdict_word(m)
        );
    }
    for t in &c.transfer {
        let _ = writeln!(s, "{}", transfer_line(t));
    }
    if let Some(l) = &c.loss {
        let _ = writeln!(
            s,
            "  loss {:.2} (each term 1 at its verdict's threshold, squared and summed: what `tune` minimises)",
            l.total
        );
    }
    if let Some(line) = clearest_curvature_difference(c) {
        let _ = writeln!(s, "{line}");
    }
    if let Some(d) = &c.step_scatter {
        let _ = writeln!(s, "  {}", d.line());
    }
    if let Some(d) = &c.turn_memory {
        let _ = writeln!(s, "  {}", d.line());
    }
    if let Some(t) = &c.time {
        let _ = writeln!(
            s,
            "  time efficiency real {:.1} %, sim {:.1} %; interruptions per step real {:.3}, sim {:.3}",
            100.0 * t.real_time_efficiency,
            100.0 * t.sim_time_efficiency,
            t.real_interruptions_per_step,
            t.sim_interruptions_per_step
        );
    }
}

/// A map's line of [`verdict_text`]: its RMS difference against the yardstick, and the
/// permutation test's p where it was run.
fn transfer_line(t: &TfDiff) -> String {
    format!(
        "  TF {:<17} RMS {:.4} {}, yardstick {:.4} (split-half {:.4} over {} halvings; odd/even {:.4}), ratio {:.2} on {} points: {}{}",
        t.channel,
        t.rms,
        t.unit,
        t.yardstick,
        t.split_half_rms_mean.unwrap_or(t.split_half_rms),
        t.yardstick_splits.unwrap_or(1),
        t.split_half_rms,
        t.ratio,
        t.points,
        if t.points == 0 {
            "not compared"
        } else if t.within {
            "within"
        } else {
            "beyond"
        },
        t.p_permutation_holm
            .map(|p| format!("; permutation p (Holm) {p:.3}"))
            .unwrap_or_default()
    )
}

/// The body against its wheels, by curvature: of the ratios whose interval excludes no
/// difference, the one that differs most (a diagnostic; the report has the whole table).
fn clearest_curvature_difference(c: &SimComparison) -> Option<String> {
    let (k, what, st) = c
        .curvature
        .classes
        .iter()
        .flat_map(|k| {
            [("forward speed", &k.forward_ratio), ("yaw rate", &k.yaw_ratio)].map(|(what, st)| (k, what, st))
        })
        .filter(|(_, _, st)| {
            st.difference.is_finite() && st.difference_ci95.is_some_and(|i| !i.contains(0.0))
        })
        .max_by(|a, b| a.2.difference.abs().total_cmp(&b.2.difference.abs()))?;
    Some(format!(
        "  body / wheel {what} by curvature, largest clear difference: {} (real {} / sim {} steps) real {:.3}, sim {:.3}, sim-real {:+.3} {} (report: the table per class)",
        k.class, k.steps.0, k.steps.1, st.real, st.sim, st.difference, ci(&st.difference_ci95)
    ))
}

fn curvature_table(r: &ComparisonReport, c: &SimComparison) -> Comparison {
    let k = &c.curvature.classes;
    let stat_rows =
        |label: &str, f: fn(&super::curvature::CurvatureClass) -> &super::curvature::ClassStatistic| {
            [
                (
                    format!("{label}, real"),
                    "-".to_string(),
                    k.iter()
                        .map(|x| format!("{:.3} {}", f(x).real, ci(&f(x).real_ci95)))
                        .collect::<Vec<_>>(),
                ),
                (
                    format!("{label}, sim"),
                    "-".to_string(),
                    k.iter()
                        .map(|x| format!("{:.3} {}", f(x).sim, ci(&f(x).sim_ci95)))
                        .collect(),
                ),
                (
                    format!("{label}, sim − real"),
                    "-".to_string(),
                    k.iter()
                        .map(|x| format!("{:+.3} {}", f(x).difference, ci(&f(x).difference_ci95)))
                        .collect(),
                ),
            ]
        };
    let mut rows = vec![(
        "steps (real / sim)".to_string(),
        "-".to_string(),
        k.iter()
            .map(|x| format!("{} / {}", x.steps.0, x.steps.1))
            .collect(),
    )];
    rows.extend(stat_rows("body / wheel forward speed", |x| &x.forward_ratio));
    rows.extend(stat_rows("body / wheel yaw rate", |x| &x.yaw_ratio));
    rows.extend(stat_rows("median ρ", |x| &x.rho));
    Comparison {
        caption: format!("{} against {}, by commanded curvature", c.sim.name, r.real.name),
        columns: k
            .iter()
            .map(|x| match x.d_max {
                Some(hi) => format!("{} ({} ≤ d < {})", x.class, x.d_min, hi),
                None => format!("{} (d ≥ {})", x.class, x.d_min),
            })
            .collect(),
        rows,
    }
}

fn verdict_table(r: &ComparisonReport, c: &SimComparison) -> Comparison {
    Comparison {
        caption: format!(
            "{} against {}: {} ({:?} bootstrap by step, Holm-corrected at {})",
            c.sim.name,
            r.real.name,
            if c.verdict.reproduces {
                "reproduces the real run"
            } else {
                "differs from the real run"
            },
            c.pairing,
            r.options.alpha
        ),
        columns: vec![
            "real [95 %]".into(),
            "sim [95 %]".into(),
            "sim − real [95 %]".into(),
            "p (Holm)".into(),
            "verdict".into(),
        ],
        rows: c
            .metrics
            .iter()
            .map(|m| {
                (
                    m.metric.clone(),
                    m.unit.clone(),
                    vec![
                        format!("{:.4} {}", m.real, ci(&m.real_ci95)),
                        format!("{:.4} {}", m.sim, ci(&m.sim_ci95)),
                        format!("{:.4} {}", m.difference, ci(&m.difference_ci95)),
                        format!("{:.4}", m.p_holm),
                        verdict_word(m).to_string(),
                    ],
                )
            })
            .chain(c.transfer.iter().map(|t| {
                (
                    format!("TF RMS {}", t.channel),
                    t.unit.clone(),
                    vec![
                        format!("yardstick {:.4}", t.yardstick),
                        format!("RMS {:.4}", t.rms),
                        format!(
                            "ratio {:.2}{}",
                            t.ratio,
                            t.p_permutation_holm
                                .map(|p| format!(" (permutation p, Holm: {p:.3})"))
                                .unwrap_or_default()
                        ),
                        format!("≤ {}", r.options.tf_tolerance),
                        if t.points == 0 {
                            "not compared".into()
                        } else if t.within {
                            "within yardstick".into()
                        } else {
                            "beyond yardstick".into()
                        },
                    ],
                )
            }))
            .collect(),
    }
}

/// The body channels of the maps (vx, vy, wz) and the wheel channels (left, right), drawn as
/// two figures: the body frame in m/s and rad/s, the wheels in rad/s.
const MAP_FIGURES: &[(&str, std::ops::Range<usize>, &str)] = &[
    ("tf_difference", 0..3, "body frame"),
    ("tf_difference_wheels", 3..5, "wheels"),
];

/// Whether the channels `range` of a comparison's maps hold a compared point.
fn has_points(c: &SimComparison, range: &std::ops::Range<usize>) -> bool {
    c.maps
        .values
        .get(range.clone())
        .is_some_and(|v| v.iter().any(|m| m.iter().any(|x| x.is_finite())))
}

fn map_figure(
    dir: &Path,
    idx: usize,
    r: &ComparisonReport,
    c: &SimComparison,
    real_u: &[(f64, f64)],
    (stem, range, frame): &(&str, std::ops::Range<usize>, &str),
) -> Result<FigureFiles> {
    let panels: Vec<HeatPanel> = c
        .maps
        .channels
        .iter()
        .zip(&c.maps.values)
        .skip(range.start)
        .take(range.len())
        .map(|(name, v)| HeatPanel {
            title: name.clone(),
            grid: Grid2 {
                vx_m_s: c.maps.vx_m_s.clone(),
                wz_rad_s: c.maps.wz_rad_s.clone(),
                values: v.iter().map(|x| x.is_finite().then_some(*x)).collect(),
            },
            command_space: real_u.to_vec(),
        })
        .collect();
    Ok(heat_maps(
        dir,
        &format!("{stem}_{idx}"),
        &format!(
            "Transfer-function difference ({frame}), {} − {}",
            c.sim.name, r.real.name
        ),
        &panels,
        &ColourScale {
            value: AxisLabel::new("slip difference (sim − real)", "m/s, rad/s"),
            map: ColourMap::Diverging,
            range: None,
        },
        None,
    )?)
}

/// Writes `comparison.json`, one difference-map figure per simulated log and `report.html`
/// into `dir`; returns the paths written. `real_u` is U in the body frame of the real robot.
pub fn write_comparison(r: &ComparisonReport, real_u: &[(f64, f64)], dir: &Path) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let json = dir.join("comparison.json");
    let text = serde_json::to_string_pretty(r).map_err(|e| Error::json(&json, e))?;
    std::fs::write(&json, text).map_err(|e| Error::io(&json, e))?;
    let mut paths = vec![json];
    let mut html = HtmlReport::new(format!("Does the simulation reproduce {}?", r.real.name));
    html.section("Verdicts");
    for c in &r.sims {
        html.comparison(verdict_table(r, c));
    }
    for w in &r.warnings {
        html.paragraph(format!("Warning [{}]: {}", w.name, w.message));
    }
    let mut figures = Vec::new();
    for (i, c) in r.sims.iter().enumerate() {
        for spec in MAP_FIGURES {
            // A map with no compared point has nothing to draw.
            if !has_points(c, &spec.1) {
                continue;
            }
            let f = map_figure(dir, i, r, c, real_u, spec)?;
            paths.push(f.svg.clone());
            paths.push(f.png.clone());
            figures.push((format!("{}, {}", c.sim.name, spec.2), f));
        }
    }
    html.section("How to read this").paragraph(format!(
        "Each difference is sim − real with a {:.0} % bootstrap-by-step interval ({} resamples; paired by step when the simulated log replays the real commands, two-sample otherwise). p-values are Holm-adjusted over each simulated log's six medians (ρ and the five slips); a median differs when its adjusted p is below {}. A T/U area is judged by its tolerance: it must agree within {} percentage points. Its interval is shown but is not a test: a resample's hull is the hull of a subset of the steps, so its area is never above the run's, and the resampled difference is shifted by how much each run's hull shrinks (the estimate can lie outside its own interval). A transfer function's RMS difference is judged against the real run's split-half RMS (the quadratic mean over {} halvings: its odd and even steps, then random balanced halvings) scaled to full size (at most {}×).",
        100.0 * r.options.bootstrap.level,
        r.options.bootstrap.resamples,
        r.options.alpha,
        r.options.area_tolerance_pp,
        r.options.tf_yardstick_splits,
        r.options.tf_tolerance
    ));
    if !figures.is_empty() {
        html.section("Transfer-function difference maps");
        for (name, f) in &figures {
            html.figure(
                format!("Steady slip transfer functions, {name} minus {} (blank: outside U or too few steps nearby in either run).", r.real.name),
                f,
            )?;
        }
    }
    html.section("Body against wheels, by commanded curvature");
    html.paragraph(
        "Where the transfer-function maps say where the runs differ, this says what: per class of commanded wheel differential d = |ω_R − ω_L| / |ω_R + ω_L| (0 straight, 1 one side stopped, above 1 the sides counter-rotate), the body's forward speed and yaw rate over the ones its measured wheel speeds imply, and ρ; medians of the steady-state windows with 95 % bootstrap-by-step intervals. A diagnostic: not part of the verdict above.",
    );
    for c in &r.sims {
        html.comparison(curvature_table(r, c));
    }
    html.section("Step scatter");
    html.paragraph(
        "How far apart two steps with nearly the same command (within 1 rad/s) land, per wheel: 1.4826 · median |d| / √2 of the pairs' differences in tracking error, with a 95 % bootstrap-over-pairs interval; a step-level offset that window noise does not explain. Not part of the verdict; a term of the loss (the difference over the width of the real run's interval, at least 0.1 rad/s), so that `tune` and `twin` match it.",
    );
    for c in &r.sims {
        if let Some(d) = &c.step_scatter {
            html.paragraph(format!("{}: {}", c.sim.name, d.line()));
        }
    }
    html.section("Turn memory");
    html.paragraph(
        "How far a loaded wheel (a turn of at least 6 rad/s between the sides, the wheel commanded at least 3 rad/s) falls short of its command in the first steady window, after a turn the other way against after a turn the same way: the median shortfall's difference, with a 95 % two-sample bootstrap-by-step interval. A speed loop with an integral remembers the previous step's torque; one without does not. A diagnostic: not part of the verdict or the loss.",
    );
    for c in &r.sims {
        if let Some(d) = &c.turn_memory {
            html.paragraph(format!("{}: {}", c.sim.name, d.line()));
        }
    }
    html.section("Runs").paragraph(format!(
        "real: {} ({} on {}, {} steps{}).",
        r.real.name,
        r.real.robot,
        r.real.terrain,
        r.real.steps,
        r.real
            .time_efficiency
            .map_or(String::new(), |t| format!(", time efficiency {:.1} %", 100.0 * t))
    ));
    for c in &r.sims {
        html.paragraph(format!(
            "simulated: {} ({} on {}, {} steps{}).",
            c.sim.name,
            c.sim.robot,
            c.sim.terrain,
            c.sim.steps,
            c.sim
                .time_efficiency
                .map_or(String::new(), |t| format!(", time efficiency {:.1} %", 100.0 * t))
        ));
    }
    paths.push(html.write(dir)?);
    Ok(paths)
}
