//! Measured-CSV reader (format: shared/data/measured/README.md).
//!
//! A measured dataset is `<name>.csv` (one row per 20 Hz sample) plus its sibling `<name>.json`
//! (metadata and the operators' nominal robot parameters). [`read_measured_csv`] turns both into
//! a [`DriveLog`] through [`DriveLog::from_frames`], like every other log source.
//!
//! Time is not continuous across steps in these files (the operator may have re-oriented the
//! robot between steps), so each frame's log stamp is synthesized as
//! `step * step_s + t_in_step_s`: monotonic, and exact inside a step.
//!
//! Errors name the file and, for the CSV, the location as `row N, column `name``, where `N` is
//! the line number in the file (the header is line 1).

mod row;

use super::{DriveLog, Frame, LogMeta, Nominal, Origin, Phase};
use drive_sim_model::{Error, Result};
use row::{Columns, Row};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// The sibling JSON of a measured CSV.
#[derive(Debug, Clone, Deserialize)]
struct MeasuredJson {
    #[serde(default)]
    name: Option<String>,
    robot: String,
    terrain: String,
    rate_hz: f64,
    window_s: f64,
    windows_per_step: u32,
    samples_per_window: u32,
    steps: u32,
    nominal: Nominal,
}

/// Required numeric columns, in the order the reader stores them.
const REQUIRED: [&str; 18] = [
    "step",
    "window",
    "k",
    "t_in_step_s",
    "cmd_left_rad_s",
    "cmd_right_rad_s",
    "enc_left_rad_s",
    "enc_right_rad_s",
    "icp_x_m",
    "icp_y_m",
    "icp_z_m",
    "icp_roll_rad",
    "icp_pitch_rad",
    "icp_yaw_rad",
    "imu_wz_rad_s",
    "imu_ax_m_s2",
    "imu_ay_m_s2",
    "imu_az_m_s2",
];

/// Optional columns: the source's own body-velocity estimate, empty where it had none.
const REFERENCE: [&str; 3] = ["ref_vx_m_s", "ref_vy_m_s", "ref_wz_rad_s"];

/// Path of the JSON metadata beside a CSV (same stem, `.json`).
pub fn sibling_json(csv_path: &Path) -> PathBuf {
    csv_path.with_extension("json")
}

fn read_meta(csv_path: &Path) -> Result<(MeasuredJson, PathBuf)> {
    let json_path = sibling_json(csv_path);
    let text = std::fs::read_to_string(&json_path).map_err(|e| Error::io(&json_path, e))?;
    let de = &mut serde_json::Deserializer::from_str(&text);
    let meta: MeasuredJson = serde_path_to_error::deserialize(de).map_err(|e| {
        let path = e.path().to_string();
        Error::log(&json_path, format!("field `{path}`"), e.into_inner().to_string())
    })?;
    let bad = |field: &str, msg: &str| {
        Err(Error::log(
            &json_path,
            format!("field `{field}`"),
            msg.to_string(),
        ))
    };
    let positive = |v: f64| v.is_finite() && v > 0.0;
    if !positive(meta.rate_hz) {
        return bad("rate_hz", "must be a positive finite number");
    }
    if !positive(meta.window_s) {
        return bad("window_s", "must be a positive finite number");
    }
    if meta.windows_per_step < 2 {
        return bad(
            "windows_per_step",
            "must be at least 2 (one transient and one steady window)",
        );
    }
    if meta.samples_per_window == 0 {
        return bad("samples_per_window", "must be positive");
    }
    let n = &meta.nominal;
    for (field, v) in [
        ("nominal.wheel_radius_m", n.wheel_radius_m),
        ("nominal.baseline_m", n.baseline_m),
        ("nominal.max_wheel_rad_s", n.max_wheel_rad_s),
        ("nominal.max_lin_m_s", n.max_lin_m_s),
        ("nominal.max_ang_rad_s", n.max_ang_rad_s),
        ("nominal.mass_kg", n.mass_kg),
        ("nominal.width_m", n.width_m),
        ("nominal.length_m", n.length_m),
    ] {
        if !positive(v) {
            return bad(field, &format!("must be a positive finite number, got {v}"));
        }
    }
    for (field, v) in [
        ("nominal.height_m", n.height_m),
        ("nominal.max_lin_acc_m_s2", n.max_lin_acc_m_s2),
        ("nominal.command_turn_scale", n.command_turn_scale),
    ] {
        if let Some(v) = v {
            if !positive(v) {
                return bad(field, &format!("must be a positive finite number, got {v}"));
            }
        }
    }
    // The one validation pass of log metadata (ranges with units, consistent sampling).
    let probe = LogMeta {
        name: String::new(),
        robot: meta.robot.clone(),
        terrain: meta.terrain.clone(),
        rate_hz: meta.rate_hz,
        window_s: meta.window_s,
        windows_per_step: meta.windows_per_step,
        samples_per_window: meta.samples_per_window,
        nominal: meta.nominal.clone(),
        origin: Origin::Measured { file: String::new() },
    };
    if let Err((field, msg)) = probe.validate() {
        return bad(&field, &msg);
    }
    Ok((meta, json_path))
}

/// The frames of every data row of `rdr`, checked against `meta`.
fn read_frames(
    rdr: &mut ::csv::Reader<std::fs::File>,
    cols: &Columns,
    meta: &MeasuredJson,
    csv_path: &Path,
) -> Result<Vec<Frame>> {
    let step_s = meta.window_s * meta.windows_per_step as f64;
    let mut frames: Vec<Frame> = Vec::new();
    let mut prev: Option<(u32, u32, u32)> = None;
    let mut record = ::csv::StringRecord::new();
    loop {
        let more = rdr.read_record(&mut record).map_err(|e| {
            let line = e.position().map(|p| p.line()).unwrap_or(0);
            Error::log(csv_path, format!("row {line}"), e.to_string())
        })?;
        if !more {
            break;
        }
        let row = Row {
            record: &record,
            line: record.position().map(|p| p.line()).unwrap_or(0),
            cols,
            csv_path,
        };
        let (step, window, k) = row.position(meta, prev)?;
        prev = Some((step, window, k));
        let t_in_step_s = row.field(3)?;
        let m = row.measurement()?;
        frames.push(Frame {
            stamp_s: step as f64 * step_s + t_in_step_s,
            phase: Phase::Step {
                step,
                attempt: 0,
                window,
                k,
                t_in_step_s,
            },
            m,
        });
    }
    Ok(frames)
}

/// Reads a measured DRIVE dataset: the CSV at `csv_path` and its sibling JSON.
///
/// Every row becomes one [`Frame`] in [`Phase::Step`] with attempt 0 (the files hold completed
/// steps only). Fails with [`Error::Log`] naming the file and the row/column or JSON field on a
/// missing column, an unparsable or non-finite number in a required column, a partially filled
/// reference estimate, a window or sample index out of the declared range, or rows that go back
/// in (step, window, k) order. Non-finite reference values are read as "no reference".
pub fn read_measured_csv(csv_path: impl AsRef<Path>) -> Result<DriveLog> {
    let csv_path = csv_path.as_ref();
    let (meta, _json_path) = read_meta(csv_path)?;
    let file = std::fs::File::open(csv_path).map_err(|e| Error::io(csv_path, e))?;
    let mut rdr = ::csv::ReaderBuilder::new().has_headers(true).from_reader(file);
    let headers = rdr
        .headers()
        .map_err(|e| Error::log(csv_path, "row 1 (header)", e.to_string()))?
        .clone();
    let cols = Columns::of(&headers, csv_path)?;
    let frames = read_frames(&mut rdr, &cols, &meta, csv_path)?;
    if frames.is_empty() {
        return Err(Error::log(csv_path, "row 2", "no data rows"));
    }
    let name = meta.name.clone().unwrap_or_else(|| {
        csv_path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default()
    });
    let log_meta = LogMeta {
        name,
        robot: meta.robot,
        terrain: meta.terrain,
        rate_hz: meta.rate_hz,
        window_s: meta.window_s,
        windows_per_step: meta.windows_per_step,
        samples_per_window: meta.samples_per_window,
        nominal: meta.nominal,
        origin: Origin::Measured {
            file: csv_path.display().to_string(),
        },
    };
    Ok(DriveLog::from_frames(log_meta, &frames))
}

#[cfg(test)]
mod tests {
    use super::*;
    use drive_sim_model::kinematics::{BodyVelocity, WheelSpeeds};
    use std::io::Write;

    const JSON: &str = r#"{"name":"t","robot":"warthog","terrain":"asphalt","rate_hz":20.0,
        "window_s":2.0,"windows_per_step":3,"samples_per_window":40,"steps":5,
        "nominal":{"wheel_radius_m":0.3,"baseline_m":1.08,"max_wheel_rad_s":16.6667,
        "max_lin_m_s":5.0,"max_ang_rad_s":4.0,"mass_kg":470.0,"width_m":1.52,"length_m":2.13}}"#;
    const HEADER: &str = "step,window,k,t_in_step_s,cmd_left_rad_s,cmd_right_rad_s,enc_left_rad_s,enc_right_rad_s,icp_x_m,icp_y_m,icp_z_m,icp_roll_rad,icp_pitch_rad,icp_yaw_rad,imu_wz_rad_s,imu_ax_m_s2,imu_ay_m_s2,imu_az_m_s2,ref_vx_m_s,ref_vy_m_s,ref_wz_rad_s";

    fn row(step: u32, window: u32, k: u32) -> String {
        let t = window as f64 * 2.0 + k as f64 / 20.0;
        format!("{step},{window},{k},{t},1,2,0.9,1.8,0.1,0.2,0,0,0,0.05,0.1,0.2,0.3,9.8,0.4,0,0.1")
    }

    fn write(dir: &tempfile::TempDir, csv: &str, json: Option<&str>) -> PathBuf {
        let p = dir.path().join("t.csv");
        std::fs::File::create(&p)
            .unwrap()
            .write_all(csv.as_bytes())
            .unwrap();
        if let Some(j) = json {
            std::fs::write(dir.path().join("t.json"), j).unwrap();
        }
        p
    }

    fn expect_err(csv: &str, json: Option<&str>, location: &str, message: &str) {
        let dir = tempfile::tempdir().unwrap();
        let p = write(&dir, csv, json);
        match read_measured_csv(&p) {
            Err(Error::Log {
                location: l,
                message: m,
                ..
            }) => {
                assert!(
                    l.contains(location),
                    "location `{l}` should contain `{location}` ({m})"
                );
                assert!(m.contains(message), "message `{m}` should contain `{message}`");
            }
            Err(Error::Io { .. }) if location == "io" => {}
            other => panic!("expected a log error at {location}, got {other:?}"),
        }
    }

    #[test]
    fn reads_rows_and_synthesizes_stamps() {
        let csv = format!(
            "{HEADER}\n{}\n{}\n{}\n",
            row(0, 0, 0),
            row(0, 1, 3),
            row(2, 2, 39)
        );
        let dir = tempfile::tempdir().unwrap();
        let log = read_measured_csv(write(&dir, &csv, Some(JSON))).unwrap();
        assert_eq!(log.samples.len(), 3);
        assert_eq!(log.steps(), vec![0, 2]);
        let s = &log.samples[2];
        assert_eq!((s.step, s.window, s.k), (2, 2, 39));
        // 2 * 6 s + 2 * 2 s + 39 / 20 s.
        assert!((s.stamp_s - (12.0 + 4.0 + 1.95)).abs() < 1e-12);
        assert_eq!(s.m.cmd, WheelSpeeds::new(1.0, 2.0));
        assert_eq!(s.m.enc, WheelSpeeds::new(0.9, 1.8));
        assert_eq!(s.m.pose.yaw_rad, 0.05);
        assert_eq!(s.m.imu.az_m_s2, 9.8);
        assert_eq!(s.m.reference, Some(BodyVelocity::new(0.4, 0.0, 0.1)));
        assert!(matches!(log.meta.origin, Origin::Measured { .. }));
        assert!(log.interruptions.is_empty());
    }

    #[test]
    fn empty_reference_is_none() {
        let r = row(0, 0, 0).replace(",0.4,0,0.1", ",,,");
        let dir = tempfile::tempdir().unwrap();
        let log = read_measured_csv(write(&dir, &format!("{HEADER}\n{r}\n"), Some(JSON))).unwrap();
        assert_eq!(log.samples[0].m.reference, None);
    }

    #[test]
    fn partial_reference_is_an_error() {
        let r = row(0, 0, 0).replace(",0.4,0,0.1", ",0.4,,");
        expect_err(
            &format!("{HEADER}\n{r}\n"),
            Some(JSON),
            "row 2, column `ref_vy_m_s`",
            "partially",
        );
    }

    #[test]
    fn missing_column() {
        let h = HEADER.replace("imu_wz_rad_s,", "");
        let r = row(0, 0, 0).replacen(",0.1,0.2,0.3,9.8", ",0.2,0.3,9.8", 1);
        expect_err(
            &format!("{h}\n{r}\n"),
            Some(JSON),
            "column `imu_wz_rad_s`",
            "missing",
        );
    }

    #[test]
    fn unparsable_and_non_finite_numbers() {
        let r = row(0, 0, 1).replacen(",0.9,", ",abc,", 1);
        expect_err(
            &format!("{HEADER}\n{}\n{r}\n", row(0, 0, 0)),
            Some(JSON),
            "row 3, column `enc_left_rad_s`",
            "cannot parse",
        );
        let r = row(0, 0, 1).replacen(",0,0,0.05,", ",0,0,NaN,", 1);
        expect_err(
            &format!("{HEADER}\n{}\n{r}\n", row(0, 0, 0)),
            Some(JSON),
            "row 3, column `icp_yaw_rad`",
            "non-finite",
        );
        let r = row(0, 0, 0).replacen(",9.8,", ",inf,", 1);
        expect_err(
            &format!("{HEADER}\n{r}\n"),
            Some(JSON),
            "row 2, column `imu_az_m_s2`",
            "non-finite",
        );
        let r = row(0, 0, 0).replacen(",1,2,", ",,2,", 1);
        expect_err(
            &format!("{HEADER}\n{r}\n"),
            Some(JSON),
            "row 2, column `cmd_left_rad_s`",
            "empty",
        );
    }

    #[test]
    fn indices_out_of_range() {
        expect_err(
            &format!("{HEADER}\n{}\n", row(0, 3, 0)),
            Some(JSON),
            "row 2, column `window`",
            "out of range",
        );
        expect_err(
            &format!("{HEADER}\n{}\n", row(0, 0, 40)),
            Some(JSON),
            "row 2, column `k`",
            "out of range",
        );
        expect_err(
            &format!("{HEADER}\n{}\n", row(5, 0, 0)),
            Some(JSON),
            "row 2, column `step`",
            "beyond",
        );
        let r = row(0, 0, 0).replacen("0,0,0,", "0,0,1.5,", 1);
        expect_err(
            &format!("{HEADER}\n{r}\n"),
            Some(JSON),
            "row 2, column `k`",
            "integer",
        );
    }

    #[test]
    fn non_monotonic_rows() {
        let csv = format!("{HEADER}\n{}\n{}\n", row(1, 0, 0), row(0, 2, 5));
        expect_err(&csv, Some(JSON), "row 3", "increasing");
        let csv = format!("{HEADER}\n{}\n{}\n", row(0, 1, 5), row(0, 1, 5));
        expect_err(&csv, Some(JSON), "row 3", "increasing");
    }

    #[test]
    fn json_problems() {
        let csv = format!("{HEADER}\n{}\n", row(0, 0, 0));
        expect_err(&csv, None, "io", "");
        expect_err(&csv, Some("{not json"), "field", "");
        expect_err(
            &csv,
            Some(&JSON.replace("\"mass_kg\":470.0", "\"mass_kg\":-1")),
            "field `nominal.mass_kg`",
            "positive",
        );
        expect_err(
            &csv,
            Some(&JSON.replace("\"rate_hz\":20.0,", "")),
            "field",
            "rate_hz",
        );
        expect_err(
            &csv,
            Some(&JSON.replace("\"windows_per_step\":3", "\"windows_per_step\":1")),
            "windows_per_step",
            "at least 2",
        );
    }

    #[test]
    fn empty_file() {
        expect_err(&format!("{HEADER}\n"), Some(JSON), "row 2", "no data");
    }

    #[test]
    fn reads_every_measured_dataset() {
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/measured");
        for (name, steps) in [
            ("warthog_asphalt", 100),
            ("warthog_ice", 100),
            ("warthog_gravel", 100),
            ("husky_2023", 201),
        ] {
            let log = read_measured_csv(format!("{dir}/{name}.csv")).unwrap();
            assert_eq!(log.steps().len(), steps, "{name}");
            assert_eq!(log.samples.len(), steps * 120, "{name}");
            assert_eq!(log.meta.name, name);
        }
    }
}
