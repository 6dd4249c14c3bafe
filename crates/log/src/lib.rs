//! DRIVE logs on disk: readers and writers of every format, all meeting in the common
//! [`DriveLog`].
//!
//! The data model itself ([`DriveLog`], [`Frame`], [`Measurement`], ...) lives in
//! [`drive_sim_model::measurement`], below the simulator and the protocol that produce it; it is
//! re-exported here so that `crate::Pose` and friends keep working.
//!
//! ```no_run
//! use std::path::Path;
//!
//! // Any supported input: a measured CSV, a drive-sim MCAP, or a rosbag2 bag of the DRIVE node.
//! let opened = drive_sim_log::open(Path::new("bags/warthog_gravel"), &Default::default())?;
//! for note in &opened.notes {
//!     println!("{note}"); // how the bag was read: roles, nominal values, segmentation
//! }
//! println!("{} samples of {} on {}", opened.log.samples.len(), opened.log.meta.robot, opened.log.meta.terrain);
//! # Ok::<(), drive_sim_model::Error>(())
//! ```

#![warn(missing_docs, unreachable_pub)]

pub mod bag;
pub mod cdr;
pub mod csv;
pub mod mcap;
pub mod readers;
pub mod ros_msgs;

pub use drive_sim_model::measurement::{
    held_command, DriveLog, Frame, FrameSink, GroundTruth, HeldCommand, ImuReading, Interruption, LogMeta,
    Measurement, Nominal, Origin, Phase, Pose, Sample, UseSteps,
};

/// Reads a DRIVE log that declares its robot and terrain itself: a measured `.csv` (with its
/// JSON) or a drive-sim `.mcap` (the [`readers::Reader::self_describing`] readers; a bag needs
/// [`open`] and its options).
pub fn read_log(path: &std::path::Path) -> drive_sim_model::Result<DriveLog> {
    let described: Vec<&'static dyn readers::Reader> = readers::READERS
        .iter()
        .copied()
        .filter(|r| r.self_describing())
        .collect();
    let reader = readers::reader_of(path, &described)?;
    reader.read(path, &OpenOptions::default()).map(|o| o.log)
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
/// a `.db3`, or a rosbag2 `.mcap`); the first of [`readers::READERS`] that takes the path
/// reads it.
pub fn open(path: &std::path::Path, opts: &OpenOptions) -> drive_sim_model::Result<Opened> {
    let opened = readers::reader_of(path, readers::READERS)?.read(path, opts)?;
    settle_terrain(opened, path, opts)
}

/// The terrain label of a log that does not say which terrain it was recorded on.
pub const UNLABELLED: &str = "unlabelled";

/// The terrain models start from for an [`UNLABELLED`] log (a stated default, with a warning).
pub const DEFAULT_TERRAIN: &str = "asphalt";

/// The terrain model of a log's terrain label: the terrain of that name (or file); for
/// [`UNLABELLED`], [`DEFAULT_TERRAIN`] with a warning (returned); for a label no terrain file
/// provides, an error naming the label and `file`, pointing to `--terrain`. The origin of a
/// simulated log also names the terrain file it was run on, tried when the label is not in
/// the catalog.
pub fn terrain_of_log(
    meta: &LogMeta,
    file: &std::path::Path,
) -> drive_sim_model::Result<(drive_sim_model::terrain::Terrain, Option<String>)> {
    use drive_sim_model::terrain::Terrain;
    let label = meta.terrain.as_str();
    if label == UNLABELLED {
        let (t, _) = Terrain::resolve(DEFAULT_TERRAIN)?;
        return Ok((
            t,
            Some(format!(
                "terrain `{UNLABELLED}`: the log does not say which terrain it was recorded on; \
                 models start from the default `{DEFAULT_TERRAIN}` (pass `--terrain NAME|FILE` to say which)"
            )),
        ));
    }
    match Terrain::resolve(label) {
        Ok((t, _)) => Ok((t, None)),
        Err(e @ drive_sim_model::Error::Config { .. }) => Err(e),
        Err(unknown) => {
            if let Origin::Simulated { terrain_file, .. } = &meta.origin {
                if let Ok((t, _)) = Terrain::resolve(terrain_file) {
                    return Ok((t, None));
                }
            }
            let known = match unknown {
                drive_sim_model::Error::Unknown { available, .. } => format!(" (known: {available})"),
                _ => String::new(),
            };
            Err(drive_sim_model::Error::log(
                file,
                "metadata `terrain`",
                format!(
                    "unknown terrain `{label}`{known}; pass `--terrain NAME|FILE` to say which \
                     terrain model this log was recorded on"
                ),
            ))
        }
    }
}

/// Applies `--terrain` to an opened log (its label becomes the name or file given), or checks
/// the label the log declares (see [`terrain_of_log`]).
fn settle_terrain(
    mut o: Opened,
    path: &std::path::Path,
    opts: &OpenOptions,
) -> drive_sim_model::Result<Opened> {
    match &opts.terrain {
        Some(t) => {
            let (terrain, _) = drive_sim_model::terrain::Terrain::resolve(t)?;
            if o.log.meta.terrain != *t && o.log.meta.terrain != terrain.name {
                o.notes.push(format!(
                    "terrain: `{t}` as --terrain says (the log declares `{}`)",
                    o.log.meta.terrain
                ));
            }
            o.log.meta.terrain = t.clone();
        }
        None => {
            if let (_, Some(w)) = terrain_of_log(&o.log.meta, path)? {
                o.warnings.push(w);
            }
        }
    }
    Ok(o)
}
