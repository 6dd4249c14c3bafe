//! DRIVE on the simulator into memory: the building block of the sampler comparison, the sweep
//! runs and the protocol-claim tests, which analyse the log without writing MCAP.

use crate::error::Result;
use crate::ground_truth::{ground_truth, GroundTruthParams, TruthField};
use drive_sim_analysis::smoother::{Grid, KernelCovariance};
use drive_sim_analysis::{AnalysisParams, SmootherParams};
use drive_sim_log::{DriveLog, Frame, LogMeta, Nominal, Origin};
use drive_sim_model::kinematics::WheelSpeeds;
use drive_sim_model::robot::Robot;
use drive_sim_model::terrain::Terrain;
use drive_sim_protocol::sampler::{make_sampler_for, Sampler, SAMPLERS};
use drive_sim_protocol::samplers::matched::Matched;
use drive_sim_protocol::{run_drive, FrameSink, ProtocolConfig, RunSummary};
use drive_sim_sim::{SensorNoise, SimConfig, Simulator};
use std::time::Instant;

/// A simulated DRIVE run held in memory.
#[derive(Debug, Clone)]
pub struct SimulatedRun {
    /// The log, as the analysis reads it.
    pub log: DriveLog,
    /// Steps, interruptions, time efficiency.
    pub summary: RunSummary,
    /// Wall-clock time of the simulation, s.
    pub wall_s: f64,
}

/// The log metadata of a simulated run of `sampler_name` with `seed`.
pub fn simulated_meta(
    name: String,
    robot: &Robot,
    terrain: &Terrain,
    protocol: &ProtocolConfig,
    seed: u64,
    sampler_name: &str,
) -> LogMeta {
    LogMeta {
        name,
        robot: robot.name.clone(),
        terrain: terrain.name.clone(),
        rate_hz: protocol.rate_hz,
        window_s: protocol.window_s,
        windows_per_step: protocol.windows_per_step,
        samples_per_window: protocol.samples_per_window(),
        nominal: Nominal::from_robot(robot),
        origin: Origin::Simulated {
            seed,
            robot_file: robot.name.clone(),
            terrain_file: terrain.name.clone(),
            sampler: sampler_name.to_string(),
            injected: vec![],
        },
    }
}

/// Frames kept in memory and, when given, passed on to a second sink (an MCAP writer keeping
/// the run's log) as they come.
struct Tee<'a> {
    frames: Vec<Frame>,
    also: Option<&'a mut dyn FrameSink>,
}

impl FrameSink for Tee<'_> {
    fn frame(&mut self, frame: &Frame) -> drive_sim_model::Result<()> {
        self.frames.push(*frame);
        match self.also.as_deref_mut() {
            Some(s) => s.frame(frame),
            None => Ok(()),
        }
    }
    fn step_done(&mut self, completed: u32) {
        if let Some(s) = self.also.as_deref_mut() {
            s.step_done(completed);
        }
    }
}

/// Runs DRIVE with `sampler` on a simulator built from `robot`, `terrain` and `sim`, with the
/// protocol `protocol`, into memory.
pub fn simulate_with(
    robot: &Robot,
    terrain: &Terrain,
    sampler: &mut dyn Sampler,
    protocol: &ProtocolConfig,
    sim: SimConfig,
) -> Result<SimulatedRun> {
    simulate_into(robot, terrain, sampler, protocol, sim, None)
}

/// [`simulate_with`], also passing every frame to `also` (e.g. an MCAP writer) as it is made.
pub fn simulate_into(
    robot: &Robot,
    terrain: &Terrain,
    sampler: &mut dyn Sampler,
    protocol: &ProtocolConfig,
    sim: SimConfig,
    also: Option<&mut dyn FrameSink>,
) -> Result<SimulatedRun> {
    let seed = sim.seed;
    let mut plant = Simulator::new(robot, terrain, sim)?;
    let mut tee = Tee {
        frames: Vec::new(),
        also,
    };
    let t0 = Instant::now();
    let summary = run_drive(&mut plant, robot, sampler, protocol, &mut tee)?;
    let wall_s = t0.elapsed().as_secs_f64();
    let meta = simulated_meta(
        format!("{}_{}_{}_s{seed}", robot.name, terrain.name, sampler.name()),
        robot,
        terrain,
        protocol,
        seed,
        sampler.name(),
    );
    Ok(SimulatedRun {
        log: DriveLog::from_frames(meta, &tee.frames),
        summary,
        wall_s,
    })
}

/// Runs DRIVE of `steps` steps with the registered sampler `sampler` (seeded with `seed`, as
/// is the simulator) and the protocol defaults for the robot and terrain.
pub fn simulate(
    robot: &Robot,
    terrain: &Terrain,
    sampler: &str,
    steps: u32,
    seed: u64,
    noise: SensorNoise,
) -> Result<SimulatedRun> {
    seeded(robot, terrain, steps, seed, noise, |protocol| {
        make_sampler_for(sampler, seed, protocol).ok_or_else(|| unknown_sampler(sampler).into())
    })
}

/// [`simulate`] with draws in the quadrants of `commands` (step `i` draws uniformly in U in
/// the quadrant of command `i`; see [`Matched`]) instead of the paper's sampler: a twin's
/// candidate run, its protocol time limited
/// ([`ProtocolConfig::limit_for_candidates`]; past it, [`drive_sim_model::Error::Diverged`]).
pub fn simulate_matched(
    robot: &Robot,
    terrain: &Terrain,
    commands: &[WheelSpeeds],
    steps: u32,
    seed: u64,
    noise: SensorNoise,
) -> Result<SimulatedRun> {
    let protocol = ProtocolConfig::for_run(robot, terrain, steps).limit_for_candidates();
    let mut sampler = Matched::new(commands, seed)?;
    simulate_with(robot, terrain, &mut sampler, &protocol, sim_config(seed, noise))
}

/// A run of `steps` steps with the protocol defaults, the simulator seeded with `seed`, and
/// the sampler `sampler` builds for that protocol.
fn seeded(
    robot: &Robot,
    terrain: &Terrain,
    steps: u32,
    seed: u64,
    noise: SensorNoise,
    sampler: impl FnOnce(&ProtocolConfig) -> Result<Box<dyn Sampler>>,
) -> Result<SimulatedRun> {
    let protocol = ProtocolConfig::for_run(robot, terrain, steps);
    let mut s = sampler(&protocol)?;
    simulate_with(robot, terrain, s.as_mut(), &protocol, sim_config(seed, noise))
}

/// The simulator seeded with `seed`, with `noise`.
fn sim_config(seed: u64, noise: SensorNoise) -> SimConfig {
    SimConfig {
        seed,
        noise,
        ..SimConfig::default()
    }
}

/// The error for a sampler name that is not registered, listing those that are.
pub fn unknown_sampler(name: &str) -> drive_sim_model::Error {
    drive_sim_model::Error::Unknown {
        kind: "sampler",
        name: name.to_string(),
        available: SAMPLERS.join(", "),
    }
}

/// Analysis parameters without the transfer functions (they are smoothed on the truth's grid
/// instead).
pub fn analysis_params_without_smoother() -> AnalysisParams {
    AnalysisParams {
        smoother: SmootherParams {
            enabled: false,
            ..SmootherParams::default()
        },
        ..AnalysisParams::default()
    }
}

/// Kernel covariance for a robot: the paper's lessons learned (0.8 I for the Warthog,
/// 0.25 I for the Husky), scaled by the square of the robot's linear limit over the Warthog's
/// for other robots.
pub fn kernel_for(robot: &Robot) -> KernelCovariance {
    let v = if robot.name == "husky" {
        0.25
    } else if robot.name == "warthog" {
        0.8
    } else {
        0.8 * (robot.limits.max_lin_m_s / 5.0).powi(2)
    };
    KernelCovariance { var_vx: v, var_wz: v }
}

/// The ground-truth grid: `nvx × nwz` points over U's bounding box.
pub fn truth_grid(robot: &Robot, nvx: usize, nwz: usize) -> Grid {
    Grid::with_counts(&robot.command_space(), nvx, nwz)
}

/// Open-loop ground truth of `robot` on `terrain` (noise off, terrain seed 0) on `grid`.
pub fn simulator_truth(robot: &Robot, terrain: &Terrain, grid: &Grid) -> Result<TruthField> {
    ground_truth(
        || Ok(Simulator::new(robot, terrain, SimConfig::default())?),
        &robot.command_space(),
        grid,
        &GroundTruthParams::default(),
    )
}
