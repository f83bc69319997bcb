//! Writing a rig: as rig TOML, and as the scene of its machine.

use super::{keys, Rig, RigKind, Stated, UNCERTAINTY_SECTION};
use crate::model::chassis::ChassisParams;
use crate::model::gearbox::GearboxParams;
use crate::model::motor::MotorParams;

impl Rig {
    /// The rig as TOML text: `rig`, `motion`, then each section in the key table's order.
    pub fn to_toml(&self) -> String {
        let mut doc = toml_edit::DocumentMut::new();
        doc["rig"] = toml_edit::value(self.rig.as_str());
        if let Some(m) = &self.motion {
            doc["motion"] = toml_edit::value(m.as_str());
        }
        for (k, v) in self.stated() {
            let (section, key) = k.key.split_once('.').unwrap_or(("", &k.key));
            if doc.get(section).is_none() {
                doc[section] = toml_edit::table();
            }
            doc[section][key] = match v {
                Stated::Number(x) => toml_edit::value(*x),
                Stated::Text(t) => toml_edit::value(t.as_str()),
            };
        }
        if !self.uncertainty_pct.is_empty() {
            let table = keys::table();
            let mut t = toml_edit::Table::new();
            for (o, pct) in &self.uncertainty_pct {
                t.insert(&table[*o].key, toml_edit::value(*pct));
            }
            doc[UNCERTAINTY_SECTION] = toml_edit::Item::Table(t);
        }
        doc.to_string()
    }

    /// A scene of this machine for the simulator (`calibrate`, `replay`, `run`), when it is
    /// a vehicle: every numeric value the scene has a key for, under that key, with the
    /// rig's `[uncertainty_pct]`, at full fidelity; no gear play and no Coulomb friction
    /// (a rig is the machine as believed, its effects for calibrate to find). A rig whose
    /// drive wheels carry every load puts the centre of gravity over their axle. What a
    /// rig does not state is the scene's default (the thesis's vehicle): the comments say
    /// so.
    pub fn scene_toml(&self, description: &str) -> Option<String> {
        if self.rig != RigKind::Vehicle {
            return None;
        }
        let mut doc = toml_edit::DocumentMut::new();
        doc["description"] = toml_edit::value(description);
        doc["sim"] = toml_edit::table();
        doc["sim"]["fidelity"] = toml_edit::value("full");
        let mut put = |key: &str, v: toml_edit::Item| {
            let (section, name) = key.split_once('.').unwrap_or(("", key));
            if doc.get(section).is_none() {
                doc[section] = toml_edit::table();
            }
            doc[section][name] = v;
        };
        put(MotorParams::coulomb_nm.key(), toml_edit::value(0.0));
        put(GearboxParams::backlash_rad.key(), toml_edit::value(0.0));
        for (k, v) in self.stated() {
            if let (Some(scene_key), Stated::Number(x)) = (k.scene_key, v) {
                put(scene_key, toml_edit::value(*x));
            }
        }
        if self.get(ChassisParams::drive_load_fraction.key()) == Some(1.0) {
            put(ChassisParams::cg_x_m.key(), toml_edit::value(0.0));
        }
        if !self.uncertainty_pct.is_empty() {
            let table = keys::table();
            let mut t = toml_edit::Table::new();
            for (o, pct) in &self.uncertainty_pct {
                if let Some(scene_key) = table[*o].scene_key {
                    t.insert(scene_key, toml_edit::value(*pct));
                }
            }
            doc["uncertainty_pct"] = toml_edit::Item::Table(t);
        }
        Some(doc.to_string())
    }
}
