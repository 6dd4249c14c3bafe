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
