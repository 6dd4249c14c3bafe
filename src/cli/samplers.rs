//! `drive-sim samplers`: parses the options, runs the comparison of
//! [`drive_sim::harness::samplers`], prints its table.

use drive_sim::harness::samplers::{compare, table, write_outputs, SamplersOptions};
use drive_sim::protocol::samplers::REGISTRY;
use std::path::PathBuf;

/// Options of `drive-sim samplers`.
#[derive(Debug, Clone, clap::Args)]
pub struct SamplersArgs {
    /// Robot name or file.
    #[arg(long, default_value = "warthog")]
    pub robot: String,
    /// Terrain name or file.
    #[arg(long, default_value = "asphalt")]
    pub terrain: String,
    /// Steps per run (the budget every strategy gets).
    #[arg(long, default_value_t = 150)]
    pub steps: u32,
    /// Seeds per strategy (1..=K).
    #[arg(long, default_value_t = 3)]
    pub seeds: u64,
    /// Only these strategies (comma-separated names).
    #[arg(long, value_delimiter = ',')]
    pub only: Vec<String>,
    /// List the strategies and exit.
    #[arg(long)]
    pub list: bool,
    /// Sensor noise: `typical` or `off`.
    #[arg(long, default_value = "typical", value_parser = ["typical", "off"])]
    pub noise: String,
    /// Ground-truth grid, points along vx.
    #[arg(long, default_value_t = 11)]
    pub grid_vx: usize,
    /// Ground-truth grid, points along wz.
    #[arg(long, default_value_t = 9)]
    pub grid_wz: usize,
    /// Output directory.
    #[arg(long, default_value = "out/samplers")]
    pub out: PathBuf,
}

impl SamplersArgs {
    /// The comparison these arguments ask for.
    pub fn options(&self) -> SamplersOptions {
        SamplersOptions {
            robot: self.robot.clone(),
            terrain: self.terrain.clone(),
            steps: self.steps,
            seeds: self.seeds,
            only: self.only.clone(),
            noise: super::run::noise_named(&self.noise),
            grid_vx: self.grid_vx,
            grid_wz: self.grid_wz,
        }
    }
}

/// `drive-sim samplers`.
pub fn samplers(args: &SamplersArgs) -> anyhow::Result<()> {
    if args.list {
        for e in REGISTRY {
            println!("{:<16} {}", e.name, e.summary);
        }
        return Ok(());
    }
    let report = compare(&args.options())?;
    print!("{}", table(&report));
    let html = write_outputs(&report, &args.out)?;
    eprintln!("drive-sim samplers: wrote {} and samplers.json", html.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;
    use drive_sim::sim::SensorNoise;

    #[derive(Debug, Parser)]
    struct Cli {
        #[command(flatten)]
        samplers: SamplersArgs,
    }

    #[test]
    fn noise_names_map_to_the_sensor_models() {
        let c = Cli::try_parse_from(["x", "--noise", "off", "--only", "halton,active"]).unwrap();
        let o = c.samplers.options();
        assert_eq!(o.noise, SensorNoise::default());
        assert_eq!(o.only, vec!["halton".to_string(), "active".to_string()]);
        let c = Cli::try_parse_from(["x"]).unwrap();
        assert_eq!(c.samplers.options().noise, SensorNoise::typical());
    }
}
