//! DRIVE logs on disk: readers and writers of every format, all meeting in the common
//! [`DriveLog`].
//!
//! The data model itself ([`DriveLog`], [`Frame`], [`Measurement`], ...) lives in
//! [`crate::measurement`], below the simulator and the protocol that produce it; it is
//! re-exported here so that `crate::log::Pose` and friends keep working.

pub mod cdr;
pub mod csv;
pub mod mcap;
pub mod ros_msgs;

pub use crate::measurement::{
    DriveLog, Frame, FrameSink, GroundTruth, ImuReading, Interruption, LogMeta, Measurement, Nominal, Origin,
    Phase, Pose, Sample,
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
