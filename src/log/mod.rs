//! DRIVE logs on disk: readers and writers of every format, all meeting in the common
//! [`DriveLog`].
//!
//! The data model itself ([`DriveLog`], [`Frame`], [`Measurement`], ...) lives in
//! [`crate::measurement`], below the simulator and the protocol that produce it; it is
//! re-exported here so that `crate::log::Pose` and friends keep working.

pub mod bag;
pub mod cdr;
pub mod csv;
pub mod mcap;
pub mod ros_msgs;

pub use crate::measurement::{
    DriveLog, Frame, FrameSink, GroundTruth, ImuReading, Interruption, LogMeta, Measurement, Nominal, Origin,
    Phase, Pose, Sample, UseSteps,
};

/// Reads a DRIVE log of either kind: a simulated `.mcap` or a measured `.csv` (with its JSON).
pub fn read_log(path: &std::path::Path) -> crate::Result<DriveLog> {
    match path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("mcap") => mcap::read_mcap(path),
        Some("csv") => csv::read_measured_csv(path),
        _ => Err(crate::Error::log(
            path,
            "file name",
            "expected a .mcap (simulated) or .csv (measured) DRIVE log",
        )),
    }
}

/// What [`open`] needs besides the path: what a bag does not record (ignored for the other
/// formats, which declare their robot and terrain).
pub type OpenOptions = bag::BagOptions;

/// A log opened by [`open`], with what the user should be told about how it was read.
#[derive(Debug, Clone)]
pub struct Opened {
    /// The log.
    pub log: DriveLog,
    /// Decisions made while reading (roles, nominal values, segmentation).
    pub notes: Vec<String>,
    /// Data left out, and why (steps excluded by a gap, incomplete steps).
    pub warnings: Vec<String>,
}

/// Opens any supported DRIVE input into the common [`DriveLog`]: a measured `.csv` (JSON
/// beside it), a drive-sim `.mcap`, or a rosbag2 recording of the DRIVE node (a bag directory,
/// a `.db3`, or a rosbag2 `.mcap`).
pub fn open(path: &std::path::Path, opts: &OpenOptions) -> crate::Result<Opened> {
    let plain = |log| Opened {
        log,
        notes: Vec::new(),
        warnings: Vec::new(),
    };
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let from_bag = |b: bag::BagLog| Opened {
        log: b.log,
        notes: b.notes,
        warnings: b.warnings,
    };
    if path.is_dir() {
        return bag::read_bag(path, opts).map(from_bag);
    }
    match ext.as_deref() {
        Some("csv") => csv::read_measured_csv(path).map(plain),
        Some("mcap") if !path.exists() => Err(crate::Error::io(
            path,
            std::io::Error::new(std::io::ErrorKind::NotFound, "no such file"),
        )),
        Some("mcap") if mcap::read::is_drive_sim_mcap(path)? => mcap::read_mcap(path).map(plain),
        Some("mcap") | Some("db3") => bag::read_bag(path, opts).map(from_bag),
        _ => Err(crate::Error::log(
            path,
            "file name",
            "expected a measured .csv, a drive-sim .mcap, or a rosbag2 bag (directory, .db3 or .mcap)",
        )),
    }
}
