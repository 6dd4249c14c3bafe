//! rosbag2 recordings of the DRIVE ROS 2 node (`norlab-ulaval/DRIVE`) as [`DriveLog`]s.
//!
//! A bag is a directory (`metadata.yaml` + `.db3` or `.mcap` files), or one `.db3` / `.mcap`
//! file. [`storage`] reads the raw messages of the role topics only, [`roles`] says which topic
//! is what (presets for the Warthog and Husky, a TOML of one's own, or a printed guess), and
//! [`assemble`] decodes them with the crate's CDR messages, finds the steps, resamples onto the
//! analysis clock and excludes broken steps with a warning.
//!
//! A bag does not record the robot's mass or footprint, nor the terrain: the nominal values
//! come from `--robot` (or the roles preset's robot), overridden by the DRIVE node's own
//! parameter YAML when one lies beside the bag (wheel radius, baseline, speed limits, step
//! length); the terrain comes from `--terrain`.

pub mod assemble;
mod mcap_index;
pub mod roles;
pub mod storage;

use crate::{DriveLog, LogMeta, Nominal, Origin};
use drive_sim_model::error::{Error, Result};
use std::path::{Path, PathBuf};

pub use assemble::Segmentation;
pub use roles::{Role, RoleMap};
pub use storage::{Bag, Compression, Storage};

/// How to read a bag: what it does not record itself.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BagOptions {
    /// Robot name or robot TOML for the nominal values (`--robot`).
    pub robot: Option<String>,
    /// Terrain label (`--terrain`); `unlabelled` without one.
    pub terrain: Option<String>,
    /// Roles preset name or TOML (`--roles`); without one, a fitting preset or a guess.
    pub roles: Option<String>,
}

/// A bag read into a log, with what the user should be told.
#[derive(Debug, Clone)]
pub struct BagLog {
    /// The log.
    pub log: DriveLog,
    /// What was decided (roles, nominal values, segmentation).
    pub notes: Vec<String>,
    /// Steps excluded, and why.
    pub warnings: Vec<String>,
}

/// The DRIVE node's parameters (`drive_node: ros__parameters:`) found beside a bag.
#[derive(Debug, Clone, PartialEq)]
pub struct DriveParams {
    /// The YAML file.
    pub file: PathBuf,
    /// `wheel_radius`, m.
    pub wheel_radius_m: Option<f64>,
    /// `wheel_baseline`, m.
    pub baseline_m: Option<f64>,
    /// `max_lin_speed`, m/s.
    pub max_lin_m_s: Option<f64>,
    /// `max_ang_speed`, rad/s.
    pub max_ang_rad_s: Option<f64>,
    /// `step_len`, s.
    pub step_s: Option<f64>,
}

/// Looks for the DRIVE node's parameter YAML in the bag's directory (or beside the bag file).
pub fn find_drive_params(bag: &Path) -> Result<Option<DriveParams>> {
    let dir = if bag.is_dir() {
        bag.to_path_buf()
    } else {
        bag.parent().map_or_else(|| PathBuf::from("."), Path::to_path_buf)
    };
    let Ok(entries) = std::fs::read_dir(&dir) else {
        return Ok(None);
    };
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.extension().is_some_and(|e| e == "yaml" || e == "yml")
                && p.file_name().is_some_and(|n| n != "metadata.yaml")
        })
        .collect();
    files.sort();
    for file in files {
        let Ok(text) = std::fs::read_to_string(&file) else {
            continue;
        };
        let Ok(docs) = yaml_rust2::YamlLoader::load_from_str(&text) else {
            continue;
        };
        let Some(p) = docs
            .first()
            .map(|d| &d["drive_node"]["ros__parameters"])
            .filter(|p| !p.is_badvalue())
        else {
            continue;
        };
        let num = |k: &str| -> Result<Option<f64>> {
            let v = &p[k];
            if v.is_badvalue() {
                return Ok(None);
            }
            let x = v.as_f64().or_else(|| v.as_i64().map(|i| i as f64));
            match x {
                Some(x) if x.is_finite() && x > 0.0 => Ok(Some(x)),
                _ => Err(Error::config(
                    &file,
                    format!("drive_node.ros__parameters.{k}"),
                    format!("{v:?} is not a positive number"),
                )),
            }
        };
        return Ok(Some(DriveParams {
            wheel_radius_m: num("wheel_radius")?,
            baseline_m: num("wheel_baseline")?,
            max_lin_m_s: num("max_lin_speed")?,
            max_ang_rad_s: num("max_ang_speed")?,
            step_s: num("step_len")?,
            file,
        }));
    }
    Ok(None)
}

/// Nominal values and protocol timing for a bag, with a note saying where they come from.
fn nominal_for(
    bag: &Path,
    opts: &BagOptions,
    roles: &RoleMap,
) -> Result<(String, Nominal, f64, Vec<String>)> {
    let mut notes = Vec::new();
    let robot_name = opts
        .robot
        .clone()
        .or_else(|| roles.robot.clone())
        .ok_or_else(|| {
            Error::log(
                bag,
                "robot",
                "a bag does not record the robot's mass and footprint: pass --robot warthog|husky|FILE.toml",
            )
        })?;
    let (robot, file) = drive_sim_model::robot::Robot::resolve(&robot_name)?;
    let mut nominal = Nominal::from_robot(&robot);
    notes.push(format!(
        "nominal values: robot `{}` ({}){}",
        robot.name,
        file.display(),
        if opts.robot.is_none() {
            ", from the roles preset"
        } else {
            ""
        }
    ));
    let mut step_s = 6.0;
    if let Some(p) = find_drive_params(bag)? {
        let mut set = Vec::new();
        if let Some(r) = p.wheel_radius_m {
            nominal.wheel_radius_m = r;
            set.push(format!("wheel radius {r} m"));
        }
        if let Some(b) = p.baseline_m {
            nominal.baseline_m = b;
            set.push(format!("baseline {b} m"));
        }
        if let Some(v) = p.max_lin_m_s {
            nominal.max_lin_m_s = v;
            // The DRIVE node bounds each wheel by the wheel speed of the linear limit.
            nominal.max_wheel_rad_s = v / nominal.wheel_radius_m;
            set.push(format!("max linear speed {v} m/s"));
        }
        if let Some(w) = p.max_ang_rad_s {
            nominal.max_ang_rad_s = w;
            set.push(format!("max angular speed {w} rad/s"));
        }
        if let Some(s) = p.step_s {
            step_s = s;
            set.push(format!("step length {s} s"));
        }
        notes.push(format!(
            "DRIVE node parameters from {}: {}",
            p.file.display(),
            if set.is_empty() {
                "none used".into()
            } else {
                set.join(", ")
            }
        ));
    }
    Ok((robot.name.clone(), nominal, step_s, notes))
}

/// Reads a DRIVE bag into the common log.
pub fn read_bag(path: &Path, opts: &BagOptions) -> Result<BagLog> {
    let bag = Bag::open(path)?;
    let roles = roles::choose(&bag, opts.roles.as_deref(), opts.robot.as_deref())?;
    read_opened(&bag, &roles, opts)
}

/// Reads an opened bag with the roles chosen for it.
fn read_opened(bag: &Bag, roles: &RoleMap, opts: &BagOptions) -> Result<BagLog> {
    let path = bag.path.as_path();
    let mut notes = vec![format!("roles: {}", roles.source)];
    if roles.source.starts_with("guessed") {
        notes.extend(roles.describe().into_iter().map(|l| format!("  {l}")));
    }
    roles.check_required(path)?;
    if !roles.roles.contains_key(&Role::Imu) {
        notes.push("no IMU: IMU readings are NaN, the yaw rate comes from the pose".into());
    }
    let (robot, nominal, step_s, more) = nominal_for(path, opts, roles)?;
    notes.extend(more);
    let rate_hz = 20.0;
    let windows_per_step = 3;
    let window_s = step_s / windows_per_step as f64;
    let samples_per_window = (window_s * rate_hz).round() as u32;
    if samples_per_window < 2 {
        return Err(Error::log(
            path,
            "step length",
            format!("{step_s} s is too short for 3 windows at 20 Hz"),
        ));
    }
    let name = path
        .file_stem()
        .map_or_else(|| "bag".to_string(), |s| s.to_string_lossy().into_owned());
    let meta = LogMeta {
        name,
        robot,
        terrain: opts.terrain.clone().unwrap_or_else(|| "unlabelled".into()),
        rate_hz,
        window_s,
        windows_per_step,
        samples_per_window,
        nominal,
        origin: Origin::Measured {
            file: path.display().to_string(),
        },
    };
    meta.validate()
        .map_err(|(field, m)| Error::log(path, format!("declared `{field}`"), m))?;
    let (signals, t0) = assemble::decode(bag, roles)?;
    let (log, report) = assemble::build_log(&signals, t0, meta, roles, path)?;
    notes.push(match report.segmentation {
        Some(Segmentation::StepTopic) => "steps: from the step index topic".into(),
        _ => "steps: no step index recorded, from runs of constant command".into(),
    });
    notes.push(format!(
        "{} complete steps, {} excluded, {} interruptions",
        log.steps().len(),
        report.warnings.len(),
        log.interruptions.len()
    ));
    let mut warnings = bag.warnings.clone();
    warnings.extend(report.warnings);
    Ok(BagLog { log, notes, warnings })
}

/// What `drive-sim inspect` shows of a bag; built even from a broken bag, with its problems.
#[derive(Debug, Clone, Default)]
pub struct Inspection {
    /// The bag, if it opened.
    pub bag: Option<Bag>,
    /// Message count and time span per topic, when they could be read.
    pub stats: std::collections::BTreeMap<String, storage::TopicStats>,
    /// The roles it would use.
    pub roles: Option<RoleMap>,
    /// What reading it as a log gives.
    pub read: Option<BagLog>,
    /// Everything that went wrong, in order.
    pub problems: Vec<String>,
}

/// Looks at a bag as far as it can: topics, counts, roles, then the log. The bag is opened
/// once: counts come with the opening (MCAP) or from one query (sqlite3), and only the role
/// topics are read for the log.
pub fn inspect(path: &Path, opts: &BagOptions) -> Inspection {
    let mut out = Inspection::default();
    let bag = match Bag::open(path) {
        Ok(b) => b,
        Err(e) => {
            out.problems.push(e.to_string());
            return out;
        }
    };
    match bag.stats() {
        Ok(s) => out.stats = s,
        Err(e) => out.problems.push(e.to_string()),
    }
    match roles::choose(&bag, opts.roles.as_deref(), opts.robot.as_deref()) {
        Ok(r) => {
            if let Err(e) = r.check_required(path) {
                out.problems.push(e.to_string());
            }
            out.roles = Some(r);
        }
        Err(e) => out.problems.push(e.to_string()),
    }
    if out.problems.is_empty() {
        if let Some(roles) = &out.roles {
            match read_opened(&bag, roles, opts) {
                Ok(r) => out.read = Some(r),
                Err(e) => out.problems.push(e.to_string()),
            }
        }
    }
    out.bag = Some(bag);
    out
}

impl std::fmt::Display for Inspection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if let Some(b) = &self.bag {
            writeln!(
                f,
                "{}: rosbag2, storage {}, compression {}, {} file(s), {} topics",
                b.path.display(),
                b.storage.id(),
                b.compression.describe(),
                b.files.len(),
                b.topics.len()
            )?;
            let (mut lo, mut hi) = (u64::MAX, 0u64);
            for s in self.stats.values() {
                lo = lo.min(s.first_ns);
                hi = hi.max(s.last_ns);
            }
            if lo <= hi {
                writeln!(
                    f,
                    "time span {:.2} s from t = {:.3} s (epoch)",
                    (hi - lo) as f64 * 1e-9,
                    lo as f64 * 1e-9
                )?;
            }
            writeln!(
                f,
                "{:<36} {:<34} {:>8} {:>8} {:>9}",
                "topic", "type", "count", "rate_hz", "span_s"
            )?;
            for t in &b.topics {
                match self.stats.get(&t.name) {
                    Some(s) => {
                        let span = (s.last_ns - s.first_ns) as f64 * 1e-9;
                        let rate = if span > 0.0 {
                            (s.count - 1) as f64 / span
                        } else {
                            0.0
                        };
                        writeln!(
                            f,
                            "{:<36} {:<34} {:>8} {:>8.2} {:>9.2}",
                            t.name, t.msg_type, s.count, rate, span
                        )?
                    }
                    None => writeln!(
                        f,
                        "{:<36} {:<34} {:>8} {:>8} {:>9}",
                        t.name, t.msg_type, "-", "-", "-"
                    )?,
                }
            }
        }
        if let Some(r) = &self.roles {
            writeln!(f, "roles ({}):", r.source)?;
            for l in r.describe() {
                writeln!(f, "  {l}")?;
            }
            let name = self
                .bag
                .as_ref()
                .and_then(|b| b.path.file_stem())
                .map_or_else(|| "bag".to_string(), |s| s.to_string_lossy().into_owned());
            writeln!(
                f,
                "roles file that reads the bag this way (save, edit, pass with --roles FILE):"
            )?;
            write!(f, "{}", r.to_toml(&name))?;
        }
        match (&self.read, &self.bag) {
            (Some(r), _) => {
                for n in &r.notes {
                    writeln!(f, "{n}")?;
                }
                for w in &r.warnings {
                    writeln!(f, "warning: {w}")?;
                }
            }
            (None, Some(b)) => {
                for w in &b.warnings {
                    writeln!(f, "warning: {w}")?;
                }
            }
            (None, None) => {}
        }
        for p in &self.problems {
            writeln!(f, "problem: {p}")?;
        }
        Ok(())
    }
}
