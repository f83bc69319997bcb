//! Every key a rig file may hold, each read from its declaration: the scene's keys a rig
//! states under the same name, the contract's aliases of scene keys, and the keys of the
//! parts of other machines ([`super::blocks`]).

use std::sync::OnceLock;

use super::blocks::{CurrentAmplifier, FallingWeight, Instruments, LinearLoad, PositionLoop};
use crate::param::{open_closed, Allowed, Block, Takes};

/// One key a rig may hold.
#[derive(Debug)]
pub struct RigKey {
    /// The dotted key as a rig file writes it.
    pub key: String,
    /// The scene key it is (the same name, or the one the contract's alias names), if the
    /// scene has it.
    pub scene_key: Option<&'static str>,
    /// Its unit, as declared.
    pub unit: &'static str,
    /// What it takes: the declaration's rule, or the rig's where a rig may state less
    /// (a zero that a model then accepts or refuses with its reason).
    pub takes: Takes,
    /// What it is, as declared.
    pub meaning: &'static str,
    /// Its place in the table: a rig is written in this order.
    pub order: usize,
}

/// The rig keys that are scene keys, in the contract's order (a rig is written in it):
/// each the scene's own key, or a rename where the contract calls a scene key otherwise
/// (the supply is the battery, the controller the DCMC).
const FROM_SCENE: [SceneKey; 20] = [
    SceneKey::Same("motor.resistance_ohm"),
    SceneKey::Same("motor.inductance_H"),
    SceneKey::Same("motor.torque_constant_Nm_A"),
    SceneKey::Same("motor.rotor_inertia_kg_m2"),
    SceneKey::Same("motor.viscous_Nm_s_rad"),
    SceneKey::Same("motor.coulomb_Nm"),
    SceneKey::Same("gearbox.ratio"),
    SceneKey::Same("wheel.radius_m"),
    SceneKey::Same("wheel.inertia_kg_m2"),
    SceneKey::Renamed("supply.voltage_V", "battery.open_circuit_V"),
    SceneKey::Renamed("controller.kind", "dcmc.kind"),
    SceneKey::Renamed("controller.gain_V_pct", "dcmc.forward_gain_V_pct"),
    SceneKey::Renamed("controller.turn_gain_V_pct", "dcmc.turn_gain_V_pct"),
    SceneKey::Renamed("controller.speed_per_pct_rad_s", "dcmc.speed_per_pct_rad_s"),
    SceneKey::Renamed("controller.kp_V_s_rad", "dcmc.kp_V_s_rad"),
    SceneKey::Renamed("controller.ki_V_rad", "dcmc.ki_V_rad"),
    SceneKey::Same("chassis.mass_kg"),
    SceneKey::Same("chassis.yaw_inertia_kg_m2"),
    SceneKey::Same("chassis.track_width_m"),
    SceneKey::Same("chassis.drive_load_fraction"),
];

/// A scene key a rig states.
#[derive(Clone, Copy)]
enum SceneKey {
    /// Under the scene's own name.
    Same(&'static str),
    /// Under the contract's name (rig key, scene key).
    Renamed(&'static str, &'static str),
}

impl SceneKey {
    /// (the rig's name, the scene's).
    fn names(self) -> (&'static str, &'static str) {
        match self {
            SceneKey::Same(k) => (k, k),
            SceneKey::Renamed(rig, scene) => (rig, scene),
        }
    }
}

/// Where a rig allows what the scene does not: a zero that means "lumped" or "negligible"
/// (each model accepts it or refuses it with its reason), and a drivetrain whose wheels
/// carry all the weight.
fn rig_rule(key: &str) -> Option<Allowed> {
    match key {
        "motor.inductance_H" | "wheel.inertia_kg_m2" => Some(Allowed::NonNegative),
        "chassis.drive_load_fraction" => Some(open_closed(0.0, 1.0)),
        // A rig may state a name for what the model then checks (`gain`, `p`, `pi`).
        _ => None,
    }
}

/// The table, built once.
pub fn table() -> &'static [RigKey] {
    static TABLE: OnceLock<Vec<RigKey>> = OnceLock::new();
    TABLE.get_or_init(build)
}

fn build() -> Vec<RigKey> {
    let scene = crate::scene::keys::table();
    let mut out: Vec<RigKey> = Vec::new();
    for (key, scene_key) in FROM_SCENE.map(SceneKey::names) {
        let Some(k) = scene.find(scene_key) else {
            continue;
        };
        let takes = match (k.takes, rig_rule(key)) {
            (_, Some(rule)) => Takes::Number(rule),
            // A rig states its controller's kind by name; the model checks it.
            (Takes::Other(_), None) => Takes::Other(|| "a name".into()),
            (t, None) => t,
        };
        out.push(RigKey {
            key: key.to_string(),
            scene_key: Some(scene_key),
            unit: k.unit,
            takes,
            meaning: k.meaning,
            order: out.len(),
        });
    }
    block::<LinearLoad>(&mut out, "load");
    block::<CurrentAmplifier>(&mut out, "drive");
    block::<PositionLoop>(&mut out, "feedback");
    block::<Instruments>(&mut out, "sensors");
    block::<FallingWeight>(&mut out, "falling_weight");
    out
}

/// A rig-only block's keys under its section.
fn block<B: Block>(out: &mut Vec<RigKey>, section: &str) {
    for p in B::PARAMS {
        out.push(RigKey {
            key: format!("{section}.{}", p.key),
            scene_key: None,
            unit: p.unit,
            takes: p.takes,
            meaning: p.meaning,
            order: out.len(),
        });
    }
}

/// A key by its dotted name.
pub fn find(key: &str) -> Option<&'static RigKey> {
    table().iter().find(|k| k.key == key)
}

/// The sections a rig has, in order.
pub fn sections() -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for k in table() {
        let s = k.key.split('.').next().unwrap_or("");
        if !out.iter().any(|have| have == s) {
            out.push(s.to_string());
        }
    }
    out.into_iter().map(|s| format!("[{s}]")).collect()
}

/// The keys of one section (without the section's name).
pub fn in_section(section: &str) -> Vec<String> {
    table()
        .iter()
        .filter_map(|k| k.key.strip_prefix(&format!("{section}.")).map(String::from))
        .collect()
}

/// The unit of a parameter: its declaration's if a rig or scene declares the key, else
/// the one its name ends in.
pub fn unit_key_or_name(key: &str) -> &'static str {
    match unit_of_key(key) {
        "" => crate::numtext::unit_of_name(key),
        u => u,
    }
}

/// The unit of a dotted key as its declaration states it: a rig's key, else a scene's;
/// `""` for a key neither declares (a model's own parameter) or one without a unit.
pub fn unit_of_key(key: &str) -> &'static str {
    if let Some(k) = find(key) {
        return k.unit;
    }
    crate::scene::keys::table()
        .find(key)
        .map(|k| k.unit)
        .unwrap_or("")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_key_has_its_declared_unit_else_the_one_its_name_ends_in() {
        // A rig key, a key only scenes have, and a model's own parameter.
        assert_eq!(unit_key_or_name("motor.rotor_inertia_kg_m2"), "kg m^2");
        assert_eq!(unit_of_key("tyre.peak_mu"), "");
        assert_eq!(unit_of_key("gearbox.backlash_rad"), "rad");
        assert_eq!(unit_key_or_name("delay_s"), "s");
        assert_eq!(unit_of_key("delay_s"), "");
    }

    #[test]
    fn every_contract_key_is_in_the_table_and_scene_keys_resolve() {
        let contract = [
            "motor.resistance_ohm",
            "motor.inductance_H",
            "motor.torque_constant_Nm_A",
            "motor.rotor_inertia_kg_m2",
            "motor.viscous_Nm_s_rad",
            "gearbox.ratio",
            "wheel.radius_m",
            "wheel.inertia_kg_m2",
            "supply.voltage_V",
            "controller.kind",
            "controller.gain_V_pct",
            "chassis.mass_kg",
            "chassis.yaw_inertia_kg_m2",
            "chassis.track_width_m",
            "chassis.drive_load_fraction",
            "load.mass_kg",
            "load.viscous_N_s_m",
            "drive.force_per_volt_N_V",
            "drive.torque_per_volt_Nm_V",
            "drive.limit_V",
            "feedback.kind",
            "feedback.kp_1_s",
            "feedback.kv_V_s_m",
            "sensors.motor_encoder_counts_per_rev",
            "sensors.current_noise_A",
            "sensors.tracker_position_noise_m",
            "sensors.tracker_heading_noise_rad",
            "sensors.tracker_rate_hz",
        ];
        for key in contract {
            assert!(find(key).is_some(), "{key} missing");
        }
        // Every key that names a scene key names one the scene has.
        let n_scene = FROM_SCENE.len();
        let resolved = table().iter().filter(|k| k.scene_key.is_some()).count();
        assert_eq!(resolved, n_scene);
        assert_eq!(
            find("supply.voltage_V").and_then(|k| k.scene_key),
            Some("battery.open_circuit_V")
        );
        assert_eq!(find("motor.resistance_ohm").map(|k| k.unit), Some("ohm"));
    }
}
