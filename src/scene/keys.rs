//! Every scene key in one table: the blocks' declared parameters, each under its
//! section. Validation, `--set`, `--vary`, calibration and `agvsim keys` read it, and
//! the README's scene reference is its text (a test keeps them equal).

use std::sync::OnceLock;

use super::{ExpectSpec, Invalid, Scene};
use crate::param::KeyTable;
use crate::sensing::wire::WireParams;

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
            .block(|s| &s.sim, |s| &mut s.sim)
            .block(|s| &s.chassis, |s| &mut s.chassis)
            .block(|s| &s.payload, |s| &mut s.payload)
            .block(|s| &s.castors, |s| &mut s.castors)
            .block(|s| &s.motor, |s| &mut s.motor)
            .block(|s| &s.gearbox, |s| &mut s.gearbox)
            .block(|s| &s.wheel, |s| &mut s.wheel)
            .block(|s| &s.term, |s| &mut s.term)
            .block(|s| &s.tyre, |s| &mut s.tyre)
            .block(|s| &s.floor, |s| &mut s.floor)
            .block(|s| &s.battery, |s| &mut s.battery)
            .block(|s| &s.dcmc, |s| &mut s.dcmc)
            .block(|s| &s.base, |s| &mut s.base)
            .block(|s| &s.sensors, |s| &mut s.sensors)
            .block(|s| &s.controller, |s| &mut s.controller)
            .block(|s| &s.manoeuvre, |s| &mut s.manoeuvre)
            .block(
                |s| &s.controller.swing_away,
                |s| &mut s.controller.swing_away,
            )
            .block(|s| &s.wire, |s| &mut s.wire)
            .block(|s| &s.start, |s| &mut s.start)
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
            // Every length lies on the floor the wire may span: beyond it, positions
            // computed from it overflow.
            let floor = crate::sensing::wire::MAX_FLOOR_M;
            if k.unit == "m" && allowed.admits(v) && v.abs() > floor {
                return Err(Invalid {
                    key: k.key.clone(),
                    value: with_unit(&crate::param::plain_number(v), k.unit),
                    expected: format!(
                        "{}, within {} m (the floor's extent)",
                        expected_with_unit(allowed.expected(), k.unit),
                        crate::param::plain_number(floor)
                    ),
                });
            }
            if !allowed.admits(v) {
                return Err(Invalid {
                    key: k.key.clone(),
                    value: with_unit(&crate::param::plain_number(v), k.unit),
                    expected: expected_with_unit(allowed.expected(), k.unit),
                });
            }
        }
    }
    Ok(())
}

/// The numeric keys whose values are furthest from the thesis machine's, by orders of
/// magnitude (at least two), as `key = value (thesis default)`, at most `n`.
pub fn furthest_from_default(scene: &Scene, n: usize) -> Vec<String> {
    use crate::param::plain_number;
    let defaults = Scene::default();
    let mut far: Vec<(f64, String)> = table()
        .numbers()
        .filter_map(|(k, _)| {
            let (v, d) = (k.get(scene)?, k.get(&defaults)?);
            let orders = if !v.is_finite() {
                f64::INFINITY
            } else if v == d {
                0.0
            } else if d == 0.0 || v == 0.0 {
                (v - d).abs().log10().max(0.0)
            } else {
                (v.abs() / d.abs()).log10().abs()
            };
            (orders >= 2.0).then(|| {
                (
                    orders,
                    format!(
                        "{} = {} (thesis {})",
                        k.key,
                        plain_number(v),
                        plain_number(d)
                    ),
                )
            })
        })
        .collect();
    far.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    far.into_iter().take(n).map(|(_, s)| s).collect()
}

/// A value as typed, with its key's unit when it has one (`-5 kg`).
pub(crate) fn with_unit(value: &str, unit: &str) -> String {
    if unit.is_empty() {
        value.to_string()
    } else {
        format!("{value} {unit}")
    }
}

/// What an error says was expected, in the key's unit when it has one.
pub(crate) fn expected_with_unit(expected: String, unit: &str) -> String {
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
            toml::Value::Array(a) if key == WireParams::points_m.key() => {
                format!("{} points", a.len())
            }
            toml::Value::Array(a) if a.is_empty() => "none".into(),
            _ => String::new(),
        })
}
