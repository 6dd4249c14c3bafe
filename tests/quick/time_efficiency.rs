//! The simulated DRIVE spends its time like the robot's. The paper's Table "lessons" gives the
//! Warthog's "time data gathering" as 60.4-72.3 %, on sites of 740-1900 m²; an operator that
//! plans re-orientations on the ideal drive, shrinks the area by the stopping distance on every
//! side and interrupts robots heading back in leaves it at 39-47 % on ice (README, "Time
//! efficiency").
//!
//! The declared Warthog, 150 steps, seeds 0-2, on the paper's site areas (shapes our choice):
//! every run must gather data at least 60 % of the time. Measured with `cargo test --test
//! time_efficiency -- --nocapture`: ice on 47 x 20 m 70.1 / 68.9 / 68.3 % (paper 62.8 %),
//! asphalt on 50 x 25 m 80.7 / 79.5 / 76.5 % (paper 71.3 %).

use drive_sim::harness::simulate::simulate;
use drive_sim::robot::{Robot, SafeArea};
use drive_sim::sim::SensorNoise;
use drive_sim::terrain::Terrain;

fn data_gathering(terrain: &str, site: SafeArea, seed: u64) -> f64 {
    let (mut robot, _) = Robot::resolve("warthog").unwrap();
    robot.safe_area = site;
    let (terrain, _) = Terrain::resolve(terrain).unwrap();
    let run = simulate(
        &robot,
        &terrain,
        "uniform-wheel",
        150,
        seed,
        SensorNoise::typical(),
    )
    .unwrap();
    assert_eq!(run.summary.steps_completed, 150);
    run.summary.data_gathering_fraction
}

#[test]
fn the_warthog_gathers_data_as_the_paper_reports_on_its_sites() {
    for (terrain, length_m, width_m) in [("ice", 47.0, 20.0), ("asphalt", 50.0, 25.0)] {
        let site = SafeArea { length_m, width_m };
        let got: Vec<f64> = (0..3)
            .map(|seed| data_gathering(terrain, site.clone(), seed))
            .collect();
        eprintln!("{terrain} on {length_m} x {width_m} m: data gathering {got:.3?}");
        assert!(got.iter().all(|g| *g >= 0.60), "{terrain}: {got:?}");
    }
}
