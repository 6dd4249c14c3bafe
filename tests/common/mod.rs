//! What the calibration tests share: printing a report's figures (shown with `--nocapture`;
//! they are the numbers quoted in the README and the notes).

#[allow(dead_code)] // not every test crate that includes this module generates data
pub mod generator;
#[allow(dead_code)] // the judge's cases, used by the long tests and the statistics tier
pub mod judging;

use drive_sim::calibration::CalibrationReport;

/// The catalogue without the structural effects discovery points to (`body_lag`,
/// `centripetal_slip`, `motor_gain_drift`, ...): the candidates of `tests/long/discovery.rs` and of the
/// discovery benchmark's cases, so that such an effect can only come in through an equation.
#[allow(dead_code)] // the discovery tests' and benchmark's candidates
pub const CATALOGUE_WITHOUT_STRUCTURAL: [&str; 14] = [
    "dead_time_s",
    "command_speed_limit_m_s",
    "command_yaw_rate_limit_rad_s",
    "controller_kinematics",
    "controller_wheel_limit_rad_s",
    "motor_gain",
    "wheel_speed_saturation_rad_s",
    "time_constant_scale",
    "wheel_radius_scale",
    "imu_yaw_rate_sign_flip",
    "imu_yaw_rate_scale",
    "imu_yaw_rate_bias_rad_s",
    "pose_latency_s",
    "encoder_scale",
];

/// Prints the before/after table, the fitted terrain parameters, the first candidates of the
/// ranking and the effects kept.
#[allow(dead_code)] // not every test crate that includes this module prints reports
pub fn print_summary(name: &str, r: &CalibrationReport, secs: f64) {
    eprintln!("== {name}: {secs:.1} s, status {:?}", r.status);
    for row in &r.table {
        eprintln!(
            "{:26} {:>5}  IDD {:9.4}  before {:9.4}  after {:9.4}  floor {:8.4}",
            row.metric, row.unit, row.idd, row.sim_before, row.sim_after, row.floor
        );
    }
    for p in r.terrain_fit.iter().flat_map(|f| &f.params) {
        eprintln!(
            "  fitted {} = {:.4} (was {:?}, at bound: {})",
            p.name, p.value, p.initial, p.at_bound
        );
    }
    for e in r.rounds[0].ranking.iter().take(5) {
        eprintln!(
            "  candidate {:30} held-out reduction {:9.3} ± {:7.3}, share {:.2}, {:?}",
            e.effect,
            e.reduction,
            e.reduction_se,
            e.share,
            e.params
                .iter()
                .map(|p| (p.name.as_str(), p.value))
                .collect::<Vec<_>>()
        );
    }
    eprintln!(
        "  effects {:?}",
        r.effects
            .iter()
            .map(|e| (e.name.as_str(), e.value))
            .collect::<Vec<_>>()
    );
}

/// A DRIVE log of the Warthog on asphalt (uniform-wheel sampler) from `frames`, whose metadata
/// declares no effect: whatever the plant carried, calibrate must find it from the data.
#[allow(dead_code)] // not every test crate that includes this module makes logs
pub fn undeclared_log(
    name: &str,
    robot: &drive_sim::robot::Robot,
    seed: u64,
    pc: &drive_sim::protocol::ProtocolConfig,
    frames: &[drive_sim::log::Frame],
) -> drive_sim::log::DriveLog {
    use drive_sim::log::{DriveLog, LogMeta, Nominal, Origin};
    let meta = LogMeta {
        name: name.into(),
        robot: robot.name.clone(),
        terrain: "asphalt".into(),
        rate_hz: pc.rate_hz,
        window_s: pc.window_s,
        windows_per_step: pc.windows_per_step,
        samples_per_window: pc.samples_per_window(),
        nominal: Nominal::from_robot(robot),
        origin: Origin::Simulated {
            seed,
            robot_file: robot.name.clone(),
            terrain_file: "asphalt".into(),
            sampler: "uniform-wheel".into(),
            // Declared nowhere calibrate could read it.
            injected: Vec::new(),
        },
    };
    DriveLog::from_frames(meta, frames)
}
