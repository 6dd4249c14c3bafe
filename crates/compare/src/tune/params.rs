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
            let hint = drive_sim_model::config::did_you_mean(name, known.iter().map(String::as_str))
                .map(|k| format!("did you mean `{k}`? "))
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

/// A search box the user sets for one tuned parameter instead of the registry's
/// (`--box KEY=LOWER:UPPER`): keep a search where the model is physical, or widen it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BoxOverride {
    /// The parameter: an effect parameter's key or a base parameter's report name.
    pub name: String,
    /// Lower bound, in the parameter's unit.
    pub lower: f64,
    /// Upper bound.
    pub upper: f64,
}

impl BoxOverride {
    /// Parses `KEY=LOWER:UPPER`.
    pub fn parse(text: &str) -> Result<Self> {
        let bad = |why: &str| {
            Error::config(
                "--box",
                text,
                format!("{why} (expected KEY=LOWER:UPPER, e.g. turning_resistance_scale=0.5:1.5)"),
            )
        };
        let (name, range) = text.split_once('=').ok_or_else(|| bad("no `=`"))?;
        let (lo, hi) = range
            .split_once(':')
            .ok_or_else(|| bad("no `:` between the bounds"))?;
        let num = |t: &str| {
            t.trim()
                .parse::<f64>()
                .map_err(|_| bad(&format!("`{t}` is not a number")))
        };
        Ok(Self {
            name: name.trim().to_string(),
            lower: num(lo)?,
            upper: num(hi)?,
        })
    }
}

/// Sets the boxes of `boxes` on the specs they name. A box naming no tuned parameter, empty or
/// reversed, or outside an effect parameter's valid range is an error naming it.
pub fn apply_boxes(specs: &mut [ParamSpec], boxes: &[BoxOverride]) -> Result<()> {
    for b in boxes {
        let key_of = |s: &ParamSpec| s.param.key();
        let Some(s) = specs
            .iter_mut()
            .find(|s| key_of(s) == b.name || s.param.name() == b.name)
        else {
            return Err(Error::config(
                "--box",
                &b.name,
                "names no parameter being tuned (`--tune` names them; effect parameters by their key)",
            ));
        };
        if !(b.lower.is_finite() && b.upper.is_finite() && b.lower < b.upper) {
            return Err(Error::config(
                "--box",
                &b.name,
                format!(
                    "needs finite bounds with lower < upper, got {}:{}",
                    b.lower, b.upper
                ),
            ));
        }
        if let Some(d) = s.param.def() {
            let min = if d.kind == effects::ParamKind::Limit {
                f64::MIN_POSITIVE
            } else {
                d.min
            };
            if b.lower < min || b.upper > d.max {
                return Err(Error::config(
                    "--box",
                    &b.name,
                    format!(
                        "must lie in the parameter's valid range [{}, {}] {}",
                        d.min, d.max, d.unit
                    ),
                ));
            }
        }
        s.lower = b.lower;
        s.upper = b.upper;
        if !(b.lower..=b.upper).contains(&s.start) {
            s.start = 0.5 * (b.lower + b.upper);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use drive_sim_model::robot::Robot;
    use drive_sim_model::terrain::Terrain;

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

    #[test]
    fn boxes_replace_the_registrys_and_bad_ones_are_refused() {
        let names = vec![
            "motor_torque_speed".to_string(),
            "turning_resistance_scale".to_string(),
        ];
        let mut specs = tuned_specs(&names, &start(), &REACH).unwrap();
        let b = BoxOverride::parse("turning_resistance_scale=0.5:1.5").unwrap();
        apply_boxes(&mut specs, &[b]).unwrap();
        assert_eq!((specs[2].lower, specs[2].upper), (0.5, 1.5));
        assert!((0.5..=1.5).contains(&specs[2].start_in(&start())));
        for (text, needle) in [
            ("turning_resistance_scale=1.5:0.5", "lower < upper"),
            ("dead_time_s=0:0.2", "names no parameter being tuned"),
            ("motor_stall_torque_nm=-5:100", "valid range"),
            ("turning_resistance_scale=0.5", "no `:`"),
            ("turning_resistance_scale=a:1", "not a number"),
        ] {
            let e = BoxOverride::parse(text)
                .and_then(|b| apply_boxes(&mut specs.clone(), &[b]))
                .unwrap_err()
                .to_string();
            assert!(e.contains(needle), "{text}: {e}");
        }
    }
}
