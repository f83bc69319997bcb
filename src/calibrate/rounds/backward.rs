//! The backward pass: every effect in the model weighed against its absence, and taken
//! out where the recording does not support it.

use rayon::prelude::*;

use super::Rounds;
use crate::calibrate::search::{Presence, Problem};
use crate::calibrate::{effects, CalibrateError, EffectTrial, Removal};
use crate::diagnose::evidence::Gain;
use crate::ident::effects::Effect;

/// The backward pass: each effect the model has weighed against its absence, the least
/// supported removed, until every one left is supported. Returns the effects removed.
pub(super) fn backward(
    problem: &Problem,
    r: &mut Rounds,
    mut undecided: Vec<Effect>,
    scenes_own: &[Effect],
    driven: effects::Driven,
    progress: &dyn Fn(&str),
) -> Result<Vec<Effect>, CalibrateError> {
    let mut removed = vec![];
    while !undecided.is_empty() {
        let names: Vec<&str> = undecided.iter().map(|e| e.name()).collect();
        progress(&format!(
            "the model's effects: weighing {} against their absence",
            names.join(", ")
        ));
        let homes = undecided
            .iter()
            .map(|&e| effects::home(e, &r.stage.scene, driven))
            .collect::<Result<Vec<_>, _>>()?;
        let weighed = homes
            .par_iter()
            .map(|h| problem.weigh_present(&r.stage, h))
            .collect::<Result<Vec<_>, _>>()?;
        for w in &weighed {
            r.iterations += w.off.fit.iterations;
        }
        let weakest = (0..weighed.len())
            .filter(|&i| !supports(&weighed[i].gain))
            .min_by(|&a, &b| {
                weighed[a]
                    .gain
                    .delta_aic
                    .total_cmp(&weighed[b].gain.delta_aic)
            });
        let Some(weakest) = weakest else {
            // Every one left is supported.
            record_kept(r, &weighed, &homes, scenes_own);
            break;
        };
        let home = &homes[weakest];
        let w = weighed
            .into_iter()
            .nth(weakest)
            .expect("an index of the list");
        let was = crate::calibrate::keys::get(&r.stage.scene, home.key)?;
        progress(&format!(
            "the model's effects: {} removed ({} = {} is not supported by the recording; AIC gain {:.0} against its absence)",
            home.effect.name(),
            home.key,
            crate::numtext::quantity(was, 4, crate::rig::keys::unit_key_or_name(home.key)),
            w.gain.delta_aic
        ));
        take_out(problem, r, home, was, &w.gain, scenes_own)?;
        removed.push(home.effect);
        undecided.retain(|&e| e != home.effect);
        r.stage = problem.polished(w.off)?;
        r.iterations += r.stage.fit.iterations;
    }
    Ok(removed)
}

/// Records the effects the backward pass keeps, each supported against its absence:
/// one the scene had and this calibration did not accept is reported as weighed, the
/// scene's strength against none.
pub(super) fn record_kept(
    r: &mut Rounds,
    weighed: &[Presence],
    homes: &[effects::Home],
    scenes_own: &[Effect],
) {
    for (w, h) in weighed.iter().zip(homes) {
        let scene_value = (h.in_scene && scenes_own.contains(&h.effect)).then_some(h.start);
        if let Some(t) = r.trials.iter_mut().find(|t| t.effect == h.effect) {
            t.kept = !t.accepted;
            t.against_absence = Some(w.gain.delta_aic);
            t.scene_value = t.scene_value.or(scene_value);
            if t.kept {
                // Reported as weighed: the scene's strength against none.
                t.value = h.start;
                t.std = None;
                t.at_bound = None;
                t.delta_aic = w.gain.delta_aic;
                t.rss_reduction_pct = 100.0 * w.gain.reduction;
            }
        }
    }
}

/// Takes a weighed effect out: out of the user's scene where it had the effect (an
/// effect only this calibration added is simply not added), its switches and start
/// forgotten, its trial recorded as removed with the model's strength (`was`) against
/// none.
pub(super) fn take_out(
    problem: &Problem,
    r: &mut Rounds,
    home: &effects::Home,
    was: f64,
    gain: &Gain,
    scenes_own: &[Effect],
) -> Result<(), CalibrateError> {
    // Taken out of the user's scene where it had the effect; an effect only this
    // calibration added is simply not added.
    if scenes_own.contains(&home.effect) {
        for (key, off) in home.off_values().expect("weighed effects can be taken out") {
            let was = crate::calibrate::keys::get(&r.stage.scene, &key)?;
            r.removed.push(Removal {
                effect: home.effect,
                was: problem_scene_value(problem, &key).unwrap_or(was),
                key,
                off,
            });
        }
    }
    // An effect accepted earlier and now taken out leaves its switches and start.
    r.switches.retain(|s| s.effect != home.effect);
    let keys = home.keys();
    r.starts.retain(|(k, _)| !keys.contains(&k.as_str()));
    let mut trial = r
        .trial(home.effect)
        .cloned()
        .unwrap_or_else(|| EffectTrial::of(home, was, None, None, gain));
    trial.accepted = false;
    trial.removed = true;
    trial.kept = false;
    trial.against_absence = Some(gain.delta_aic);
    // Reported as weighed: the model's strength against none.
    trial.value = was;
    trial.std = None;
    trial.at_bound = None;
    trial.delta_aic = gain.delta_aic;
    trial.rss_reduction_pct = 100.0 * gain.reduction;
    r.record(trial);
    Ok(())
}

/// Whether the recording supports an effect the model has, by its gain over the model
/// without it: the burden is the other way round from adding one (where the rule asks
/// [`MIN_DELTA_AIC`] and [`crate::diagnose::MIN_RSS_REDUCTION`]). The scene states the physics; it stays
/// unless the model without it is as likely, its key's penalty counted (an AIC gain of
/// zero or less).
pub(super) fn supports(gain: &Gain) -> bool {
    gain.delta_aic > 0.0
}

/// The user's scene's value of `key`.
pub(super) fn problem_scene_value(problem: &Problem, key: &str) -> Option<f64> {
    crate::calibrate::keys::get(problem.belief, key).ok()
}
