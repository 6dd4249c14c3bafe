//! The fast physics step (predicted start, chord iterations on the exact tyre-solve Jacobian,
//! ray lookup, chassis integrated directly) against the reference step of the simulator
//! crate's `oracle` feature (finite-difference Jacobian, parry's ray casts, rapier's pipeline):
//! the same robot, terrain and command sequence must give the same motion, to far below what the
//! analysis resolves.

use drive_sim::kinematics::{BodyVelocity, WheelSpeeds};
use drive_sim::robot::Robot;
use drive_sim::sim::{Plant, SimConfig, Simulator, Stepping};
use drive_sim::terrain::Terrain;

/// Drives a command sequence (straight, turn in place, fast arc, brake) and records the true
/// velocity, pose and wheel spins every 0.05 s.
fn trace(robot: &str, terrain: &str, stepping: Stepping) -> Vec<[f64; 8]> {
    let robot = Robot::resolve(robot).unwrap().0;
    let terrain = Terrain::resolve(terrain).unwrap().0;
    let mut s = Simulator::new(&robot, &terrain, SimConfig::default()).unwrap();
    s.set_stepping(stepping);
    let mut out = Vec::new();
    for (l, r, secs) in [
        (0.0, 0.0, 0.5),
        (8.0, 8.0, 2.0),
        (-6.0, 6.0, 2.0),
        (12.0, 4.0, 2.0),
        (0.0, 0.0, 1.5),
    ] {
        s.command(WheelSpeeds::new(l, r));
        for _ in 0..(secs / 0.05f64).round() as usize {
            s.advance(0.05).unwrap();
            let v: BodyVelocity = s.true_velocity();
            let p = s.true_pose();
            let w = s.wheel_speeds();
            out.push([
                v.vx_m_s,
                v.vy_m_s,
                v.wz_rad_s,
                p.x_m,
                p.y_m,
                p.yaw_rad,
                w.left_rad_s,
                w.right_rad_s,
            ]);
        }
    }
    out
}

fn compare(robot: &str, terrain: &str) {
    let fast = trace(robot, terrain, Stepping::Fast);
    let reference = trace(robot, terrain, Stepping::Reference);
    assert_eq!(fast.len(), reference.len());
    // Velocities within 5 mm/s (rad/s), poses within 2 cm over 8 s: the analysis's steady
    // means are over windows of 2 s with sensor noise of 1 cm and 0.02 rad/s.
    let tol = [5e-3, 5e-3, 5e-3, 0.02, 0.02, 5e-3, 0.02, 0.02];
    let mut worst = [0.0f64; 8];
    for (a, b) in fast.iter().zip(&reference) {
        for k in 0..8 {
            worst[k] = worst[k].max((a[k] - b[k]).abs());
        }
    }
    for k in 0..8 {
        assert!(
            worst[k] <= tol[k],
            "fast step, {robot} on {terrain}: channel {k} differs by {} (tolerance {}); worst {worst:?}",
            worst[k],
            tol[k]
        );
    }
}

#[test]
fn fast_and_reference_steps_agree_on_asphalt() {
    compare("warthog", "asphalt");
}

#[test]
fn fast_and_reference_steps_agree_on_rough_gravel_and_mud() {
    compare("warthog", "gravel");
    compare("husky", "mud");
}

#[test]
fn fast_steps_are_deterministic() {
    assert_eq!(
        trace("warthog", "gravel", Stepping::Fast),
        trace("warthog", "gravel", Stepping::Fast)
    );
}

/// A reset world moves exactly as a new one, whatever it did before the reset (here a hard
/// braking turn): a calibration reuses worlds across steps and threads, so a replay must not
/// depend on which step its world ran before. Covers the fast step's state (its predictor,
/// the last physics step's change, which `reset` clears).
#[test]
fn a_reset_world_forgets_its_last_motion() {
    // The Husky in mud saturates its motors at once: a saturated side's wheel spin is an
    // unknown of the solve, started from the prediction (an unsaturated side's is its target).
    for (robot, terrain, cmd) in [
        ("warthog", "gravel", WheelSpeeds::new(6.0, 9.0)),
        ("husky", "mud", WheelSpeeds::new(6.0, -6.0)),
    ] {
        let robot = Robot::resolve(robot).unwrap().0;
        let terrain = Terrain::resolve(terrain).unwrap().0;
        let start = drive_sim::log::Pose::default();
        let (v0, w0) = (BodyVelocity::new(0.3, 0.0, 0.2), WheelSpeeds::new(1.0, 2.0));
        let drive = |s: &mut Simulator| {
            s.reset(start, v0, w0);
            s.command(cmd);
            let mut out = Vec::new();
            for _ in 0..20 {
                s.advance(0.05).unwrap();
                let (p, v, w) = (s.true_pose(), s.true_velocity(), s.wheel_speeds());
                out.push([
                    p.x_m,
                    p.y_m,
                    p.yaw_rad,
                    v.vx_m_s,
                    v.vy_m_s,
                    v.wz_rad_s,
                    w.left_rad_s,
                    w.right_rad_s,
                ]);
            }
            out
        };
        let mut fresh = Simulator::new(&robot, &terrain, SimConfig::default()).unwrap();
        let mut used = Simulator::new(&robot, &terrain, SimConfig::default()).unwrap();
        // A hard reversal from a fast turn: the last physics steps before the reset change a lot.
        used.reset(
            start,
            BodyVelocity::new(1.0, 0.0, 1.0),
            WheelSpeeds::new(5.0, 6.0),
        );
        used.command(WheelSpeeds::new(-cmd.left_rad_s, -cmd.right_rad_s));
        used.advance(0.3).unwrap();
        assert_eq!(
            drive(&mut fresh),
            drive(&mut used),
            "{} on {}",
            robot.name,
            terrain.name
        );
    }
}
