use drive_sim::kinematics::WheelSpeeds;
use drive_sim::robot::Robot;
use drive_sim::sim::{Plant, SimConfig, Simulator};
use drive_sim::terrain::Terrain;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let robot = Robot::resolve(&args[1]).unwrap().0;
    let terrain = Terrain::resolve(&args[2]).unwrap().0;
    let hz: f64 = args[3].parse().unwrap(); let mut sim = Simulator::new(&robot, &terrain, SimConfig { physics_hz: hz, ..Default::default() }).unwrap();
    let c: f64 = args[4].parse().unwrap(); if args.len() > 6 { sim.debug_set_angvel([0.0, args[6].parse().unwrap(), 0.0]); } sim.command(WheelSpeeds::new(c, c));
    let skip: usize = args[5].parse().unwrap(); for _ in 0..skip { sim.advance(0.01).unwrap(); }
    for _ in 0..20 {
        sim.advance(0.01).unwrap();
        let p = sim.true_pose();
        println!("t={:.2} pitch={:.5} q={:?} z={:.5} loads={:?} F={:?} w={:?}", sim.time_s(), p.pitch_rad, sim.debug_angvel(), p.z_m, sim.wheel_loads_n().iter().map(|x| x.round()).collect::<Vec<_>>(), sim.debug_forces().iter().map(|f| f.0.round()).collect::<Vec<_>>(), sim.wheel_speeds());
    }
}
