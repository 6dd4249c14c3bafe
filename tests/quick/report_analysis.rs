//! The analysis → report glue on measured data of two robots: every figure is written, the
//! HTML embeds them all, and the risk map puts both robots on a log energy axis.

use std::path::Path;

use drive_sim::analysis::{analyze, AnalysisParams};
use drive_sim::log::csv::read_measured_csv;
use drive_sim::report::analysis_report::write_analysis_report;

const MEASURED: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data/measured");

#[test]
fn report_of_two_robots_on_measured_data() {
    let params = AnalysisParams::default();
    let logs: Vec<_> = ["warthog_ice.csv", "husky_2023.csv"]
        .iter()
        .map(|f| {
            let log = read_measured_csv(Path::new(MEASURED).join(f)).expect("measured log reads");
            let a = analyze(&log, &params).expect("measured log analyses");
            (log, a)
        })
        .collect();
    let items: Vec<_> = logs.iter().map(|(l, a)| (l, a)).collect();
    let dir = tempfile::tempdir().unwrap();
    let files = write_analysis_report(&items, dir.path()).unwrap();
    assert!(!files.figures.is_empty());
    for f in &files.figures {
        assert!(
            std::fs::metadata(&f.png).unwrap().len() > 1000,
            "{}",
            f.png.display()
        );
    }
    let risk = std::fs::read_to_string(dir.path().join("risk_map.svg")).unwrap();
    // Both maximum-energy lines are labelled; the Warthog's (~5.9 kJ) and the Husky's (~40 J)
    // on one log axis means tick labels across decades.
    assert_eq!(
        risk.matches(" max (IDD over U) = ").count(),
        2,
        "two energy limits"
    );
    assert!(
        risk.contains(">\n1000\n<") || risk.contains(">1000<"),
        "decade ticks on the energy axis"
    );
    let html = std::fs::read_to_string(&files.html).unwrap();
    assert_eq!(html.matches("<svg").count(), files.figures.len());
    assert!(html.contains("log energy axis"));
}

/// The report opens with its findings: the first section is "Findings", its paragraph names the
/// quantity whose values differ most between the datasets in the comparison table below it
/// (spread relative to the larger magnitude, read back from the table the reader sees), with
/// the datasets at both ends; the table has one column per dataset.
#[test]
fn report_leads_with_the_largest_difference() {
    let params = AnalysisParams::default();
    let logs: Vec<_> = ["warthog_asphalt.csv", "warthog_ice.csv", "warthog_gravel.csv"]
        .iter()
        .map(|f| {
            let log = read_measured_csv(Path::new(MEASURED).join(f)).expect("measured log reads");
            let a = analyze(&log, &params).expect("measured log analyses");
            (log, a)
        })
        .collect();
    let items: Vec<_> = logs.iter().map(|(l, a)| (l, a)).collect();
    let dir = tempfile::tempdir().unwrap();
    let files = write_analysis_report(&items, dir.path()).unwrap();
    let html = std::fs::read_to_string(&files.html).unwrap();
    let first = html.split("<section>").nth(1).expect("a first section");
    let first = &first[..first.find("</section>").unwrap()];
    assert!(first.starts_with("\n<h2>Findings</h2>"), "{first}");
    let paragraph = &first[first.find("<p>").unwrap() + 3..first.find("</p>").unwrap()];
    // The comparison table: header columns, then rows of quantity, unit, one value per dataset.
    let table = &first[first
        .find("<table class=\"comparison\">")
        .expect("comparison table")..];
    let cells = |row: &str, tag: &str| -> Vec<String> {
        row.split(&format!("<{tag}"))
            .skip(1)
            .map(|c| {
                let c = &c[c.find('>').unwrap() + 1..];
                c[..c.find(&format!("</{tag}>")).unwrap()].to_string()
            })
            .collect()
    };
    let rows: Vec<&str> = table.split("<tr>").skip(1).collect();
    let header = cells(rows[0], "th");
    assert_eq!(header.len(), 2 + logs.len(), "{header:?}");
    let datasets: Vec<String> = logs.iter().map(|(_, a)| a.dataset.clone()).collect();
    for (h, d) in header[2..].iter().zip(&datasets) {
        assert!(h.starts_with(d.as_str()), "{h} vs {d}");
    }
    // Relative spread of every row the paragraph may name (counts are not findings).
    let not_findings = [
        "interruptions",
        "steps analysed",
        "steps excluded",
        "steps commanded outside the declared U",
        "max kinetic energy over U",
    ];
    let mut spreads: Vec<(f64, String, String, String)> = Vec::new();
    for row in &rows[1..] {
        let c = cells(row, "td");
        if not_findings.contains(&c[0].as_str()) {
            continue;
        }
        let vals: Vec<(f64, &String)> = c[2..]
            .iter()
            .zip(&datasets)
            .filter_map(|(v, d)| v.parse::<f64>().ok().map(|x| (x, d)))
            .collect();
        if vals.len() < 2 {
            continue;
        }
        let hi = vals.iter().max_by(|a, b| a.0.total_cmp(&b.0)).unwrap();
        let lo = vals.iter().min_by(|a, b| a.0.total_cmp(&b.0)).unwrap();
        let scale = hi.0.abs().max(lo.0.abs());
        let spread = if scale > 0.0 { (hi.0 - lo.0) / scale } else { 0.0 };
        spreads.push((spread, c[0].clone(), hi.1.clone(), lo.1.clone()));
    }
    let best = spreads.iter().map(|s| s.0).fold(0.0, f64::max);
    assert!(best > 0.0);
    let named = spreads
        .iter()
        .find(|(_, name, _, _)| {
            paragraph.starts_with(&format!(
                "The largest difference between the datasets is the {name}: "
            ))
        })
        .unwrap_or_else(|| panic!("the paragraph names no row of the table: {paragraph}"));
    // The table rounds its values: allow a near tie.
    assert!(
        named.0 >= best - 0.02,
        "named {named:?}, largest spread {best}: {spreads:?}"
    );
    let sentence = &paragraph[..paragraph.find(". ").unwrap_or(paragraph.len())];
    assert!(
        sentence.contains(&format!(" on {} against ", named.2))
            && sentence.contains(&format!(" on {} (", named.3)),
        "{sentence}"
    );
    // Then the key figure, with a caption that says what to look at.
    assert!(first.contains("<figure>") && first.contains("Key figure: unpredictability ρ"));
    assert!(first.contains("Compare the boxes of"), "{first}");
}
