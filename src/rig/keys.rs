//! Every key a rig file may hold, each read from its declaration: the scene's keys a rig
//! states under the same name, the contract's aliases of scene keys, and the keys of the
//! parts of other machines ([`super::blocks`]).

use std::sync::OnceLock;

use super::blocks::{CurrentAmplifier, FallingWeight, Instruments, LinearLoad, PositionLoop};
use crate::model::base_controller::BaseParams;
use crate::model::battery::BatteryParams;
use crate::model::chassis::ChassisParams;
use crate::model::dcmc::DcmcParams;
use crate::model::gearbox::GearboxParams;
use crate::model::motor::MotorParams;
use crate::model::wheel::WheelParams;
use crate::param::{open_closed, Allowed, ParamKey, Sectioned, Takes};

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

/// The contract's names for scene keys it calls otherwise (the supply is the battery, the
/// controller the DCMC): each in its scene key's unit.
pub mod alias {
    use crate::model::battery::BatteryParams;
    use crate::model::dcmc::DcmcParams;
    use crate::param::ParamKey;

    /// `supply.voltage_V`: the battery's open-circuit voltage.
    pub const SUPPLY_VOLTAGE_V: ParamKey =
        ParamKey::new("supply.voltage_V", BatteryParams::open_circuit_v.unit());
    /// `controller.kind`: the DCMC's kind.
    pub const CONTROLLER_KIND: ParamKey = ParamKey::new("controller.kind", DcmcParams::kind.unit());
    /// `controller.gain_V_pct`: the DCMC's forward gain.
    pub const CONTROLLER_GAIN_V_PCT: ParamKey = ParamKey::new(
        "controller.gain_V_pct",
        DcmcParams::forward_gain_v_pct.unit(),
    );
    /// `controller.turn_gain_V_pct`: the DCMC's turn gain.
    pub const CONTROLLER_TURN_GAIN_V_PCT: ParamKey = ParamKey::new(
        "controller.turn_gain_V_pct",
        DcmcParams::turn_gain_v_pct.unit(),
    );
    /// `controller.speed_per_pct_rad_s`: the DCMC's speed set-point per percent.
    pub const CONTROLLER_SPEED_PER_PCT_RAD_S: ParamKey = ParamKey::new(
        "controller.speed_per_pct_rad_s",
        DcmcParams::speed_per_pct_rad_s.unit(),
    );
    /// `controller.kp_V_s_rad`: the DCMC's speed loop's proportional gain.
    pub const CONTROLLER_KP_V_S_RAD: ParamKey =
        ParamKey::new("controller.kp_V_s_rad", DcmcParams::kp_v_s_rad.unit());
    /// `controller.ki_V_rad`: the DCMC's speed loop's integral gain.
    pub const CONTROLLER_KI_V_RAD: ParamKey =
        ParamKey::new("controller.ki_V_rad", DcmcParams::ki_v_rad.unit());
}

/// The rig keys that are scene keys, in the contract's order (a rig is written in it):
/// each the scene's own key, or the contract's [`alias`] of one.
const FROM_SCENE: [SceneKey; 28] = [
    SceneKey::Same(MotorParams::resistance_ohm),
    SceneKey::Same(MotorParams::inductance_h),
    SceneKey::Same(MotorParams::torque_constant_nm_a),
    SceneKey::Same(MotorParams::rotor_inertia_kg_m2),
    SceneKey::Same(MotorParams::viscous_nm_s_rad),
    SceneKey::Same(MotorParams::coulomb_nm),
    SceneKey::Same(GearboxParams::ratio),
    SceneKey::Same(WheelParams::radius_m),
    SceneKey::Same(WheelParams::inertia_kg_m2),
    SceneKey::Renamed(alias::SUPPLY_VOLTAGE_V, BatteryParams::open_circuit_v),
    SceneKey::Renamed(alias::CONTROLLER_KIND, DcmcParams::kind),
    SceneKey::Renamed(alias::CONTROLLER_GAIN_V_PCT, DcmcParams::forward_gain_v_pct),
    SceneKey::Renamed(
        alias::CONTROLLER_TURN_GAIN_V_PCT,
        DcmcParams::turn_gain_v_pct,
    ),
    SceneKey::Renamed(
        alias::CONTROLLER_SPEED_PER_PCT_RAD_S,
        DcmcParams::speed_per_pct_rad_s,
    ),
    SceneKey::Renamed(alias::CONTROLLER_KP_V_S_RAD, DcmcParams::kp_v_s_rad),
    SceneKey::Renamed(alias::CONTROLLER_KI_V_RAD, DcmcParams::ki_v_rad),
    SceneKey::Same(ChassisParams::mass_kg),
    SceneKey::Same(ChassisParams::yaw_inertia_kg_m2),
    SceneKey::Same(ChassisParams::track_width_m),
    SceneKey::Same(ChassisParams::drive_load_fraction),
    // A velocity-commanded base's (rig kind `base`): its base controller's limits and
    // configured geometry, its drivers' speed loops.
    SceneKey::Same(BaseParams::max_linear_m_s),
    SceneKey::Same(BaseParams::max_linear_accel_m_s2),
    SceneKey::Same(BaseParams::max_angular_rad_s),
    SceneKey::Same(BaseParams::max_angular_accel_rad_s2),
    SceneKey::Same(BaseParams::speed_kp_v_s_rad),
    SceneKey::Same(BaseParams::speed_ki_v_rad),
    SceneKey::Same(BaseParams::wheel_radius_m),
    SceneKey::Same(BaseParams::wheel_separation_m),
];

/// A scene key a rig states.
#[derive(Clone, Copy)]
enum SceneKey {
    /// Under the scene's own name.
    Same(ParamKey),
    /// Under the contract's name (rig key, scene key).
    Renamed(ParamKey, ParamKey),
}

impl SceneKey {
    /// (the rig's name, the scene's).
    fn names(self) -> (&'static str, &'static str) {
        match self {
            SceneKey::Same(k) => (k.key(), k.key()),
            SceneKey::Renamed(rig, scene) => (rig.key(), scene.key()),
        }
    }
}

/// Where a rig allows what the scene does not: a zero that means "lumped" or "negligible"
/// (each model accepts it or refuses it with its reason), and a drivetrain whose wheels
/// carry all the weight.
fn rig_rule(key: &str) -> Option<Allowed> {
    if key == MotorParams::inductance_h.key() || key == WheelParams::inertia_kg_m2.key() {
        Some(Allowed::NonNegative)
    } else if key == ChassisParams::drive_load_fraction.key() {
        Some(open_closed(0.0, 1.0))
    } else {
        // A rig may state a name for what the model then checks (`gain`, `p`, `pi`).
        None
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
    block::<LinearLoad>(&mut out);
    block::<CurrentAmplifier>(&mut out);
    block::<PositionLoop>(&mut out);
    block::<Instruments>(&mut out);
    block::<FallingWeight>(&mut out);
    out
}

/// A rig-only block's keys under its declared section.
fn block<B: Sectioned>(out: &mut Vec<RigKey>) {
    let section = B::SECTION;
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
