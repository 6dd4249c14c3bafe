//! The judge's cases on the independent generator, shared by `tests/long/judge.rs` and the
//! statistics tier's level measurement (`tests/statistics/judge_level.rs`): the generator's
//! run whose motors clip, the model judged against it, and small but decisive options.

use super::generator::{drive_log_with, TestRobotSpec, Unmodelled};
use drive_sim::calibration::twin;
use drive_sim::compare::judge::{judge, JudgeOptions, JudgeOutcome, JudgeRequest};
use drive_sim::log::{DriveLog, UseSteps};
use drive_sim::terrain::Terrain;

/// The runs' length for the null case and the inverted judge: 60 steps hold every criterion's
/// statistics (the maps' cells, the hulls). Power needs more: on 60 steps the generator's clip
/// makes every run differ, but not beyond every reference (the count's p 0.5), so the
/// clipping robot is judged on 100.
pub const STEPS: u32 = 60;

/// Small but decisive: 9 references give p-values down to 0.1, the level of the test.
pub fn opts() -> JudgeOptions {
    JudgeOptions {
        real_steps: UseSteps::All,
        steps: None,
        seed: 0,
        sims: 4,
        references: 9,
        resamples: 200,
        alpha: 0.1,
        ..JudgeOptions::default()
    }
}

/// The generator's DRIVE run of `steps`, its motors clipping at `limit_rad_s`, and the model
/// judged against it: the simulated Warthog on asphalt without a wheel-speed limit.
pub fn generator_and_model(limit_rad_s: f64, steps: u32) -> (DriveLog, drive_sim::calibration::ModelParams) {
    let extra = Unmodelled {
        wheel_limit_rad_s: limit_rad_s,
        centripetal_s: -0.20,
        pose_yaw_noise_rad: 0.01,
        ..Unmodelled::default()
    };
    let (log, robot) = drive_log_with("generator", TestRobotSpec::warthog_on_asphalt(3), extra, steps);
    let (terrain, _) = Terrain::resolve("asphalt").unwrap();
    (log, twin::lift_effects(&robot, &terrain).unwrap())
}

/// Judges `model` against `real` with [`opts`], printing the progress and the table.
pub fn judged(real: &DriveLog, model: &drive_sim::calibration::ModelParams) -> JudgeOutcome {
    judged_with(real, model, &opts())
}

/// Judges `model` against `real` with `opts`, printing the progress and the table.
pub fn judged_with(
    real: &DriveLog,
    model: &drive_sim::calibration::ModelParams,
    opts: &JudgeOptions,
) -> JudgeOutcome {
    let j = judge(&JudgeRequest { real, model, opts }, &|event| eprintln!("{event}")).unwrap();
    eprintln!("{}", drive_sim::compare::judge::write::table(&j));
    j
}
