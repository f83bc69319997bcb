//! Every scene key in one table: the blocks' declared parameters, each under its
//! section. Validation, `--set`, `--vary`, calibration and `agvsim keys` read it, and
//! the README's scene reference is its text (a test keeps them equal).

use std::sync::OnceLock;

use super::{ExpectSpec, Invalid, Scene};
use crate::param::KeyTable;

/// The scene's keys, section by section in the scene's order.
pub fn table() -> &'static KeyTable<Scene> {
    static TABLE: OnceLock<KeyTable<Scene>> = OnceLock::new();
    TABLE.get_or_init(|| {
        KeyTable::<Scene>::new()
            .other(
                "description",
                || "text".into(),
                "Free text shown in summaries.",
            )
            .section("sim", |s| &s.sim, |s| &mut s.sim)
            .section("chassis", |s| &s.chassis, |s| &mut s.chassis)
            .section("payload", |s| &s.payload, |s| &mut s.payload)
            .section("castors", |s| &s.castors, |s| &mut s.castors)
            .section("motor", |s| &s.motor, |s| &mut s.motor)
            .section("gearbox", |s| &s.gearbox, |s| &mut s.gearbox)
            .section("wheel", |s| &s.wheel, |s| &mut s.wheel)
            .section("tyre", |s| &s.tyre, |s| &mut s.tyre)
            .section("floor", |s| &s.floor, |s| &mut s.floor)
            .section("battery", |s| &s.battery, |s| &mut s.battery)
            .section("dcmc", |s| &s.dcmc, |s| &mut s.dcmc)
            .section("sensors", |s| &s.sensors, |s| &mut s.sensors)
            .section("controller", |s| &s.controller, |s| &mut s.controller)
            .section(
                "controller.swing_away",
                |s| &s.controller.swing_away,
                |s| &mut s.controller.swing_away,
            )
            .section("wire", |s| &s.wire, |s| &mut s.wire)
            .section("start", |s| &s.start, |s| &mut s.start)
            .other(
                "obstacles",
                crate::sensing::bumper::obstacle_tables,
                "Fixed obstacles on the floor; the bumper stops the vehicle on contact.",
            )
            .other(
                "expect",
                ExpectSpec::takes,
                "What a run of the scene as written shows, checked by `run` and the tests.",
            )
    })
}

/// Sets a numeric key of a scene by its dotted name (whole numbers for integer keys);
/// `false` for a name that is not a numeric scene key. The value is not validated (see
/// [`check`]).
pub fn set_number(scene: &mut Scene, key: &str, value: f64) -> bool {
    match table().find(key) {
        Some(k) if k.allowed().is_some() => {
            k.set(scene, value);
            true
        }
        _ => false,
    }
}

/// A numeric key's value in a scene by its dotted name (`None`: not a numeric key, or an
/// optional one left out).
pub fn number(scene: &Scene, key: &str) -> Option<f64> {
    table().find(key).and_then(|k| k.get(scene))
}

/// Checks every numeric key present against its declared rule.
pub fn check(scene: &Scene) -> Result<(), Invalid> {
    for (k, allowed) in table().numbers() {
        if let Some(v) = k.get(scene) {
            if !allowed.admits(v) {
                return Err(Invalid {
                    key: k.key.clone(),
                    value: v.to_string(),
                    expected: expected_with_unit(allowed.expected(), k.unit),
                });
            }
        }
    }
    Ok(())
}

/// What an error says was expected, in the key's unit when it has one.
fn expected_with_unit(expected: String, unit: &str) -> String {
    if unit.is_empty() {
        expected
    } else {
        format!("{expected}, in {unit}")
    }
}

/// The scene reference in Markdown: every key with its unit, the values it allows, its
/// default (the thesis machine) and what it is.
pub fn markdown() -> String {
    let defaults = Scene::default();
    let tree = toml::Value::try_from(&defaults).unwrap_or(toml::Value::Boolean(false));
    let mut out = String::from(
        "| key | unit | allowed | default | meaning |\n| --- | --- | --- | --- | --- |\n",
    );
    for k in table().keys() {
        let default = match (k.allowed(), k.get(&defaults)) {
            (Some(_), Some(v)) => format!("{v}"),
            (Some(_), None) => format!("unset: {}", k.unset),
            (None, _) => other_default(&tree, &k.key),
        };
        out.push_str(&format!(
            "| `{}` | {} | {} | {} | {} |\n",
            k.key,
            k.unit,
            k.takes.text(),
            default,
            k.meaning_line()
        ));
    }
    out
}

/// A key that is not a number, as its default reads in the scene's TOML.
fn other_default(tree: &toml::Value, key: &str) -> String {
    key.split('.')
        .try_fold(tree, |v, part| v.get(part))
        .map_or(String::new(), |v| match v {
            toml::Value::String(t) if t.is_empty() => "(empty)".into(),
            toml::Value::String(t) => format!("`{t}`"),
            toml::Value::Boolean(b) => b.to_string(),
            toml::Value::Array(a) if key == "wire.points_m" => format!("{} points", a.len()),
            toml::Value::Array(a) if a.is_empty() => "none".into(),
            _ => String::new(),
        })
}
