//! Reading a discovered equation: its text, what its structure says in words, and the
//! catalogue's named effects it points to (a constant in vy: a lateral drift; vy in wz: a
//! turning centre off the origin). Discovery tries those effects beside the equation's generic
//! term ([`super::discovery`]), so that a physical effect can win where it explains as much.

use crate::discovery::Equation;
use drive_sim_model::effects::term::HINGES_RAD_S;
use drive_sim_model::effects::{Feature, TermTarget};

/// `Δvy = 0.101 [0.097, 0.105] · vx·wz - 0.02 [...]`.
pub(super) fn text_of(target: TermTarget, eq: &Equation) -> String {
    let terms: Vec<String> = eq
        .terms
        .iter()
        .map(|t| {
            let sym = Feature::from_name(&t.feature).map_or(t.feature.as_str(), |f| f.symbol());
            let coef = format!("{:.4} [{:.4}, {:.4}]", t.coefficient, t.ci95[0], t.ci95[1]);
            if sym == "1" {
                coef
            } else {
                format!("{coef} · {sym}")
            }
        })
        .collect();
    format!(
        "{} = {}   (validation R² {:.2}, {})",
        target.symbol(),
        terms.join(" + "),
        eq.validation_r2,
        eq.solver.name()
    )
}

/// What an equation says: in words, the catalogue effects it points to, and where their
/// parameters start (read from the equation's coefficients).
pub(super) struct Reading {
    /// Its structure in plain language.
    pub text: Vec<String>,
    /// Named effects of the catalogue it points to, each once.
    pub suggests: Vec<String>,
    /// Starting values of those effects' parameters (`wheel_knee_rad_s` at the strongest
    /// hinge's knee), by parameter key.
    pub starts: Vec<(&'static str, f64)>,
}

/// A plain-language reading of an equation's structure, and the catalogue effects it points
/// to.
pub(super) fn read(target: TermTarget, eq: &Equation) -> Reading {
    let has = |f: Feature| eq.terms.iter().any(|t| t.feature == f.name());
    let coef = |f: Feature| {
        eq.terms
            .iter()
            .find(|t| t.feature == f.name())
            .map_or(0.0, |t| t.coefficient)
    };
    let mut reading = Vec::new();
    let mut suggests: Vec<&str> = Vec::new();
    let mut starts: Vec<(&'static str, f64)> = Vec::new();
    let wheel = matches!(target, TermTarget::WheelLeft | TermTarget::WheelRight);
    if has(Feature::Step) || has(Feature::StepCmdWheel) || has(Feature::StepCmdVx) {
        reading.push("gain changes over the run (battery sag, motors heating)".into());
        suggests.push("motor_gain_drift");
    }
    if target == TermTarget::BodyVy && has(Feature::One) {
        reading.push(format!(
            "lateral drift of {:.3} m/s in every step: a side slope or a crabbing chassis",
            coef(Feature::One)
        ));
        suggests.push("lateral_drift");
    }
    if target == TermTarget::BodyVy && has(Feature::VxWz) {
        reading.push(format!(
            "lateral slip with the centripetal acceleration ({:.3} s · vx·wz): tyres slip sideways in turns",
            coef(Feature::VxWz)
        ));
        suggests.push("centripetal_slip");
    }
    if target == TermTarget::BodyVy && has(Feature::Wz) {
        // A rigid body turning about a point x_ICR along its axis moves its origin sideways
        // at -x_ICR · wz, whichever way it drives.
        reading.push(format!(
            "lateral slip with the yaw rate ({:.3} m · wz): the robot turns about a point {:.3} m {} its origin (load nearer one axle, or a pose frame off the turning centre)",
            coef(Feature::Wz),
            coef(Feature::Wz).abs(),
            if coef(Feature::Wz) > 0.0 { "behind" } else { "ahead of" }
        ));
        suggests.push("icr_longitudinal_offset");
    }
    if target == TermTarget::BodyVy && has(Feature::Vx) {
        reading.push(format!(
            "lateral slip with the forward speed ({:.3} · vx): the robot moves {:.1}° off its axis (axles out of square, or a pose frame yawed against the body)",
            coef(Feature::Vx),
            coef(Feature::Vx).atan().to_degrees()
        ));
        suggests.push("crab_angle");
    }
    if has(Feature::ReverseVx)
        || has(Feature::ReverseWz)
        || has(Feature::ReverseCmdWheel)
        || has(Feature::SignVx)
    {
        reading.push("direction-dependent: the robot behaves differently in reverse".into());
        if target == TermTarget::BodyWz {
            suggests.push("reverse_baseline_scale");
        }
    }
    if has(Feature::Ax) || has(Feature::Alpha) {
        // A body lagging the model by τ reads as a residual −τ · (the model's acceleration):
        // a negative coefficient is a lag of that many seconds, a positive one a lead.
        let c = [Feature::Ax, Feature::Alpha]
            .into_iter()
            .filter(|&f| has(f))
            .map(coef)
            .fold(f64::INFINITY, f64::min);
        reading.push(if c < 0.0 {
            format!(
                "a lag: the body follows its wheels with a time constant of about {:.2} s",
                -c
            )
        } else {
            format!("a term in the acceleration ({c:+.3} s): the body responds faster than the model")
        });
        if !wheel {
            suggests.push("body_lag");
        } else {
            suggests.push("time_constant_scale");
        }
    }
    if wheel && has(Feature::CmdWheel) {
        reading.push("a wheel gain error: the wheel settles off its target in proportion to it".into());
        suggests.push("motor_gain");
    }
    // Linear in the wheel's own speed and nothing else (its command, or the body's vx and wz
    // it is made of): a scale on this side, of the wheel itself or of its encoder only.
    let linear = [
        Feature::CmdWheel,
        Feature::Vx,
        Feature::Wz,
        Feature::CmdVx,
        Feature::CmdWz,
    ];
    if wheel
        && !eq.terms.is_empty()
        && eq
            .terms
            .iter()
            .all(|t| linear.iter().any(|f| f.name() == t.feature))
    {
        reading.push("a scale on this side: its wheel's gain, or its encoder's count".into());
        suggests.push("motor_gain");
        suggests.push("encoder_side_scale");
    }
    // The wheel's own command's nonlinearities, each named with its physical reading and unit.
    if wheel && has(Feature::CmdWheelOdd) {
        reading.push(format!(
            "a gain curve: the wheel's gain is 1 {:+.4} s/rad × |ω_cmd| (a motor that gains or loses gain with speed)",
            coef(Feature::CmdWheelOdd)
        ));
    }
    if wheel && has(Feature::CmdWheelCube) {
        reading.push(format!(
            "a soft saturation: the wheel's gain changes by {:+.2e} s²/rad² × ω_cmd² (a limit approached gradually)",
            coef(Feature::CmdWheelCube)
        ));
    }
    // Gain lost at speed, in any odd form of the command (its square with its sign, its cube,
    // a knee with a negative slope change): a limit approached gradually is one parameter
    // where the polynomial needs several. S·tanh(ω/S) ≈ ω − ω³/(3S²) gives its start.
    let hinges = || (0..HINGES_RAD_S.len()).map(|i| Feature::Hinge(i as u8));
    let loses_at_speed = coef(Feature::CmdWheelCube) < 0.0
        || coef(Feature::CmdWheelOdd) < 0.0
        || hinges().any(|f| coef(f) < 0.0);
    if wheel && loses_at_speed {
        suggests.push("wheel_speed_soft_limit_rad_s");
        let c3 = coef(Feature::CmdWheelCube);
        if c3 < 0.0 {
            starts.push(("wheel_speed_soft_limit_rad_s", (-1.0 / (3.0 * c3)).sqrt()));
        }
    }
    // A hinge on the grid stands for a knee somewhere near it: the named knee fits where.
    if let Some((knee, c)) = hinges()
        .zip(HINGES_RAD_S)
        .filter(|&(f, _)| wheel && has(f))
        .map(|(f, k)| (k, coef(f)))
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
    {
        suggests.push("wheel_gain_knee");
        starts.push(("wheel_knee_rad_s", knee));
        starts.push(("wheel_gain_above_knee", 1.0 + c));
    }
    if wheel && has(Feature::SignCmdWheel) {
        let c = coef(Feature::SignCmdWheel);
        if c < 0.0 {
            reading.push(format!(
                "a deadband: the wheel loses {:.3} rad/s against the direction it is told to turn (commands below it do not move it)",
                -c
            ));
            suggests.push("wheel_deadband_rad_s");
        } else {
            reading.push(format!(
                "a constant push of {c:.3} rad/s in the direction the wheel is told to turn (a friction compensation that overshoots)"
            ));
        }
    }
    if wheel && has(Feature::ReverseWheel) {
        reading.push(format!(
            "a reverse gain: backwards, the wheel's gain is 1 {:+.3}",
            coef(Feature::ReverseWheel)
        ));
        starts.push(("wheel_reverse_gain", 1.0 + coef(Feature::ReverseWheel)));
    }
    // A wheel term that acts only backwards, on the wheel's own command or on the body's
    // direction (vx and |vx| together are 2·min(vx, 0)): the wheel's gain backwards.
    let backwards = [
        Feature::ReverseWheel,
        Feature::ReverseCmdWheel,
        Feature::ReverseVx,
        Feature::ReverseWz,
        Feature::SignVx,
    ]
    .into_iter()
    .any(has)
        || (has(Feature::Vx) && has(Feature::AbsVx));
    if wheel && backwards {
        suggests.push("wheel_reverse_gain");
    }
    for (i, knee) in HINGES_RAD_S.iter().enumerate() {
        let f = Feature::Hinge(i as u8);
        if wheel && has(f) {
            reading.push(format!(
                "a knee at {knee:.0} rad/s: above it the wheel's gain changes by {:+.3}",
                coef(f)
            ));
        }
    }
    if target == TermTarget::ImuWz {
        if has(Feature::One) {
            reading.push("an IMU yaw-rate bias".into());
            suggests.push("imu_yaw_rate_bias");
        }
        if has(Feature::Wz) {
            reading.push("an IMU yaw-rate scale error".into());
            suggests.push("imu_yaw_rate_scale");
        }
    }
    if has(Feature::TimeInStep) {
        reading.push("changes within the step: a transient the model lacks".into());
    }
    if has(Feature::PrevCmdVx)
        || has(Feature::PrevCmdWz)
        || has(Feature::DeltaCmdVx)
        || has(Feature::DeltaCmdWz)
    {
        reading.push("depends on the previous command: memory from one step to the next".into());
        // In a step response, a residual that depends on where the previous step left the
        // robot is a lag that has not caught up.
        if wheel {
            suggests.push("time_constant_scale");
        } else {
            suggests.push("body_lag");
        }
    }
    // Memory of earlier commands: the filtered copies (a load the loop learns and forgets
    // over the filter's time) and the delayed ones (an actuation that acts late).
    let mut turn_memory: Option<(f64, f64)> = None;
    for f in Feature::ALL.into_iter().filter(|&f| has(f)) {
        let Some(t) = f.memory_s() else { continue };
        if matches!(f, Feature::DelayedWheel(_)) {
            reading.push(format!(
                "acts on the command of {t} s ago ({:+.4} · {}): an actuation that answers late",
                coef(f),
                f.symbol()
            ));
            suggests.push("dead_time_s");
        } else {
            reading.push(format!(
                "remembers the commands of the last {t} s ({:+.4} · {}): a response that builds up or is learnt over several seconds",
                coef(f),
                f.symbol()
            ));
            // A wheel, or the yaw it makes, that remembers the commanded turn: a speed loop
            // learning the turn's load. The strongest such memory sets where its time starts.
            let turns = wheel || matches!(target, TermTarget::BodyWz | TermTarget::ImuWz);
            if turns
                && matches!(f, Feature::FilteredWz(_))
                && turn_memory.is_none_or(|(_, c)| coef(f).abs() > c)
            {
                turn_memory = Some((t, coef(f).abs()));
            }
        }
    }
    if let Some((t, _)) = turn_memory {
        reading.push(format!(
            "a turn's load learnt over about {t} s and carried into the next step: a wheel speed loop with an integral"
        ));
        suggests.push("turn_memory");
        starts.push(("turn_memory_s", t));
    }
    if has(Feature::VxSq) || has(Feature::WzSq) || has(Feature::AbsVx) || has(Feature::AbsWz) {
        reading.push("nonlinear in speed (drag, a soft limit)".into());
    }
    if reading.is_empty() {
        reading.push(format!(
            "a {} correction linear in the model's state",
            target.stage().as_str()
        ));
    }
    let mut unique: Vec<&str> = Vec::new();
    for x in suggests {
        if !unique.contains(&x) {
            unique.push(x);
        }
    }
    Reading {
        text: reading,
        suggests: unique.into_iter().map(String::from).collect(),
        starts,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::discovery::Term;

    fn equation(terms: &[(Feature, f64)]) -> Equation {
        Equation {
            terms: terms
                .iter()
                .map(|&(f, c)| Term {
                    feature: f.name().to_string(),
                    coefficient: c,
                    ci95: [c - 0.01, c + 0.01],
                    stability: 1.0,
                })
                .collect(),
            threshold: 0.0,
            solver: Default::default(),
            solvers: Vec::new(),
            validation_r2: 0.5,
            validation_rms: [1.0, 0.5],
            unstable: Vec::new(),
            skipped: Vec::new(),
            rows: [100, 30],
        }
    }

    #[test]
    fn a_wheel_that_remembers_the_turn_points_to_the_turn_memory_at_its_strongest_filter() {
        let eq = equation(&[
            (Feature::Wz, 0.05),
            (Feature::FilteredWz(1), -0.18),
            (Feature::FilteredWz(2), 0.04),
        ]);
        let r = read(TermTarget::WheelLeft, &eq);
        assert!(
            r.suggests.contains(&"turn_memory".to_string()),
            "{:?}",
            r.suggests
        );
        assert_eq!(r.starts, vec![("turn_memory_s", 2.0)]);
        // A memory of the forward command is not a turn's; a late command is a dead time.
        let eq = equation(&[(Feature::FilteredVx(1), 0.1), (Feature::DelayedWheel(0), 0.3)]);
        let r = read(TermTarget::WheelRight, &eq);
        assert!(!r.suggests.contains(&"turn_memory".to_string()));
        assert!(r.suggests.contains(&"dead_time_s".to_string()));
        // The lateral velocity does not learn a turn's load.
        let r = read(TermTarget::BodyVy, &equation(&[(Feature::FilteredWz(1), 0.1)]));
        assert!(!r.suggests.contains(&"turn_memory".to_string()));
    }
}
