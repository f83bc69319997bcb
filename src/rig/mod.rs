//! Rig files (`NAME.rig.toml`, `shared/spec/recording-format.md`): what machine a recording
//! was made on and what the experimenter nominally believes about it. Every key of the
//! contract is accepted; unknown keys are refused with the file, line and key, because a
//! misspelt parameter silently left at a default would corrupt an identification.
//!
//! A rig's keys are the scene's keys ([`keys`]): the same name (`motor.resistance_ohm`),
//! or a named alias where the contract calls a scene key otherwise
//! (`supply.voltage_V` is `battery.open_circuit_V`, `controller.gain_V_pct` is
//! `dcmc.forward_gain_V_pct`); the parts of other machines that the AGV's scene has no
//! block for declare their keys in [`blocks`]. Each key's unit, rule and meaning come
//! from its declaration. A rig file is read and checked in `read.rs` (each refusal naming
//! the file, line and key) and written, as rig TOML or as its machine's scene, in
//! `write.rs`.
//!
//! Keys this project adds (the contract allows additions): rig kind `drive_pair` (two
//! lifted drive axes behind the DCMC, the thesis's random-demand runs), `motor.coulomb_Nm`,
//! `controller.turn_gain_V_pct`, `controller.speed_per_pct_rad_s`,
//! `controller.kp_V_s_rad`, `controller.ki_V_rad`, `feedback.kv_V_s_rad` and the
//! `[falling_weight]` section, and `[uncertainty_pct]`: how far each stated belief may be
//! off, one standard deviation in percent of it, by key (`"chassis.mass_kg" = 50`); a fit
//! holds a parameter its record cannot determine near its belief by that much
//! ([`crate::ident::model::ParamSpec::belief_sd_rel`]; unstated: 30 %).

mod base;
pub mod blocks;
pub mod keys;
mod kind;
mod read;
mod write;

use crate::model::gearbox::GearboxParams;
use crate::model::motor::MotorParams;
use crate::model::wheel::WheelParams;
use std::path::{Path, PathBuf};

use keys::RigKey;
pub use kind::RigKind;

/// A value a rig states.
#[derive(Debug, Clone, PartialEq)]
enum Stated {
    Number(f64),
    Text(String),
}

/// A rig file as read: its kind and every value it states, by key. A rig states only what
/// it believes; every value is optional.
#[derive(Debug, Clone, PartialEq)]
pub struct Rig {
    /// What machine it is.
    pub rig: RigKind,
    /// `rotary` (default) or `linear` (drive axis only).
    pub motion: Option<String>,
    /// Stated values by their key's place in the table ([`keys::table`]), in that order.
    values: Vec<(usize, Stated)>,
    /// `[uncertainty_pct]`: one standard deviation of a stated belief, percent of it, by
    /// the key's place in the table, in that order.
    uncertainty_pct: Vec<(usize, f64)>,
}

/// The rig section that states how far beliefs may be off.
pub const UNCERTAINTY_SECTION: &str = "uncertainty_pct";

/// A rig file that cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum RigError {
    /// The file could not be read.
    #[error("{file}: cannot read: {source}")]
    Read {
        /// The rig file.
        file: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The file breaks the format or a model cannot use one of its values.
    #[error("{file}: {message}")]
    Invalid {
        /// The rig file.
        file: PathBuf,
        /// What is wrong, naming the key (and line where it came from the file).
        message: String,
    },
}

impl RigError {
    /// The file breaks the format: `message` says where and how.
    fn invalid(file: &Path, message: String) -> RigError {
        RigError::Invalid {
            file: file.to_owned(),
            message,
        }
    }
}

impl Rig {
    /// A rig of a kind stating nothing yet.
    pub fn new(kind: RigKind) -> Rig {
        Rig {
            rig: kind,
            motion: None,
            values: Vec::new(),
            uncertainty_pct: Vec::new(),
        }
    }

    /// States the uncertainty of the key at `order` in the key table, kept in its order.
    fn state_uncertainty(&mut self, order: usize, pct: f64) {
        match self.uncertainty_pct.iter_mut().find(|(o, _)| *o == order) {
            Some(slot) => slot.1 = pct,
            None => {
                self.uncertainty_pct.push((order, pct));
                self.uncertainty_pct.sort_by_key(|(o, _)| *o);
            }
        }
    }

    /// How far the belief `key` may be off, one standard deviation in percent of it, if
    /// the rig states it.
    pub fn uncertainty_pct(&self, key: &str) -> Option<f64> {
        let table = keys::table();
        self.uncertainty_pct
            .iter()
            .find(|(o, _)| table[*o].key == key)
            .map(|(_, p)| *p)
    }

    /// States how far the belief `key` may be off (percent, one standard deviation);
    /// `None` for a key the rig format does not have.
    pub fn set_uncertainty_pct(&mut self, key: &str, pct: f64) -> Option<()> {
        let k = keys::find(key)?;
        self.state_uncertainty(k.order, pct);
        Some(())
    }

    /// Sets (or replaces) a stated value, keeping the table's order.
    fn state(&mut self, k: &RigKey, v: Stated) {
        match self.values.iter_mut().find(|(have, _)| *have == k.order) {
            Some(slot) => slot.1 = v,
            None => {
                let at = self
                    .values
                    .iter()
                    .position(|(have, _)| *have > k.order)
                    .unwrap_or(self.values.len());
                self.values.insert(at, (k.order, v));
            }
        }
    }

    /// The stated values with their keys, in the table's order.
    fn stated(&self) -> impl Iterator<Item = (&'static RigKey, &Stated)> {
        let table = keys::table();
        self.values.iter().map(move |(i, v)| (&table[*i], v))
    }

    /// A rig of `kind` stating the scene's value of each rig key in `keys` (those the
    /// scene has a value for).
    pub fn from_scene(kind: RigKind, scene: &crate::scene::Scene, keys: &[&str]) -> Rig {
        let mut rig = Rig::new(kind);
        let table = crate::scene::keys::table();
        for key in keys {
            let value = keys::find(key)
                .and_then(|k| k.scene_key)
                .and_then(|scene_key| table.find(scene_key))
                .and_then(|k| k.get(scene));
            if let Some(v) = value {
                rig.set(key, v);
            }
        }
        rig
    }

    /// Each stated number that is a scene key, as a `--set` text under the scene's name
    /// (`battery.open_circuit_V=24` for the rig's `supply.voltage_V`).
    pub fn scene_sets(&self) -> Vec<String> {
        self.stated()
            .filter_map(|(k, v)| match (k.scene_key, v) {
                (Some(scene_key), Stated::Number(x)) => Some(format!("{scene_key}={x}")),
                _ => None,
            })
            .collect()
    }

    /// This rig stating `key = value` as well (a number), replacing any value it had.
    /// `None` for a key the rig format does not have.
    pub fn set(&mut self, key: &str, value: f64) -> Option<()> {
        let k = keys::find(key)?;
        self.state(k, Stated::Number(value));
        Some(())
    }

    /// This rig stating a name (`controller.kind`, `feedback.kind`).
    pub fn set_text(&mut self, key: &str, value: &str) -> Option<()> {
        let k = keys::find(key)?;
        self.state(k, Stated::Text(value.to_string()));
        Some(())
    }

    /// Whether this is a linear drive axis.
    pub fn is_linear(&self) -> bool {
        self.motion.as_deref() == Some("linear")
    }

    /// Every numeric value with its dotted key, in the key table's order.
    pub fn numbers(&self) -> Vec<(String, f64)> {
        self.stated()
            .filter_map(|(k, v)| match v {
                Stated::Number(x) => Some((k.key.clone(), *x)),
                Stated::Text(_) => None,
            })
            .collect()
    }

    /// A numeric value by dotted key (`motor.resistance_ohm`).
    pub fn get(&self, key: &str) -> Option<f64> {
        self.stated().find_map(|(k, v)| match v {
            Stated::Number(x) if k.key == key => Some(*x),
            _ => None,
        })
    }

    /// A name by dotted key (`controller.kind`).
    pub fn text(&self, key: &str) -> Option<&str> {
        self.stated().find_map(|(k, v)| match v {
            Stated::Text(t) if k.key == key => Some(t.as_str()),
            _ => None,
        })
    }

    /// A value the model needs, or an error naming the key.
    pub fn require(&self, key: &str, path: &Path, why: &str) -> Result<f64, RigError> {
        self.get(key).ok_or_else(|| RigError::Invalid {
            file: path.to_owned(),
            message: format!("`{key}` is missing ({why})"),
        })
    }

    /// Motor turns per wheel turn: `gearbox.ratio`, required when the rig states a
    /// wheel-side value (which the motor sees through the gear); a rig of the motor alone
    /// (a linear axis, a motor on a bench) is taken as direct drive, 1.
    pub fn gear_ratio(&self, path: &Path) -> Result<f64, RigError> {
        if let Some(n) = self.get(GearboxParams::ratio.key()) {
            return Ok(n);
        }
        let wheel: Vec<&str> = [
            WheelParams::inertia_kg_m2.key(),
            WheelParams::radius_m.key(),
        ]
        .into_iter()
        .filter(|k| self.get(k).is_some())
        .collect();
        if wheel.is_empty() {
            return Ok(1.0);
        }
        Err(RigError::Invalid {
            file: path.to_owned(),
            message: format!(
                "`gearbox.ratio` is missing: the rig states {}, which the motor sees through the gear (say ratio = 1 under [gearbox] for a direct drive)",
                wheel.join(" and ")
            ),
        })
    }

    /// Every numeric value scaled by `f(key, value)` (a perturbed belief).
    pub fn map_numbers(&mut self, mut f: impl FnMut(&str, f64) -> f64) {
        let table = keys::table();
        for (i, v) in &mut self.values {
            if let Stated::Number(x) = v {
                *x = f(&table[*i].key, *x);
            }
        }
    }
}

/// The error for a rig value of zero that a model cannot use, with the reason.
pub fn zero_refused(path: &Path, key: &str, why: &str) -> RigError {
    RigError::Invalid {
        file: path.to_owned(),
        message: format!("`{key}` = 0: {why}"),
    }
}

/// The electrical damping K^2/R of the rig's motor, N m s/rad (the ceiling of a viscous
/// friction believed zero: a drive's mechanical losses are not larger than its motor's
/// own braking), if the rig gives both.
pub fn electrical_damping(rig: &Rig) -> Option<f64> {
    match (
        rig.get(MotorParams::torque_constant_nm_a.key()),
        rig.get(MotorParams::resistance_ohm.key()),
    ) {
        (Some(k), Some(r)) if r > 0.0 => {
            Some(crate::model::motor::electrical_damping_nm_s_rad(k, r))
        }
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(t: &str) -> Result<Rig, RigError> {
        Rig::parse(t, Path::new("x.rig.toml"))
    }

    #[test]
    fn reads_every_contract_key() {
        let text = r#"
rig = "drive_axis"
motion = "linear"
[motor]
resistance_ohm = 0.35
inductance_H = 0.0008
torque_constant_Nm_A = 0.063
rotor_inertia_kg_m2 = 2.0e-4
viscous_Nm_s_rad = 1.0e-4
[gearbox]
ratio = 23.41
[wheel]
radius_m = 0.075
inertia_kg_m2 = 0.02
[supply]
voltage_V = 24.0
[controller]
kind = "gain"
gain_V_pct = 0.24
[chassis]
mass_kg = 120.0
yaw_inertia_kg_m2 = 14.0
track_width_m = 0.50
drive_load_fraction = 0.6
[load]
mass_kg = 80.0
viscous_N_s_m = 150.0
[drive]
force_per_volt_N_V = 35.15
torque_per_volt_Nm_V = 1.0
limit_V = 10.0
[feedback]
kind = "position_velocity_cascade"
kp_1_s = 160.18
kv_V_s_m = 243.45
[sensors]
motor_encoder_counts_per_rev = 1024
current_noise_A = 0.3
tracker_position_noise_m = 0.002
tracker_heading_noise_rad = 0.005
tracker_rate_hz = 50
"#;
        let r = parse(text).unwrap();
        assert!(r.is_linear());
        assert_eq!(r.get("load.viscous_N_s_m"), Some(150.0));
        assert_eq!(r.get("sensors.motor_encoder_counts_per_rev"), Some(1024.0));
        let back = parse(&r.to_toml()).unwrap();
        assert_eq!(back, r);
    }

    #[test]
    fn unknown_keys_and_bad_values_are_refused_with_the_key() {
        let e = parse("rig = \"drive_axis\"\n[motor]\nresistance_ohms = 0.3\n")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("x.rig.toml") && e.contains("resistance_ohms") && e.contains("line 3"),
            "{e}"
        );
        let e = parse("rig = \"boat\"\n").unwrap_err().to_string();
        assert!(e.contains("boat") && e.contains("drive_axis"), "{e}");
        let e = parse("rig = \"drive_axis\"\n[motor]\nresistance_ohm = -1\n")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("motor.resistance_ohm") && e.contains("greater than zero"),
            "{e}"
        );
        let e = parse("[motor]\nresistance_ohm = 1\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("rig"), "{e}");
    }
}
