//! A calibration run: the request, the replays before, the first stage, the effect rounds,
//! the settled keys and their uncertainty, the replays after.

use crate::ident::data::Dataset;
use crate::ident::effects::Effect;
use crate::ident::fit::Weighting;
use crate::ident::weighting::spread_weights;
use crate::record::channels as chan;
use crate::record::Recording;
use crate::replay::{replay, replay_with, Drive, Engine, Replay};
use crate::rig::RigKind;
use crate::scene::Scene;

use super::search::{Problem, Stage};
use super::{
    contract_outputs, default_free_of, effects, faithful, first, keys, odometry, pose_windows,
    rounds, search, terms, validation, CalibrateError,
};
use super::{Calibration, EffectTrial, KeyFit, TRADE_OFF_CORRELATION};

/// What to calibrate.
#[derive(Debug, Clone, Default)]
pub struct Request {
    /// Scene keys to fit; empty: the recording kind's [`default_free`] set.
    pub free: Vec<String>,
    /// Effects to try, each through its scene key ([`effects::home`]).
    pub effects: effects::Choice,
    /// Other recordings of the machine (joined): an effect is added only where it also
    /// improves their replay (a finding the other runs do not confirm is fitted noise or
    /// the fitted run's own circumstance).
    pub validate: Option<Recording>,
}

/// Fits `free` scene keys (the recording kind's default set when empty) to the recording.
pub fn calibrate(
    scene: &Scene,
    rec: &Recording,
    free: &[String],
) -> Result<Calibration, CalibrateError> {
    let request = Request {
        free: free.to_vec(),
        effects: effects::Choice::None,
        validate: None,
    };
    calibrate_telling(scene, rec, &request, &|_| {})
}

/// The largest voltage the recording asks of the motors, V: its largest voltage command,
/// or, driven through a DCMC or a base's speed loops, the largest terminal voltage they
/// applied in the scene's replay.
fn max_command_v(replayed: &Replay) -> f64 {
    match replayed.drive {
        Drive::Voltages | Drive::AxisVoltage => replayed
            .inputs
            .iter()
            .flatten()
            .fold(0.0_f64, |m, v| m.max(v.abs())),
        _ => replayed.peak_terminal_v,
    }
}

/// [`calibrate`] with effects, telling `progress` each stage as it starts (the command
/// prints them on standard error; each fit iteration replays the recording once per key
/// and once more).
///
/// The free keys are fitted first. Then, in rounds as the diagnosis does, each effect not
/// yet accepted is switched on in the scene and its key fitted with the free keys; the one
/// with the most evidence is accepted, and the next round starts from that scene. An
/// effect the recording does not support leaves its keys as the scene had them.
pub fn calibrate_telling(
    scene: &Scene,
    rec: &Recording,
    request: &Request,
    progress: &dyn Fn(&str),
) -> Result<Calibration, CalibrateError> {
    let free = free_keys(request, rec)?;
    let engine = engine_for(scene, rec);
    progress(said(engine, FIRST_LOOK));
    let first_look = replay_with(scene, rec, engine)?;
    let outputs = fitted_outputs(&first_look, rec)?;
    let driven = driven_by(&first_look, rec);
    // Every effect's home is checked before any fit's work.
    let tried = effects::chosen(&request.effects, scene, driven)?;
    let (data, outputs, left_out) = excited_data(rec, &first_look, outputs)?;
    // Terms outside the vocabulary are searched where every effect is offered.
    let term_ceilings = (matches!(request.effects, effects::Choice::All)
        && terms::searched(rec, scene, engine))
    .then(|| terms::ceilings(scene, &data, max_command_v(&first_look)));
    let signed = signed_keys(&tried, scene, driven, term_ceilings.as_ref());
    // A tracked pose is compared over windows: a drifting simulation must not swamp the fit.
    let windows = pose_windows::PoseWindows::of(&data);
    let data = match &windows {
        Some(w) => w.measured(&data),
        None => data,
    };
    let explore = search::Exploration::of(rec, &data, windows.as_ref());
    let mut problem = Problem {
        rec,
        belief: scene,
        free: free.clone(),
        signed,
        weighting: Weighting::outputs_only(spread_weights(&data)),
        data,
        explore,
        held: Default::default(),
        wheel_turns: windows.as_ref().and_then(|_| {
            odometry::WheelTurns::of(
                rec,
                scene.base.wheel_radius_m.unwrap_or(scene.wheel.radius_m),
            )
        }),
        windows,
        engine,
        validation: None,
        simulator_judges: Default::default(),
        simulated: Default::default(),
        defect: Default::default(),
        bound_held: Default::default(),
        term_ceilings,
    };
    if let Some(v) = &request.validate {
        problem.validation =
            validation::Validation::of(v, &problem.data.output_names, driven.drive)?
                .map(std::sync::Arc::new);
    }
    progress(&format!(
        "fitting {} keys through {} ({} or more replays an iteration, at most 30 iterations in this stage)",
        free.len(),
        said(problem.engine, FITTED_THROUGH),
        free.len() + 1,
    ));
    // What the recording shows without dynamics (a base's limits, its wheels' geometry)
    // first: no mass or gain is to explain it.
    let found = first::found_first(&problem, scene, &tried, driven, progress)?;
    let mut fitted = free.clone();
    fitted.extend(found.extra_free.iter().cloned());
    let stage = faithful::faithful_first_stage(&mut problem, &found.scene, &fitted, progress)?;
    let baseline = stage.scene.clone();
    let stage = faithful::judged_first_stage(&mut problem, &found.scene, stage, progress)?;
    let tried: Vec<Effect> = tried
        .into_iter()
        .filter(|e| !found.decided.contains(e))
        .collect();
    let rounds = rounds::effect_rounds(&problem, stage, &tried, driven, progress, found)?;
    let iterations = rounds.iterations;
    let (keys, final_scene, trials) = settled(scene, &problem, &free, &rounds)?;
    let rounds = settle_term(rounds, &keys, &problem);
    progress(&format!(
        "fitted in {iterations} iterations in all stages; replaying the recording on the calibrated scene"
    ));
    let (before, after) = replays_before_after(engine, first_look, scene, &final_scene, rec)?;
    Ok(Calibration {
        keys,
        effects: trials,
        terms: rounds.terms,
        switches: rounds.switches,
        removed: rounds.removed,
        outputs,
        left_out,
        before,
        after,
        scene: final_scene,
        baseline,
        iterations,
        residual_correlation_s: rounds.stage.fit.correlation_rows as f64
            * problem.data.median_interval_s(),
        residual_correlation_rows: rounds.stage.fit.correlation_rows,
        residual_links: super::adequacy::residual_links(
            &problem.data,
            &rounds.stage.fit.predicted,
            problem.windows.as_ref(),
        ),
    })
}

/// The rounds with their accepted term at the calibration's final values
/// ([`terms::TermSearch::settle`]).
fn settle_term(mut rounds: rounds::Rounds, keys: &[KeyFit], problem: &Problem) -> rounds::Rounds {
    if let (Some(search), Some(c)) = (&mut rounds.terms, &problem.term_ceilings) {
        search.settle(keys, &problem.data, &rounds.stage.fit, c);
    }
    rounds
}

/// The keys the fits search on a linear scale through zero, with their half-widths: the
/// effects' of either sign, and every term coefficient where terms are searched.
fn signed_keys(
    tried: &[Effect],
    scene: &Scene,
    driven: effects::Driven,
    term_ceilings: Option<&crate::diagnose::terms::Ceilings>,
) -> Vec<(String, f64)> {
    let mut signed: Vec<(String, f64)> = tried
        .iter()
        .filter_map(|&e| {
            let h = effects::home(e, scene, driven).ok()?;
            Some((h.key.to_string(), h.signed_range?))
        })
        .collect();
    if let Some(c) = term_ceilings {
        signed.extend(terms::signed_keys(c));
    }
    signed
}

/// The simulator's replays of the scene as written and calibrated: the first look's where
/// it was the simulator's, both together where the fits ran on the reduced base.
fn replays_before_after(
    engine: Engine,
    first_look: Replay,
    scene: &Scene,
    calibrated: &Scene,
    rec: &Recording,
) -> Result<(Replay, Replay), CalibrateError> {
    Ok(if engine.is_reduced() {
        let (b, a) = rayon::join(|| replay(scene, rec), || replay(calibrated, rec));
        (b?, a?)
    } else {
        (first_look, replay(calibrated, rec)?)
    })
}

/// What the progress says of the engine's first replay, and what the fits run through:
/// on the simulator, and on the reduced base.
const FIRST_LOOK: [&str; 2] = [
    "replaying the recording on the scene as written",
    "replaying the recording on the scene as written (the reduced base; the simulator's replay at the end)",
];
const FITTED_THROUGH: [&str; 2] = [
    "the simulator",
    "the reduced base (each effect accepted confirmed through the simulator)",
];

/// The words of `said` for `engine`.
fn said(engine: Engine, said: [&'static str; 2]) -> &'static str {
    said[usize::from(engine.is_reduced())]
}

/// Said when the simulator takes over judging the evidence ([`search::Problem::rejudge`]).
pub(crate) const JUDGED_BY_THE_SIMULATOR: &str = "the reduced base and the simulator disagree here by more than a tenth of the residual: the evidence for each effect, and the keys at the end, from the simulator's replays";

/// What the fits replay on: a vehicle driven by velocity commands on the reduced base
/// ([`crate::sim::reduced`]: the same laws without rapier, the tooth mesh's sub-steps and
/// the castors' bodies), where the scene allows it, stepped throughout as the scene as
/// written asks ([`crate::sim::reduced::Stepping`]: the keys' fits move its replays
/// smoothly, and every fit of the run is judged on one discretisation); everything else on
/// the simulator.
fn engine_for(scene: &Scene, rec: &Recording) -> Engine {
    let velocity = crate::replay::drive_of(rec).is_ok_and(|d| d == Drive::Velocity);
    let reducible = velocity
        && rec.rig == RigKind::Vehicle
        && crate::sim::reduced::ReducedBase::new(scene).is_ok();
    match Engine::reduced_held_at(scene) {
        Ok(held) if reducible => held,
        _ => Engine::Simulator,
    }
}

/// The keys to fit: the request's, the recording kind's by default, none for `none`;
/// a simulator setting is refused.
fn free_keys(request: &Request, rec: &Recording) -> Result<Vec<String>, CalibrateError> {
    let free: Vec<String> = if request.free.is_empty() {
        default_free_of(rec).iter().map(|s| s.to_string()).collect()
    } else if request.free == ["none"] {
        // The scene's keys as they are: only the effects' are fitted.
        vec![]
    } else {
        request.free.clone()
    };
    // Only the machine's physics is fitted: not the simulator's own settings.
    if let Some(k) = free.iter().find(|k| k.starts_with("sim.")) {
        return Err(CalibrateError::Key(format!(
            "--free {k}: a setting of the simulation, not of the machine; only physical keys can be fitted"
        )));
    }
    Ok(free)
}

/// The contract's outputs the replay has of the recording (none is an error).
fn fitted_outputs(before: &Replay, rec: &Recording) -> Result<Vec<String>, CalibrateError> {
    let outputs: Vec<String> = contract_outputs(rec.rig)
        .iter()
        .filter(|n| before.output(n).is_some())
        .map(|n| n.to_string())
        .collect();
    if outputs.is_empty() {
        return Err(CalibrateError::Recording {
            file: rec.path.clone(),
            message: format!(
                "none of the rig's outputs to fit ({})",
                contract_outputs(rec.rig).join(", ")
            ),
        });
    }
    Ok(outputs)
}

/// How the recording drives the machine, for the effects' homes.
fn driven_by(before: &Replay, rec: &Recording) -> effects::Driven {
    effects::Driven {
        drive: before.drive,
        on_floor: rec.rig == RigKind::Vehicle,
        max_command_v: Some(max_command_v(before)),
        tracked_pose: [chan::X_M, chan::Y_M, chan::HEADING_RAD].iter().all(|c| {
            before
                .output(c)
                .is_some_and(|o| o.measured.iter().flatten().count() >= 2)
        }),
    }
}

/// The recording as the fit's dataset, without the outputs it does not excite (each said
/// with why); refused when nothing is left to fit or it is too short.
fn excited_data(
    rec: &Recording,
    before: &Replay,
    outputs: Vec<String>,
) -> Result<(Dataset, Vec<String>, Vec<crate::ident::LeftOut>), CalibrateError> {
    let inputs: Vec<String> = before
        .drive
        .columns()
        .iter()
        .map(|s| s.to_string())
        .collect();
    // The dataset's error names the recording already.
    let data = Dataset::from_recording(rec, &inputs, &outputs)
        .map_err(|e| CalibrateError::Data(e.to_string()))?;
    let left_out = unexcited_outputs(&data, before.drive);
    let (data, outputs) = if left_out.is_empty() {
        (data, outputs)
    } else {
        let names: Vec<String> = left_out.iter().map(|l| l.output.clone()).collect();
        let kept: Vec<String> = outputs.into_iter().filter(|o| !names.contains(o)).collect();
        if kept.is_empty() {
            return Err(CalibrateError::Data(format!(
                "{}: no output left to fit: {}",
                rec.path.display(),
                left_out
                    .iter()
                    .map(|l| format!("{} ({})", l.output, l.why))
                    .collect::<Vec<_>>()
                    .join("; ")
            )));
        }
        (data.without_outputs(&names), kept)
    };
    if outputs.is_empty() {
        return Err(CalibrateError::Recording {
            file: rec.path.clone(),
            message: "no output the recording excites: nothing to fit".into(),
        });
    }
    if data.len() < crate::diagnose::MIN_SAMPLES {
        return Err(CalibrateError::Recording {
            file: rec.path.clone(),
            message: format!(
                "{} rows: too short to calibrate on (at least {} are needed, as for diagnose)",
                data.len(),
                crate::diagnose::MIN_SAMPLES
            ),
        });
    }
    Ok((data, outputs, left_out))
}

/// The keys as reported after the rounds, in the order asked for (the effects' after
/// them; the wheel odometry's geometry where it was accepted; the keys the recording
/// could not tell apart, held), the calibrated scene (what is no estimate kept as the
/// user's scene had it), and the effects tried with the accepted ones at their final
/// values.
fn settled(
    scene: &Scene,
    problem: &Problem,
    free: &[String],
    rounds: &rounds::Rounds,
) -> Result<(Vec<KeyFit>, Scene, Vec<EffectTrial>), CalibrateError> {
    let mut keys = key_fits(scene, &rounds.stage, &rounds.starts);
    let held: Vec<String> = problem
        .held
        .lock()
        .expect("no fit panics holding it")
        .clone();
    for h in &held {
        for (key, shift) in moves_with_held(problem, &rounds.stage, h)? {
            if let Some(k) = keys.iter_mut().find(|k| k.key == key) {
                k.moves_with_held.push((h.clone(), shift));
            }
        }
    }
    // The wheel geometry from the wheels' odometry, where it was accepted and stays.
    if let Some(geometry) = &rounds.geometry {
        let kept = rounds
            .trials
            .iter()
            .any(|t| t.effect == Effect::WheelGeometry && t.accepted);
        if kept {
            keys.extend(geometry.iter().cloned());
        }
    }
    // The keys the recording could not tell apart, held at the scene's values.
    for key in &held {
        keys.push(KeyFit {
            confounded: true,
            ..kept_at_scene(scene, key, None)?
        });
    }
    // The keys the reduced base's first fit drove to a bound, held at the scene's values.
    for (key, bound) in &problem.bound_held {
        keys.push(kept_at_scene(scene, key, Some(*bound))?);
    }
    // In the order the keys were asked for, the effects' after them.
    keys.sort_by_key(|k| free.iter().position(|f| *f == k.key).unwrap_or(free.len()));
    // What is no estimate, the calibrated scene keeps as the user's scene had it.
    let mut final_scene = rounds.stage.scene.clone();
    for k in keys.iter_mut().filter(|k| !k.calibrated()) {
        if let Ok(was) = keys::get(scene, &k.key) {
            k.after = was;
            final_scene = keys::set(&final_scene, &[(k.key.clone(), was)])?;
        }
    }
    // An accepted effect is reported at its final value (the rounds after it refit it).
    let mut trials = rounds.trials.clone();
    for t in trials.iter_mut().filter(|t| t.accepted) {
        if let Some(k) = keys.iter().find(|k| k.key == t.key) {
            t.value = k.after;
            t.std = k.std;
        }
    }
    Ok((keys, final_scene, trials))
}

/// Share of a held key's value by which [`moves_with_held`] moves it: a round figure a
/// reader can scale to what they know of the key.
pub const HELD_STEP_SHARE: f64 = 0.10;

/// How each fitted key of `stage` moves when `held` (a key the recording could not tell
/// apart, held at the scene's value) is [`HELD_STEP_SHARE`] above where it is held and the
/// others are refitted from where they ended: each fitted key with its change. The
/// recording determines the fitted keys only given the held value; this is how much they
/// lean on it.
fn moves_with_held(
    problem: &Problem,
    stage: &Stage,
    held: &str,
) -> Result<Vec<(String, f64)>, CalibrateError> {
    let was = keys::get(&stage.reached, held)?;
    let moved = keys::set(
        &stage.reached,
        &[(held.to_string(), was * (1.0 + HELD_STEP_SHARE))],
    )?;
    let refit = problem.fit_quick(&moved, &stage.free, vec![])?;
    Ok(stage
        .free
        .iter()
        .enumerate()
        .map(|(i, k)| (k.clone(), refit.fit.params[i] - stage.fit.params[i]))
        .collect())
}

/// The outputs a recording does not excite, each with why: a vehicle driven on its two
/// voltages without a turn leaves its yaw outputs out (the gyro's noise, and the model's
/// answer to the drivers' imbalance, would steer the fit without showing anything;
/// [`crate::ident::models::vehicle::Turning`]).
///
/// Outputs without spread are left out whatever the drive ([`Dataset::flat_outputs`]).
fn unexcited_outputs(data: &Dataset, drive: Drive) -> Vec<crate::ident::LeftOut> {
    let yaw = if drive == Drive::Voltages {
        crate::ident::models::vehicle::Turning::of(data).yaw_left_out()
    } else {
        Vec::new()
    };
    crate::ident::LeftOut::of(data, yaw)
}

/// Each fitted key of the final stage against the user's scene (for an effect's key the
/// scene did not set, against where its fit started: the value its physics had).
fn key_fits(scene: &Scene, stage: &Stage, starts: &[(String, f64)]) -> Vec<KeyFit> {
    stage
        .free
        .iter()
        .enumerate()
        .map(|(i, key)| {
            let at_bound = stage.at_bound(i);
            let before = keys::get(scene, key).unwrap_or_else(|_| {
                starts
                    .iter()
                    .find(|(k, _)| k == key)
                    .map_or(f64::NAN, |(_, v)| *v)
            });
            KeyFit {
                key: key.clone(),
                before,
                after: keys::get(&stage.scene, key).unwrap_or(before),
                fitted: stage.fit.params[i],
                std: if at_bound.is_some() {
                    None
                } else {
                    stage.fit.std[i]
                },
                at_bound,
                held: stage.fit.weighting.holds(i) && stage.fit.held_by_belief(i),
                confounded: false,
                trades_with: trades_with(stage, i),
                moves_with_held: vec![],
            }
        })
        .collect()
}

/// A key the fits held at `scene`'s value, no estimate: where it ended at a bound of its
/// search, that bound (its `fitted` value).
fn kept_at_scene(scene: &Scene, key: &str, bound: Option<f64>) -> Result<KeyFit, CalibrateError> {
    let value = keys::get(scene, key)?;
    Ok(KeyFit {
        key: key.to_string(),
        before: value,
        after: value,
        fitted: bound.unwrap_or(value),
        std: None,
        at_bound: bound,
        held: false,
        confounded: false,
        trades_with: vec![],
        moves_with_held: vec![],
    })
}

/// The keys free slot `i` of the stage trades off against ([`TRADE_OFF_CORRELATION`]),
/// from the fit's covariance; none where a key is at a bound or undetermined.
fn trades_with(stage: &Stage, i: usize) -> Vec<(String, f64)> {
    let usable: Vec<bool> = (0..stage.free.len())
        .map(|j| stage.fit.std[j].is_some() && stage.at_bound(j).is_none())
        .collect();
    correlated_with(&stage.fit.covariance, &usable, i)
        .into_iter()
        .map(|(j, r)| (stage.free[j].clone(), r))
        .collect()
}

/// The slots whose correlation with slot `i` reaches [`TRADE_OFF_CORRELATION`] in size,
/// each with the correlation `c_ij / sqrt(c_ii c_jj)`; only `usable` slots count, and
/// none where the covariance does not cover them.
fn correlated_with(c: &nalgebra::DMatrix<f64>, usable: &[bool], i: usize) -> Vec<(usize, f64)> {
    if c.nrows() != usable.len() || !usable[i] {
        return vec![];
    }
    (0..usable.len())
        .filter(|&j| j != i && usable[j])
        .filter_map(|j| {
            let r = c[(i, j)] / (c[(i, i)] * c[(j, j)]).sqrt();
            (r.abs() >= TRADE_OFF_CORRELATION).then_some((j, r))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_whose_estimates_move_together_are_said_to_trade_off() {
        // Slots 0 and 1 correlated -0.995 (a mass and a gain that make the same response),
        // slot 2 independent of both (0.5 with slot 0: below the line).
        let (s0, s1, s2) = (2.0, 0.5, 1.0);
        let c = nalgebra::DMatrix::from_row_slice(
            3,
            3,
            &[
                s0 * s0,
                -0.995 * s0 * s1,
                0.5 * s0 * s2,
                -0.995 * s0 * s1,
                s1 * s1,
                0.0,
                0.5 * s0 * s2,
                0.0,
                s2 * s2,
            ],
        );
        let all = [true, true, true];
        let r = correlated_with(&c, &all, 0);
        assert_eq!(r.len(), 1, "{r:?}");
        assert_eq!(r[0].0, 1);
        assert!((r[0].1 + 0.995).abs() < 1e-12, "{r:?}");
        assert_eq!(correlated_with(&c, &all, 1)[0].0, 0);
        assert!(correlated_with(&c, &all, 2).is_empty());
        // A slot at a bound (unusable) trades with nothing, and nothing with it.
        assert!(correlated_with(&c, &[true, false, true], 0).is_empty());
        assert!(correlated_with(&c, &[false, true, true], 0).is_empty());
        // A covariance of another size (an intermediate fit's) says nothing.
        assert!(correlated_with(&c, &[true, true], 0).is_empty());
    }
}
