//! The calibrated scene as a file: the user's own scene text with each fitted key
//! replaced and a comment beside it giving the old value, the fitted value and its
//! standard deviation. Everything else (comments, order, other keys) is left as written.

use super::{CalibrateError, Calibration};
use crate::numtext::{change_pct, estimate, quantity, sig};
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

/// A fitted key's calibrated value as printed (with its deviation where it has one;
/// `None`: no number worth printing, a key at its bound) and, where it is no plain
/// estimate, why the scene keeps its value: the key table's and the HTML report's cells.
pub(crate) fn key_cells(k: &super::KeyFit, unit: &str) -> (Option<String>, Option<String>) {
    let keeps = |why: &str| Some(why.to_string());
    match (k.at_bound, k.std) {
        (None, None) if k.confounded => (
            Some(sig(k.after, 6)),
            keeps("not told apart from the other keys by the recording: held at the scene's value"),
        ),
        (None, Some(std)) if !k.calibrated() => (
            Some(estimate(k.fitted, Some(std), "")),
            keeps("its standard deviation exceeds its value: the scene keeps its value"),
        ),
        (Some(b), _) => (
            None,
            Some(format!(
                "at bound {}: not an estimate; the scene keeps its value (check the belief or the model)",
                quantity(b, 4, unit)
            )),
        ),
        (None, None) => (
            Some(sig(k.after, 6)),
            keeps("undetermined by the recording: the scene keeps its value"),
        ),
        (None, Some(std)) if k.held => (
            Some(estimate(k.after, Some(std), "")),
            keeps("held by its stated belief: the recording determines it less well"),
        ),
        (None, Some(std)) => (
            Some(estimate(k.after, Some(std), "")),
            k.loose_share().map(|share| {
                format!(
                    "loosely determined: its 95 % interval reaches ±{:.0} % of it, so the recording does not tell it to 10 %",
                    100.0 * share
                )
            }),
        ),
    }
}

/// Each fitted key before and after, with its unit and standard deviation.
fn key_table(s: &mut String, c: &Calibration) {
    use std::fmt::Write as _;
    let _ = writeln!(
        s,
        "{:<30} {:<10} {:>12}   calibrated ± 1 std",
        "key", "unit", "scene"
    );
    for k in &c.keys {
        let unit = unit_of_key(&k.key);
        let head = format!("{:<30} {:<10} {:>12}", k.key, unit, sig(k.before, 6));
        let _ = match key_cells(k, unit) {
            (Some(v), Some(note)) => writeln!(s, "{head}   {v:<30} {note}"),
            (Some(v), None) => writeln!(s, "{head}   {v}"),
            (None, Some(note)) => writeln!(s, "{head}   {note}"),
            (None, None) => writeln!(s, "{head}"),
        };
    }
    trade_off_lines(s, c);
    for r in &c.removed {
        let unit = unit_of_key(&r.key);
        let _ = writeln!(
            s,
            "{:<30} {:<10} {:>12}   {:<30} removed: the recording does not support {}",
            r.key,
            unit,
            sig(r.was, 6),
            sig(r.off, 6),
            r.effect.name()
        );
    }
}

/// A line per pair of fitted keys that trade off ([`super::TRADE_OFF_CORRELATION`]):
/// their values are one combination the recording determines, not two findings.
fn trade_off_lines(s: &mut String, c: &Calibration) {
    use std::fmt::Write as _;
    for (i, k) in c.keys.iter().enumerate() {
        for (other, r) in &k.trades_with {
            // Each pair once, in the table's order.
            if c.keys[..i].iter().any(|e| &e.key == other) {
                continue;
            }
            let _ = writeln!(
                s,
                "trade-off: {} and {} (correlation {r:+.3}): the recording shows a combination of them far better than either; a model that lacks something moves both along it (hold one with --set, or record a run that tells them apart)",
                k.key, other
            );
        }
    }
}

/// An effect's value as the key table prints it: an accepted one to the digits its
/// standard deviation supports (the key table's number), others to 4 figures.
fn effect_value(t: &super::EffectTrial, unit: &str) -> String {
    match t.std.filter(|s| t.accepted && s.is_finite() && *s > 0.0) {
        Some(std) => crate::numtext::estimate_value(t.value, std, unit),
        None => quantity(t.value, 4, unit),
    }
}

/// Whether a trial's search failed: the model with the effect contains the model
/// without it (the effect at its off value), so a fit that ends worse than that model by
/// more than the engines may disagree ([`super::search::JUDGE_SHARE`] of the residual) did
/// not converge; its "gain" is no evidence either way. Weighings against absence (kept,
/// removed) compare two fits, and a race is a few iterations' screen: neither is such a
/// search.
pub(crate) fn search_failed(t: &super::EffectTrial) -> bool {
    !t.accepted
        && !t.removed
        && !t.kept
        && !t.raced_only
        && t.against_absence.is_none()
        && -t.rss_reduction_pct > 100.0 * super::search::JUDGE_SHARE
}

/// What became of an effect tried, in words.
pub(crate) fn verdict(t: &super::EffectTrial, unit: &str) -> String {
    let kept = |was: Option<f64>| match was {
        Some(was) => format!("the scene keeps its {}", quantity(was, 4, unit)),
        None => "not added".to_string(),
    };
    if search_failed(t) {
        return format!(
            "the search failed: its fit ended worse than the model without it, which the effect at its off value is (no evidence either way); {}",
            kept(t.scene_value)
        );
    }
    match (t.accepted, t.scene_value, t.at_bound) {
        _ if t.removed => match t.scene_value {
            Some(was) => format!(
                "removed: the scene had it at {}; without it the model fits as well (AIC gain and residual: the effect against none)",
                quantity(was, 4, unit)
            ),
            None => "not supported: accepted in a round, but without it the model fits as well (AIC gain and residual: the effect against none)".to_string(),
        },
        (false, Some(was), _) if t.kept => format!(
            "kept: the recording supports the scene's {} (AIC gain and residual: the effect against none)",
            quantity(was, 4, unit)
        ),
        (true, Some(was), _) => format!(
            "accepted: refined in the scene (the scene had it at {})",
            quantity(was, 4, unit)
        ),
        (true, None, _) => "accepted: added to the scene".to_string(),
        _ if t.unconfirmed == Some(super::Unconfirmed::Simulator) => format!(
            "not confirmed: the reduced base supported it, but the simulator replays the recording no better with it; {}",
            kept(t.scene_value)
        ),
        _ if t.unconfirmed == Some(super::Unconfirmed::Validation) => format!(
            "not confirmed: the recording supported it, but the validation recordings replay no better with it; {}",
            kept(t.scene_value)
        ),
        _ if t.raced_only => format!(
            "not tried in full: its race on the recording's first part gained {} beyond the keys refitted alone; {}",
            if t.shows_no_sign() {
                "next to nothing"
            } else {
                "less than others'"
            },
            kept(t.scene_value)
        ),
        (false, was, Some(b)) => format!(
            "not supported: the key ended at its bound {}; {}",
            quantity(b, 4, unit),
            kept(was)
        ),
        (false, Some(was), None) => format!(
            "the scene's {} stands: refitting it gained too little to count",
            quantity(was, 4, unit)
        ),
        (false, None, None) => "not supported by the recording: not added".to_string(),
    }
}

/// The text `agvsim calibrate` prints: each key before and after, then each fitted output's
/// replay fit on the original and on the calibrated scene.
pub fn render(c: &Calibration) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    key_table(&mut s, c);
    if !c.effects.is_empty() {
        let _ = writeln!(
            s,
            "{:<20} {:<32} {:>14} {:>9} {:>10}  verdict",
            "effect", "key", "value", "AIC gain", "residual"
        );
        for t in &c.effects {
            let unit = unit_of_key(&t.key);
            let verdict = verdict(t, unit);
            // The residual's change; a fit that ended far off (at a bound) on a clean
            // record can multiply it by millions, which says no more than "worse".
            let change = -t.rss_reduction_pct;
            let residual = if change > 999.0 {
                ">+999 %".to_string()
            } else {
                change_pct(change)
            };
            let aic = if t.delta_aic.is_finite() && !search_failed(t) {
                format!("{:.1}", t.delta_aic)
            } else {
                "-".to_string()
            };
            let _ = writeln!(
                s,
                "{:<20} {:<32} {:>14} {:>9} {:>10}  {verdict}",
                t.effect.name(),
                t.key,
                effect_value(t, unit),
                aic,
                residual
            );
        }
        for sw in &c.switches {
            let _ = writeln!(
                s,
                "{:<20} {:<32} {:>11}  set to switch it on",
                sw.effect.name(),
                sw.key,
                sw.value
            );
        }
    }
    if let Some(t) = &c.terms {
        term_lines(&mut s, t);
    }
    if let Some(g) = c.wheel_geometry() {
        let _ = writeln!(
            s,
            "wheel geometry: effective radius left {}, right {}, track {} (configured: radius {}, separation {}); UMBmark Ed = {} (right/left diameter), Eb = {} (track/configured)",
            estimate(g.radii_m[0].0, g.radii_m[0].1, "m"),
            estimate(g.radii_m[1].0, g.radii_m[1].1, "m"),
            estimate(g.track_m.0, g.track_m.1, "m"),
            quantity(g.configured_m.0, 6, "m"),
            quantity(g.configured_m.1, 6, "m"),
            sig(g.ed(), 6),
            sig(g.eb(), 6)
        );
        let m = g.controller_multipliers();
        let _ = writeln!(
            s,
            "diff_drive_controller: wheel_separation_multiplier: {}, left_wheel_radius_multiplier: {}, right_wheel_radius_multiplier: {} (of the configured separation and radius; where its file has multipliers already, times those)",
            sig(m.wheel_separation, 6),
            sig(m.left_wheel_radius, 6),
            sig(m.right_wheel_radius, 6)
        );
    }
    let _ = writeln!(
        s,
        "replay fit, %        {:>10} {:>12}",
        "original", "calibrated"
    );
    for name in &c.outputs {
        let (Some(b), Some(a)) = (c.before.output(name), c.after.output(name)) else {
            continue;
        };
        let _ = writeln!(s, "  {:<28} {:>8.1} {:>12.1}", name, b.fit_pct, a.fit_pct);
    }
    for l in &c.left_out {
        let _ = writeln!(s, "  {:<28} left out: {}", l.output, l.why);
    }
    s
}

/// The term search's lines: what was screened, each form fitted with its verdict, and
/// the accepted one in words.
fn term_lines(s: &mut String, t: &super::terms::TermSearch) {
    use std::fmt::Write as _;
    let _ = writeln!(
        s,
        "terms outside the vocabulary: {} forms screened through the simulator; {}",
        t.screened,
        if t.trials.is_empty() {
            "none removed enough of the held-out residual to be fitted"
        } else {
            "fitted:"
        }
    );
    for trial in &t.trials {
        let r = &trial.row;
        let verdict = if trial.accepted {
            "accepted: added to the scene ([term])".to_string()
        } else if let Some(effect) = trial.outranked_by {
            format!("passed the rules, but the vocabulary's {effect} explains the residual nearly as well (a term needs twice its AIC gain): not added")
        } else if trial.wrong_sign {
            "not supported: a coefficient took the sign the physics cannot have".to_string()
        } else if r.significant {
            "passed the rules, but another order of its family fits the recording better: not added"
                .to_string()
        } else if r.at_bound {
            "not supported: a coefficient ended at its bound".to_string()
        } else if r.undetermined {
            "not supported: the recording does not determine its coefficients".to_string()
        } else {
            "not supported by the recording: not added".to_string()
        };
        let _ = writeln!(
            s,
            "  {:<24} {:>9.1} AIC gain {:>8.1} % residual {:>7.1} % held out  {verdict}",
            r.name, r.delta_aic, -r.rss_reduction_pct, -r.held_out_reduction_pct
        );
        let coefficients: Vec<String> = trial
            .coefficients
            .iter()
            .map(|(k, v, sd)| format!("{k} = {}", estimate(*v, *sd, unit_of_key(k))))
            .chain(
                trial
                    .setting
                    .iter()
                    .map(|(k, v)| format!("{k} = {}", sig(*v, 4))),
            )
            .collect();
        let _ = writeln!(s, "    {}", coefficients.join(", "));
        if trial.accepted {
            let _ = writeln!(s, "    {}", crate::diagnose::terms::describe(r));
        }
    }
}

/// Mean replay fit over the calibration's outputs, %.
pub fn mean_fit(r: &crate::replay::Replay, outputs: &[String]) -> f64 {
    let fits: Vec<f64> = outputs
        .iter()
        .filter_map(|n| r.output(n))
        .map(|o| o.fit_pct)
        .filter(|f| f.is_finite())
        .collect();
    fits.iter().sum::<f64>() / fits.len().max(1) as f64
}

/// The wheel geometry as the JSON carries it: radii and track with their deviations,
/// the configured values, UMBmark's figures and `diff_drive_controller`'s multipliers.
fn geometry_json(g: &super::WheelGeometry) -> serde_json::Value {
    let m = g.controller_multipliers();
    serde_json::json!({
        "left_radius_m": g.radii_m[0].0, "left_radius_std_m": g.radii_m[0].1,
        "right_radius_m": g.radii_m[1].0, "right_radius_std_m": g.radii_m[1].1,
        "track_m": g.track_m.0, "track_std_m": g.track_m.1,
        "configured_radius_m": g.configured_m.0, "configured_separation_m": g.configured_m.1,
        "umbmark_ed": g.ed(), "umbmark_eb": g.eb(),
        "diff_drive_controller": {
            "wheel_separation_multiplier": m.wheel_separation,
            "left_wheel_radius_multiplier": m.left_wheel_radius,
            "right_wheel_radius_multiplier": m.right_wheel_radius,
        },
    })
}

/// The calibration as JSON: each key (before, after, std, at bound) and each fitted
/// output's replay fit on the original and the calibrated scene.
pub fn json(c: &Calibration, scene: &str, recording: &str) -> serde_json::Value {
    let keys: Vec<serde_json::Value> = c
        .keys
        .iter()
        .map(|k| {
            serde_json::json!({
                "key": k.key,
                "scene": k.before,
                "calibrated": k.after,
                "fitted": k.fitted,
                "std": k.std,
                "at_bound": k.at_bound,
                "held_by_belief": k.held,
                "trades_with": k.trades_with.iter().map(|(key, r)| serde_json::json!({"key": key, "correlation": r})).collect::<Vec<_>>(),
                "confounded": k.confounded,
                "estimate": k.calibrated(),
                "loosely_determined": k.loose_share().is_some(),
            })
        })
        .collect();
    let fits: serde_json::Map<String, serde_json::Value> = c
        .outputs
        .iter()
        .filter_map(|n| {
            let (b, a) = (c.before.output(n)?, c.after.output(n)?);
            Some((
                n.clone(),
                serde_json::json!({"original_pct": b.fit_pct, "calibrated_pct": a.fit_pct}),
            ))
        })
        .collect();
    let effects: Vec<serde_json::Value> = c
        .effects
        .iter()
        .map(|t| {
            serde_json::json!({
                "name": t.effect.name(),
                "key": t.key,
                "value": t.value,
                "std": t.std,
                "at_bound": t.at_bound,
                "delta_aic": t.delta_aic,
                "rss_reduction_pct": t.rss_reduction_pct,
                "accepted": t.accepted,
                "removed": t.removed,
                "raced_only": t.raced_only,
                "unconfirmed": t.unconfirmed.map(|u| match u {
                    super::Unconfirmed::Simulator => "simulator",
                    super::Unconfirmed::Validation => "validation",
                }),
                "scene_value": t.scene_value,
            })
        })
        .collect();
    let switches: Vec<serde_json::Value> = c
        .switches
        .iter()
        .map(|s| serde_json::json!({"effect": s.effect.name(), "key": s.key, "value": s.value}))
        .collect();
    serde_json::json!({
        "scene": scene,
        "recording": recording,
        "keys": keys,
        "effects": effects,
        "switches": switches,
        "removed": c.removed.iter().map(|r| serde_json::json!({"effect": r.effect.name(), "key": r.key, "was": r.was, "now": r.off})).collect::<Vec<_>>(),
        "replay_fit": fits,
        "left_out": c.left_out,
        "mean_fit_pct": {"original": mean_fit(&c.before, &c.outputs), "calibrated": mean_fit(&c.after, &c.outputs)},
        "wheel_geometry": c.wheel_geometry().map(|g| geometry_json(&g)),
        "iterations": c.iterations,
        "terms": c.terms.as_ref().map(|t| serde_json::json!({
            "screened": t.screened,
            "fitted": t.trials.iter().map(|trial| serde_json::json!({
                "name": trial.row.name,
                "outside_vocabulary": true,
                "params": trial.row.params.iter().cloned().collect::<serde_json::Map<String, serde_json::Value>>(),
                "std": trial.row.std,
                "keys": trial.coefficients.iter().map(|(k, v, sd)| serde_json::json!({"key": k, "value": v, "std": sd})).collect::<Vec<_>>(),
                "setting": trial.setting.as_ref().map(|(k, v)| serde_json::json!({"key": k, "value": v})),
                "delta_aic": trial.row.delta_aic,
                "rss_reduction_pct": trial.row.rss_reduction_pct,
                "held_out_reduction_pct": trial.row.held_out_reduction_pct,
                "at_bound": trial.row.at_bound,
                "undetermined": trial.row.undetermined,
                "wrong_sign": trial.wrong_sign,
                "accepted": trial.accepted,
            })).collect::<Vec<_>>(),
        })),
    })
}

/// `DIR/OUTPUT_calibrated.svg` per fitted output: measured (wide, pale) under the
/// original scene's and the calibrated scene's replays.
pub fn write_plots(
    dir: &std::path::Path,
    c: &Calibration,
    rec_name: &str,
) -> std::io::Result<Vec<std::path::PathBuf>> {
    crate::plot::write_figures(dir, &figures(c, rec_name))
}

/// The figures of [`write_plots`]: per fitted output, the recording replayed on the
/// original and on the calibrated scene.
pub fn figures(c: &Calibration, rec_name: &str) -> Vec<crate::plot::Figure> {
    use crate::plot::{svg, Figure, Series, Style};
    let mut files = vec![];
    for name in &c.outputs {
        let (Some(b), Some(a)) = (c.before.output(name), c.after.output(name)) else {
            continue;
        };
        let (t, y) = crate::plot::measured_points(&c.before.t_s, &b.measured);
        let orig = format!("original scene ({:.1} %)", b.fit_pct);
        let cal = format!("calibrated scene ({:.1} %)", a.fit_pct);
        let doc = svg(
            &format!("{name}: {rec_name} replayed on the original and the calibrated scene"),
            "t (s)",
            name,
            &[
                Series::line("measured", &t, &y, "#555").with_style(Style::Measured),
                Series::line(&orig, &c.before.t_s, &b.simulated, "#d08000"),
                Series::line(&cal, &c.after.t_s, &a.simulated, "#1f5fbf"),
            ],
            None,
        );
        files.push(Figure {
            file: format!("{name}_calibrated.svg"),
            svg: doc,
        });
    }
    files.extend(path_figure(c, rec_name));
    files
}

/// The path seen from above (x against y, to scale): measured, replayed on the original
/// scene and on the calibrated one, where the recording has a pose that was fitted.
fn path_figure(c: &Calibration, rec_name: &str) -> Option<crate::plot::Figure> {
    use crate::plot::{Figure, Plot, Series, Style};
    let (bx, by) = (c.before.output("x_m")?, c.before.output("y_m")?);
    let (ax, ay) = (c.after.output("x_m")?, c.after.output("y_m")?);
    let (mx, my): (Vec<f64>, Vec<f64>) = bx
        .measured
        .iter()
        .zip(&by.measured)
        .filter_map(|(x, y)| Some(((*x)?, (*y)?)))
        .unzip();
    let orig = format!(
        "original scene (x {:.1} %, y {:.1} %)",
        bx.fit_pct, by.fit_pct
    );
    let cal = format!(
        "calibrated scene (x {:.1} %, y {:.1} %)",
        ax.fit_pct, ay.fit_pct
    );
    let title = format!("path of {rec_name} seen from above, to scale: measured and replayed");
    let series = [
        Series::line("measured", &mx, &my, "#555").with_style(Style::Measured),
        Series::line(&orig, &bx.simulated, &by.simulated, "#d08000"),
        Series::line(&cal, &ax.simulated, &ay.simulated, "#1f5fbf"),
    ];
    let svg = Plot {
        title: &title,
        x_label: "x (m)",
        y_label: "y (m)",
        series: &series,
        band: None,
        flags: None,
        empty_note: "no pose measured",
    }
    .render_to_scale();
    Some(Figure {
        file: "path_calibrated.svg".into(),
        svg,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ident::effects::Effect;

    fn trial(rss_reduction_pct: f64) -> super::super::EffectTrial {
        super::super::EffectTrial {
            effect: Effect::Backlash,
            key: "gearbox.backlash_rad".into(),
            value: 0.01,
            std: None,
            at_bound: None,
            delta_aic: -21065.8,
            rss_reduction_pct,
            accepted: false,
            removed: false,
            raced_only: false,
            unconfirmed: None,
            kept: false,
            against_absence: None,
            accepted_as: None,
            scene_value: None,
        }
    }

    #[test]
    fn an_estimate_known_to_no_better_than_ten_per_cent_is_said_to_be_loosely_determined() {
        // The example bag's yaw inertia: 2.61 +- 0.35, a 95 % interval of +-27 %.
        let k = super::super::KeyFit {
            key: "chassis.yaw_inertia_kg_m2".into(),
            before: 3.0,
            after: 2.61,
            fitted: 2.61,
            std: Some(0.35),
            at_bound: None,
            held: false,
            confounded: false,
            trades_with: vec![],
        };
        let (_, note) = key_cells(&k, "kg m^2");
        let note = note.expect("a note");
        assert!(
            note.starts_with("loosely determined") && note.contains("±27 %"),
            "{note}"
        );
        // Known to 2 % (a 95 % interval of +-4 %): a plain estimate.
        let tight = super::super::KeyFit {
            std: Some(0.05),
            ..k.clone()
        };
        assert_eq!(key_cells(&tight, "kg m^2").1, None);
        // No estimate (its deviation beyond its value) is not called loosely determined.
        let none = super::super::KeyFit {
            std: Some(3.0),
            ..k
        };
        assert_eq!(none.loose_share(), None);
    }

    #[test]
    fn a_fit_that_ends_worse_than_without_its_effect_is_a_failed_search_not_evidence() {
        // The residual multiplied: the nested model (the effect off) fits better.
        let failed = trial(-5000.0);
        assert!(search_failed(&failed));
        assert!(verdict(&failed, "rad").starts_with("the search failed"));
        // Within the engines' disagreement (a tenth of the residual): an ordinary verdict.
        let close = trial(-5.0);
        assert!(!search_failed(&close));
        assert_eq!(
            verdict(&close, "rad"),
            "not supported by the recording: not added"
        );
        // A race (a few iterations' screen) or a weighing against absence is no search.
        assert!(!search_failed(&super::super::EffectTrial {
            raced_only: true,
            ..trial(-5000.0)
        }));
        assert!(!search_failed(&super::super::EffectTrial {
            removed: true,
            ..trial(-5000.0)
        }));
    }
}
