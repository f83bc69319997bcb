//! The calibration as the console prints it: the keys with their deviations and notes,
//! the trade-offs, each effect's verdict, the terms outside the vocabulary, the fits.

use crate::calibrate::Calibration;
use crate::numtext::{change_pct, estimate, quantity, sig};
use crate::rig::keys::unit_of_key;

/// A fitted key's calibrated value as printed (with its deviation where it has one;
/// `None`: no number worth printing, a key at its bound) and, where it is no plain
/// estimate, why the scene keeps its value: the key table's and the HTML report's cells.
pub(crate) fn key_cells(
    k: &crate::calibrate::KeyFit,
    unit: &str,
) -> (Option<String>, Option<String>) {
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
    held_lines(s, c);
    if c.residual_correlation_rows > 1 {
        let _ = writeln!(
            s,
            "standard deviations (± 1 std, a 68 % interval where the model is right): from the spread of the scores of {:.3} s blocks of the residual (the length, up to a twentieth of the recording, that gave the widest intervals), not from a white-noise assumption",
            c.residual_correlation_s
        );
    }
    model_check_line(s, c);
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

/// A line per pair of fitted keys that trade off ([`crate::calibrate::TRADE_OFF_CORRELATION`]):
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

/// Whether the calibrated model leaves a residual that follows a signal it knows
/// ([`crate::calibrate::adequacy`]): the intervals' condition, said with its numbers.
fn model_check_line(s: &mut String, c: &Calibration) {
    use std::fmt::Write as _;
    let Some(l) = c.residual_links.first() else {
        return;
    };
    let link = l.describe();
    let _ = if l.says_model_wrong() {
        writeln!(
            s,
            "MODEL CHECK FAILED: {link}: the calibrated model does not reproduce the recording down to its noise (physics it lacks, or where its fitting model differs from the machine); the intervals assume a right model and are not to be trusted"
        )
    } else {
        writeln!(
            s,
            "model check: no output's residual follows a signal the model knows ({:.0} % of the way to saying the model is wrong at the strongest: {link})",
            100.0 * l.strength()
        )
    };
}

/// A line per estimate whose interval holds only given a key the recording could not tell
/// apart ([`crate::calibrate::KeyFit::conditional`]): how far 10 % of the held key moves it.
fn held_lines(s: &mut String, c: &Calibration) {
    use std::fmt::Write as _;
    for k in c.keys.iter().filter(|k| k.calibrated() && k.conditional()) {
        let unit = unit_of_key(&k.key);
        let std = k.std.unwrap_or(f64::NAN);
        for (held, shift) in k.moves_with_held.iter().filter(|(_, d)| d.abs() > std) {
            let _ = writeln!(
                s,
                "given {held} (held): {}'s ± is the recording's at the held value only; {:.0} % more of {held} moves it by {} ({:.1} of its standard deviation)",
                k.key,
                100.0 * crate::calibrate::HELD_STEP_SHARE,
                quantity(*shift, 3, unit),
                shift.abs() / std
            );
        }
    }
}

/// An effect's value as the key table prints it: an accepted one to the digits its
/// standard deviation supports (the key table's number), others to 4 figures.
fn effect_value(t: &crate::calibrate::EffectTrial, unit: &str) -> String {
    match t.std.filter(|s| t.accepted && s.is_finite() && *s > 0.0) {
        Some(std) => crate::numtext::estimate_value(t.value, std, unit),
        None => quantity(t.value, 4, unit),
    }
}

/// Whether a trial's search failed: the model with the effect contains the model
/// without it (the effect at its off value), so a fit that ends worse than that model by
/// more than the engines may disagree ([`crate::calibrate::search::JUDGE_SHARE`] of the residual) did
/// not converge; its "gain" is no evidence either way. Weighings against absence (kept,
/// removed) compare two fits, and a race is a few iterations' screen: neither is such a
/// search.
pub(crate) fn search_failed(t: &crate::calibrate::EffectTrial) -> bool {
    !t.accepted
        && !t.removed
        && !t.kept
        && !t.raced_only
        && t.against_absence.is_none()
        && -t.rss_reduction_pct > 100.0 * crate::calibrate::search::JUDGE_SHARE
}

/// What became of an effect tried, in words.
pub(crate) fn verdict(t: &crate::calibrate::EffectTrial, unit: &str) -> String {
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
        _ if t.unconfirmed == Some(crate::calibrate::Unconfirmed::Simulator) => format!(
            "not confirmed: the reduced base supported it, but the simulator replays the recording no better with it; {}",
            kept(t.scene_value)
        ),
        _ if t.unconfirmed == Some(crate::calibrate::Unconfirmed::Validation) => format!(
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
fn term_lines(s: &mut String, t: &crate::calibrate::terms::TermSearch) {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ident::effects::Effect;

    fn trial(rss_reduction_pct: f64) -> crate::calibrate::EffectTrial {
        crate::calibrate::EffectTrial {
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
        let k = crate::calibrate::KeyFit {
            key: "chassis.yaw_inertia_kg_m2".into(),
            before: 3.0,
            after: 2.61,
            fitted: 2.61,
            std: Some(0.35),
            at_bound: None,
            held: false,
            confounded: false,
            trades_with: vec![],
            moves_with_held: vec![],
        };
        let (_, note) = key_cells(&k, "kg m^2");
        let note = note.expect("a note");
        assert!(
            note.starts_with("loosely determined") && note.contains("±27 %"),
            "{note}"
        );
        // Known to 2 % (a 95 % interval of +-4 %): a plain estimate.
        let tight = crate::calibrate::KeyFit {
            std: Some(0.05),
            ..k.clone()
        };
        assert_eq!(key_cells(&tight, "kg m^2").1, None);
        // No estimate (its deviation beyond its value) is not called loosely determined.
        let none = crate::calibrate::KeyFit {
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
        assert!(!search_failed(&crate::calibrate::EffectTrial {
            raced_only: true,
            ..trial(-5000.0)
        }));
        assert!(!search_failed(&crate::calibrate::EffectTrial {
            removed: true,
            ..trial(-5000.0)
        }));
    }
}
