//! Terrain profiles as data (`terrains/*.toml`): slip-dependent friction, rolling resistance,
//! soft-soil effects and roughness.

use crate::config::{non_negative, positive, Validate};
use crate::effects::Effects;
use crate::error::Result;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// Terrains shipped with the binary; files in `./terrains/` override or extend them.
pub const BUILTIN_TERRAINS: &[(&str, &str)] = &[
    ("asphalt", include_str!("../../../terrains/asphalt.toml")),
    ("grass", include_str!("../../../terrains/grass.toml")),
    ("gravel", include_str!("../../../terrains/gravel.toml")),
    ("ice", include_str!("../../../terrains/ice.toml")),
    ("mud", include_str!("../../../terrains/mud.toml")),
    ("sand", include_str!("../../../terrains/sand.toml")),
    ("snow", include_str!("../../../terrains/snow.toml")),
    ("tile", include_str!("../../../terrains/tile.toml")),
];

/// A terrain's wheel-terrain interaction profile.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Terrain {
    /// Short name, e.g. `ice`.
    pub name: String,
    /// One-line description.
    pub description: String,
    /// Slip-dependent friction.
    pub friction: FrictionProfile,
    /// Resistance to rolling and soft-soil effects.
    pub resistance: Resistance,
    /// Ground unevenness.
    pub roughness: Roughness,
    /// Model effects the ground adds (contact effects such as turning resistance), by the effect registry's parameter names (`[effects]` table;
    /// optional). Checked against the registry when the file is read; the simulator applies
    /// them (see [`crate::effects_table`]).
    #[serde(
        default,
        skip_serializing_if = "Effects::is_empty",
        serialize_with = "crate::effects_table::serialize",
        deserialize_with = "crate::effects_table::deserialize"
    )]
    pub effects: Effects,
}

/// Slip-dependent friction: the coefficient rises to a peak at a characteristic slip, then
/// falls towards the sliding value.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FrictionProfile {
    /// Peak longitudinal friction coefficient.
    pub peak_longitudinal: f64,
    /// Fully sliding longitudinal friction coefficient.
    pub sliding_longitudinal: f64,
    /// Peak lateral friction coefficient.
    pub peak_lateral: f64,
    /// Fully sliding lateral friction coefficient.
    pub sliding_lateral: f64,
    /// Longitudinal slip ratio at the peak (dimensionless).
    pub peak_slip_ratio: f64,
    /// Lateral slip angle at the peak, rad.
    pub peak_slip_angle_rad: f64,
}

/// Rolling resistance and soft-soil effects (a reduced Bekker/Wong terramechanics model).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Resistance {
    /// Rolling resistance coefficient (resisting force / normal load), applied as a torque
    /// `f_r N r` opposing each wheel's spin; on soft soil it includes compaction resistance.
    pub rolling_coefficient: f64,
    /// Static sinkage of a tyre, m (0 on hard ground): the wheel sits this much below the
    /// surface, which sets the frontal and side areas that bulldoze soil.
    pub sinkage_m: f64,
    /// Bulldozing pressure, Pa: soil pushed by the sunk part of a tyre resists with this
    /// pressure times the sunk frontal area (width x sinkage, longitudinal motion) or the sunk
    /// side area (contact chord x sinkage, lateral motion, which is what piles dirt beside the
    /// wheels when skid-steering). 0 on hard ground.
    pub bulldozing_pressure_pa: f64,
    /// Churning drag of a wheel spinning in viscous soil (mud, slush), s/m: a torque
    /// `c N r (w r)` opposing the spin, proportional to the rim speed. 0 on dry ground.
    pub churning_drag_s_m: f64,
}

/// Random ground unevenness.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Roughness {
    /// Standard deviation of the ground height, m.
    pub height_std_m: f64,
    /// Correlation length of the height field, m.
    pub correlation_length_m: f64,
}

impl Terrain {
    /// Loads a terrain by name (catalog) or path.
    pub fn resolve(name_or_path: &str) -> Result<(Self, PathBuf)> {
        crate::config::resolve("terrain", name_or_path, BUILTIN_TERRAINS)
    }
}

impl Validate for Terrain {
    fn validate(&self) -> std::result::Result<(), (String, String)> {
        let f = &self.friction;
        positive("friction.peak_longitudinal", f.peak_longitudinal)?;
        positive("friction.sliding_longitudinal", f.sliding_longitudinal)?;
        positive("friction.peak_lateral", f.peak_lateral)?;
        positive("friction.sliding_lateral", f.sliding_lateral)?;
        positive("friction.peak_slip_ratio", f.peak_slip_ratio)?;
        positive("friction.peak_slip_angle_rad", f.peak_slip_angle_rad)?;
        if f.sliding_longitudinal > f.peak_longitudinal {
            return Err((
                "friction.sliding_longitudinal".into(),
                "must not exceed peak_longitudinal".into(),
            ));
        }
        if f.sliding_lateral > f.peak_lateral {
            return Err((
                "friction.sliding_lateral".into(),
                "must not exceed peak_lateral".into(),
            ));
        }
        let r = &self.resistance;
        non_negative("resistance.rolling_coefficient", r.rolling_coefficient)?;
        non_negative("resistance.sinkage_m", r.sinkage_m)?;
        non_negative("resistance.bulldozing_pressure_pa", r.bulldozing_pressure_pa)?;
        non_negative("resistance.churning_drag_s_m", r.churning_drag_s_m)?;
        if r.rolling_coefficient >= 1.0 {
            return Err((
                "resistance.rolling_coefficient".into(),
                format!(
                    "{} is not a rolling resistance (must be < 1)",
                    r.rolling_coefficient
                ),
            ));
        }
        for (field, v) in [
            ("friction.peak_longitudinal", f.peak_longitudinal),
            ("friction.peak_lateral", f.peak_lateral),
        ] {
            if v > 3.0 {
                return Err((
                    field.into(),
                    format!("{v}: friction coefficients above 3 are not physical for tyres"),
                ));
            }
        }
        if f.peak_slip_angle_rad >= std::f64::consts::FRAC_PI_2 {
            return Err(("friction.peak_slip_angle_rad".into(), "must be below pi/2".into()));
        }
        non_negative("roughness.height_std_m", self.roughness.height_std_m)?;
        positive(
            "roughness.correlation_length_m",
            self.roughness.correlation_length_m,
        )?;
        self.validate_ranges()
    }
}

impl Terrain {
    /// Physical ranges (with units) of the terrain quantities: a value outside is a unit slip
    /// or a typo, refused before any simulation.
    fn validate_ranges(&self) -> std::result::Result<(), (String, String)> {
        let (f, r, g) = (&self.friction, &self.resistance, &self.roughness);
        for (field, v, lo, hi, unit) in [
            (
                "friction.peak_slip_ratio",
                f.peak_slip_ratio,
                1e-3,
                1.0,
                "(ratio)",
            ),
            (
                "friction.peak_slip_angle_rad",
                f.peak_slip_angle_rad,
                1e-3,
                1.5,
                "rad",
            ),
            ("resistance.sinkage_m", r.sinkage_m, 0.0, 1.0, "m"),
            (
                "resistance.bulldozing_pressure_pa",
                r.bulldozing_pressure_pa,
                0.0,
                1e7,
                "Pa",
            ),
            (
                "resistance.churning_drag_s_m",
                r.churning_drag_s_m,
                0.0,
                100.0,
                "s/m",
            ),
            ("roughness.height_std_m", g.height_std_m, 0.0, 1.0, "m"),
            (
                "roughness.correlation_length_m",
                g.correlation_length_m,
                1e-3,
                1_000.0,
                "m",
            ),
        ] {
            crate::config::in_range(field, v, lo, hi, unit)?;
        }
        Ok(())
    }
}
