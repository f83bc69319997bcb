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
//!
//! This file holds the rounds' order; the passes are [`forward`] and [`backward`].

mod backward;
mod forward;
use backward::backward;
use forward::forward;

use super::search::{Problem, Stage};
use super::{effects, CalibrateError, EffectTrial, Removal, Switch};
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
