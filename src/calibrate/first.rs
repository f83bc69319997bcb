//! What a velocity-commanded recording shows before any dynamics: the base controller's
//! limits (commands the wheels never follow) and the wheels' geometry (their turns against
//! the tracked pose). Both are read off the recording without the motors, loops or
//! chassis, so they are decided first: a mass, a loop gain or a supply's clipping must not
//! be asked to explain a gap that the base's own limits or its wheels' sizes make.
//!
//! Each is weighed as every effect is (the evidence rule against the scene without it,
//! confirmed through the simulator and on the validation recordings); what is accepted
//! stays in the model for the stages after, where the backward pass weighs it again.

use super::search::{Added, Problem, Stage};
use super::{base_limits, effects, keys, CalibrateError, EffectTrial, KeyFit};
use crate::ident::effects::Effect;
use crate::scene::Scene;

/// What was found first: the scene with it, the keys fitted with the free ones from
/// then on, and the trials (accepted in order), their keys' starts and the wheel
/// geometry's keys.
pub(super) struct First {
    /// The user's scene with the findings switched on.
    pub scene: Scene,
    /// Keys the later stages fit with the free ones (the limits').
    pub extra_free: Vec<String>,
    /// Each finding's trial (accepted or not).
    pub trials: Vec<EffectTrial>,
    /// The accepted findings' keys with their starts.
    pub starts: Vec<(String, f64)>,
    /// The wheel geometry's keys from the wheels' odometry, where it was accepted.
    pub geometry: Option<Vec<KeyFit>>,
    /// The effects decided here (not raced in the rounds).
    pub decided: Vec<Effect>,
    /// Fit iterations spent.
    pub iterations: usize,
}

/// The base's limits, then the wheels' geometry, each where `effects` offers it and the
/// recording shows it.
pub(super) fn found_first(
    problem: &Problem,
    scene: &Scene,
    offered: &[Effect],
    driven: effects::Driven,
    progress: &dyn Fn(&str),
) -> Result<First, CalibrateError> {
    let mut first = First {
        scene: scene.clone(),
        extra_free: vec![],
        trials: vec![],
        starts: vec![],
        geometry: None,
        decided: vec![],
        iterations: 0,
    };
    if offered.contains(&Effect::WheelGeometry) && problem.wheel_turns.is_some() {
        geometry(problem, &mut first, driven, progress)?;
    }
    if offered.contains(&Effect::BaseLimits) && driven.drive == crate::replay::Drive::Velocity {
        first.decided.push(Effect::BaseLimits);
        limits(problem, &mut first, driven, progress)?;
    }
    Ok(first)
}

/// The scene as it stands, nothing fitted: the reference each finding is weighed against.
fn as_it_stands(problem: &Problem, first: &First) -> Result<Stage, CalibrateError> {
    problem.fit_quick(&first.scene, &first.extra_free, vec![])
}

/// The base controller's limits the recording shows ([`base_limits::shown`]), fitted from
/// their starts with the scene's keys held, weighed against none.
fn limits(
    problem: &Problem,
    first: &mut First,
    driven: effects::Driven,
    progress: &dyn Fn(&str),
) -> Result<(), CalibrateError> {
    let shown = base_limits::shown(problem.rec, &first.scene);
    if shown.starts.is_empty() {
        return Ok(());
    }
    let pairs: Vec<(String, f64)> = shown
        .starts
        .iter()
        .map(|(k, v)| (k.key().to_string(), *v))
        .collect();
    progress(&format!(
        "base limits: the recording commands what {} never follow: {}; fitting them first",
        shown.seen_by.noun(),
        pairs
            .iter()
            .map(|(k, v)| format!("{k} from {}", crate::numtext::sig(*v, 3)))
            .collect::<Vec<_>>()
            .join(", ")
    ));
    let reference = as_it_stands(problem, first)?;
    let on = keys::set(&first.scene, &pairs)?;
    let home = effects::home(Effect::BaseLimits, &on, driven)?;
    let free: Vec<String> = home.keys().iter().map(|k| k.to_string()).collect();
    let mut next = problem.fit(&on, &free)?;
    first.iterations += next.fit.iterations;
    // A limit's window is a factor of 10 either way of its start, which the recording's
    // noise sets: where the fit presses a limit against the window's edge, the window moves
    // there (twice at most), kept where the fit gains.
    for _ in 0..2 {
        if !(0..free.len()).any(|i| next.at_bound(i).is_some()) {
            break;
        }
        let moved = problem.fit(&next.reached, &free)?;
        first.iterations += moved.fit.iterations;
        if moved.fit.cost >= next.fit.cost {
            break;
        }
        next = moved;
    }
    let n_ref = reference.effective_n(&problem.data);
    let mut t = problem.trial(&home, &reference, &n_ref, &next)?;
    if t.accepted {
        if let Some(why) =
            problem.unconfirmed(&first.scene, &next.scene, Added::Keys(free.len()))?
        {
            t.accepted = false;
            t.unconfirmed = Some(why);
        }
    }
    if t.accepted {
        t.accepted_as = Some(1);
        first.scene = next.scene.clone();
        for k in &free {
            first.starts.push((k.clone(), keys::get(&next.scene, k)?));
        }
        first.extra_free = free;
        progress(&format!(
            "base limits: accepted ({}, AIC gain {:.0})",
            home.keys()
                .iter()
                .map(|k| format!(
                    "{k} = {}",
                    crate::numtext::sig(keys::get(&next.scene, k).unwrap_or(f64::NAN), 4)
                ))
                .collect::<Vec<_>>()
                .join(", "),
            t.delta_aic
        ));
    }
    first.trials.push(t);
    Ok(())
}

/// The wheels' geometry on their odometry ([`Problem::geometry_by_odometry`]), weighed
/// against the configured one and confirmed through the model.
fn geometry(
    problem: &Problem,
    first: &mut First,
    driven: effects::Driven,
    progress: &dyn Fn(&str),
) -> Result<(), CalibrateError> {
    let home = effects::home(Effect::WheelGeometry, &first.scene, driven)?;
    // Confirmed through the model at the scene's keys as they stand, nothing refitted: the
    // model with the geometry must replay the recording better than without it (a refit
    // of the other keys on a drifting pose would blur a change of a few tenths of a
    // percent).
    let reference = problem.fit_quick(&first.scene, &[], vec![])?;
    let Some((mut t, with, fits)) = problem.geometry_by_odometry(&reference, &home)? else {
        return Ok(());
    };
    if t.accepted {
        if let Some(why) = problem.unconfirmed(&first.scene, &with.scene, Added::Pose)? {
            t.accepted = false;
            t.unconfirmed = Some(why);
        }
    }
    // Not established on the odometry (tyres that creep under hard accelerations roll on
    // other radii than the odometry assumes): raced through the model in the rounds.
    if !t.accepted {
        progress(&format!(
            "wheel geometry on the wheels' odometry: not established ({} = {}, AIC gain {:.1}{}); raced through the model",
            t.key,
            crate::numtext::sig(t.value, 5),
            t.delta_aic,
            if t.unconfirmed.is_some() { ", the simulator's pose no better with it" } else { "" }
        ));
        return Ok(());
    }
    first.decided.push(Effect::WheelGeometry);
    {
        t.accepted_as = Some(first.trials.iter().filter(|t| t.accepted).count() + 1);
        let pairs: Vec<(String, f64)> = fits.iter().map(|k| (k.key.clone(), k.after)).collect();
        first.scene = keys::set(&first.scene, &pairs)?;
        first.starts.extend(home.keys().iter().map(|k| {
            (
                k.to_string(),
                keys::get(&first.scene, k).unwrap_or(f64::NAN),
            )
        }));
        first.geometry = Some(fits);
        progress(&format!(
            "wheel geometry on the wheels' odometry: accepted ({} = {}, AIC gain {:.0})",
            t.key,
            crate::numtext::sig(t.value, 5),
            t.delta_aic
        ));
    }
    first.trials.push(t);
    Ok(())
}
