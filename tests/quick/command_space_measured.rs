//! The U a twin's own DRIVE draws in, fitted to the measured runs' commands by the twin's start
//! (`drive_sim::twin::input::starting_models`): the Warthog's runs stay in their configured U,
//! the Husky's run fills the metadata's wheel square once its turning is divided by about 2.5,
//! and draws in the fitted U spread as the run's commands do where the square's do not.

use drive_sim::kinematics::{CommandSpace, WheelSpeeds};
use drive_sim::log::csv::read_measured_csv;
use drive_sim::log::DriveLog;
use drive_sim::protocol::sampler::uniform_in_wheel_space;
use drive_sim::twin::input::starting_models;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

const DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data/measured");

fn log(name: &str) -> DriveLog {
    read_measured_csv(format!("{DIR}/{name}.csv")).unwrap()
}

fn fitted(log: &DriveLog) -> (CommandSpace, Vec<String>) {
    let (starts, notes) = starting_models(&[log], None, None).unwrap();
    (starts[0].robot.command_space(), notes)
}

/// Interquartile range of the commanded yaw rate (nominal IDD), rad/s.
fn yaw_rate_iqr(space: &CommandSpace, commands: &[WheelSpeeds]) -> f64 {
    let mut wz: Vec<f64> = commands
        .iter()
        .map(|c| space.idd.body_from_wheels(*c).wz_rad_s)
        .collect();
    wz.sort_by(f64::total_cmp);
    let q = |p: f64| wz[((wz.len() - 1) as f64 * p).round() as usize];
    q(0.75) - q(0.25)
}

#[test]
fn the_warthog_runs_keep_their_configured_command_space() {
    for name in [
        "warthog_asphalt",
        "warthog_asphalt_b",
        "warthog_gravel",
        "warthog_ice",
    ] {
        let run = log(name);
        let (u, notes) = fitted(&run);
        assert!(notes.is_empty(), "{name}: {notes:?}");
        assert_eq!(u, run.meta.nominal.command_space(), "{name}");
        assert_eq!(u.turn_scale, 1.0, "{name}");
    }
}

#[test]
fn the_husky_run_is_drawn_in_a_turned_square_and_its_twin_draws_there() {
    let run = log("husky_2023");
    let commands = run.held_commands();
    let (u, notes) = fitted(&run);
    assert!((2.3..=2.7).contains(&u.turn_scale), "{u:?}");
    assert_eq!(
        u.max_wheel_rad_s, 6.1,
        "the metadata's 6.06 rad/s, rounded up: {u:?}"
    );
    assert!(commands.iter().all(|c| u.contains_wheels(*c)));
    assert!(
        notes.iter().any(|n| n.contains("limits.command_turn_scale")),
        "{notes:?}"
    );
    // The square holding the commands as they are, the start's U before the turn scale.
    let square = CommandSpace {
        turn_scale: 1.0,
        max_wheel_rad_s: commands
            .iter()
            .map(|c| c.left_rad_s.abs().max(c.right_rad_s.abs()))
            .fold(0.0, f64::max),
        ..u
    };
    let draw = |space: &CommandSpace| {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        (0..4000)
            .map(|_| uniform_in_wheel_space(space, &mut rng))
            .collect::<Vec<_>>()
    };
    let robot = yaw_rate_iqr(&u, &commands);
    let in_fit = yaw_rate_iqr(&u, &draw(&u));
    let in_square = yaw_rate_iqr(&u, &draw(&square));
    assert!(
        (in_fit / robot - 1.0).abs() < 0.15 && in_square / robot > 1.25,
        "yaw rate IQR: robot {robot:.2}, fitted U {in_fit:.2}, square {in_square:.2} rad/s"
    );
}
