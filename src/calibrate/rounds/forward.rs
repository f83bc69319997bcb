//! The forward pass: each round races the effects not yet in the model on the recording's
//! first part, tries the most promising in full, confirms the best through the simulator
//! and accepts it; then the terms outside the vocabulary.

use rayon::prelude::*;

use super::{accepted_odometry_geometry, Rounds, FULL_TRIALS};
use crate::calibrate::search::{Added, Problem, Stage};
use crate::calibrate::{effects, CalibrateError, EffectTrial, Unconfirmed};
use crate::diagnose::round::VOCABULARY_PREFERENCE;
use crate::diagnose::MIN_DELTA_AIC;
use crate::ident::effects::Effect;

/// The forward rounds: effects raced, the most promising tried in full, the best
/// supported accepted, round after round.
pub(super) fn forward(
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
            progress(crate::calibrate::JUDGED_BY_THE_SIMULATOR);
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
        let rival = best
            .as_ref()
            .map(|((t, _), _)| crate::calibrate::terms::Rival {
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
pub(super) fn term_round(
    problem: &Problem,
    r: &mut Rounds,
    best: Option<crate::calibrate::terms::Rival>,
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
        crate::calibrate::terms::search(problem, &r.stage, ceilings, best.as_ref(), progress)?;
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
pub(super) fn simulators_strength(
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
            reached: crate::calibrate::keys::set(&next.reached, &pairs)?,
            scene: crate::calibrate::keys::set(&next.scene, &pairs)?,
            ..next
        },
    ))
}

/// The accepted candidate with the most evidence; on the reduced base, the first in that
/// order the simulator confirms (the recording replayed on it with the effect fits better
/// than without). One not confirmed is recorded so and not accepted.
pub(super) fn confirmed_best<'h>(
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
pub(super) fn race_then_try(
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

/// The races to try in full: the [`FULL_TRIALS`] whose races removed the most of the
/// residual beyond the keys refitted alone (a share of the stage's, `reductions`; in the
/// races' order), of those that removed some: a race that gained no more than a tenth of
/// what acceptance asks ([`crate::calibrate::result::NO_SIGN_PCT`]) beyond the keys alone shows no sign
/// of its effect, and its full trial would be spent for nothing.
pub(super) fn most_promising(reductions: &[f64]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..reductions.len())
        .filter(|&i| 100.0 * reductions[i] >= crate::calibrate::result::NO_SIGN_PCT)
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
pub(super) fn raced_trial(home: &effects::Home, s: &Stage, reduction: f64) -> EffectTrial {
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
