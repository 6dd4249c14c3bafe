//! The reports as a reader sees them: rendered in headless Chromium by `tests/render_report.py`
//! (screenshot of the first screen, no script error, no broken image, every figure non-empty
//! and captioned, nothing wider than the window). Needs `chromium` on PATH (Debian package
//! `chromium`): without it the script exits 2 and these tests fail rather than pass unchecked.

use drive_sim::analysis::{analyze, AnalysisParams};
use drive_sim::log::csv::read_measured_csv;
use drive_sim::report::analysis_report::write_analysis_report;
use std::path::Path;
use std::process::Command;

const MEASURED: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data/measured");
const SCRIPT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/render_report.py");

fn render(reports: &[&Path], shots: &Path) -> (bool, String) {
    let o = Command::new("python3")
        .arg(SCRIPT)
        .args(reports)
        .arg("--screenshots")
        .arg(shots)
        .output()
        .expect("python3 runs");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    assert_ne!(o.status.code(), Some(2), "the render check could not run: {text}");
    (o.status.success(), text)
}

#[test]
fn analysis_and_calibration_reports_render_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let params = AnalysisParams::default();
    let logs: Vec<_> = ["warthog_ice.csv", "warthog_asphalt.csv"]
        .iter()
        .map(|f| {
            let log = read_measured_csv(Path::new(MEASURED).join(f)).unwrap();
            let a = analyze(&log, &params).unwrap();
            (log, a)
        })
        .collect();
    let items: Vec<_> = logs.iter().map(|(l, a)| (l, a)).collect();
    let analysis = dir.path().join("analysis");
    let files = write_analysis_report(&items, &analysis).unwrap();

    let cal = dir.path().join("calibration");
    let o = Command::new(env!("CARGO_BIN_EXE_drive-sim"))
        .args([
            "calibrate",
            &format!("{MEASURED}/warthog_asphalt.csv"),
            "--model",
            "kinematic",
            "--max-effects",
            "1",
            "--max-fit-steps",
            "10",
            "--out",
        ])
        .arg(&cal)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));

    let shots = dir.path().join("shots");
    let (ok, text) = render(&[&files.html, &cal.join("report.html")], &shots);
    assert!(ok, "{text}");
    assert!(text.contains("first section `Findings`"), "{text}");
    for name in ["analysis.png", "calibration.png"] {
        assert!(shots.join(name).exists(), "{name}: {text}");
    }
}

#[test]
fn the_render_check_catches_a_broken_image_and_a_missing_caption() {
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("bad").join("report.html");
    std::fs::create_dir_all(page.parent().unwrap()).unwrap();
    std::fs::write(
        &page,
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"></head><body><section><h2>S</h2>\
         <figure><img src=\"missing.png\" width=\"300\" height=\"200\"></figure></section></body></html>\n",
    )
    .unwrap();
    let (ok, text) = render(&[&page], dir.path());
    assert!(!ok, "{text}");
    assert!(
        text.contains("broken image") && text.contains("without a caption"),
        "{text}"
    );
}
