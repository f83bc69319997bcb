//! The scene reference is one table (`src/scene/keys.rs`, the blocks' declarations under
//! their sections): validation reads it, docs/scene-reference.md prints it. These tests keep the three in step: every key of the schema has a
//! row, every row is a key the schema takes, every rule refuses what it says it refuses
//! (naming the key), and docs/scene-reference.md holds the table's text.

use std::path::Path;

use agvsim::param::Allowed;
use agvsim::scene::{keys, Scene, SceneError};

/// Dotted paths of every leaf in a TOML tree (arrays are leaves).
fn leaves(prefix: &str, v: &toml::Value, out: &mut Vec<String>) {
    match v {
        toml::Value::Table(t) => {
            for (k, v) in t {
                let p = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                leaves(&p, v, out);
            }
        }
        _ => out.push(prefix.to_string()),
    }
}

#[test]
fn every_schema_key_has_a_row_and_every_row_is_a_key() {
    let tree = toml::Value::try_from(Scene::default()).unwrap();
    let mut keys = vec![];
    leaves("", &tree, &mut keys);
    let table = keys::table();
    let covered = |k: &str| {
        table
            .keys()
            .iter()
            .any(|r| r.key == k || k.starts_with(&format!("{}.", r.key)))
    };
    let missing: Vec<&String> = keys.iter().filter(|k| !covered(k)).collect();
    assert!(missing.is_empty(), "keys without a row: {missing:?}");
    // A row names a key the schema takes (unknown keys are refused when read).
    for (r, _) in table.numbers() {
        // The default (an integer where it is one, which float keys also take), or a
        // value inside the rule for an optional key left out.
        let value = r.get(&Scene::default()).unwrap_or(0.5).to_string();
        let arg = format!("{}={value}", r.key);
        if let Err(SceneError::Override { message, .. }) =
            Scene::from_toml("", Path::new("t.toml"), std::slice::from_ref(&arg))
        {
            panic!("{arg}: {message}")
        }
    }
}

/// A value each rule refuses, if it has one.
fn outside(a: Allowed) -> Option<&'static str> {
    Some(match a {
        Allowed::Positive => "0.0",
        Allowed::Negative => "0.0",
        Allowed::NonNegative => "-1.0",
        Allowed::Finite => "nan",
        Allowed::OpenFraction => "1.0",
        Allowed::Interval { hi, .. } if hi > 100.0 => "1000",
        Allowed::Interval { .. } => "1e9",
        Allowed::NonZeroInteger => "0",
        Allowed::Integer => return None,
    })
}

#[test]
fn every_rule_refuses_a_value_outside_it_naming_the_key() {
    let mut checked = 0;
    for (r, allowed) in keys::table().numbers() {
        let Some(bad) = outside(allowed) else {
            continue;
        };
        // An integer key (controller.duty_*, sim.max_steps): an integer outside.
        let integer = [
            "controller.duty_min",
            "controller.duty_max",
            "sim.max_steps",
        ];
        let bad = match (integer.contains(&r.key.as_str()), bad) {
            (true, "0.0") => "0",
            (true, _) => "1000",
            (false, b) => b,
        };
        let arg = format!("{}={bad}", r.key);
        let err = Scene::from_toml("", Path::new("t.toml"), std::slice::from_ref(&arg))
            .err()
            .unwrap_or_else(|| panic!("{arg} was accepted"));
        let text = err.to_string();
        assert!(
            matches!(err, SceneError::Invalid { ref key, .. } if *key == r.key),
            "{arg}: {text}"
        );
        checked += 1;
    }
    assert!(checked > 80, "only {checked} rules checked");
}

#[test]
fn the_documented_scene_reference_is_the_table() {
    let reference = std::fs::read_to_string("docs/scene-reference.md").unwrap();
    let table = agvsim::scene::keys::markdown();
    assert!(
        reference.contains(&table),
        "docs/scene-reference.md differs from `agvsim keys`; paste its output between the markers"
    );
}
