use drive_sim::kinematics::WheelSpeeds;
use drive_sim::robot::Robot;
use drive_sim::sim::{Plant, SimConfig, Simulator};
use drive_sim::terrain::Terrain;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let robot = Robot::resolve(&args[1]).unwrap().0;
    let terrain = Terrain::resolve(&args[2]).unwrap().0;
    let l: f64 = args[3].parse().unwrap();
    let r: f64 = args[4].parse().unwrap();
    let secs: f64 = args.get(5).map_or(6.0, |s| s.parse().unwrap());
    let mut sim = Simulator::new(&robot, &terrain, SimConfig::default()).unwrap();
    sim.advance(1.0).unwrap();
    let p0 = sim.true_pose();
    println!("settled {:?}", p0);
    sim.command(WheelSpeeds::new(l, r));
    let idd = robot.idd().body_from_wheels(WheelSpeeds::new(l, r));
    let n = (secs * 20.0) as usize;
    for k in 0..n {
        sim.advance(0.05).unwrap();
        if k % 2 == 1 || k < 8 {
            let m = sim.measure();
            let v = sim.true_velocity();
            println!("t={:5.2} enc=({:6.3},{:6.3}) v=({:6.3},{:6.3},{:6.3}) idd=({:6.3},{:6.3}) imu=({:6.2},{:6.2},{:6.2}) z={:.3} sat={:?} loads={:?}",
              sim.time_s(), m.enc.left_rad_s, m.enc.right_rad_s, v.vx_m_s, v.vy_m_s, v.wz_rad_s, idd.vx_m_s, idd.wz_rad_s,
              m.imu.ax_m_s2, m.imu.ay_m_s2, m.imu.az_m_s2, m.truth.unwrap().pose.z_m, sim.torque_saturated(),
              sim.wheel_loads_n().iter().map(|x| x.round()).collect::<Vec<_>>());
        }
    }
    println!("final {:?}", sim.true_pose());
}
