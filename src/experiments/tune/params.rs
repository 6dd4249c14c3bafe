//! What a tuning varies: names resolved to typed parameters with the registry's boxes.

use super::*;

/// The parameters named by `names` with their search boxes for a log commanding up to
/// `reach`: an effect name gives all its parameters, an effect parameter key that one, a
/// simulator base parameter name (as `calibration.json` writes it) that one. Unknown names,
/// duplicates and too many parameters are errors naming the entry.
pub fn tuned_specs(names: &[String], start: &ModelParams, reach: &CommandReach) -> Result<Vec<ParamSpec>> {
    let base = SimFactory::default().base_params(start);
    let mut specs: Vec<ParamSpec> = Vec::new();
    for name in names {
        let found: Vec<ParamSpec> = if let Some(i) = REGISTRY.iter().position(|e| e.name() == name) {
            (0..REGISTRY[i].params().len())
                .map(|j| ParamSpec::for_effect(i, j, reach))
                .collect()
        } else if let Some((i, j)) = effects::param_owner(name) {
            vec![ParamSpec::for_effect(i, j, reach)]
        } else if let Some(s) = base.iter().find(|s| s.param.name() == *name) {
            vec![*s]
        } else {
            let known: Vec<String> = REGISTRY
                .iter()
                .map(|e| e.name().to_string())
                .chain(base.iter().map(|s| s.param.name()))
                .collect();
            let hint = known
                .iter()
                .map(|k| (k, strsim::jaro_winkler(name, k)))
                .filter(|(_, s)| *s >= 0.8)
                .max_by(|a, b| a.1.total_cmp(&b.1))
                .map(|(k, _)| format!("did you mean `{k}`? "))
                .unwrap_or_default();
            return Err(Error::config(
                "--tune",
                name,
                format!(
                    "not an effect, an effect parameter or a simulator base parameter; {hint}known: {} and every effect parameter (`drive-sim effects`)",
                    known.join(", ")
                ),
            ));
        };
        for s in found {
            if s.discrete {
                return Err(Error::config(
                    "--tune",
                    name,
                    format!(
                        "`{}` is an on/off parameter: a closed-loop search varies continuous ones",
                        s.param.name()
                    ),
                ));
            }
            if specs.iter().any(|t| t.param == s.param) {
                return Err(Error::config(
                    "--tune",
                    name,
                    format!("`{}` is named twice", s.param.name()),
                ));
            }
            specs.push(s);
        }
    }
    if specs.is_empty() {
        return Err(Error::config("--tune", "", "name at least one parameter"));
    }
    if specs.len() > MAX_TUNED {
        return Err(Error::config(
            "--tune",
            names.join(","),
            format!(
                "{} parameters; at most {MAX_TUNED} are tuned at once",
                specs.len()
            ),
        ));
    }
    Ok(specs)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::Robot;
    use crate::terrain::Terrain;

    fn start() -> ModelParams {
        let (r, _) = Robot::resolve("warthog").unwrap();
        let (t, _) = Terrain::resolve("asphalt").unwrap();
        twin::lift_effects(&r, &t).unwrap()
    }

    const REACH: CommandReach = CommandReach {
        wheel_rad_s: 16.0,
        speed_m_s: 5.0,
        yaw_rate_rad_s: 4.0,
    };

    #[test]
    fn names_resolve_to_effects_parameters_and_base_parameters() {
        let names: Vec<String> = [
            "motor_torque_speed",
            "turning_resistance_scale",
            "terrain.friction.peak_lateral",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        let specs = tuned_specs(&names, &start(), &REACH).unwrap();
        let got: Vec<String> = specs.iter().map(|s| s.param.name()).collect();
        assert_eq!(
            got,
            [
                "effect.motor_stall_torque_nm",
                "effect.motor_no_load_speed_rad_s",
                "effect.turning_resistance_scale",
                "terrain.friction.peak_lateral"
            ]
        );
        // The no-load speed's box scales with what the log commands.
        assert_eq!((specs[1].lower, specs[1].upper), (8.0, 24.0));
    }

    #[test]
    fn bad_names_are_refused_with_a_hint() {
        let e = tuned_specs(&["motor_torque_sped".to_string()], &start(), &REACH)
            .unwrap_err()
            .to_string();
        assert!(e.contains("did you mean `motor_torque_speed`"), "{e}");
        let e = tuned_specs(
            &[
                "motor_torque_speed".to_string(),
                "motor_stall_torque_nm".to_string(),
            ],
            &start(),
            &REACH,
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("named twice"), "{e}");
        let e = tuned_specs(&["imu_yaw_rate_sign_flip".to_string()], &start(), &REACH)
            .unwrap_err()
            .to_string();
        assert!(e.contains("on/off"), "{e}");
    }
}
