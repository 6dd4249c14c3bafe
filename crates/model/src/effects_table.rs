//! The `[effects]` table of robot and terrain files: effects as data.
//!
//! A robot or terrain file may carry the model effects the robot or ground shows, by the
//! parameter names of the effect registry ([`crate::effects::REGISTRY`]):
//!
//! ```toml
//! [effects]
//! wheel_speed_saturation_rad_s = 12.6   # measured on three runs
//! motor_gain_left = 0.95
//! ```
//!
//! Each name is checked against the registry (an unknown one is refused with the closest
//! known name) and each value against the parameter's validity bounds, when the file is read,
//! so a bad twin fails before any simulation. The simulator applies a robot's effects, then a
//! terrain's, then those of the run itself (`--inject`, a calibration's fitted set): a later
//! source overrides the parameters it sets away from their neutral value ([`combine`]).

use crate::effects::{param_keys, param_owner, Effects, REGISTRY};
use crate::error::{Error, Result};
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::collections::BTreeMap;

/// The registry's parameter name closest to `name` (by Jaro-Winkler similarity), when it is
/// close enough to be a likely typo.
pub fn closest_param(name: &str) -> Option<&'static str> {
    param_keys()
        .into_iter()
        .map(|k| (k, strsim::jaro_winkler(name, k)))
        .filter(|(_, s)| *s >= 0.8)
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(k, _)| k)
}

/// Checks one `name = value` entry of an `[effects]` table and sets it in `effects`. The error
/// message names the parameter, says what is wrong and, for an unknown name, suggests the
/// closest known one.
pub fn set_checked(effects: &mut Effects, name: &str, value: f64) -> std::result::Result<(), String> {
    let Some((i, j)) = param_owner(name) else {
        let hint = closest_param(name)
            .map(|k| format!("did you mean `{k}`? "))
            .unwrap_or_default();
        return Err(format!(
            "unknown effect parameter `{name}`; {hint}known: {} (`drive-sim effects` lists them)",
            crate::effects::known_params_text()
        ));
    };
    let def = &REGISTRY[i].params()[j];
    let why = |e: Error| match e {
        Error::Config { message, .. } => format!("`{name}` {message}"),
        other => other.to_string(),
    };
    let v = def.check(value).map_err(why)?;
    effects.set(name, v).map_err(why)
}

/// Deserializes an `[effects]` table (`serde(deserialize_with = ...)`), checking every entry
/// with [`set_checked`].
pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> std::result::Result<Effects, D::Error> {
    let map = BTreeMap::<String, f64>::deserialize(d)?;
    let mut effects = Effects::default();
    for (k, v) in map {
        set_checked(&mut effects, &k, v).map_err(serde::de::Error::custom)?;
    }
    Ok(effects)
}

/// Serializes an `[effects]` table (`serde(serialize_with = ...)`): every parameter of a named
/// effect that is on, and of a discovered term only the features it uses (a term has a
/// coefficient for each of its 22–25 features, all but a few at 0, which would bury the file's
/// few real values). Reads back to the same effects: an absent coefficient is 0.
pub fn serialize<S: Serializer>(effects: &Effects, s: S) -> std::result::Result<S::Ok, S::Error> {
    let map: BTreeMap<&str, f64> = effects
        .values()
        .into_iter()
        .filter(|&(k, v)| {
            param_owner(k).is_none_or(|(i, j)| {
                let e = REGISTRY[i];
                !(e.generic() && e.params()[j].is_neutral(v))
            })
        })
        .collect();
    map.serialize(s)
}

/// The effects a simulator runs with: the robot's, then the terrain's, then the run's own
/// (each later source overrides the parameters it sets away from their neutral value; a
/// neutral value, e.g. the other motor's gain of 1, is what the effect's parameters default
/// to and overrides nothing).
pub fn combine(robot: &Effects, terrain: &Effects, run: &Effects) -> Result<Effects> {
    if robot.is_empty() && terrain.is_empty() {
        return Ok(run.clone());
    }
    let mut out = Effects::default();
    for source in [robot, terrain, run] {
        for (k, v) in source.declared() {
            out.set(k, v)?;
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn typo_gets_a_suggestion() {
        let mut e = Effects::default();
        let msg = set_checked(&mut e, "motor_gain_lft", 0.9).unwrap_err();
        assert!(msg.contains("did you mean `motor_gain_left`"), "{msg}");
        // The named effects' parameters are listed; the terms' 140 coefficients as one pattern.
        assert!(msg.contains("crab_angle_rad") && msg.contains("term_<target>__<feature>"));
        assert!(!msg.contains("term_body_vy__abs_wz"), "{msg}");
    }

    #[test]
    fn out_of_bounds_names_the_range() {
        let mut e = Effects::default();
        let msg = set_checked(&mut e, "turning_resistance_scale", 500.0).unwrap_err();
        assert!(
            msg.contains("turning_resistance_scale") && msg.contains("100"),
            "{msg}"
        );
    }

    #[test]
    fn later_sources_override() {
        let mut r = Effects::default();
        r.set("wheel_speed_saturation_rad_s", 12.5).unwrap();
        r.set("motor_gain_left", 0.9).unwrap();
        let mut run = Effects::default();
        run.set("motor_gain_left", 0.8).unwrap();
        let c = combine(&r, &Effects::default(), &run).unwrap();
        assert_eq!(c.get("motor_gain_left"), Some(0.8));
        assert_eq!(c.get("wheel_speed_saturation_rad_s"), Some(12.5));
    }
}
