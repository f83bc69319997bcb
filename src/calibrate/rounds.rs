//! The effect rounds of a calibration, on the stage of its free keys, as stepwise
//! selection goes:
//!
//! 1. **Forward**, in rounds as the diagnosis adds effects: each effect tried is raced
//!    (its key scanned from the stage and from the beliefs, then fitted with the stage's
//!    keys for a few iterations; an effect the scene already has starts at the scene's
//!    strength), the most promising are tried in full (the fit carried to convergence),
//!    the one with the most evidence is accepted (added, or refined where the scene had
//!    it), and the next round starts from that stage. They end when no effect is
//!    supported.
//! 2. **Backward**: every effect the model then has (the scene's own, those accepted and
//!    those refined in the rounds) is weighed against its absence on the final stage: its
//!    key at its off value (no play, no delay...) and the other keys refitted. A key's
//!    standard deviation does not stand in for that fit: a play refined to the edge of its
//!    search window can look determined there while the model without it fits as well.
//!    The least supported is removed until every one left is supported.
//! 3. Where something was removed, the forward rounds run once more on what is left: an
//!    effect the removed one had masked may now show.

use rayon::prelude::*;

use super::search::{Added, Presence, Problem, Stage};
use super::{effects, CalibrateError, EffectTrial, Removal, Switch, Unconfirmed};
use crate::diagnose::evidence::Gain;
use crate::diagnose::round::VOCABULARY_PREFERENCE;
use crate::diagnose::MIN_DELTA_AIC;
use crate::ident::effects::Effect;

/// Effects tried in full in a round at least: those whose race removed the most of the
/// residual. A race is a few iterations from a start that a missing effect distorted, so
/// it can rank the right effect below one that mimics it; the full trials decide.
const FULL_TRIALS: usize = 3;

/// What the effect rounds leave: the last stage, each effect as last tried, the switch
/// keys and starts of the accepted ones, the effects removed, and the fit iterations spent.
pub(super) struct Rounds {
    pub stage: Stage,
    pub trials: Vec<EffectTrial>,
    pub switches: Vec<Switch>,
    pub starts: Vec<(String, f64)>,
    pub removed: Vec<Removal>,
    pub iterations: usize,
    /// The wheel geometry's keys, where the wheels' odometry gave them (held, not fitted
    /// through the simulator: [`Problem::geometry_by_odometry`]).
    pub geometry: Option<Vec<super::KeyFit>>,
    /// The search for a term outside the vocabulary: the round's that accepted one, else
    /// the last round's (`None` where none ran).
    pub terms: Option<super::terms::TermSearch>,
}

impl Rounds {
    /// Keeps an accepted effect's switches and its keys' starts for the rounds after.
    fn switch_on(&mut self, home: &effects::Home) {
        self.switches.extend(home.switches.iter().map(|s| Switch {
            effect: home.effect,
            key: s.key.to_string(),
            value: s.value_text(),
        }));
        self.starts.push((home.key.to_string(), home.start));
        self.starts
            .extend(home.also.iter().map(|c| (c.key.to_string(), c.start)));
    }

    /// Records a trial, replacing the effect's earlier one.
    fn record(&mut self, t: EffectTrial) {
        self.trials.retain(|old| old.effect != t.effect);
        self.trials.push(t);
    }

    fn trial(&self, e: Effect) -> Option<&EffectTrial> {
        self.trials.iter().find(|t| t.effect == e)
    }
}

/// The effect rounds on the free keys' stage ([`self`]).
pub(super) fn effect_rounds(
    problem: &Problem,
    stage: Stage,
    effects: &[Effect],
    driven: effects::Driven,
    progress: &dyn Fn(&str),
    first: super::first::First,
) -> Result<Rounds, CalibrateError> {
    let mut r = Rounds {
        iterations: stage.fit.iterations + first.iterations,
        stage,
        trials: first.trials,
        switches: vec![],
        starts: first.starts,
        removed: vec![],
        geometry: first.geometry,
        terms: None,
    };
    // Every effect offered, and those decided first.
    let mut effects = effects.to_vec();
    effects.extend(first.decided.iter().copied());
    let effects = &effects[..];
    // The scene's own effects that can be taken out, as the user wrote them.
    let scenes_own: Vec<Effect> = effects
        .iter()
        .copied()
        .filter(|&e| {
            effects::home(e, problem.belief, driven).is_ok_and(|h| h.in_scene && h.off.is_some())
        })
        .collect();
    let raced: Vec<Effect> = effects
        .iter()
        .copied()
        .filter(|e| !first.decided.contains(e))
        .collect();
    forward(problem, &mut r, raced, driven, progress)?;
    // The backward pass reads the keys' standard deviations.
    if problem.rejudge(&r.stage)? {
        progress(super::JUDGED_BY_THE_SIMULATOR);
    }
    progress("settling the keys and their uncertainty");
    r.stage = problem.settled(&r.stage, added_in_rounds(&r, &first.decided))?;
    r.iterations += r.stage.fit.iterations;
    let present: Vec<Effect> = effects
        .iter()
        .copied()
        .filter(|e| scenes_own.contains(e) || r.trial(*e).is_some_and(|t| t.accepted))
        .filter(|&e| effects::home(e, &r.stage.scene, driven).is_ok_and(|h| h.off.is_some()))
        // A geometry found on the wheels' odometry stands on that evidence, which no other
        // effect changes (the pose against the wheels' turns, no dynamics); the model's
        // fit of a drifting pose is the weaker judge of it.
        .filter(|&e| !(e == Effect::WheelGeometry && r.geometry.is_some()))
        .collect();
    let removed = backward(problem, &mut r, present, &scenes_own, driven, progress)?;
    if !removed.is_empty() {
        // An effect that showed no sign is not raced again: the one removed explained less
        // than its key's penalty, so what it masked is about as little (on OptiOdom's
        // square runs, racing every unsupported effect again took a fifth of the time).
        let again: Vec<Effect> = effects
            .iter()
            .copied()
            .filter(|e| !removed.contains(e) && !first.decided.contains(e))
            .filter(|&e| {
                effects::home(e, &r.stage.scene, driven).is_ok_and(|h| !h.in_scene)
                    && !r.trial(e).is_some_and(|t| t.accepted || t.shows_no_sign())
            })
            .collect();
        forward(problem, &mut r, again, driven, progress)?;
        progress("settling the keys and their uncertainty");
        r.stage = problem.settled(&r.stage, added_in_rounds(&r, &first.decided))?;
        r.iterations += r.stage.fit.iterations;
    }
    Ok(r)
}

/// Whether the rounds accepted an effect beyond those decided first: the effects whose
/// laws the reduced base shares with the simulator (the wheels' geometry, the base's
/// limits) are decided first; an effect the rounds add (a play, a dead time, castor drag)
/// the reduced base models more simply, so where the simulator judges its keys, and those
/// traded against them, are settled from the scene's values too ([`Problem::settled`]).
fn added_in_rounds(r: &Rounds, decided: &[Effect]) -> bool {
    r.trials
        .iter()
        .any(|t| t.accepted && !decided.contains(&t.effect))
}

/// The wheel geometry found on the wheels' odometry and accepted there, taken out of
/// `homes` with its home; `None` where the recording has no wheel turns or they do not
/// establish it (it is then raced through the simulator as every other effect).
fn accepted_odometry_geometry(
    problem: &Problem,
    r: &Rounds,
    homes: &mut Vec<effects::Home>,
) -> Result<Option<(OdometryGeometry, effects::Home)>, CalibrateError> {
    let Some(i) = homes.iter().position(|h| h.effect == Effect::WheelGeometry) else {
        return Ok(None);
    };
    Ok(match problem.geometry_by_odometry(&r.stage, &homes[i])? {
        Some(found) if found.0.accepted => Some((found, homes.remove(i))),
        _ => None,
    })
}

/// A geometry fitted on the wheels' odometry: its trial, the stage with it, its keys' fits.
type OdometryGeometry = (EffectTrial, Stage, Vec<super::KeyFit>);

/// The forward rounds: effects raced, the most promising tried in full, the best
/// supported accepted, round after round.
fn forward(
    problem: &Problem,
    r: &mut Rounds,
    mut remaining: Vec<Effect>,
    driven: effects::Driven,
    progress: &dyn Fn(&str),
) -> Result<(), CalibrateError> {
    let mut round = 0;
    while !remaining.is_empty() {
        round += 1;
        if problem.rejudge(&r.stage)? {
            progress(super::JUDGED_BY_THE_SIMULATOR);
        }
        let mut homes = remaining
            .iter()
            .map(|&e| effects::home(e, &r.stage.scene, driven))
            .collect::<Result<Vec<_>, _>>()?;
        // The wheel geometry on the wheels' odometry, where the recording has their turns;
        // where that does not establish it (a robot whose tyres creep under hard
        // acceleration rolls on other radii than its odometry assumes), through the
        // simulator as every other effect.
        let by_odometry = accepted_odometry_geometry(problem, r, &mut homes)?;
        let (full, tried) = race_then_try(problem, r, &homes, round, progress)?;
        let mut candidates: Vec<((EffectTrial, Stage), &effects::Home)> = tried
            .into_iter()
            .zip(full.iter().map(|&i| &homes[i]))
            .collect();
        if let Some(((t, next, fits), home)) = &by_odometry {
            r.record(t.clone());
            if t.accepted {
                r.geometry = Some(fits.clone());
            }
            candidates.push(((t.clone(), next.clone()), home));
        }
        let best = confirmed_best(problem, r, candidates, progress)?;
        let rival = best.as_ref().map(|((t, _), _)| super::terms::Rival {
            effect: t.effect.name(),
            delta_aic: t.delta_aic,
            reduction: t.rss_reduction_pct / 100.0,
        });
        if let Some(with) = term_round(problem, r, rival, round, progress)? {
            r.stage = problem.polished(with)?;
            r.iterations += r.stage.fit.iterations;
            continue;
        }
        let Some(((mut t, next), home)) = best else {
            break;
        };
        if t.effect != Effect::WheelGeometry {
            // A geometry found but not the best stays out of the scene this round.
            if by_odometry
                .as_ref()
                .is_some_and(|((g, _, _), _)| g.accepted)
            {
                r.geometry = None;
            }
        }
        t.accepted_as = Some(r.trials.iter().filter(|t| t.accepted_as.is_some()).count() + 1);
        r.record(t.clone());
        progress(&format!(
            "effects, round {round}: {} accepted ({} = {}, AIC gain {:.0})",
            t.effect.name(),
            t.key,
            crate::numtext::quantity(t.value, 4, crate::rig::keys::unit_key_or_name(&t.key)),
            t.delta_aic
        ));
        r.switch_on(home);
        remaining.retain(|&e| e != t.effect);
        // An effect that shows no sign in this recording is not tried again, as the
        // rounds that follow start from a stage that fits better still.
        let trials = &r.trials;
        remaining.retain(|&e| {
            trials
                .iter()
                .find(|t| t.effect == e)
                .is_none_or(|t| !t.shows_no_sign())
        });
        r.stage = problem.polished(next)?;
        r.iterations += r.stage.fit.iterations;
    }
    Ok(())
}

/// A round's search for a term outside the vocabulary, where the calibration searches
/// terms and has taken none yet: the stage with the term where it passes the rules and
/// has more than [`VOCABULARY_PREFERENCE`] times the AIC gain of the round's best effect
/// (`best`) plus [`MIN_DELTA_AIC`]; a vocabulary effect that explains the residual keeps
/// its name, as in `diagnose`.
fn term_round(
    problem: &Problem,
    r: &mut Rounds,
    best: Option<super::terms::Rival>,
    round: usize,
    progress: &dyn Fn(&str),
) -> Result<Option<Stage>, CalibrateError> {
    let Some(ceilings) = &problem.term_ceilings else {
        return Ok(None);
    };
    if r.terms.as_ref().is_some_and(|t| t.accepted().is_some()) {
        return Ok(None);
    }
    let (mut search, with) =
        super::terms::search(problem, &r.stage, ceilings, best.as_ref(), progress)?;
    let wins = match (search.accepted(), &best) {
        (Some(t), Some(b)) => t.row.delta_aic > VOCABULARY_PREFERENCE * b.delta_aic + MIN_DELTA_AIC,
        (Some(_), None) => true,
        (None, _) => false,
    };
    let with = match (wins, with) {
        (true, Some(with)) => with,
        _ => {
            for t in search.trials.iter_mut().filter(|t| t.accepted) {
                t.accepted = false;
                t.outranked_by = best.as_ref().map(|b| b.effect);
            }
            r.terms = Some(search);
            return Ok(None);
        }
    };
    let t = search.accepted().expect("a winning search has its term");
    progress(&format!(
        "terms, round {round}: {} accepted (AIC gain {:.0}): {}",
        t.row.name,
        t.row.delta_aic,
        crate::diagnose::terms::describe(&t.row)
    ));
    // Its coefficients start from none: the scene had no term.
    r.starts
        .extend(t.coefficients.iter().map(|(k, _, _)| (k.clone(), 0.0)));
    r.terms = Some(search);
    Ok(Some(with))
}

/// An effect tried in full: its trial and the stage it reaches.
type Tried = (EffectTrial, Stage);

/// The accepted effect's strength where the simulator judges ([`Problem::simulator_judges`]): its keys
/// refitted through the simulator from where the reduced base put them (the reduced base
/// leaves out what the simulator's teeth and castors do, and a play or a dead time found
/// on it is off by that); its trial's value is then the simulator's.
fn simulators_strength(
    problem: &Problem,
    mut t: EffectTrial,
    next: Stage,
    home: &effects::Home,
) -> Result<Tried, CalibrateError> {
    if !problem.simulator_judges() {
        return Ok((t, next));
    }
    let keys: Vec<String> = home.keys().iter().map(|k| k.to_string()).collect();
    let refit = problem.through_simulator(&next.scene, &keys)?;
    let i = keys.len() - 1;
    if refit.at_bound(i).is_some() {
        return Ok((t, next));
    }
    let pairs: Vec<(String, f64)> = keys
        .iter()
        .cloned()
        .zip(refit.fit.params.iter().copied())
        .collect();
    t.value = refit.fit.params[i];
    Ok((
        t,
        Stage {
            reached: super::keys::set(&next.reached, &pairs)?,
            scene: super::keys::set(&next.scene, &pairs)?,
            ..next
        },
    ))
}

/// The accepted candidate with the most evidence; on the reduced base, the first in that
/// order the simulator confirms (the recording replayed on it with the effect fits better
/// than without). One not confirmed is recorded so and not accepted.
fn confirmed_best<'h>(
    problem: &Problem,
    r: &mut Rounds,
    candidates: Vec<(Tried, &'h effects::Home)>,
    progress: &dyn Fn(&str),
) -> Result<Option<(Tried, &'h effects::Home)>, CalibrateError> {
    let mut accepted: Vec<(Tried, &effects::Home)> = candidates
        .into_iter()
        .filter(|((t, _), _)| t.accepted)
        .collect();
    accepted.sort_by(|((a, _), _), ((b, _), _)| b.delta_aic.total_cmp(&a.delta_aic));
    for ((t, next), home) in accepted {
        let added = next.free.len().saturating_sub(r.stage.free.len());
        let Some(why) = problem.unconfirmed(&r.stage.scene, &next.scene, Added::Keys(added))?
        else {
            return Ok(Some((simulators_strength(problem, t, next, home)?, home)));
        };
        progress(&format!(
            "effects: {} not confirmed: {}",
            t.effect.name(),
            match why {
                Unconfirmed::Simulator => "the simulator replays the recording no better with it",
                Unconfirmed::Validation => "the validation recordings replay no better with it",
            }
        ));
        r.record(EffectTrial {
            accepted: false,
            unconfirmed: Some(why),
            ..t
        });
    }
    Ok(None)
}

/// One round's race: every effect raced on the recording's first part (each key
/// scanned, then fitted with the others for a few iterations), the most promising then
/// fitted in full. Records the trials; returns which homes were tried in full and their
/// trials with the stages they reach.
fn race_then_try(
    problem: &Problem,
    r: &mut Rounds,
    homes: &[effects::Home],
    round: usize,
    progress: &dyn Fn(&str),
) -> Result<(Vec<usize>, Vec<Tried>), CalibrateError> {
    let names: Vec<&str> = homes.iter().map(|h| h.effect.name()).collect();
    if !names.is_empty() {
        progress(&format!(
            "effects, round {round}: racing {} (each key scanned, then fitted with the others for a few iterations)",
            names.join(", ")
        ));
    }
    // Raced on the recording's first part, against the keys refitted there alone: each
    // race's gain is what it removed beyond them.
    let explore = problem.explore();
    let stage_rss = explore.rss_of(&r.stage.scene, &r.stage.free)?;
    let (null, raced) = rayon::join(
        || explore.null_race(&r.stage),
        || {
            homes
                .par_iter()
                .map(|h| explore.race(&r.stage, h))
                .collect::<Result<Vec<_>, _>>()
        },
    );
    let (null, raced) = (null?, raced?);
    let null_rss = null.fit.rss().min(stage_rss);
    let gains: Vec<f64> = raced
        .iter()
        .map(|s| (null_rss - s.fit.rss()) / stage_rss)
        .collect();
    r.iterations += null.fit.iterations;
    for s in &raced {
        r.iterations += s.fit.iterations;
    }
    let full = most_promising(&gains);
    let tried_names: Vec<&str> = full.iter().map(|&i| homes[i].effect.name()).collect();
    if !tried_names.is_empty() {
        progress(&format!(
            "effects, round {round}: fitting {} with the keys",
            tried_names.join(", ")
        ));
    }
    let tried = full
        .par_iter()
        .map(|&i| problem.try_effect(&r.stage, &homes[i], &raced[i]))
        .collect::<Result<Vec<_>, _>>()?;
    for (i, ((h, s), g)) in homes.iter().zip(&raced).zip(&gains).enumerate() {
        if !full.contains(&i) {
            r.record(raced_trial(h, s, *g));
        }
    }
    for (t, next) in &tried {
        r.iterations += next.fit.iterations;
        r.record(t.clone());
    }
    Ok((full, tried))
}

/// The backward pass: each effect the model has weighed against its absence, the least
/// supported removed, until every one left is supported. Returns the effects removed.
fn backward(
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
fn record_kept(
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
fn take_out(
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
fn supports(gain: &Gain) -> bool {
    gain.delta_aic > 0.0
}

/// The user's scene's value of `key`.
fn problem_scene_value(problem: &Problem, key: &str) -> Option<f64> {
    crate::calibrate::keys::get(problem.belief, key).ok()
}

/// The races to try in full: the [`FULL_TRIALS`] whose races removed the most of the
/// residual beyond the keys refitted alone (a share of the stage's, `reductions`; in the
/// races' order), of those that removed some: a race that gained no more than a tenth of
/// what acceptance asks ([`super::result::NO_SIGN_PCT`]) beyond the keys alone shows no sign
/// of its effect, and its full trial would be spent for nothing.
fn most_promising(reductions: &[f64]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..reductions.len())
        .filter(|&i| 100.0 * reductions[i] >= super::result::NO_SIGN_PCT)
        .collect();
    order.sort_by(|&a, &b| reductions[b].total_cmp(&reductions[a]));
    let mut chosen: Vec<usize> = order.into_iter().take(FULL_TRIALS).collect();
    chosen.sort_unstable();
    chosen
}

/// The trial of an effect only raced: its key as the race left it, not supported (the
/// round's full trials went to effects whose races gained more, or it gained next to
/// nothing); `reduction` the share of the residual its race removed on the recording's
/// first part beyond the keys refitted alone.
fn raced_trial(home: &effects::Home, s: &Stage, reduction: f64) -> EffectTrial {
    let i = s.free.len() - 1;
    // No AIC gain: a race's few iterations weigh nothing.
    let race = crate::diagnose::evidence::Gain {
        delta_aic: f64::NAN,
        reduction,
    };
    EffectTrial {
        raced_only: true,
        ..EffectTrial::of(home, s.fit.params[i], None, s.at_bound(i), &race)
    }
}
