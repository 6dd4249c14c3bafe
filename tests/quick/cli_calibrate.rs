//! The undeclared-effect loop end to end, as a user runs it: `drive-sim run --inject` writes a
//! simulated MCAP carrying an effect its robot and terrain files do not declare, and
//! `drive-sim calibrate` on that file, with the simulator and every candidate effect, must name
//! the effect and measure it.

use std::path::Path;
use std::process::{Command, Output};

fn drive_sim(args: &[&str], cwd: &Path) -> Output {
    let out = Command::new(env!("CARGO_BIN_EXE_drive-sim"))
        .args(args)
        .current_dir(cwd)
        .output()
        .expect("the drive-sim binary runs");
    assert!(
        out.status.success(),
        "drive-sim {args:?} failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

#[test]
fn injected_dead_time_is_found_by_the_cli() {
    let dir = tempfile::tempdir().unwrap();
    drive_sim(
        &[
            "run",
            "--robot",
            "warthog",
            "--terrain",
            "asphalt",
            "--steps",
            "24",
            "--seed",
            "5",
            "--inject",
            "dead_time_s=0.3",
            "--out",
            "logs",
        ],
        dir.path(),
    );
    let log = dir.path().join("logs/warthog_asphalt_s5.mcap");
    assert!(log.exists());
    let out = drive_sim(
        &[
            "calibrate",
            log.to_str().unwrap(),
            "--model",
            "simulator",
            "--max-effects",
            "1",
            "--max-fit-steps",
            "10",
            "--out",
            "cal",
        ],
        dir.path(),
    );
    // The CLI says what each stage found as it goes.
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("round 0") && err.contains("dead_time_s"), "{err}");

    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("cal/calibration.json")).unwrap())
            .unwrap();
    let ranking = json["rounds"][0]["ranking"].as_array().unwrap();
    // Every candidate the kinematic model can represent was screened (21 of the registry's
    // 24 catalogue effects: the generic terms are discovery's, and the wheel-speed limit the
    // Warthog file declares is refit and judged, not a candidate), the shortlist and the 2
    // contact effects went to the simulator, and the dead time came first there.
    let screened = json["screening"]["ranking"].as_array().unwrap();
    assert_eq!(screened.len(), 21, "{screened:#?}");
    let declared = json["declared_effects"].as_array().unwrap();
    assert_eq!(declared.len(), 1, "{declared:#?}");
    assert_eq!(declared[0]["effect"], "wheel_speed_saturation_rad_s");
    assert!(declared[0]["verdict"].as_str().unwrap().contains("declared 12.7"));
    assert!(ranking.len() >= 3, "{}", ranking.len());
    assert_eq!(ranking[0]["effect"], "dead_time_s", "{ranking:#?}");
    let effects = json["model_after"]["effects"].as_object().unwrap();
    let dead = effects["dead_time_s"].as_f64().unwrap();
    eprintln!(
        "dead time 0.3 s injected: fitted {dead:.4} s, ranked first of {}, held-out score {:.2} -> {:.2}",
        ranking.len(),
        json["before"]["score"],
        json["after"]["score"]
    );
    assert!((dead - 0.3).abs() < 0.03, "{effects:?}");
    let (before, after) = (
        json["before"]["score"].as_f64().unwrap(),
        json["after"]["score"].as_f64().unwrap(),
    );
    assert!(after < 0.5 * before, "{before} -> {after}");
}
