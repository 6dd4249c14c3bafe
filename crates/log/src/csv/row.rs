//! One data row of a measured CSV: where the columns are, and each field read and checked,
//! with errors that name the file, the row and the column.

use super::{MeasuredJson, REFERENCE, REQUIRED};
use crate::{ImuReading, Measurement, Pose};
use drive_sim_model::kinematics::{BodyVelocity, WheelSpeeds};
use drive_sim_model::{Error, Result};
use std::path::Path;

/// Where the columns are in the CSV header.
pub(super) struct Columns {
    /// Index of each [`REQUIRED`] column.
    required: [usize; REQUIRED.len()],
    /// Index of each [`REFERENCE`] column, if present.
    reference: Vec<Option<usize>>,
}

impl Columns {
    /// The columns of `headers`; an error naming the first required column missing.
    pub(super) fn of(headers: &::csv::StringRecord, csv_path: &Path) -> Result<Self> {
        let col = |name: &str| headers.iter().position(|h| h.trim() == name);
        let mut required = [0usize; REQUIRED.len()];
        for (i, name) in REQUIRED.iter().enumerate() {
            required[i] = col(name).ok_or_else(|| {
                Error::log(
                    csv_path,
                    format!("row 1 (header), column `{name}`"),
                    "missing required column",
                )
            })?;
        }
        let reference = REFERENCE.iter().map(|n| col(n)).collect();
        Ok(Self { required, reference })
    }
}

/// One data row of the CSV, read field by field; errors name the file, the row and the column.
pub(super) struct Row<'a> {
    /// The row's fields.
    pub(super) record: &'a ::csv::StringRecord,
    /// Line number in the file (the header is line 1).
    pub(super) line: u64,
    /// Column positions.
    pub(super) cols: &'a Columns,
    /// The CSV, for errors.
    pub(super) csv_path: &'a Path,
}

impl Row<'_> {
    fn loc(&self, name: &str) -> String {
        format!("row {}, column `{name}`", self.line)
    }

    /// Required column `i` as a finite number.
    pub(super) fn field(&self, i: usize) -> Result<f64> {
        let name = REQUIRED[i];
        let raw = self.record.get(self.cols.required[i]).unwrap_or("").trim();
        if raw.is_empty() {
            return Err(Error::log(
                self.csv_path,
                self.loc(name),
                "empty value in a required column",
            ));
        }
        let v: f64 = raw.parse().map_err(|_| {
            Error::log(
                self.csv_path,
                self.loc(name),
                format!("cannot parse `{raw}` as a number"),
            )
        })?;
        if !v.is_finite() {
            return Err(Error::log(
                self.csv_path,
                self.loc(name),
                format!("non-finite value `{raw}`"),
            ));
        }
        Ok(v)
    }

    /// Required column `i` as a non-negative integer.
    fn index(&self, i: usize) -> Result<u32> {
        let v = self.field(i)?;
        if v < 0.0 || v.fract() != 0.0 || v > u32::MAX as f64 {
            return Err(Error::log(
                self.csv_path,
                self.loc(REQUIRED[i]),
                format!("expected a non-negative integer, got {v}"),
            ));
        }
        Ok(v as u32)
    }

    /// The row's (step, window, k), each within the declared range and after `prev`.
    pub(super) fn position(
        &self,
        meta: &MeasuredJson,
        prev: Option<(u32, u32, u32)>,
    ) -> Result<(u32, u32, u32)> {
        let (step, window, k) = (self.index(0)?, self.index(1)?, self.index(2)?);
        if step >= meta.steps {
            return Err(Error::log(
                self.csv_path,
                self.loc("step"),
                format!(
                    "step {step} is beyond the {} steps declared in the JSON",
                    meta.steps
                ),
            ));
        }
        if window >= meta.windows_per_step {
            return Err(Error::log(
                self.csv_path,
                self.loc("window"),
                format!("window {window} out of range 0..{}", meta.windows_per_step),
            ));
        }
        if k >= meta.samples_per_window {
            return Err(Error::log(
                self.csv_path,
                self.loc("k"),
                format!("sample index {k} out of range 0..{}", meta.samples_per_window),
            ));
        }
        if let Some(p) = prev {
            if (step, window, k) <= p {
                return Err(Error::log(
                    self.csv_path,
                    self.loc("step"),
                    format!(
                        "rows not in increasing (step, window, k) order: ({step}, {window}, {k}) after ({}, {}, {})",
                        p.0, p.1, p.2
                    ),
                ));
            }
        }
        Ok((step, window, k))
    }

    /// The source's own body-velocity estimate: all three reference columns or none;
    /// non-finite values mean "no reference".
    fn reference(&self) -> Result<Option<BodyVelocity>> {
        let raw_ref: Vec<&str> = self
            .cols
            .reference
            .iter()
            .map(|i| i.and_then(|i| self.record.get(i)).unwrap_or("").trim())
            .collect();
        if raw_ref.iter().all(|r| r.is_empty()) {
            return Ok(None);
        }
        let mut v = [0.0; 3];
        for (j, raw) in raw_ref.iter().enumerate() {
            if raw.is_empty() {
                return Err(Error::log(
                    self.csv_path,
                    self.loc(REFERENCE[j]),
                    "reference estimate partially filled (all three or none)",
                ));
            }
            v[j] = raw.parse().map_err(|_| {
                Error::log(
                    self.csv_path,
                    self.loc(REFERENCE[j]),
                    format!("cannot parse `{raw}` as a number"),
                )
            })?;
        }
        let b = BodyVelocity::new(v[0], v[1], v[2]);
        Ok(b.is_finite().then_some(b))
    }

    /// Commands, encoders, pose, IMU and reference of the row.
    pub(super) fn measurement(&self) -> Result<Measurement> {
        let cmd = WheelSpeeds::new(self.field(4)?, self.field(5)?);
        let enc = WheelSpeeds::new(self.field(6)?, self.field(7)?);
        let pose = Pose {
            x_m: self.field(8)?,
            y_m: self.field(9)?,
            z_m: self.field(10)?,
            roll_rad: self.field(11)?,
            pitch_rad: self.field(12)?,
            yaw_rad: self.field(13)?,
        };
        let imu = ImuReading {
            wz_rad_s: self.field(14)?,
            ax_m_s2: self.field(15)?,
            ay_m_s2: self.field(16)?,
            az_m_s2: self.field(17)?,
        };
        Ok(Measurement {
            cmd,
            enc,
            pose,
            imu,
            reference: self.reference()?,
            truth: None,
        })
    }
}
