//! The first stage a velocity recording's calibration is fitted on: the reduced base as it
//! is, the reduced base carrying its defect ([`super::defect`]), or the simulator, chosen by
//! whether the simulator sees the gain each fit claims.

use super::search::{Problem, Stage, FAITHFUL_SHARE};
use super::CalibrateError;
use crate::replay::Engine;
use crate::scene::Scene;

/// The first stage on the fits' engine. Where that is the reduced base and the simulator
/// does not see the improvement it claims ([`Problem::simulator_sees_gain`]: the castors'
/// swing or the teeth's ringing made up for by a mass or a gain), the reduced base carries
/// its defect ([`Defect`](super::defect::Defect): the simulator's replay minus its own at the scene's keys) and
/// fits again ([`corrected_first_stage`]); where the simulator sees no gain in that either,
/// the calibration runs on the simulator from then on, the first stage fitted again there.
pub(super) fn faithful_first_stage(
    problem: &mut Problem,
    scene: &Scene,
    fitted: &[String],
    progress: &dyn Fn(&str),
) -> Result<Stage, CalibrateError> {
    let stage = problem.first_stage(scene, fitted)?;
    if problem.engine == Engine::Simulator
        || problem.simulator_sees_gain(scene, &stage, FAITHFUL_SHARE)?
    {
        return Ok(stage);
    }
    if let Some(stage) = corrected_first_stage(problem, scene, fitted, progress)? {
        return Ok(stage);
    }
    progress("the simulator does not see the reduced base's first fit: the keys bent to make up for what it leaves out; fitting through the simulator from here");
    problem.engine = Engine::Simulator;
    problem.carry_defect(None);
    clear_held(problem);
    problem.first_stage(scene, fitted)
}

/// The first stage as the simulator judges it: where the reduced base and the simulator
/// disagree on it by more than [`super::search::JUDGE_SHARE`] of its residual, the
/// simulator judges from then on ([`Problem::rejudge`]), and where no defect is carried yet
/// the reduced base takes its defect at the scene's keys (where no fit has bent a key to
/// make up for what the reduced base leaves out) and the stage is refitted with it, so that
/// what the fits claim is what their judge sees.
pub(super) fn judged_first_stage(
    problem: &mut Problem,
    scene: &Scene,
    stage: Stage,
    progress: &dyn Fn(&str),
) -> Result<Stage, CalibrateError> {
    if !problem.rejudge(&stage)? {
        return Ok(stage);
    }
    progress(super::JUDGED_BY_THE_SIMULATOR);
    if problem.defect().is_none() && problem.correct_at(scene)? {
        return problem.fit(&stage.reached, &stage.free);
    }
    Ok(stage)
}

/// The first stage on the reduced base carrying its defect, taken at the scene's keys; where
/// the simulator sees its gain, refined once ([`refined_first_stage`]). Where the fit drove
/// keys of the user's to a bound of their search (no estimates, and a simulator far from
/// where the defect was taken), those are held ([`first_stage_without_bounds`]). `None`:
/// the simulator sees none of these fits' gains.
fn corrected_first_stage(
    problem: &mut Problem,
    scene: &Scene,
    fitted: &[String],
    progress: &dyn Fn(&str),
) -> Result<Option<Stage>, CalibrateError> {
    if !problem.correct_at(scene)? {
        return Ok(None);
    }
    progress(DEFECT_CARRIED);
    clear_held(problem);
    let stage = problem.first_stage(scene, fitted)?;
    let bound: Vec<(String, f64)> = (0..stage.free.len())
        .filter(|&i| problem.free.contains(&stage.free[i]))
        .filter_map(|i| Some((stage.free[i].clone(), stage.at_bound(i)?)))
        .collect();
    if bound.is_empty() && problem.simulator_sees_gain(scene, &stage, ANY_GAIN)? {
        return refined_first_stage(problem, scene, fitted, stage).map(Some);
    }
    first_stage_without_bounds(problem, scene, fitted, bound, progress)
}

/// The corrected first stage fitted again with the defect taken where it ended (the
/// defect changes with the keys); kept where the simulator sees its gain, else the first
/// (and its defect) stands.
fn refined_first_stage(
    problem: &mut Problem,
    scene: &Scene,
    fitted: &[String],
    stage: Stage,
) -> Result<Stage, CalibrateError> {
    let held = problem
        .held
        .lock()
        .expect("no fit panics holding it")
        .clone();
    if !problem.correct_at(&stage.reached)? {
        problem.correct_at(scene)?;
        return Ok(stage);
    }
    clear_held(problem);
    let again = problem.first_stage(scene, fitted)?;
    if problem.simulator_sees_gain(scene, &again, ANY_GAIN)? {
        return Ok(again);
    }
    problem.correct_at(scene)?;
    *problem.held.lock().expect("no fit panics holding it") = held;
    Ok(stage)
}

/// The corrected first stage with the user's keys its fit drove to a bound of their
/// search (`bound`, each with the bound; no estimates: the model cannot place them) held at
/// the scene's values ([`Problem::bound_held`]) and the others fitted; `None` where there
/// are none or the simulator does not see this fit's gain either.
fn first_stage_without_bounds(
    problem: &mut Problem,
    scene: &Scene,
    fitted: &[String],
    bound: Vec<(String, f64)>,
    progress: &dyn Fn(&str),
) -> Result<Option<Stage>, CalibrateError> {
    let rest: Vec<String> = fitted
        .iter()
        .filter(|k| !bound.iter().any(|(b, _)| b == *k))
        .cloned()
        .collect();
    if bound.is_empty() || rest.is_empty() {
        return Ok(None);
    }
    clear_held(problem);
    let stage = problem.first_stage(scene, &rest)?;
    if !problem.simulator_sees_gain(scene, &stage, ANY_GAIN)? {
        return Ok(None);
    }
    let names: Vec<&str> = bound.iter().map(|(k, _)| k.as_str()).collect();
    progress(&format!(
        "the reduced base's fit drove {} to the bounds of their search (no estimates): held at the scene's values, the other keys fitted; the simulator sees that fit's gain",
        names.join(", ")
    ));
    problem.bound_held = bound;
    Ok(Some(stage))
}

/// The share of a corrected fit's claimed gain the simulator must see: any. The corrected
/// reduced base predicts the simulator where its defect was taken and claims a gain for
/// the keys' move from there; where the simulator sees some of it, the move is the
/// simulator's too (where the two then disagree by more than [`super::search::JUDGE_SHARE`] of
/// the residual, the simulator judges the evidence and settles the keys).
const ANY_GAIN: f64 = f64::MIN_POSITIVE;

/// Said when the reduced base takes on its defect ([`faithful_first_stage`]).
const DEFECT_CARRIED: &str = "the simulator does not see the reduced base's first fit: the reduced base carries what the simulator adds to it (their replays' difference at the scene's keys) and fits again";

/// Forgets the keys a first fit held as undetermined, for a first fit on another model.
fn clear_held(problem: &Problem) {
    problem
        .held
        .lock()
        .expect("no fit panics holding it")
        .clear();
}
