//! Rig files (`NAME.rig.toml`, `shared/spec/recording-format.md`): what machine a recording
//! was made on and what the experimenter nominally believes about it. Every key of the
//! contract is accepted; unknown keys are refused with the file, line and key, because a
//! misspelt parameter silently left at a default would corrupt an identification.
//!
//! Keys this project adds (the contract allows additions): rig kind `drive_pair` (two
//! lifted drive axes behind the DCMC, the thesis's random-demand runs), `motor.coulomb_Nm`,
//! `controller.turn_gain_V_pct`, `controller.speed_per_pct_rad_s`,
//! `controller.kp_V_s_rad`, `controller.ki_V_rad`, and the `[falling_weight]` section.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

/// A rig file as read. Every value is optional: a rig states only what it believes.
#[derive(Debug, Clone, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Rig {
    /// `drive_axis`, `vehicle` or `drive_pair`.
    pub rig: String,
    /// `rotary` (default) or `linear` (drive axis only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub motion: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub motor: Option<MotorRig>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gearbox: Option<GearboxRig>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wheel: Option<WheelRig>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub supply: Option<SupplyRig>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub controller: Option<ControllerRig>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub chassis: Option<ChassisRig>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub load: Option<LoadRig>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drive: Option<DriveRig>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub feedback: Option<FeedbackRig>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sensors: Option<SensorsRig>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub falling_weight: Option<FallingWeightRig>,
}

/// Permanent-magnet DC motor.
#[allow(non_snake_case)]
#[derive(Debug, Clone, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MotorRig {
    pub resistance_ohm: Option<f64>,
    pub inductance_H: Option<f64>,
    /// Torque constant, N m/A (= back-EMF constant, V s/rad).
    pub torque_constant_Nm_A: Option<f64>,
    pub rotor_inertia_kg_m2: Option<f64>,
    /// All viscous friction of the drive train referred to the motor shaft, N m s/rad.
    pub viscous_Nm_s_rad: Option<f64>,
    /// Coulomb friction at the motor shaft, N m (project key).
    pub coulomb_Nm: Option<f64>,
}

#[derive(Debug, Clone, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct GearboxRig {
    /// Motor turns per wheel turn.
    pub ratio: Option<f64>,
}

#[derive(Debug, Clone, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct WheelRig {
    pub radius_m: Option<f64>,
    /// Wheel plus output gear about its axle, kg m^2.
    pub inertia_kg_m2: Option<f64>,
}

#[allow(non_snake_case)]
#[derive(Debug, Clone, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SupplyRig {
    pub voltage_V: Option<f64>,
}

/// How `demand_*_pct` becomes motor voltage.
#[allow(non_snake_case)]
#[derive(Debug, Clone, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ControllerRig {
    /// `gain` (contract), `p` or `pi` (project).
    pub kind: Option<String>,
    /// Volts per percent of (forward) demand.
    pub gain_V_pct: Option<f64>,
    /// Volts per percent of turn demand (project key, drive pairs).
    pub turn_gain_V_pct: Option<f64>,
    /// Speed-loop set-point per percent of demand, rad/s (project key).
    pub speed_per_pct_rad_s: Option<f64>,
    /// Speed-loop proportional gain, V s/rad (project key).
    pub kp_V_s_rad: Option<f64>,
    /// Speed-loop integral gain, V/rad (project key).
    pub ki_V_rad: Option<f64>,
}

#[derive(Debug, Clone, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ChassisRig {
    pub mass_kg: Option<f64>,
    pub yaw_inertia_kg_m2: Option<f64>,
    pub track_width_m: Option<f64>,
    pub drive_load_fraction: Option<f64>,
}

/// Linear axis load.
#[allow(non_snake_case)]
#[derive(Debug, Clone, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct LoadRig {
    pub mass_kg: Option<f64>,
    pub viscous_N_s_m: Option<f64>,
}

/// Current amplifier: force (or torque) = gain x command.
#[allow(non_snake_case)]
#[derive(Debug, Clone, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct DriveRig {
    pub force_per_volt_N_V: Option<f64>,
    pub torque_per_volt_Nm_V: Option<f64>,
    pub limit_V: Option<f64>,
}

/// The loop that produced a closed-loop command.
#[allow(non_snake_case)]
#[derive(Debug, Clone, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct FeedbackRig {
    /// `position_velocity_cascade`: command = kv (kp (reference - position) - speed).
    pub kind: Option<String>,
    pub kp_1_s: Option<f64>,
    pub kv_V_s_m: Option<f64>,
    /// The velocity-loop gain of a rotary axis's cascade, V per rad/s of the wheel (an
    /// agvsim key beside the contract's linear `kv_V_s_m`).
    pub kv_V_s_rad: Option<f64>,
}

#[allow(non_snake_case)]
#[derive(Debug, Clone, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SensorsRig {
    pub motor_encoder_counts_per_rev: Option<f64>,
    pub current_noise_A: Option<f64>,
    pub tracker_position_noise_m: Option<f64>,
    pub tracker_heading_noise_rad: Option<f64>,
    pub tracker_rate_hz: Option<f64>,
}

/// The falling-weight test (project section): motor off the vehicle, a mass on a pulley on
/// the motor shaft, dropping from rest until it lands.
#[derive(Debug, Clone, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct FallingWeightRig {
    pub mass_kg: Option<f64>,
    pub pulley_radius_m: Option<f64>,
    /// Height the mass falls before it lands, m.
    pub drop_m: Option<f64>,
}

/// A rig file that cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum RigError {
    #[error("{file}: cannot read: {source}")]
    Read {
        file: PathBuf,
        source: std::io::Error,
    },
    #[error("{file}: {message}")]
    Invalid { file: PathBuf, message: String },
}

/// Rig kinds this reader knows.
pub const RIG_KINDS: [&str; 3] = ["drive_axis", "vehicle", "drive_pair"];

impl Rig {
    pub fn load(path: &Path) -> Result<Rig, RigError> {
        let text = std::fs::read_to_string(path).map_err(|source| RigError::Read {
            file: path.to_owned(),
            source,
        })?;
        Rig::parse(&text, path)
    }

    /// Parses and checks a rig file; `path` is used in messages.
    pub fn parse(text: &str, path: &Path) -> Result<Rig, RigError> {
        // A leading UTF-8 byte-order mark (as some editors write) is not TOML.
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let invalid = |message: String| RigError::Invalid {
            file: path.to_owned(),
            message,
        };
        let rig: Rig = toml::from_str(text).map_err(|e| {
            let mut msg = e.message().to_string();
            if let Some(span) = e.span() {
                let line = text[..span.start.min(text.len())].matches('\n').count() + 1;
                msg = format!("line {line}: {msg}");
            }
            invalid(msg)
        })?;
        if !RIG_KINDS.contains(&rig.rig.as_str()) {
            return Err(invalid(format!(
                "rig = \"{}\": expected one of {}",
                rig.rig,
                RIG_KINDS.join(", ")
            )));
        }
        match rig.motion.as_deref() {
            None | Some("rotary") | Some("linear") => {}
            Some(m) => {
                return Err(invalid(format!(
                    "motion = \"{m}\": expected \"rotary\" or \"linear\""
                )))
            }
        }
        for (key, value) in rig.numbers() {
            if !value.is_finite() {
                return Err(invalid(format!(
                    "`{key}` = {value}: expected a finite number"
                )));
            }
            let may_be_zero_or_negative =
                key.starts_with("controller.") || key == "motor.coulomb_Nm";
            if ZERO_MEANINGFUL.contains(&key.as_str()) && value == 0.0 {
                // Each model accepts it or refuses it with its reason.
                continue;
            }
            if !may_be_zero_or_negative && value <= 0.0 {
                return Err(invalid(format!(
                    "`{key}` = {value}: expected a positive value (SI units, see the key's suffix)"
                )));
            }
        }
        if let Some(f) = rig.chassis.as_ref().and_then(|c| c.drive_load_fraction) {
            if f > 1.0 {
                return Err(invalid(format!(
                    "`chassis.drive_load_fraction` = {f}: expected a share of the weight, 0..1"
                )));
            }
        }
        Ok(rig)
    }

    /// Whether this is a linear drive axis.
    pub fn is_linear(&self) -> bool {
        self.motion.as_deref() == Some("linear")
    }

    /// Every numeric key with its dotted name.
    pub fn numbers(&self) -> Vec<(String, f64)> {
        let value = toml::Value::try_from(self).unwrap_or(toml::Value::Boolean(false));
        let mut out = Vec::new();
        if let toml::Value::Table(t) = value {
            for (section, v) in t {
                if let toml::Value::Table(inner) = v {
                    for (k, v) in inner {
                        if let Some(x) = v.as_float().or(v.as_integer().map(|i| i as f64)) {
                            out.push((format!("{section}.{k}"), x));
                        }
                    }
                }
            }
        }
        out
    }

    /// A numeric value by dotted key (`motor.resistance_ohm`).
    pub fn get(&self, key: &str) -> Option<f64> {
        self.numbers()
            .into_iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v)
    }

    /// A value the model needs, or an error naming the key.
    pub fn require(&self, key: &str, path: &Path, why: &str) -> Result<f64, RigError> {
        self.get(key).ok_or_else(|| RigError::Invalid {
            file: path.to_owned(),
            message: format!("`{key}` is missing ({why})"),
        })
    }

    /// The rig as TOML text.
    pub fn to_toml(&self) -> String {
        toml::to_string(self).expect("a rig always serialises")
    }
}

/// Rig values that mean something at zero: no viscous friction, an inertia lumped into
/// another one, a negligible inductance. The reader takes them; a model that cannot use a
/// zero refuses it with its reason ([`zero_refused`]).
pub const ZERO_MEANINGFUL: [&str; 4] = [
    "motor.viscous_Nm_s_rad",
    "wheel.inertia_kg_m2",
    "load.viscous_N_s_m",
    "motor.inductance_H",
];

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
        rig.get("motor.torque_constant_Nm_A"),
        rig.get("motor.resistance_ohm"),
    ) {
        (Some(k), Some(r)) if r > 0.0 => Some(k * k / r),
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
            e.contains("motor.resistance_ohm") && e.contains("positive"),
            "{e}"
        );
        let e = parse("[motor]\nresistance_ohm = 1\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("rig"), "{e}");
    }
}
