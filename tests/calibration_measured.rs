//! Calibration on the measured datasets (kinematic model: cheap enough for CI).

use drive_sim::calibration::{calibrate, models_for_log, CalibrationOptions, KinematicFactory};
use drive_sim::log::csv::read_measured_csv;

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data/measured");

#[test]
#[ignore = "exploration"]
fn explore() {
    for name in ["warthog_asphalt", "warthog_ice", "warthog_gravel", "husky_2023"] {
        let t0 = std::time::Instant::now();
        let log = read_measured_csv(format!("{DATA}/{name}.csv")).unwrap();
        let (robot, terrain, _) = models_for_log(&log).unwrap();
        let r = calibrate(&log, &robot, &terrain, &KinematicFactory, &CalibrationOptions::default()).unwrap();
        println!("== {name} ({:.1} s)", t0.elapsed().as_secs_f64());
        for row in &r.table {
            println!("{:28} {:>6} idd {:8.4} before {:8.4} after {:8.4} floor {:8.4}", row.metric, row.unit, row.idd, row.sim_before, row.sim_after, row.floor);
        }
        if let Some(f) = &r.terrain_fit { for p in &f.params { println!("  fit {} = {:.4} ({:?})", p.name, p.value, p.initial); } }
        for round in &r.rounds {
            println!(" round {} added {:?}", round.round, round.added);
            for e in &round.ranking {
                println!("   {:30} red {:8.4} ± {:.4} share {:.2} sig {} {:?}", e.effect, e.reduction, e.reduction_se, e.share, e.significant, e.params.iter().map(|p| (p.name.clone(), p.value)).collect::<Vec<_>>());
            }
        }
        println!(" effects {:?}", r.effects.iter().map(|p| (p.name.clone(), p.value)).collect::<Vec<_>>());
        println!(" notes {:?}", r.status.notes);
    }
}
