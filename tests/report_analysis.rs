//! The analysis → report glue on measured data: every figure is written and the HTML embeds
//! them all.

use std::path::Path;

use drive_sim::analysis::{analyze, AnalysisParams};
use drive_sim::log::csv::read_measured_csv;
use drive_sim::report::{analysis_figures, analysis_report};

const MEASURED: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data/measured");

#[test]
fn report_of_two_robots_on_measured_data() {
    let params = AnalysisParams::default();
    let analyses: Vec<_> = ["warthog_ice.csv", "husky_2023.csv"]
        .iter()
        .map(|f| {
            let log = read_measured_csv(Path::new(MEASURED).join(f)).expect("measured log reads");
            analyze(&log, &params).expect("measured log analyses")
        })
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let figs = analysis_figures(dir.path(), &analyses).unwrap();
    // Two robots: command space, slips, rho, 3 transfer maps (if smoothed), rho scatter each;
    // one risk map.
    let transfer = analyses.iter().filter(|a| a.transfer.is_some()).count();
    assert_eq!(
        figs.len(),
        2 * 4 + 3 * transfer + 1,
        "{:?}",
        figs.iter().map(|f| &f.files.svg).collect::<Vec<_>>()
    );
    for f in &figs {
        assert!(std::fs::metadata(&f.files.png).unwrap().len() > 1000);
    }
    let risk = std::fs::read_to_string(dir.path().join("risk_map.svg")).unwrap();
    // Two robots on one map: both maximum-energy lines are labelled.
    assert!(risk.matches(" max = ").count() == 2, "two energy limits");
    let html = analysis_report(dir.path(), "Measured data", &analyses).unwrap();
    let text = std::fs::read_to_string(html).unwrap();
    assert_eq!(text.matches("<svg").count(), figs.len());
    assert!(text.contains("analysed steps"));
}
