//! The readers of DRIVE inputs, registered in one list: [`READERS`].
//!
//! [`crate::open`] and [`crate::read_log`] ask each reader in turn whether it takes a path and
//! hand the path to the first that does; the error for a path none takes lists what each
//! reader reads. A new input format is one [`Reader`] and one line in [`READERS`].

use crate::{bag, csv, mcap, DriveLog, OpenOptions, Opened};
use drive_sim_model::Result;
use std::path::Path;

/// A reader of one kind of DRIVE input.
pub trait Reader: Sync {
    /// Name in messages (`measured CSV`).
    fn name(&self) -> &'static str;
    /// What it reads, as the error for an unreadable path lists it (`a measured .csv`).
    fn reads(&self) -> &'static str;
    /// The input declares its robot and terrain itself: [`crate::read_log`], which takes no
    /// options, reads it.
    fn self_describing(&self) -> bool;
    /// Whether it takes `path` (`ext`: its extension in lower case). It may look inside the
    /// file (an MCAP of drive-sim or of rosbag2); a file that cannot be looked into is an error.
    fn takes(&self, path: &Path, ext: Option<&str>) -> Result<bool>;
    /// Reads `path`.
    fn read(&self, path: &Path, opts: &OpenOptions) -> Result<Opened>;
}

/// Every reader, asked in this order: the first that takes a path reads it.
pub static READERS: &[&dyn Reader] = &[&MeasuredCsv, &DriveSimMcap, &Rosbag2];

/// The reader of `path` among `readers`, or an error listing what they read.
pub(crate) fn reader_of(path: &Path, readers: &[&'static dyn Reader]) -> Result<&'static dyn Reader> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    for r in readers {
        if r.takes(path, ext.as_deref())? {
            return Ok(*r);
        }
    }
    let what: Vec<&str> = readers.iter().map(|r| r.reads()).collect();
    Err(drive_sim_model::Error::log(
        path,
        "file name",
        format!("expected {}", one_of(&what)),
    ))
}

/// `a`, `a or b`, `a, b, or c`.
fn one_of(v: &[&str]) -> String {
    match v {
        [] => "nothing".into(),
        [a] => (*a).into(),
        [a, b] => format!("{a} or {b}"),
        [init @ .., last] => format!("{}, or {last}", init.join(", ")),
    }
}

fn plain(log: DriveLog) -> Opened {
    Opened {
        log,
        notes: Vec::new(),
        warnings: Vec::new(),
    }
}

/// A measured run: the CSV of `../shared/data/measured`, its JSON beside it.
struct MeasuredCsv;

impl Reader for MeasuredCsv {
    fn name(&self) -> &'static str {
        "measured CSV"
    }
    fn reads(&self) -> &'static str {
        "a measured .csv (its .json beside it)"
    }
    fn self_describing(&self) -> bool {
        true
    }
    fn takes(&self, path: &Path, ext: Option<&str>) -> Result<bool> {
        Ok(!path.is_dir() && ext == Some("csv"))
    }
    fn read(&self, path: &Path, _opts: &OpenOptions) -> Result<Opened> {
        csv::read_measured_csv(path).map(plain)
    }
}

/// A drive-sim MCAP (`drive-sim run`), recognised by its own metadata record.
struct DriveSimMcap;

impl Reader for DriveSimMcap {
    fn name(&self) -> &'static str {
        "drive-sim MCAP"
    }
    fn reads(&self) -> &'static str {
        "a drive-sim .mcap"
    }
    fn self_describing(&self) -> bool {
        true
    }
    fn takes(&self, path: &Path, ext: Option<&str>) -> Result<bool> {
        if path.is_dir() || ext != Some("mcap") {
            return Ok(false);
        }
        if !path.exists() {
            return Err(drive_sim_model::Error::io(
                path,
                std::io::Error::new(std::io::ErrorKind::NotFound, "no such file"),
            ));
        }
        mcap::read::is_drive_sim_mcap(path)
    }
    fn read(&self, path: &Path, _opts: &OpenOptions) -> Result<Opened> {
        mcap::read_mcap(path).map(plain)
    }
}

/// A rosbag2 recording of the DRIVE node: a bag directory, one `.db3` or `.mcap` file, or
/// either compressed as `.zstd`. It does not say which robot or terrain it recorded; the
/// options ([`OpenOptions`]) do.
struct Rosbag2;

impl Reader for Rosbag2 {
    fn name(&self) -> &'static str {
        "rosbag2"
    }
    fn reads(&self) -> &'static str {
        "a rosbag2 bag (directory, .db3 or .mcap, or either as .zstd)"
    }
    fn self_describing(&self) -> bool {
        false
    }
    fn takes(&self, path: &Path, ext: Option<&str>) -> Result<bool> {
        Ok(path.is_dir() || matches!(ext, Some("mcap" | "db3" | "zstd")))
    }
    fn read(&self, path: &Path, opts: &OpenOptions) -> Result<Opened> {
        bag::read_bag(path, opts).map(|b| Opened {
            log: b.log,
            notes: b.notes,
            warnings: b.warnings,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_kind_of_path_goes_to_its_reader_and_the_rest_are_told_what_is_read() {
        let dir = std::env::temp_dir();
        let name = |p: &str| reader_of(Path::new(p), READERS).map(|r| r.name());
        assert_eq!(name("run.CSV").unwrap(), "measured CSV");
        assert_eq!(name("bag.db3").unwrap(), "rosbag2");
        assert_eq!(name("bag.mcap.zstd").unwrap(), "rosbag2");
        assert_eq!(reader_of(&dir, READERS).unwrap().name(), "rosbag2");
        // An MCAP that does not exist is an error of its own, not "expected ...".
        let missing = name("no/such/run.mcap").unwrap_err().to_string();
        assert!(missing.contains("no such file"), "{missing}");
        let e = name("run.txt").unwrap_err().to_string();
        for r in READERS {
            assert!(e.contains(r.reads()), "{e}");
        }
        // Without options, only the inputs that say their robot and terrain.
        let described: Vec<&'static dyn Reader> =
            READERS.iter().copied().filter(|r| r.self_describing()).collect();
        let e = match reader_of(Path::new("bag.db3"), &described) {
            Ok(r) => panic!("{} took a bag without options", r.name()),
            Err(e) => e.to_string(),
        };
        assert!(
            e.contains("a measured .csv") && e.contains("a drive-sim .mcap"),
            "{e}"
        );
        assert!(!e.contains("rosbag2"), "{e}");
    }
}
