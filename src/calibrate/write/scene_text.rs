//! The calibrated scene as a file: the user's own scene text with each fitted key
//! replaced and a comment beside it giving the old value, the fitted value and its
//! standard deviation. Everything else (comments, order, other keys) is left as written.

use crate::calibrate::{CalibrateError, Calibration};
use crate::numtext::{estimate, quantity};
use crate::rig::keys::unit_of_key;

/// Six significant digits, for the comments: more than any fit determines. The keys
/// themselves are written in full, so that the written scene replays exactly as the
/// calibrated one did (a lifted wheel rattling in its gear play replays differently at
/// the sixth digit of its keys).
fn rounded(v: f64) -> f64 {
    format!("{v:.5e}").parse().unwrap_or(v)
}

/// The table at `path` in the document, made (implicit) where the scene left it out.
fn table_at<'d>(
    doc: &'d mut toml_edit::DocumentMut,
    path: &[&str],
    key: &str,
) -> Result<&'d mut toml_edit::Table, CalibrateError> {
    let mut table = doc.as_table_mut();
    for p in path {
        if !table.contains_key(p) {
            let mut t = toml_edit::Table::new();
            t.set_implicit(true);
            table.insert(p, toml_edit::Item::Table(t));
        }
        table = table[p].as_table_mut().ok_or_else(|| {
            CalibrateError::Key(format!("`{key}`: `{p}` is not a table in the scene"))
        })?;
    }
    Ok(table)
}

/// Writes `KEY = VALUE` (VALUE as `--set` text) into the document with a comment.
fn set_text(
    doc: &mut toml_edit::DocumentMut,
    key: &str,
    value: &str,
    comment: impl Fn(&str) -> String,
) -> Result<(), CalibrateError> {
    let parts: Vec<&str> = key.split('.').collect();
    let (leaf, path) = parts.split_last().expect("a key has a name");
    let table = table_at(doc, path, key)?;
    let was = table
        .get(leaf)
        .and_then(|v| v.as_value())
        .map_or("not in the file".to_string(), |v| {
            v.clone().decorated("", "").to_string()
        });
    let mut item: toml_edit::Value = match crate::scene::parse_value(value) {
        toml::Value::String(t) => t.into(),
        toml::Value::Float(f) => f.into(),
        toml::Value::Integer(i) => i.into(),
        toml::Value::Boolean(b) => b.into(),
        other => other.to_string().into(),
    };
    item.decor_mut()
        .set_suffix(format!("  # {}", comment(&was)));
    table.insert(leaf, toml_edit::Item::Value(item));
    Ok(())
}

/// The original scene text as calibrated: the `--set` values the calibration ran with
/// (`overrides`), the fitted keys (those not at a bound) and the keys that switch the
/// accepted effects on, each with a comment. It loads as the calibrated scene.
pub fn calibrated_text(
    original: &str,
    c: &Calibration,
    source: &str,
    overrides: &[String],
) -> Result<String, CalibrateError> {
    let mut doc: toml_edit::DocumentMut = original
        .parse()
        .map_err(|e| CalibrateError::Key(format!("the scene cannot be edited: {e}")))?;
    for o in overrides {
        let (key, value) = o
            .split_once('=')
            .ok_or_else(|| CalibrateError::Key(format!("--set {o}: expected KEY=VALUE")))?;
        set_text(&mut doc, key.trim(), value.trim(), |was| {
            format!("set by --set for the calibration against {source} (was {was})")
        })?;
    }
    // A key at a bound, undetermined, or less certain than its value is no estimate: the
    // scene keeps its value, and says why where the fit had one.
    for k in c.keys.iter().filter(|k| !k.calibrated()) {
        let unit = unit_of_key(&k.key);
        let why = match (k.std, k.at_bound) {
            (_, Some(b)) => format!(
                "the fit ended at the bound {} of its search, which is no estimate",
                quantity(b, 4, unit)
            ),
            (Some(std), None) => format!(
                "fitted {}, its standard deviation exceeds its value, so the recording cannot tell it from zero",
                estimate(k.fitted, Some(std), unit)
            ),
            (None, None) if k.confounded => {
                "the recording cannot tell it apart from the other keys (it shows a combination of them)".to_string()
            }
            (None, None) => "the recording does not determine it".to_string(),
        };
        set_text(&mut doc, &k.key, &format!("{:e}", k.before), |_| {
            format!("not calibrated against {source}: {why}; kept")
        })?;
    }
    for r in &c.removed {
        let unit = unit_of_key(&r.key);
        set_text(&mut doc, &r.key, &format!("{:e}", r.off), |_| {
            format!(
                "calibrated against {source}: {} removed, the recording does not support it (was {})",
                r.effect.name(),
                quantity(r.was, 6, unit)
            )
        })?;
    }
    for k in c.keys.iter().filter(|k| k.calibrated()) {
        let Some(std) = k.std else { continue };
        let held = if k.held {
            " (held by its stated belief: the recording determines it less well)"
        } else {
            ""
        };
        let unit = unit_of_key(&k.key);
        set_text(&mut doc, &k.key, &format!("{:e}", k.after), |_| {
            format!(
                "calibrated against {source}: was {}, fitted {}{held}",
                quantity(k.before, 6, unit),
                estimate(rounded(k.after), Some(std), unit)
            )
        })?;
    }
    for sw in &c.switches {
        set_text(&mut doc, &sw.key, &sw.value, |was| {
            format!(
                "calibrated against {source}: set to switch on {} (was {was})",
                sw.effect.name()
            )
        })?;
    }
    // An accepted term's order (exponent, periods per turn, time constant): its
    // coefficients are among the fitted keys.
    if let Some(t) = c.terms.as_ref().and_then(|t| t.accepted()) {
        // A refined thermal time constant is a fitted key, written with them.
        let setting = t
            .setting
            .as_ref()
            .filter(|(k, _)| !c.keys.iter().any(|f| f.key == *k));
        if let Some((key, _)) = setting {
            let v = crate::calibrate::keys::get(&c.scene, key)?;
            set_text(&mut doc, key, &format!("{v:e}"), |was| {
                format!(
                    "calibrated against {source}: the order the term search chose for {} (was {was})",
                    t.row.name
                )
            })?;
        }
    }
    let mut text = format!(
        "# Calibrated by `agvsim calibrate` against {source}; the fitted keys carry a `# calibrated` comment.\n"
    );
    describe_as_calibrated(&mut doc, source);
    if let Some(claims) = drop_claims(&mut doc) {
        text.push_str(&claims);
    }
    text.push_str(&doc.to_string());
    Ok(text)
}

/// The scene's description, said to be the original's: it described runs of the scene
/// before its keys changed.
fn describe_as_calibrated(doc: &mut toml_edit::DocumentMut, source: &str) {
    let old = doc
        .get("description")
        .and_then(|d| d.as_str())
        .map(str::to_string);
    let new = match old {
        Some(old) => format!(
            "Calibrated against {source}. Before calibration this scene was described as: {old}"
        ),
        None => format!("Calibrated against {source}."),
    };
    doc["description"] = toml_edit::value(new);
}

/// Takes the `[expect]` table out of the scene and returns it as comment lines saying why:
/// its claims described runs of the scene before calibration, and the calibrated keys
/// change those runs, so `agvsim run` must not check them as the new scene's. `None`
/// when the scene made no claims.
fn drop_claims(doc: &mut toml_edit::DocumentMut) -> Option<String> {
    let table = doc.remove("expect")?;
    let mut claims = toml_edit::DocumentMut::new();
    claims.insert("expect", table);
    let mut text = String::from(
        "# The original scene's [expect] claims are left out: they described its runs before\n\
         # calibration, and the calibrated keys change those runs. Run this scene and state\n\
         # what its runs show. They were:\n",
    );
    for line in claims.to_string().lines().filter(|l| !l.trim().is_empty()) {
        text.push_str("#   ");
        text.push_str(line.trim_start_matches('#').trim_start());
        text.push('\n');
    }
    text.push('\n');
    Some(text)
}
