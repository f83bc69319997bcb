//! Calibration: the simulator itself fitted to a recording. The scene's values are the
//! beliefs; the free scene keys are fitted by output error through [`crate::replay`] (the
//! simulator at the scene's fidelity, driven by the recording's inputs), with the same
//! Levenberg-Marquardt fitter and statistics as `identify`. The result is a scene: what
//! was fitted goes back into the file the user runs, and the fit is shown before and after
//! in the simulation itself.

pub mod effects;
pub mod keys;
pub mod write;

use std::path::PathBuf;

use crate::ident::data::Dataset;
use rayon::prelude::*;

use crate::diagnose::evidence::{effective_n, likelihood_gain};
use crate::diagnose::{MIN_DELTA_AIC, MIN_RSS_REDUCTION};
use crate::ident::effects::Effect;
use crate::ident::fit::{fit_predictor, residuals, Fit, FitSettings};
use crate::ident::model::{Diverged, ParamSpec, Predictor};
use crate::record::Recording;
use crate::replay::{replay, Drive, Replay, ReplayError};
use crate::scene::Scene;

/// Why a calibration cannot be done.
#[derive(Debug, thiserror::Error)]
pub enum CalibrateError {
    #[error(transparent)]
    Replay(#[from] ReplayError),
    #[error("{0}")]
    Key(String),
    #[error("{file}: {message}")]
    Recording { file: PathBuf, message: String },
    /// The recording cannot be fitted (the message names it).
    #[error("{0}")]
    Data(String),
    #[error("{file}: the fit failed: {message}")]
    Fit { file: PathBuf, message: String },
}

/// The contract's outputs per rig: what a real rig measures, and what a calibration fits.
pub fn contract_outputs(rig: &str) -> &'static [&'static str] {
    match rig {
        "drive_axis" => &[
            "motor_speed_rad_s",
            "motor_angle_rad",
            "wheel_angle_rad",
            "current_A",
        ],
        _ => &[
            "x_m",
            "y_m",
            "heading_rad",
            "left_motor_speed_rad_s",
            "right_motor_speed_rad_s",
            "sensor_left_adc",
            "sensor_right_adc",
            "left_wheel_speed_m_s",
            "right_wheel_speed_m_s",
            "yaw_rate_rad_s",
        ],
    }
}

/// The scene keys a calibration fits by default, per recording kind: those the record
/// determines and a scene is most often wrong about.
///
/// - a lifted drive (`drive_axis`, `drive_pair`): the armature resistance, the torque
///   constant, the rotor inertia and the viscous friction, which set the motor's gain,
///   its time constant and its current;
/// - a `vehicle`: the torque constant and resistance (the drive's gain) and the chassis
///   mass and yaw inertia (how fast it answers in speed and in turn).
pub fn default_free(rig: &str) -> &'static [&'static str] {
    match rig {
        "vehicle" => &[
            "motor.torque_constant_Nm_A",
            "motor.resistance_ohm",
            "chassis.mass_kg",
            "chassis.yaw_inertia_kg_m2",
        ],
        _ => &[
            "motor.resistance_ohm",
            "motor.torque_constant_Nm_A",
            "motor.rotor_inertia_kg_m2",
            "motor.viscous_Nm_s_rad",
        ],
    }
}

/// The simulator replaying a recording, as a model the fitter can fit: its parameters are
/// scene keys.
pub struct SceneReplay<'a> {
    scene: Scene,
    rec: &'a Recording,
    specs: Vec<ParamSpec>,
}

impl<'a> SceneReplay<'a> {
    /// Every key is a strictly positive quantity searched on a log scale within a factor
    /// of 10 of the scene's value. The simulator steps gear play and friction as events
    /// on its time grid, so its outputs are rough in the parameters below about 1e-4
    /// relative: the Jacobian is differenced over 0.1 %.
    pub fn new(scene: &Scene, rec: &'a Recording, free: &[String]) -> Result<Self, CalibrateError> {
        Self::with_signed(scene, rec, free, &[])
    }

    /// [`SceneReplay::new`] where the keys in `signed` (key, half-width) may take either
    /// sign: searched on a linear scale within the half-width around zero.
    pub fn with_signed(
        scene: &Scene,
        rec: &'a Recording,
        free: &[String],
        signed: &[(String, f64)],
    ) -> Result<Self, CalibrateError> {
        let specs = free
            .iter()
            .map(|k| {
                let v = keys::get(scene, k)?;
                if let Some((_, range)) = signed.iter().find(|(s, _)| s == k) {
                    return Ok(ParamSpec::new(k, v, -range, *range).with_fd_step(1e-2));
                }
                if !(v.is_finite() && v > 0.0) {
                    return Err(CalibrateError::Key(format!(
                        "--free {k}: the scene's value is {v}; a fitted key needs a positive starting value (set one with --set {k}=...)"
                    )));
                }
                Ok(ParamSpec::positive(k, v).with_fd_step(1e-2))
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(SceneReplay {
            scene: scene.clone(),
            rec,
            specs,
        })
    }

    /// The scene with parameters `p` in its free keys.
    pub fn scene_with(&self, p: &[f64]) -> Result<Scene, CalibrateError> {
        let pairs: Vec<(String, f64)> = self
            .specs
            .iter()
            .map(|s| s.name.clone())
            .zip(p.iter().copied())
            .collect();
        keys::set(&self.scene, &pairs)
    }
}

impl Predictor for SceneReplay<'_> {
    fn param_specs(&self) -> &[ParamSpec] {
        &self.specs
    }

    fn predict(&self, p: &[f64], data: &Dataset) -> Result<Vec<Vec<f64>>, Diverged> {
        let fail = || Diverged { t_s: data.t_s[0] };
        let scene = self.scene_with(p).map_err(|_| fail())?;
        let r = replay(&scene, self.rec).map_err(|e| match e {
            ReplayError::Diverged { t_s, .. } => Diverged { t_s },
            _ => fail(),
        })?;
        data.output_names
            .iter()
            .map(|n| r.output(n).map(|o| o.simulated.clone()).ok_or_else(fail))
            .collect()
    }
}

/// One fitted key.
#[derive(Debug, Clone, PartialEq)]
pub struct KeyFit {
    pub key: String,
    /// The scene's value (for an effect's key the scene did not set, the value its physics
    /// had: a tyre compound's friction).
    pub before: f64,
    /// The fitted value (the scene's when the fit ended at a bound).
    pub after: f64,
    /// Standard deviation of the fitted value; `None` where the record does not determine it.
    pub std: Option<f64>,
    /// The bound the search ended on, if it did: then `after` is no estimate, and the
    /// scene keeps its value (the belief or the model's structure is wrong).
    pub at_bound: Option<f64>,
}

/// An effect tried: its key fitted through the simulator with the scene's keys, and the
/// evidence the recording gives for it (the diagnosis's rule: an AIC gain above
/// [`MIN_DELTA_AIC`] with the effective sample count, at least [`MIN_RSS_REDUCTION`] of
/// the residual removed, and the key not at a bound of its search).
#[derive(Debug, Clone, PartialEq)]
pub struct EffectTrial {
    pub effect: Effect,
    pub key: String,
    pub value: f64,
    pub std: Option<f64>,
    pub at_bound: Option<f64>,
    pub delta_aic: f64,
    /// Share of the weighted residual removed, %.
    pub rss_reduction_pct: f64,
    pub accepted: bool,
}

/// A key set (not fitted) to switch an accepted effect's physics on.
#[derive(Debug, Clone, PartialEq)]
pub struct Switch {
    pub effect: Effect,
    pub key: String,
    /// The value as TOML text (`"pi"`, `2.4e1`).
    pub value: String,
}

/// What to calibrate.
#[derive(Debug, Clone, Default)]
pub struct Request {
    /// Scene keys to fit; empty: the recording kind's [`default_free`] set.
    pub free: Vec<String>,
    /// Effects to try, each through its scene key ([`effects::home`]).
    pub effects: Vec<Effect>,
}

/// A calibration's result.
#[derive(Debug, Clone)]
pub struct Calibration {
    /// The fitted keys: the free ones, then the accepted effects'.
    pub keys: Vec<KeyFit>,
    /// Each effect tried, as last fitted (an accepted one as it was accepted).
    pub effects: Vec<EffectTrial>,
    /// Keys set to switch the accepted effects on.
    pub switches: Vec<Switch>,
    /// The outputs fitted (the contract's outputs the recording has).
    pub outputs: Vec<String>,
    /// The recording replayed on the original and on the calibrated scene.
    pub before: Replay,
    pub after: Replay,
    /// The calibrated scene (the original with the fitted keys changed).
    pub scene: Scene,
    pub iterations: usize,
}

/// Fits `free` scene keys (the recording kind's default set when empty) to the recording.
pub fn calibrate(
    scene: &Scene,
    rec: &Recording,
    free: &[String],
) -> Result<Calibration, CalibrateError> {
    let request = Request {
        free: free.to_vec(),
        effects: vec![],
    };
    calibrate_telling(scene, rec, &request, &|_| {})
}

/// One fit of the scene's keys: the scene as fitted (a key at a bound keeps its start).
#[derive(Clone)]
struct Stage {
    scene: Scene,
    free: Vec<String>,
    fit: Fit,
    specs: Vec<ParamSpec>,
}

impl Stage {
    fn at_bound(&self, i: usize) -> Option<f64> {
        crate::ident::bound_reached(self.fit.params[i], self.specs[i].lo, self.specs[i].hi)
    }
}

/// What every fit of one calibration shares.
struct Problem<'a> {
    rec: &'a Recording,
    /// The scene as the user wrote it, and the keys fitted with every effect.
    belief: &'a Scene,
    free: Vec<String>,
    /// Effect keys of either sign, with their search half-widths.
    signed: Vec<(String, f64)>,
    data: Dataset,
    weights: Vec<f64>,
}

impl Problem<'_> {
    /// Fits the `free` keys of `scene` from its values.
    fn fit(&self, scene: &Scene, free: &[String]) -> Result<Stage, CalibrateError> {
        let model = SceneReplay::with_signed(scene, self.rec, free, &self.signed)?;
        let nominal: Vec<f64> = model.param_specs().iter().map(|s| s.nominal).collect();
        let settings = FitSettings {
            free: (0..free.len()).collect(),
            weights: self.weights.clone(),
            max_iterations: 30,
            starts: vec![nominal.clone()],
        };
        let fit =
            fit_predictor(&model, &self.data, &settings).map_err(|e| CalibrateError::Fit {
                file: self.rec.path.clone(),
                message: e.to_string(),
            })?;
        let specs = model.param_specs().to_vec();
        let kept: Vec<f64> = (0..free.len())
            .map(|i| {
                let b = crate::ident::bound_reached(fit.params[i], specs[i].lo, specs[i].hi);
                if b.is_some() {
                    nominal[i]
                } else {
                    fit.params[i]
                }
            })
            .collect();
        Ok(Stage {
            scene: model.scene_with(&kept)?,
            free: free.to_vec(),
            fit,
            specs,
        })
    }

    /// The scene with the free keys back at the user's values (accepted effects' keys kept).
    fn with_beliefs(&self, scene: &Scene) -> Result<Scene, CalibrateError> {
        let beliefs: Vec<(String, f64)> = self
            .free
            .iter()
            .map(|k| Ok((k.clone(), keys::get(self.belief, k)?)))
            .collect::<Result<_, CalibrateError>>()?;
        keys::set(scene, &beliefs)
    }

    /// The stage refitted from the beliefs with its effects at their fitted strengths,
    /// if that fits better: an effect fitted from a distorted start can leave the free
    /// keys in a poorer minimum, and the next round's effects must not be credited with
    /// the gain of leaving it.
    fn polished(&self, stage: Stage) -> Result<Stage, CalibrateError> {
        let again = self.fit(&self.with_beliefs(&stage.scene)?, &stage.free)?;
        Ok(if again.fit.cost < stage.fit.cost {
            again
        } else {
            stage
        })
    }

    /// Where the effect's key starts its fit: the lowest cost of a scan over its search
    /// range (a tenth to ten times its start, nine values a factor 1.78 apart; for a key of
    /// either sign, nine values evenly across its range), the other
    /// keys held. A play or a clipping limit moves the outputs in steps the gradient
    /// cannot see across, so the fit must start in the right basin.
    fn scan_start(&self, scene: &Scene, home: &effects::Home) -> Result<f64, CalibrateError> {
        let model =
            SceneReplay::with_signed(scene, self.rec, &[home.key.to_string()], &self.signed)?;
        let values: Vec<f64> = (-4..=4)
            .map(|i| match home.signed_range {
                Some(range) => range * i as f64 / 4.0,
                None => home.start * 10f64.powf(i as f64 / 4.0),
            })
            .collect();
        let costs: Vec<f64> = values
            .par_iter()
            .map(|&v| {
                model.predict(&[v], &self.data).map_or(f64::INFINITY, |y| {
                    residuals(&self.data, &y, &self.weights)
                        .iter()
                        .map(|r| r * r)
                        .sum()
                })
            })
            .collect();
        let best = (0..values.len()).fold(0, |b, i| if costs[i] < costs[b] { i } else { b });
        Ok(values[best])
    }

    /// The fit moved on while the effect's key ends at the edge of its search window where
    /// the effect grows (a window is a factor of 10 around where the scan started it, not a
    /// physical limit): up to twice, the window is centred on that edge and the fit
    /// resumed, kept if it fits better. At the edge where the effect vanishes it stays: the
    /// recording does not support the effect.
    fn beyond_the_window(
        &self,
        mut stage: Stage,
        home: &effects::Home,
        free: &[String],
    ) -> Result<Stage, CalibrateError> {
        let i = free.len() - 1;
        for _ in 0..2 {
            let Some(edge) = stage.at_bound(i) else { break };
            // A key of either sign searches a fixed range: no window to move.
            let grows = edge == stage.specs[i].hi && home.signed_range.is_none();
            if !grows {
                break;
            }
            let resumed = self.fit(
                &keys::set(&stage.scene, &[(home.key.to_string(), edge)])?,
                free,
            )?;
            if resumed.fit.cost >= stage.fit.cost {
                break;
            }
            stage = resumed;
        }
        Ok(stage)
    }

    /// The effect's key fitted with the stage's, and the evidence for it.
    fn try_effect(
        &self,
        stage: &Stage,
        home: &effects::Home,
    ) -> Result<(EffectTrial, Stage), CalibrateError> {
        let mut free = stage.free.clone();
        free.push(home.key.to_string());
        // From the stage's values, and from the beliefs: a missing effect can drag the
        // free keys far from the machine (to a bound), into a basin the effect's fit does
        // not leave.
        let mut best: Option<Stage> = None;
        for base in [stage.scene.clone(), self.with_beliefs(&stage.scene)?] {
            let scan = effects::Home {
                start: self.scan_start(&effects::switched_on(&base, home)?, home)?,
                ..home.clone()
            };
            let next = self.fit(&effects::switched_on(&base, &scan)?, &free)?;
            if best.as_ref().is_none_or(|b| next.fit.cost < b.fit.cost) {
                best = Some(next);
            }
        }
        let next = self.beyond_the_window(best.expect("two starts were fitted"), home, &free)?;
        // The gain is the effect's only if the stage's own physics, refitted from where the
        // effect's fit ended, does not reach it: the rough play or limit may have led the
        // free keys out of a poor minimum, which is no evidence for the effect.
        let fitted: Vec<(String, f64)> = stage
            .free
            .iter()
            .map(|k| Ok((k.clone(), keys::get(&next.scene, k)?)))
            .collect::<Result<_, CalibrateError>>()?;
        let null = self.fit(&keys::set(&stage.scene, &fitted)?, &stage.free)?;
        let reference = if null.fit.cost < stage.fit.cost {
            &null
        } else {
            stage
        };
        let n_ref = effective_n(&self.data, &reference.fit.predicted);
        let delta_aic = likelihood_gain(
            &self.data,
            &reference.fit.predicted,
            &n_ref,
            &next.fit.predicted,
        ) - 2.0;
        let reduction = 1.0 - next.fit.cost / reference.fit.cost;
        let i = free.len() - 1;
        let at_bound = next.at_bound(i);
        let trial = EffectTrial {
            effect: home.effect,
            key: home.key.to_string(),
            value: next.fit.params[i],
            std: next.fit.std[i],
            at_bound,
            delta_aic,
            rss_reduction_pct: 100.0 * reduction,
            // A key the recording does not determine (a limit above every command) is
            // not what earned a gain.
            accepted: delta_aic > MIN_DELTA_AIC
                && reduction >= MIN_RSS_REDUCTION
                && at_bound.is_none()
                && next.fit.std[i].is_some(),
        };
        Ok((trial, next))
    }
}

/// Each output weighted by its spread, so outputs in different units count alike.
fn spread_weights(data: &Dataset) -> Vec<f64> {
    data.outputs
        .iter()
        .map(|col| {
            let v: Vec<f64> = col.iter().flatten().copied().collect();
            let mean = v.iter().sum::<f64>() / v.len().max(1) as f64;
            let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / v.len().max(1) as f64;
            1.0 / var.sqrt().max(1e-12)
        })
        .collect()
}

/// Largest voltage command in the recording's inputs, V, when it commands voltages.
fn max_command_v(replayed: &Replay) -> Option<f64> {
    matches!(replayed.drive, Drive::Voltages | Drive::AxisVoltage).then(|| {
        replayed
            .inputs
            .iter()
            .flatten()
            .fold(0.0_f64, |m, v| m.max(v.abs()))
    })
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
    let free: Vec<String> = if request.free.is_empty() {
        default_free(&rec.rig)
            .iter()
            .map(|s| s.to_string())
            .collect()
    } else {
        request.free.clone()
    };
    progress("replaying the recording on the scene as written");
    let before = replay(scene, rec)?;
    let outputs: Vec<String> = contract_outputs(&rec.rig)
        .iter()
        .filter(|n| before.output(n).is_some())
        .map(|n| n.to_string())
        .collect();
    if outputs.is_empty() {
        return Err(CalibrateError::Recording {
            file: rec.path.clone(),
            message: format!(
                "none of the rig's outputs to fit ({})",
                contract_outputs(&rec.rig).join(", ")
            ),
        });
    }
    let inputs: Vec<String> = before
        .drive
        .columns()
        .iter()
        .map(|s| s.to_string())
        .collect();
    let driven = effects::Driven {
        drive: before.drive,
        on_floor: rec.rig == "vehicle",
        max_command_v: max_command_v(&before),
    };
    // Every effect's home is checked before any fit's work.
    for &e in &request.effects {
        effects::home(e, scene, driven)?;
    }
    // The dataset's error names the recording already.
    let data = Dataset::from_recording(rec, &inputs, &outputs)
        .map_err(|e| CalibrateError::Data(e.to_string()))?;
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
    let signed: Vec<(String, f64)> = request
        .effects
        .iter()
        .filter_map(|&e| {
            let h = effects::home(e, scene, driven).ok()?;
            Some((h.key.to_string(), h.signed_range?))
        })
        .collect();
    let problem = Problem {
        rec,
        belief: scene,
        free: free.clone(),
        signed,
        weights: spread_weights(&data),
        data,
    };
    progress(&format!(
        "fitting {} keys through the simulator ({} or more replays an iteration, at most 30 iterations)",
        free.len(),
        free.len() + 1,
    ));
    let mut stage = problem.fit(scene, &free)?;
    let mut iterations = stage.fit.iterations;
    let mut trials: Vec<EffectTrial> = vec![];
    let mut switches: Vec<Switch> = vec![];
    let mut starts: Vec<(String, f64)> = vec![];
    let mut remaining = request.effects.clone();
    let mut round = 0;
    while !remaining.is_empty() {
        round += 1;
        let names: Vec<&str> = remaining.iter().map(|e| e.name()).collect();
        progress(&format!(
            "effects, round {round}: fitting {} with the keys",
            names.join(", ")
        ));
        let homes = remaining
            .iter()
            .map(|&e| effects::home(e, &stage.scene, driven))
            .collect::<Result<Vec<_>, _>>()?;
        let tried = homes
            .par_iter()
            .map(|h| problem.try_effect(&stage, h))
            .collect::<Result<Vec<_>, _>>()?;
        for (t, next) in &tried {
            iterations += next.fit.iterations;
            trials.retain(|old| old.effect != t.effect);
            trials.push(t.clone());
        }
        let best = tried
            .into_iter()
            .zip(&homes)
            .filter(|((t, _), _)| t.accepted)
            .max_by(|((a, _), _), ((b, _), _)| a.delta_aic.total_cmp(&b.delta_aic));
        let Some(((t, next), home)) = best else { break };
        progress(&format!(
            "effects, round {round}: {} accepted ({} = {:.4e}, AIC gain {:.0})",
            t.effect.name(),
            t.key,
            t.value,
            t.delta_aic
        ));
        switches.extend(home.switches.iter().map(|(k, v)| Switch {
            effect: home.effect,
            key: k.to_string(),
            value: v.clone(),
        }));
        starts.push((home.key.to_string(), home.start));
        remaining.retain(|&e| e != t.effect);
        stage = problem.polished(next)?;
        iterations += stage.fit.iterations;
    }
    let keys: Vec<KeyFit> = stage
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
                std: if at_bound.is_some() {
                    None
                } else {
                    stage.fit.std[i]
                },
                at_bound,
            }
        })
        .collect();
    progress(&format!(
        "fitted in {iterations} iterations; replaying the recording on the calibrated scene"
    ));
    let after = replay(&stage.scene, rec)?;
    Ok(Calibration {
        keys,
        effects: trials,
        switches,
        outputs,
        before,
        after,
        scene: stage.scene,
        iterations,
    })
}
