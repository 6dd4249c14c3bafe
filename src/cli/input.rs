//! Opening any DRIVE input from the command line (`--robot`, `--terrain`, `--roles` for bags),
//! and `drive-sim inspect`.

use drive_sim::log::{DriveLog, OpenOptions};
use std::path::{Path, PathBuf};

/// What a rosbag2 bag does not record; ignored for `.csv` and drive-sim `.mcap` logs.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct InputArgs {
    /// Bags: robot for the nominal values (`warthog`, `husky` or a robot TOML); default: the
    /// roles preset's robot. The DRIVE node's parameter YAML beside the bag overrides radius,
    /// baseline, limits and step length. `replay` and `calibrate`: also the model replayed or
    /// calibrated from, used as written (e.g. a twin's `robot.toml`).
    #[arg(long)]
    pub robot: Option<String>,
    /// Terrain the log was recorded on, a name (see `drive-sim terrains`) or a terrain TOML:
    /// replaces the label a log declares (required when that label is a terrain drive-sim does
    /// not know); a bag does not record one (default `unlabelled`, models start from `asphalt`).
    /// `replay` and `calibrate`: also the terrain model, used as written (e.g. a twin's).
    #[arg(long, value_name = "NAME|FILE")]
    pub terrain: Option<String>,
    /// Bags: topic roles, `warthog`, `husky` (the DRIVE node's presets) or a roles TOML;
    /// default: the preset whose topics are in the bag, else a guess from types and names.
    #[arg(long)]
    pub roles: Option<String>,
}

impl InputArgs {
    /// As library options.
    pub fn options(&self) -> OpenOptions {
        OpenOptions {
            robot: self.robot.clone(),
            terrain: self.terrain.clone(),
            roles: self.roles.clone(),
        }
    }
}

/// Opens `path` with [`drive_sim::log::open`], printing how it was read and what was left out.
pub fn open_log(path: &Path, args: &InputArgs) -> drive_sim::Result<DriveLog> {
    let o = drive_sim::log::open(path, &args.options())?;
    for n in &o.notes {
        eprintln!("drive-sim: {n}");
    }
    for w in &o.warnings {
        eprintln!("drive-sim: warning: {w}");
    }
    Ok(o.log)
}

/// The models a replay or a tuning of `log` starts from (`--robot` / `--terrain`, names or
/// files, else the log's own), printing what resolving them noted.
pub fn starting_models(
    log: &DriveLog,
    args: &InputArgs,
) -> drive_sim::calibration::Result<drive_sim::calibration::StartingModels> {
    let models =
        drive_sim::calibration::StartingModels::resolve(log, args.robot.as_deref(), args.terrain.as_deref())?;
    for n in &models.notes {
        eprintln!("drive-sim: {n}");
    }
    Ok(models)
}

/// Options of `drive-sim inspect`.
#[derive(Debug, Clone, clap::Args)]
pub struct InspectArgs {
    /// A rosbag2 bag: directory with metadata.yaml, `.db3` or `.mcap` file.
    pub bag: PathBuf,
    /// Robot, terrain and roles as for `analyze`.
    #[command(flatten)]
    pub input: InputArgs,
}

/// Prints what the bag holds, as far as it can be read; bad input still exits with code 2.
pub fn inspect(args: &InspectArgs) -> anyhow::Result<()> {
    let i = drive_sim::log::bag::inspect(&args.bag, &args.input.options());
    print!("{i}");
    match i.problems.first() {
        None => Ok(()),
        Some(_) => Err(drive_sim::Error::log(
            &args.bag,
            "inspect",
            format!("{} problem(s), listed above", i.problems.len()),
        )
        .into()),
    }
}

/// The lines that tell how to run a twin just written into `out/twin/` and how to judge it
/// against the real log's steps it was not chosen on (all of them when it saw every step).
pub fn twin_hints(real: &Path, out: &Path, chosen_on: drive_sim::log::UseSteps) {
    let (robot, terrain) = (out.join("twin/robot.toml"), out.join("twin/terrain.toml"));
    eprintln!(
        "drive-sim: twin: drive-sim run --robot {} --terrain {}",
        robot.display(),
        terrain.display()
    );
    let judged = chosen_on.other_half().unwrap_or(drive_sim::log::UseSteps::All);
    eprintln!(
        "drive-sim: can compare tell it from the run? drive-sim judge {} --robot {} --terrain {} --real-steps {}",
        real.display(),
        robot.display(),
        terrain.display(),
        judged.as_str()
    );
}
