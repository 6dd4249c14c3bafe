//! The `drive-sim` command line: what each subcommand does, and how it reports progress.

use crate::error::{Error, Result};
use crate::robot::{Robot, BUILTIN_ROBOTS};
use crate::terrain::{Terrain, BUILTIN_TERRAINS};
use clap::{Parser, Subcommand};
use std::io::Write;
use std::path::PathBuf;

/// Simulation-backed test harness for the DRIVE protocol.
#[derive(Debug, Parser)]
#[command(name = "drive-sim", version, about, long_about = None)]
pub struct Cli {
    /// What to do; without one, runs the demonstration (`drive-sim demo`).
    #[command(subcommand)]
    pub command: Option<Command>,
}

/// Subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Lists the robots (built-in and ./robots/*.toml).
    Robots,
    /// Lists the terrains (built-in and ./terrains/*.toml).
    Terrains,
}

/// Runs the command line; returns the process exit code.
pub fn main() -> i32 {
    let cli = Cli::parse();
    match dispatch(cli) {
        Ok(()) => 0,
        // A closed pipe (`drive-sim robots | head`) is the reader's choice, not an error.
        Err(e)
            if e.downcast_ref::<std::io::Error>()
                .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe) =>
        {
            0
        }
        Err(e) => {
            eprintln!("drive-sim: error: {e:#}");
            1
        }
    }
}

fn dispatch(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        None => Err(anyhow::anyhow!("no demo yet")),
        Some(Command::Robots) => list_robots(),
        Some(Command::Terrains) => list_terrains(),
    }
}

fn list_robots() -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "{:<10} {:>8} {:>7} {:>7} {:>9} {:>10}  source",
        "robot", "mass_kg", "r_m", "b_m", "vmax_m_s", "wmax_rad_s"
    )?;
    for e in crate::config::catalog("robot", BUILTIN_ROBOTS) {
        match crate::config::parse_toml::<Robot>(&e.text, &e.origin) {
            Ok(r) => writeln!(
                out,
                "{:<10} {:>8.1} {:>7.3} {:>7.3} {:>9.2} {:>10.2}  {}",
                e.name,
                r.body.mass_kg,
                r.wheels.radius_m,
                r.wheels.baseline_m,
                r.limits.max_lin_m_s,
                r.limits.max_ang_rad_s,
                e.origin.display()
            )?,
            Err(err) => writeln!(out, "{:<10} INVALID: {err}", e.name)?,
        }
    }
    Ok(())
}

fn list_terrains() -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "{:<10} {:>8} {:>8} {:>8}  description",
        "terrain", "mu_peak", "mu_slide", "c_roll"
    )?;
    for e in crate::config::catalog("terrain", BUILTIN_TERRAINS) {
        match crate::config::parse_toml::<Terrain>(&e.text, &e.origin) {
            Ok(t) => writeln!(
                out,
                "{:<10} {:>8.2} {:>8.2} {:>8.3}  {}",
                e.name,
                t.friction.peak_longitudinal,
                t.friction.sliding_longitudinal,
                t.resistance.rolling_coefficient,
                t.description
            )?,
            Err(err) => writeln!(out, "{:<10} INVALID: {err}", e.name)?,
        }
    }
    Ok(())
}

#[allow(dead_code)]
fn ensure_out_dir(dir: &PathBuf) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))
}
