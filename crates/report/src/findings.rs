//! What the analysis report says first: the figures that differ most between the datasets,
//! found from the numbers (no wording is fixed in advance), and one comparison table with the
//! datasets as columns.
//!
//! Each [`Metric`] is a headline figure of every dataset. Its spread is measured relative to
//! the larger magnitude, `(max − min) / max(|max|, |min|)`, so that figures of different units
//! rank together; the findings name the metrics of largest spread, with the datasets at both
//! ends and the ratio (or the difference when the signs differ).

use super::analysis_report::LogSummary;
use drive_sim_analysis::stats::BoxStats;
use drive_sim_analysis::Analysis;

/// One headline figure, per dataset.
#[derive(Debug, Clone, PartialEq)]
pub struct Metric {
    /// What it is, as a reader says it.
    pub name: &'static str,
    /// Unit; empty when dimensionless.
    pub unit: &'static str,
    /// Decimals to print.
    pub decimals: usize,
    /// Whether it enters the findings (counts such as steps analysed do not).
    pub finding: bool,
    /// Value per dataset, in the order of the datasets (NaN when not available).
    pub values: Vec<f64>,
}

impl Metric {
    /// `v` formatted with the metric's decimals; "–" when not finite.
    pub fn format(&self, v: f64) -> String {
        if v.is_finite() {
            format!("{v:.*}", self.decimals)
        } else {
            "–".into()
        }
    }
}

/// The largest and smallest value of a metric across the datasets.
#[derive(Debug, Clone, PartialEq)]
pub struct Difference {
    /// Index of the metric in the list it came from.
    pub metric: usize,
    /// Dataset with the largest value, and the value.
    pub high: (String, f64),
    /// Dataset with the smallest value, and the value.
    pub low: (String, f64),
    /// `(max − min) / max(|max|, |min|)`, in [0, 2].
    pub relative: f64,
}

fn box_median(b: Option<BoxStats>) -> f64 {
    b.map_or(f64::NAN, |b| b.median)
}

/// Median over steps of the body's realized forward speed over the forward speed its realized
/// wheel speeds imply (ideal differential drive), on steps whose wheels imply at least 0.2 m/s:
/// 1 when the body follows its wheels, near 0 when the wheels spin in place.
fn body_over_wheel_speed(a: &Analysis) -> f64 {
    let idd = a.nominal.idd();
    drive_sim_analysis::stats::median(
        &a.steps
            .iter()
            .filter_map(|s| {
                let implied = idd.body_from_wheels(s.steady.realized_wheels).vx_m_s;
                (implied.abs() >= 0.2).then(|| s.steady.realized_body.vx_m_s / implied)
            })
            .collect::<Vec<f64>>(),
    )
}

/// The headline figures of `items`, each with one value per dataset.
pub fn metrics(items: &[(&LogSummary, &Analysis)]) -> Vec<Metric> {
    let col = |f: &dyn Fn(&LogSummary, &Analysis) -> f64| -> Vec<f64> {
        items.iter().map(|(l, a)| f(l, a)).collect()
    };
    let m = |name, unit, decimals, finding, values| Metric {
        name,
        unit,
        decimals,
        finding,
        values,
    };
    vec![
        m(
            "median unpredictability ρ",
            "",
            3,
            true,
            col(&|_, a| box_median(a.stats.rho)),
        ),
        m(
            "median longitudinal slip (along the command)",
            "m/s",
            3,
            true,
            col(&|_, a| box_median(a.stats.along_command.vx_m_s)),
        ),
        m(
            "median |lateral slip|",
            "m/s",
            3,
            true,
            col(&|_, a| box_median(a.stats.along_command.vy_abs_m_s)),
        ),
        m(
            "median angular slip (along the command)",
            "rad/s",
            3,
            true,
            col(&|_, a| box_median(a.stats.along_command.wz_rad_s)),
        ),
        m(
            "median wheel slip, left / right mean (along the command)",
            "rad/s",
            3,
            true,
            col(&|_, a| {
                0.5 * (box_median(a.stats.along_command.left_rad_s)
                    + box_median(a.stats.along_command.right_rad_s))
            }),
        ),
        m(
            "body speed over the speed its wheels imply (median)",
            "",
            2,
            true,
            col(&|_, a| body_over_wheel_speed(a)),
        ),
        m(
            "reached velocities T, share of U (body frame)",
            "%",
            1,
            true,
            col(&|_, a| a.spaces.t_area_pct_body),
        ),
        m(
            "ideal differential-drive RMSE, vx",
            "m/s",
            3,
            true,
            col(&|_, a| a.idd_rmse.vx_m_s),
        ),
        m(
            "reached velocities T, share of U (wheel frame)",
            "%",
            1,
            true,
            col(&|_, a| a.spaces.t_area_pct_wheels),
        ),
        m(
            "ideal differential-drive RMSE, vy",
            "m/s",
            3,
            true,
            col(&|_, a| a.idd_rmse.vy_m_s),
        ),
        m(
            "ideal differential-drive RMSE, wz",
            "rad/s",
            3,
            true,
            col(&|_, a| a.idd_rmse.wz_rad_s),
        ),
        m(
            "time efficiency",
            "%",
            1,
            true,
            col(&|l, _| 100.0 * l.time_efficiency),
        ),
        m("interruptions", "", 0, false, col(&|l, _| l.interruptions as f64)),
        m("steps analysed", "", 0, false, col(&|_, a| a.steps.len() as f64)),
        m(
            "steps excluded",
            "",
            0,
            false,
            col(&|_, a| a.exclusions.len() as f64),
        ),
        m(
            "steps commanded outside the declared U",
            "",
            0,
            false,
            col(&|_, a| a.commands_outside_u as f64),
        ),
        m(
            "max kinetic energy over U",
            "J",
            0,
            false,
            col(&|_, a| a.max_kinetic_energy.k_max_j),
        ),
    ]
}

/// The spread of every finding metric across `datasets`, largest first (ties keep the
/// metrics' order). Metrics with fewer than two finite values are left out.
pub fn differences(metrics: &[Metric], datasets: &[String]) -> Vec<Difference> {
    let mut out: Vec<Difference> = metrics
        .iter()
        .enumerate()
        .filter(|(_, m)| m.finding)
        .filter_map(|(k, m)| {
            let finite: Vec<(usize, f64)> = m
                .values
                .iter()
                .copied()
                .enumerate()
                .filter(|(_, v)| v.is_finite())
                .collect();
            if finite.len() < 2 {
                return None;
            }
            let hi = finite.iter().copied().max_by(|a, b| a.1.total_cmp(&b.1))?;
            let lo = finite.iter().copied().min_by(|a, b| a.1.total_cmp(&b.1))?;
            let scale = hi.1.abs().max(lo.1.abs());
            let relative = if scale > 0.0 { (hi.1 - lo.1) / scale } else { 0.0 };
            Some(Difference {
                metric: k,
                high: (datasets[hi.0].clone(), hi.1),
                low: (datasets[lo.0].clone(), lo.1),
                relative,
            })
        })
        .collect();
    out.sort_by(|a, b| b.relative.total_cmp(&a.relative));
    out
}

/// How much larger: a ratio when both ends are positive, else the difference with its unit.
fn how_much(m: &Metric, d: &Difference) -> String {
    let unit = if m.unit.is_empty() {
        String::new()
    } else {
        format!(" {}", m.unit)
    };
    if d.low.1 > 0.0 && d.high.1 > 0.0 {
        format!("{:.1}×", d.high.1 / d.low.1)
    } else {
        format!("{}{unit} more", m.format(d.high.1 - d.low.1))
    }
}

fn sentence(m: &Metric, d: &Difference) -> String {
    let unit = if m.unit.is_empty() {
        String::new()
    } else {
        format!(" {}", m.unit)
    };
    format!(
        "{}: {}{unit} on {} against {}{unit} on {} ({})",
        m.name,
        m.format(d.high.1),
        d.high.0,
        m.format(d.low.1),
        d.low.0,
        how_much(m, d)
    )
}

/// The findings paragraph: the `n` largest differences between the datasets, the largest
/// first, each with both ends and by how much.
pub fn findings_paragraph(metrics: &[Metric], diffs: &[Difference], n: usize) -> String {
    let Some(first) = diffs.first() else {
        return "One dataset: nothing to compare; its figures are in the table below.".into();
    };
    let mut text = format!(
        "The largest difference between the datasets is the {}.",
        sentence(&metrics[first.metric], first)
    );
    let rest: Vec<String> = diffs
        .iter()
        .skip(1)
        .take(n.saturating_sub(1))
        .map(|d| sentence(&metrics[d.metric], d))
        .collect();
    if !rest.is_empty() {
        text.push_str(&format!(" Next: {}.", rest.join("; ")));
    }
    text.push_str(
        " Differences are ranked by their size relative to the larger value; the table below has every figure of every dataset.",
    );
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    fn metric(name: &'static str, unit: &'static str, finding: bool, values: &[f64]) -> Metric {
        Metric {
            name,
            unit,
            decimals: 2,
            finding,
            values: values.to_vec(),
        }
    }

    #[test]
    fn differences_rank_by_relative_spread_and_the_paragraph_names_both_ends() {
        let ds: Vec<String> = ["asphalt", "ice", "mud"].iter().map(|s| s.to_string()).collect();
        let m = vec![
            // (0.8 - 0.1) / 0.8 = 0.875
            metric("rho", "", true, &[0.1, 0.8, 0.4]),
            // (2 - 1.5) / 2 = 0.25
            metric("slip", "m/s", true, &[1.5, 2.0, f64::NAN]),
            // Opposite signs: (0.5 - -0.5) / 0.5 = 2, the largest.
            metric("drift", "m/s", true, &[-0.5, 0.5, 0.0]),
            // Not a finding, however large its spread.
            metric("steps", "", false, &[1.0, 100.0, 50.0]),
            // One finite value: nothing to compare.
            metric("lonely", "", true, &[f64::NAN, 3.0, f64::NAN]),
        ];
        let d = differences(&m, &ds);
        assert_eq!(d.iter().map(|x| x.metric).collect::<Vec<_>>(), vec![2, 0, 1]);
        assert!((d[0].relative - 2.0).abs() < 1e-12);
        assert_eq!((d[1].high.0.as_str(), d[1].low.0.as_str()), ("ice", "asphalt"));
        let p = findings_paragraph(&m, &d, 2);
        assert!(
            p.starts_with("The largest difference between the datasets is the drift: 0.50 m/s on ice against -0.50 m/s on asphalt (1.00 m/s more)."),
            "{p}"
        );
        assert!(
            p.contains("Next: rho: 0.80 on ice against 0.10 on asphalt (8.0×)."),
            "{p}"
        );
        assert!(!p.contains("slip:"), "only the 2 largest: {p}");
        assert!(findings_paragraph(&m, &[], 3).starts_with("One dataset"));
    }
}
