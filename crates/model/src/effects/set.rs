//! A set of effects switched on with their parameter values ([`Effects`]): what `--inject
//! NAME=VALUE` builds, what a simulator runs with and what calibration fits, in registry order,
//! serialized as a map from parameter name to value.

use super::{known_params_text, param_owner, Effect, PlantModifiers, TermInput, REGISTRY};
use crate::error::{Error, Result};
use crate::kinematics::{BodyVelocity, IdealDiffDrive, WheelSpeeds};
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::collections::BTreeMap;
use std::fmt;

/// An effect switched on, with its parameter values.
#[derive(Clone, PartialEq)]
struct Active {
    /// Index in [`REGISTRY`].
    index: usize,
    values: Vec<f64>,
}

impl Active {
    fn effect(&self) -> &'static dyn Effect {
        REGISTRY[self.index]
    }
}

/// A set of effects switched on, each with its parameter values, kept in registry order. The
/// default is the nominal model (nothing switched on).
#[derive(Clone, PartialEq, Default)]
pub struct Effects {
    active: Vec<Active>,
}

impl fmt::Debug for Effects {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_map().entries(self.values()).finish()
    }
}

impl Effects {
    /// Sets one parameter by name (switching its effect on, its other parameters neutral).
    /// Booleans take 0 or 1; limits take a positive value, or 0 / infinity to remove them.
    /// Rejects unknown names and values outside the parameter's range, naming them.
    pub fn set(&mut self, key: &str, value: f64) -> Result<()> {
        let (index, j) = param_owner(key).ok_or_else(|| {
            Error::config(
                "--inject",
                key,
                format!("unknown effect; known: {}", known_params_text()),
            )
        })?;
        let def = &REGISTRY[index].params()[j];
        let value = def.check(value)?;
        let pos = match self.active.iter().position(|a| a.index >= index) {
            Some(p) if self.active[p].index == index => p,
            Some(p) => {
                self.active.insert(p, Self::neutral_entry(index));
                p
            }
            None => {
                self.active.push(Self::neutral_entry(index));
                self.active.len() - 1
            }
        };
        self.active[pos].values[j] = value;
        // An effect whose parameters are all neutral again is off.
        let e = REGISTRY[index];
        if self.active[pos]
            .values
            .iter()
            .zip(e.params())
            .all(|(v, d)| d.is_neutral(*v))
        {
            self.active.remove(pos);
        }
        Ok(())
    }

    fn neutral_entry(index: usize) -> Active {
        Active {
            index,
            values: REGISTRY[index].params().iter().map(|p| p.neutral).collect(),
        }
    }

    /// Current value of a parameter (its neutral value when its effect is off; a missing limit
    /// reads as infinity, a flag as 0 or 1); `None` for an unknown name.
    pub fn get(&self, key: &str) -> Option<f64> {
        let (index, j) = param_owner(key)?;
        Some(
            self.active
                .iter()
                .find(|a| a.index == index)
                .map_or(REGISTRY[index].params()[j].neutral, |a| a.values[j]),
        )
    }

    /// The parameters that differ from their neutral value, as `(name, value)` pairs in
    /// registry order (what a log records as "injected").
    pub fn declared(&self) -> Vec<(&'static str, f64)> {
        self.values()
            .into_iter()
            .filter(|(k, v)| param_owner(k).is_some_and(|(i, j)| !REGISTRY[i].params()[j].is_neutral(*v)))
            .collect()
    }

    /// Every parameter of every effect switched on, with its value, in registry order.
    pub fn values(&self) -> Vec<(&'static str, f64)> {
        self.active
            .iter()
            .flat_map(|a| {
                a.effect()
                    .params()
                    .iter()
                    .zip(&a.values)
                    .map(|(d, v)| (d.key, *v))
            })
            .collect()
    }

    /// The effects switched on, in registry order.
    pub fn active(&self) -> impl Iterator<Item = &'static dyn Effect> + '_ {
        self.active.iter().map(Active::effect)
    }

    /// Nothing switched on.
    pub fn is_empty(&self) -> bool {
        self.active.is_empty()
    }

    /// The first effect switched on that a plant without a tyre model cannot run.
    pub fn first_contact_effect(&self) -> Option<&'static dyn Effect> {
        self.active().find(|e| !e.kinematic())
    }

    /// Parses `NAME=VALUE` (the CLI's `--inject` syntax) and applies it.
    pub fn apply_assignment(&mut self, assignment: &str) -> Result<()> {
        let (name, value) = assignment
            .split_once('=')
            .ok_or_else(|| Error::config("--inject", assignment, "expected NAME=VALUE"))?;
        let name = name.trim();
        let v: f64 = match value.trim() {
            "true" => 1.0,
            "false" => 0.0,
            t => t
                .parse()
                .map_err(|_| Error::config("--inject", name, format!("`{t}` is not a number")))?,
        };
        self.set(name, v)
    }

    /// The physical quantities a plant built with these effects uses.
    pub fn modifiers(&self) -> PlantModifiers {
        let mut m = PlantModifiers::default();
        for a in &self.active {
            a.effect().modify_plant(&a.values, &mut m);
        }
        m
    }

    /// The wheel-speed targets the motors receive for the command `cmd`, given the nominal
    /// geometry the command was computed with: the controller's body-space clamps and
    /// kinematics, then the wheel-stage effects in registry order. With nothing switched on,
    /// `cmd` comes back unchanged (bit for bit).
    pub fn wheel_targets(&self, cmd: WheelSpeeds, nominal: &IdealDiffDrive) -> WheelSpeeds {
        let x = TermInput {
            cmd,
            cmd_body: nominal.body_from_wheels(cmd),
            ..TermInput::default()
        };
        self.wheel_targets_in(cmd, nominal, &x)
    }

    /// The command after the controller's body-space clamps and kinematics.
    fn controller_targets(&self, cmd: WheelSpeeds, nominal: &IdealDiffDrive) -> WheelSpeeds {
        let mut w = cmd;
        if self.active.iter().any(|a| a.effect().uses_body_space()) {
            let mut v = nominal.body_from_wheels(cmd);
            v.vy_m_s = 0.0;
            let mut controller = *nominal;
            for a in &self.active {
                v = a.effect().body_command(&a.values, v);
                controller = a.effect().controller_geometry(&a.values, controller);
            }
            w = controller.wheels_from_body(v);
        }
        w
    }

    /// The wheel-speed targets as [`Effects::wheel_targets`], with the effects that read the
    /// step or the model's state ([`Effect::wheel_targets_in`]) given `x`.
    #[inline]
    pub fn wheel_targets_in(&self, cmd: WheelSpeeds, nominal: &IdealDiffDrive, x: &TermInput) -> WheelSpeeds {
        let mut w = self.controller_targets(cmd, nominal);
        for a in &self.active {
            w = a.effect().wheel_targets_in(&a.values, w, x);
        }
        w
    }

    /// The sum of the body-velocity offsets ([`Effect::body_offset`]) at `x`.
    #[inline]
    pub fn body_offset(&self, x: &TermInput) -> BodyVelocity {
        self.active.iter().fold(BodyVelocity::default(), |acc, a| {
            let o = a.effect().body_offset(&a.values, x);
            BodyVelocity::new(
                acc.vx_m_s + o.vx_m_s,
                acc.vy_m_s + o.vy_m_s,
                acc.wz_rad_s + o.wz_rad_s,
            )
        })
    }

    /// Whether any effect switched on moves the body apart from its wheels
    /// ([`Effect::moves_body`]): plants skip the body-stage bookkeeping otherwise.
    #[inline]
    pub fn acts_on_body(&self) -> bool {
        self.active().any(|e| e.moves_body())
    }

    /// The IMU yaw-rate reading for the true yaw rate `wz_rad_s`.
    pub fn imu_yaw_rate(&self, wz_rad_s: f64) -> f64 {
        self.active
            .iter()
            .fold(wz_rad_s, |wz, a| a.effect().imu_yaw_rate(&a.values, wz))
    }

    /// The IMU yaw-rate reading for the true yaw rate `wz_rad_s`, with the effects that read
    /// the model's state given `x`.
    #[inline]
    pub fn imu_yaw_rate_in(&self, wz_rad_s: f64, x: &TermInput) -> f64 {
        self.active
            .iter()
            .fold(wz_rad_s, |wz, a| a.effect().imu_yaw_rate_in(&a.values, wz, x))
    }

    /// The encoder readings for the true wheel spins.
    #[inline]
    pub fn encoders(&self, wheels: WheelSpeeds) -> WheelSpeeds {
        self.active
            .iter()
            .fold(wheels, |w, a| a.effect().encoders(&a.values, w))
    }

    /// The wheel spins that give the encoder readings `encoders` (inverse of
    /// [`Effects::encoders`]).
    #[inline]
    pub fn wheels_from_encoders(&self, encoders: WheelSpeeds) -> WheelSpeeds {
        self.active
            .iter()
            .rev()
            .fold(encoders, |w, a| a.effect().wheels_from_encoders(&a.values, w))
    }
}

impl Serialize for Effects {
    fn serialize<S: Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        // Infinity (a limit that is off) has no JSON form; an active limit is finite.
        let map: BTreeMap<&str, f64> = self.values().into_iter().collect();
        map.serialize(s)
    }
}

impl<'de> Deserialize<'de> for Effects {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        let map = BTreeMap::<String, f64>::deserialize(d)?;
        let mut e = Effects::default();
        for (k, v) in map {
            e.set(&k, v).map_err(serde::de::Error::custom)?;
        }
        Ok(e)
    }
}
