//! The staged search of a calibration: the free keys fitted through the simulator (a
//! stage), an effect's key screened on a stage (scanned with the stage's keys held), an
//! effect tried on a stage (its key fitted with the stage's), an effect the scene has
//! weighed against its absence, and the evidence that decides each.

use rayon::prelude::*;

use super::{effects, keys, CalibrateError, EffectTrial, SceneReplay};
use crate::diagnose::evidence::{effective_n, Gain};
use crate::ident::data::Dataset;
use crate::ident::fit::{
    fit_predictor, fit_predictor_quick, fit_predictor_raced, residuals, Fit, FitError, FitSettings,
    Weighting,
};
use crate::ident::model::{ParamSpec, Predictor};
use crate::record::Recording;
use crate::scene::Scene;

/// A simulation's outputs, one series per fitted output (`None`: diverged).
type Outputs = Vec<Vec<f64>>;

/// One fit of the scene's keys: the scene as fitted (a key that is no estimate keeps its
/// start), and as the fit reached it.
#[derive(Clone)]
pub(super) struct Stage {
    pub scene: Scene,
    /// The scene at every fitted value, estimate or not: where a fit cut short goes on.
    pub reached: Scene,
    pub free: Vec<String>,
    pub fit: Fit,
    pub specs: Vec<ParamSpec>,
}

impl Stage {
    pub fn at_bound(&self, i: usize) -> Option<f64> {
        crate::ident::bound_reached(self.fit.params[i], self.specs[i].lo, self.specs[i].hi)
    }

    /// The fit's effective residual counts ([`effective_n`]).
    pub fn effective_n(&self, data: &Dataset) -> Vec<f64> {
        effective_n(data, &self.fit.predicted)
    }
}

/// What every fit of one calibration shares.
pub(super) struct Problem<'a> {
    pub rec: &'a Recording,
    /// The scene as the user wrote it, and the keys fitted with every effect.
    pub belief: &'a Scene,
    pub free: Vec<String>,
    /// Effect keys of either sign, with their search half-widths.
    pub signed: Vec<(String, f64)>,
    pub data: Dataset,
    /// How every fit after the first stage weighs outputs and beliefs (the first stage's).
    pub weighting: Weighting,
    /// The recording's first part, where effects are raced ([`Problem::explore`]); `None`
    /// where the recording is short enough to race on whole.
    pub explore: Option<Exploration>,
    /// The free keys the recording cannot tell apart from the others, held at the scene's
    /// values ([`Problem::determined`]), in the order they were held.
    pub held: std::sync::Mutex<Vec<String>>,
    /// The windows a tracked pose is compared over (`data`'s pose is already so).
    pub windows: Option<super::pose_windows::PoseWindows>,
    /// The wheels' measured turns, where the recording has them beside a tracked pose:
    /// the wheel geometry is searched on their odometry ([`super::odometry`]).
    pub wheel_turns: Option<super::odometry::WheelTurns>,
    /// What the fits replay on: the reduced base for a velocity-commanded recording (each
    /// round's winner confirmed through the simulator), else the simulator.
    pub engine: crate::replay::Engine,
    /// Other recordings of the machine each finding must also improve.
    pub validation: Option<std::sync::Arc<super::validation::Validation>>,
    /// Whether the simulator judges the evidence for an effect (its replays of where the
    /// fits end), the reduced base having disagreed with it by more than [`JUDGE_SHARE`] of
    /// a stage's residual ([`Problem::rejudge`]); else the fits' engine judges.
    pub simulator_judges: std::sync::atomic::AtomicBool,
    /// The simulator's replays of the scenes asked so far, by the scene's text
    /// ([`Problem::simulator_prediction`]): a round's reference stage is asked for again
    /// by each candidate's evidence, its confirmation and the judge.
    pub simulated: std::sync::Mutex<std::collections::HashMap<String, Option<Outputs>>>,
    /// The reduced base's defect the fits on it carry ([`Problem::correct_at`]).
    pub defect: Option<super::defect::Defect>,
    /// The user's keys the reduced base's first fit drove to a bound of their search, with
    /// the bound: held at the scene's values from then on (no estimates).
    pub bound_held: Vec<(String, f64)>,
    /// The physical ceilings of a term's coefficients, where terms outside the vocabulary
    /// are searched in the rounds ([`super::terms::searched`]).
    pub term_ceilings: Option<crate::diagnose::terms::Ceilings>,
}

/// Share of the first stage's improvement (as the reduced base claims it) the simulator
/// must see for the reduced base to stay the fits' engine ([`Problem::simulator_sees_gain`]).
pub const FAITHFUL_SHARE: f64 = 0.5;

/// Share of a fit's weighted residual the reduced base's disagreement with the simulator
/// may reach for its fits' evidence to stand for the simulator's.
pub const JUDGE_SHARE: f64 = 0.1;

/// The span from which a recording's effects are raced on its first part only, s, and
/// the least span that part covers: a race only ranks effects for their full trials on the
/// whole recording, and on a long recording of a repeated pattern (a robot's laps, a
/// joystick's random demands) its first part ranks them as well at a fraction of the
/// work. A shorter recording is raced whole: its parts differ (SysId's quasistatic ramps
/// come before the steps that clip).
pub(super) const EXPLORE_FROM_S: f64 = 60.0;
/// The least span an exploration covers, s (and [`EXPLORE_SHARE`] of the recording).
pub(super) const EXPLORE_MIN_S: f64 = 20.0;
/// Share of a long recording's span its effects are raced on.
pub(super) const EXPLORE_SHARE: f64 = 1.0 / 3.0;

/// Rows of `rec`'s first part to race effects on; `None` where it is raced whole.
pub(super) fn exploration_rows(rec: &Recording) -> Option<usize> {
    let (t0, t1) = (*rec.t_s.first()?, *rec.t_s.last()?);
    if t1 - t0 < EXPLORE_FROM_S {
        return None;
    }
    let span = (EXPLORE_SHARE * (t1 - t0)).max(EXPLORE_MIN_S);
    let rows = rec.t_s.iter().take_while(|&&t| t - t0 <= span).count();
    (rows >= crate::diagnose::MIN_SAMPLES).then_some(rows)
}

/// Restarts of the first stage's fit at most ([`Problem::first_stage`]).
const MAX_RESTARTS: usize = 3;

/// Share of its cost a restart must remove for another to follow.
const RESTART_GAIN: f64 = 0.01;

/// Iteration limit of each fit through the simulator.
pub(super) const MAX_ITERATIONS: usize = 30;

/// A tracker's position noise, m, and heading noise, rad, where nothing says otherwise:
/// what the wheels' odometry is weighed by ([`Problem::geometry_by_odometry`]).
const TRACKER_POSITION_NOISE_M: f64 = 0.002;
/// See [`TRACKER_POSITION_NOISE_M`].
const TRACKER_HEADING_NOISE_RAD: f64 = 0.005;

/// Iterations of an effect's refit through the simulator ([`Problem::through_simulator`]).
const SIMULATOR_ITERATIONS: usize = 8;

/// Iterations of the final fit through the simulator where it judges
/// ([`Problem::settled`]): every key moves there, from two starts raced.
const SETTLING_ITERATIONS: usize = 12;

/// Iterations of an effect's race ([`Problem::race`]): enough to leave the scan's grid
/// and settle the other keys' first response to the effect.
const RACE_ITERATIONS: usize = 3;

/// What a step to be confirmed adds ([`Problem::confirmed`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Added {
    /// Keys, fitted: the simulator's replays must show the gain the evidence rule asks.
    Keys(usize),
    /// The wheels' geometry, found on their odometry (its evidence): the simulator's
    /// replay of the pose must only fit better with it.
    Pose,
}

/// An effect the model has, weighed against its absence ([`Problem::weigh_present`]).
pub(super) struct Presence {
    /// What the stage, with the effect, gains over the fit without it.
    pub gain: Gain,
    /// The stage with the effect taken out (its key at its off value), the other keys
    /// refitted.
    pub off: Stage,
}

/// The recording's first part, where effects are raced: its rows, their measured outputs
/// (the pose as motions over their windows) and those windows
/// ([`super::pose_windows::PoseWindows::part`]).
pub struct Exploration {
    /// The recording's first rows.
    pub rec: Recording,
    /// Their measured outputs.
    pub data: Dataset,
    /// Their pose windows, where the recording has a pose.
    pub windows: Option<super::pose_windows::PoseWindows>,
}

impl Exploration {
    /// The first part of `rec` ([`exploration_rows`]) with its rows of `data` (measured,
    /// the pose over `windows`); `None` where the recording is raced whole.
    pub fn of(
        rec: &Recording,
        data: &Dataset,
        windows: Option<&super::pose_windows::PoseWindows>,
    ) -> Option<Exploration> {
        let rows = exploration_rows(rec)?;
        let (windows, data) = match windows {
            Some(w) => {
                let (w, part) = w.part(data, rows);
                (Some(w), part)
            }
            None => (None, data.prefix(rows)),
        };
        Some(Exploration {
            rec: rec.prefix(rows),
            data,
            windows,
        })
    }
}

impl Problem<'_> {
    /// The problem on the recording's first part ([`exploration_rows`]), weighed alike;
    /// the problem itself where there is none.
    pub fn explore(&self) -> Problem<'_> {
        let (rec, data, windows) = match &self.explore {
            Some(e) => (&e.rec, &e.data, &e.windows),
            None => (self.rec, &self.data, &self.windows),
        };
        Problem {
            rec,
            belief: self.belief,
            free: self.free.clone(),
            signed: self.signed.clone(),
            data: data.clone(),
            weighting: self.weighting.clone(),
            explore: None,
            held: Default::default(),
            windows: windows.clone(),
            wheel_turns: self.wheel_turns.clone(),
            engine: self.engine,
            validation: None,
            simulator_judges: std::sync::atomic::AtomicBool::new(self.simulator_judges()),
            simulated: Default::default(),
            defect: self.defect(),
            bound_held: vec![],
            term_ceilings: None,
        }
    }

    /// The weighted residual sum of squares of `scene` replayed on the problem's recording.
    pub fn rss_of(&self, scene: &Scene, free: &[String]) -> Result<f64, CalibrateError> {
        let model = SceneReplay::with_signed(scene, self.rec, free, &self.signed)?
            .on(self.engine)
            .corrected(self.defect())
            .windowed(self.windows.clone());
        let p = values(scene, free)?;
        Ok(model
            .predict(&p, &self.data)
            .map_or(f64::INFINITY, |y| self.cost_of(&y)))
    }

    /// `scene` replayed on the simulator itself, whatever the problem's engine, as the fit
    /// compares it (`None`: it diverged).
    pub fn simulator_prediction(&self, scene: &Scene) -> Result<Option<Outputs>, CalibrateError> {
        let text = scene.to_toml();
        if let Some(known) = self
            .simulated
            .lock()
            .expect("no replay panics holding it")
            .get(&text)
        {
            return Ok(known.clone());
        }
        let model = SceneReplay::with_signed(scene, self.rec, &[], &[])?
            .on(crate::replay::Engine::Simulator)
            .windowed(self.windows.clone());
        let predicted = model.predict(&[], &self.data).ok();
        self.simulated
            .lock()
            .expect("no replay panics holding it")
            .insert(text, predicted.clone());
        Ok(predicted)
    }

    /// The reduced base's defect the fits carry, if any.
    pub fn defect(&self) -> Option<super::defect::Defect> {
        self.defect.clone()
    }

    /// Takes the reduced base's defect at `scene`'s keys ([`super::defect`]): from then on
    /// every fit on the reduced base predicts what the simulator replays there. `false`
    /// (and no defect) where either diverged.
    pub fn correct_at(&mut self, scene: &Scene) -> Result<bool, CalibrateError> {
        let reduced = SceneReplay::with_signed(scene, self.rec, &[], &[])?
            .on(self.engine)
            .windowed(self.windows.clone());
        let (sim, own) = rayon::join(
            || self.simulator_prediction(scene),
            || reduced.predict(&[], &self.data).ok(),
        );
        let defect = match (sim?, own) {
            (Some(s), Some(r)) => Some(super::defect::Defect::between(&s, &r)),
            _ => None,
        };
        self.defect = defect;
        Ok(self.defect.is_some())
    }

    /// Whether the simulator confirms a step found on the reduced base, `added` keys
    /// more: the recording replayed on `after` and on `before` (both replays run
    /// together), the gain passing the evidence rule ([`Gain::passes`]) there too. The
    /// reduced base leaves physics out (the castors' swing, the teeth's ringing): a step
    /// that only bends a key to make up for that gains nothing in the simulator.
    pub fn confirmed(
        &self,
        before: &Scene,
        after: &Scene,
        added: Added,
    ) -> Result<bool, CalibrateError> {
        let (b, a) = rayon::join(
            || self.simulator_prediction(before),
            || self.simulator_prediction(after),
        );
        Ok(match (b?, a?) {
            (_, None) => false,
            (None, Some(_)) => true,
            (Some(b), Some(a)) => match added {
                Added::Keys(n) => {
                    Gain::of_predictions(&self.data, &b, &a, n, &self.weighting.outputs).passes()
                }
                Added::Pose => self.pose_cost(&a) < self.pose_cost(&b),
            },
        })
    }

    /// What does not confirm the step from `before` to `after` (an effect found, `added`
    /// keys more): on the reduced base, the simulator's replay of the recording; then the
    /// validation recordings' replays. `None`: confirmed.
    pub fn unconfirmed(
        &self,
        before: &Scene,
        after: &Scene,
        added: Added,
    ) -> Result<Option<super::Unconfirmed>, CalibrateError> {
        // Judged by the simulator already, or confirmed by it here.
        if self.engine.is_reduced()
            && !self.simulator_judges()
            && !self.confirmed(before, after, added)?
        {
            return Ok(Some(super::Unconfirmed::Simulator));
        }
        if let Some(v) = &self.validation {
            if !v.improved(before, after, self.engine)? {
                return Ok(Some(super::Unconfirmed::Validation));
            }
        }
        Ok(None)
    }

    /// Whether the simulator judges ([`Problem::simulator_judges`]).
    pub fn simulator_judges(&self) -> bool {
        self.simulator_judges
            .load(std::sync::atomic::Ordering::Relaxed)
    }

    /// Weighs again who judges the evidence from `stage` on: where the fits run on the
    /// reduced base, the simulator replays the stage, and the reduced base's disagreement
    /// with it (weighted as the residual) is set against the stage's residual; beyond
    /// [`JUDGE_SHARE`] of it, the simulator judges from then on (as the model grows and its
    /// residual shrinks to the noise, the reduced base's omissions weigh more). Returns
    /// whether the simulator has just taken over.
    pub fn rejudge(&self, stage: &Stage) -> Result<bool, CalibrateError> {
        if self.engine == crate::replay::Engine::Simulator || self.simulator_judges() {
            return Ok(false);
        }
        let takes_over = self.disagrees(stage)?;
        if takes_over {
            self.simulator_judges
                .store(true, std::sync::atomic::Ordering::Relaxed);
        }
        Ok(takes_over)
    }

    /// Whether the simulator sees at least `share` of the improvement the fits' engine
    /// claims for `stage` over `scene` as written (each replayed where its fit ended,
    /// weighted as the residual; [`FAITHFUL_SHARE`] for the reduced base as it is, any
    /// gain at all for one carrying its defect, whose claim is the corrected one). Where
    /// it does not, the reduced base bent the keys to make up for physics it leaves out,
    /// and is no model of this recording.
    pub fn simulator_sees_gain(
        &self,
        scene: &Scene,
        stage: &Stage,
        share: f64,
    ) -> Result<bool, CalibrateError> {
        let w = &self.weighting.outputs;
        let cost =
            |p: &[Vec<f64>]| -> f64 { residuals(&self.data, p, w).iter().map(|r| r * r).sum() };
        let before = self.fit_quick(scene, &[], vec![])?;
        let claimed = cost(&before.fit.predicted) - cost(&stage.fit.predicted);
        if !(claimed > 0.0) {
            return Ok(true);
        }
        let (b, a) = rayon::join(
            || self.simulator_prediction(scene),
            || self.simulator_prediction(&stage.reached),
        );
        Ok(match (b?, a?) {
            (Some(b), Some(a)) => cost(&b) - cost(&a) >= share * claimed,
            _ => false,
        })
    }

    /// Whether the reduced base disagrees with the simulator on `stage` by more than
    /// [`JUDGE_SHARE`] of its residual.
    fn disagrees(&self, stage: &Stage) -> Result<bool, CalibrateError> {
        let Some(sim) = self.simulator_prediction(&stage.reached)? else {
            return Ok(true);
        };
        let w = &self.weighting.outputs;
        let reduced = residuals(&self.data, &stage.fit.predicted, w);
        let simulated = residuals(&self.data, &sim, w);
        let disagreement: f64 = reduced
            .iter()
            .zip(&simulated)
            .map(|(a, b)| (a - b) * (a - b))
            .sum();
        let residual: f64 = reduced.iter().map(|r| r * r).sum();
        Ok(disagreement > JUDGE_SHARE * residual)
    }

    /// What `richer` gains over `reference` (whose effective residual counts are
    /// `n_ref`): on the fits' own predictions, or, where the simulator judges
    /// ([`Problem::simulator_judges`]), on its replays of where each fit ended.
    pub(super) fn gain(
        &self,
        reference: &Stage,
        n_ref: &[f64],
        richer: &Stage,
    ) -> Result<Gain, CalibrateError> {
        if !self.simulator_judges() {
            return Ok(Gain::of(&self.data, &reference.fit, n_ref, &richer.fit));
        }
        let (a, b) = rayon::join(
            || self.simulator_prediction(&reference.reached),
            || self.simulator_prediction(&richer.reached),
        );
        let added = richer.free.len().saturating_sub(reference.free.len());
        Ok(match (a?, b?) {
            (Some(a), Some(b)) => {
                Gain::of_predictions(&self.data, &a, &b, added, &self.weighting.outputs)
            }
            (_, None) => Gain {
                delta_aic: f64::NEG_INFINITY,
                reduction: f64::NEG_INFINITY,
            },
            (None, Some(_)) => Gain {
                delta_aic: f64::INFINITY,
                reduction: 1.0,
            },
        })
    }

    /// The first stage: the `free` keys of `scene` fitted from its values in the two
    /// passes of [`crate::ident::fit_weighted`] (outputs weighted by their residual
    /// floored at their noise; a key whose belief the user's scene states,
    /// `[uncertainty_pct]`, held near it where the recording cannot determine it). Its
    /// weighting is the one every later fit of the calibration uses, as a diagnosis's
    /// candidates use its baseline's: evidence compares fits weighed alike.
    pub fn first_stage(&mut self, scene: &Scene, free: &[String]) -> Result<Stage, CalibrateError> {
        let stage = self.stage(scene, free, |model, slots, start| {
            crate::ident::fit_weighted(model, &self.data, slots, MAX_ITERATIONS, vec![start])
        })?;
        self.weighting = stage.fit.weighting.clone();
        let stage = self.determined(stage)?;
        // The simulator's play and friction make the cost rough: a fit stops in a dent
        // that a restart (its damping reset) leaves. Restarted while that gains.
        let mut stage = stage;
        for _ in 0..MAX_RESTARTS {
            let again = self.fit_quick(&stage.scene, &stage.free, vec![])?;
            let gained = 1.0 - again.fit.cost / stage.fit.cost;
            if gained > 0.0 {
                stage = again;
            }
            if gained < RESTART_GAIN {
                break;
            }
        }
        Ok(stage)
    }

    /// Fits the `free` keys of `scene` from its values with the calibration's weighting.
    pub fn fit(&self, scene: &Scene, free: &[String]) -> Result<Stage, CalibrateError> {
        self.stage(scene, free, |model, slots, start| {
            fit_predictor(model, &self.data, &self.settings(slots, vec![start]))
        })
    }

    fn settings(&self, slots: &[usize], starts: Vec<Vec<f64>>) -> FitSettings {
        FitSettings {
            free: slots.to_vec(),
            weighting: self.weighting.clone(),
            max_iterations: MAX_ITERATIONS,
            starts,
        }
    }

    /// [`Problem::fit`] cut short after `iterations`, without the covariance: a race's
    /// fit, whose standard deviations nobody reads (its scene is where it ended).
    fn fit_for(
        &self,
        scene: &Scene,
        free: &[String],
        iterations: usize,
    ) -> Result<Stage, CalibrateError> {
        self.stage_of(scene, free, true, self.engine, |model, slots, start| {
            let settings = FitSettings {
                max_iterations: iterations,
                ..self.settings(slots, vec![start])
            };
            fit_predictor_quick(model, &self.data, &settings, false)
        })
    }

    /// `free` keys of `scene` refitted through the simulator itself for at most
    /// [`SIMULATOR_ITERATIONS`], without the covariance: an effect's strength found on the
    /// reduced base where the simulator judges ([`Problem::simulator_judges`]), the few keys that
    /// set it placed where the simulator has them.
    pub fn through_simulator(
        &self,
        scene: &Scene,
        free: &[String],
    ) -> Result<Stage, CalibrateError> {
        self.stage_of(
            scene,
            free,
            true,
            crate::replay::Engine::Simulator,
            |model, slots, start| {
                let settings = FitSettings {
                    max_iterations: SIMULATOR_ITERATIONS,
                    ..self.settings(slots, vec![start])
                };
                fit_predictor_quick(model, &self.data, &settings, false)
            },
        )
    }

    /// [`Problem::fit_raced`] without the covariance: for a fit whose cost alone is read
    /// (an effect's absence, a null fit), its scene where it ended.
    pub(super) fn fit_quick(
        &self,
        scene: &Scene,
        free: &[String],
        others: Vec<Vec<f64>>,
    ) -> Result<Stage, CalibrateError> {
        self.stage_of(scene, free, true, self.engine, |model, slots, start| {
            let mut starts = vec![start];
            starts.extend(others.iter().cloned());
            let race = starts.len() > 1;
            fit_predictor_quick(model, &self.data, &self.settings(slots, starts), race)
        })
    }

    /// The stage `fit` reaches from `scene`'s values of the `free` keys. A key that ends at
    /// a bound, that neither the recording nor a belief determines, or whose standard
    /// deviation exceeds its value, keeps its start: none of those is an estimate.
    fn stage(
        &self,
        scene: &Scene,
        free: &[String],
        fit: impl Fn(&SceneReplay, &[usize], Vec<f64>) -> Result<Fit, FitError>,
    ) -> Result<Stage, CalibrateError> {
        self.stage_of(scene, free, false, self.engine, fit)
    }

    /// [`Problem::stage`]; `quick`: the fit has no covariance, and its scene is where it
    /// ended.
    fn stage_of(
        &self,
        scene: &Scene,
        free: &[String],
        quick: bool,
        engine: crate::replay::Engine,
        fit: impl Fn(&SceneReplay, &[usize], Vec<f64>) -> Result<Fit, FitError>,
    ) -> Result<Stage, CalibrateError> {
        let model = SceneReplay::with_signed(scene, self.rec, free, &self.signed)?
            .on(engine)
            .corrected(self.defect())
            .believing(self.belief, &self.free)?
            .anchored(self.belief, &self.free)?
            .windowed(self.windows.clone());
        let start = values(scene, free)?;
        let fit =
            fit(&model, &(0..free.len()).collect::<Vec<_>>(), start.clone()).map_err(|e| {
                CalibrateError::Fit {
                    file: self.rec.path.clone(),
                    message: e.to_string(),
                }
            })?;
        let specs = model.param_specs().to_vec();
        let kept: Vec<f64> = (0..free.len())
            .map(|i| {
                let b = crate::ident::bound_reached(fit.params[i], specs[i].lo, specs[i].hi);
                // A fit without its covariance (a quick one) keeps where it ended.
                let estimate = fit.std[i].is_some_and(|s| s < fit.params[i].abs());
                if !quick && (b.is_some() || !estimate) {
                    start[i]
                } else {
                    fit.params[i]
                }
            })
            .collect();
        Ok(Stage {
            scene: model.scene_with(&kept)?,
            reached: model.scene_with(&fit.params)?,
            free: free.to_vec(),
            fit,
            specs,
        })
    }

    /// The scene with the free keys back at the user's values (accepted effects' keys kept).
    pub fn with_beliefs(&self, scene: &Scene) -> Result<Scene, CalibrateError> {
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
    pub fn polished(&self, stage: Stage) -> Result<Stage, CalibrateError> {
        let again = self.fit_quick(&self.with_beliefs(&stage.scene)?, &stage.free, vec![])?;
        Ok(if again.fit.cost < stage.fit.cost {
            again
        } else {
            stage
        })
    }

    /// The final stage: its keys refitted from where the rounds left them, with their
    /// covariance (the rounds' own stages go without: nobody reads it), and those the
    /// recording cannot tell apart held ([`Problem::determined`]). Where the simulator
    /// judges, the keys are refitted through it; where `refit` (the rounds added an effect
    /// the reduced base models more simply than the simulator), from a second start too.
    pub fn settled(&self, stage: &Stage, refit: bool) -> Result<Stage, CalibrateError> {
        let full = self.fit(&stage.reached, &stage.free)?;
        let settled = if full.fit.cost <= stage.fit.cost * (1.0 + 1e-9) {
            full
        } else {
            stage.clone()
        };
        if !self.simulator_judges() {
            return self.determined(settled);
        }
        // Where the simulator judges, it has the last word on the keys and their
        // uncertainty too: refitted through it from where the reduced base left them,
        // and from the scene's own values of the user's keys with the effects' keys
        // where the reduced base put them. The reduced base leaves out what the
        // simulator's teeth and castors do, and the keys it traded against that (a loop
        // gain against a play) can start the simulator's fit in another valley.
        let mut starts = vec![];
        if refit {
            starts.push(self.believed_start(&settled)?);
        }
        let sim = self.stage_of(
            &settled.reached,
            &settled.free,
            false,
            crate::replay::Engine::Simulator,
            |model, slots, start| {
                let mut all = vec![start];
                all.extend(starts.iter().cloned());
                let settings = FitSettings {
                    max_iterations: SETTLING_ITERATIONS,
                    ..self.settings(slots, all)
                };
                fit_predictor_raced(model, &self.data, &settings)
            },
        )?;
        Ok(sim)
    }

    /// `stage`'s keys where it ended, the user's free keys at the scene's own values.
    fn believed_start(&self, stage: &Stage) -> Result<Vec<f64>, CalibrateError> {
        stage
            .free
            .iter()
            .enumerate()
            .map(|(i, k)| {
                if self.free.contains(k) {
                    super::keys::get(self.belief, k)
                } else {
                    Ok(stage.fit.params[i])
                }
            })
            .collect()
    }

    /// The stage with the free keys the recording cannot tell apart held: while a
    /// direction of the keys is determined by neither the recording nor a belief (a lifted
    /// motor's speed alone shows two combinations of its resistance, torque constant,
    /// inertia and friction), the user's free key with the largest share of it is held at
    /// the scene's value ([`Problem::held`]) and the others refitted. Each held key is
    /// reported as undetermined; what the recording does determine is fitted.
    pub fn determined(&self, mut stage: Stage) -> Result<Stage, CalibrateError> {
        while let Some(direction) = stage.fit.undetermined_direction.clone() {
            let weakest = stage
                .free
                .iter()
                .enumerate()
                .filter(|(_, k)| self.free.contains(k))
                .max_by(|a, b| direction[a.0].abs().total_cmp(&direction[b.0].abs()))
                .map(|(i, k)| (i, k.clone()));
            let Some((i, key)) = weakest else { break };
            if stage.free.len() < 2 {
                break;
            }
            let start = keys::get(self.belief, &key)?;
            let scene = keys::set(&stage.reached, &[(key.clone(), start)])?;
            let mut free = stage.free.clone();
            free.remove(i);
            self.held
                .lock()
                .expect("no fit panics holding it")
                .push(key);
            stage = self.fit(&scene, &free)?;
        }
        Ok(stage)
    }

    /// The values of the effect's key a scan tries: a tenth to ten times its start, nine
    /// values a factor 1.78 apart; for a key of either sign, nine values evenly across its
    /// range. The fit that follows finds the value within the basin the scan points to (a
    /// lifted wheel rattling in its play has basins narrower than a factor of 2).
    fn scan_values(home: &effects::Home) -> Vec<f64> {
        (-4..=4)
            .map(|i| match home.signed_range {
                Some(range) => range * i as f64 / 4.0,
                None => home.start * 10f64.powf(i as f64 / 4.0),
            })
            .collect()
    }

    /// Each value of the scan on `scene` (the effect switched on), the other keys held:
    /// the value and the outputs, `None` where the simulation diverged.
    fn scan(
        &self,
        scene: &Scene,
        home: &effects::Home,
    ) -> Result<Vec<(f64, Option<Outputs>)>, CalibrateError> {
        let model =
            SceneReplay::with_signed(scene, self.rec, &[home.key.to_string()], &self.signed)?
                .on(self.engine)
                .corrected(self.defect())
                .windowed(self.windows.clone());
        Ok(Self::scan_values(home)
            .par_iter()
            .map(|&v| (v, model.predict(&[v], &self.data).ok()))
            .collect())
    }

    /// The weighted residual sum of squares of `predicted` over the pose outputs alone.
    fn pose_cost(&self, predicted: &[Vec<f64>]) -> f64 {
        let r = residuals(&self.data, predicted, &self.weighting.outputs);
        let mut k = 0;
        let mut cost = 0.0;
        for (j, col) in self.data.outputs.iter().enumerate() {
            let pose = ["x_m", "y_m", "heading_rad"].contains(&self.data.output_names[j].as_str());
            for cell in col.iter().flatten() {
                let _ = cell;
                if pose {
                    cost += r[k] * r[k];
                }
                k += 1;
            }
        }
        cost
    }

    /// The weighted residual sum of squares of `predicted`.
    fn cost_of(&self, predicted: &[Vec<f64>]) -> f64 {
        residuals(&self.data, predicted, &self.weighting.outputs)
            .iter()
            .map(|r| r * r)
            .sum()
    }

    /// The lowest-cost value of a scan on `scene` (its start where nothing simulated), and
    /// its outputs. A play or a clipping limit moves the outputs in steps the gradient
    /// cannot see across, so a fit must start in the right basin.
    fn scan_start(
        &self,
        scene: &Scene,
        home: &effects::Home,
    ) -> Result<(f64, Option<Outputs>, f64), CalibrateError> {
        let scanned = self.scan(scene, home)?;
        let best = scanned
            .into_iter()
            .filter(|(_, y)| y.is_some())
            .map(|(v, y)| {
                let cost = self.cost_of(y.as_ref().expect("filtered"));
                (v, y, cost)
            })
            .reduce(|a, b| if b.2 < a.2 { b } else { a });
        Ok(best.unwrap_or((home.start, None, f64::INFINITY)))
    }

    /// An effect's key raced on a stage: scanned (the other keys held) from the stage's
    /// values and from the beliefs (a missing effect can drag the free keys far from the
    /// machine, into a basin where the effect looks like no help), then fitted with the
    /// stage's keys for [`RACE_ITERATIONS`] from each scan's best; the better fit is
    /// the race's. What it gains over the
    /// stage after those few iterations ranks the effects for their full trials.
    pub fn race(&self, stage: &Stage, home: &effects::Home) -> Result<Stage, CalibrateError> {
        let mut free = stage.free.clone();
        free.extend(home.keys().iter().map(|k| k.to_string()));
        let on_stage = effects::switched_on(&stage.scene, home)?;
        let believed = effects::switched_on(&self.with_beliefs(&stage.scene)?, home)?;
        // From each base's best scan: the effect's key and the others interact (a speed
        // loop's set-point is the torque constant's), and the lower scan can be the wrong
        // basin.
        let from = |base: Scene| -> Result<Stage, CalibrateError> {
            let start = if home.scanned {
                let (value, _, _) = self.scan_start(&base, home)?;
                keys::set(&base, &[(home.key.to_string(), value)])?
            } else {
                base
            };
            self.fit_for(&start, &free, RACE_ITERATIONS)
        };
        let (a, b) = rayon::join(|| from(on_stage), || from(believed));
        Ok(better_fit(a?, b?))
    }

    /// A race without an effect: the stage's keys alone fitted for [`RACE_ITERATIONS`] from
    /// the stage and from the beliefs, the better kept, as [`Problem::race`] does with an
    /// effect's key. On the recording's first part the keys alone gain there whatever the
    /// effect; what an effect's race gains beyond this is what the effect did.
    pub fn null_race(&self, stage: &Stage) -> Result<Stage, CalibrateError> {
        let believed = self.with_beliefs(&stage.scene)?;
        let (a, b) = rayon::join(
            || self.fit_for(&stage.scene, &stage.free, RACE_ITERATIONS),
            || self.fit_for(&believed, &stage.free, RACE_ITERATIONS),
        );
        Ok(better_fit(a?, b?))
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

    /// The effect's key fitted with the stage's, going on from its race ([`Problem::race`]),
    /// and the evidence for it against the stage.
    pub fn try_effect(
        &self,
        stage: &Stage,
        home: &effects::Home,
        raced: &Stage,
    ) -> Result<(EffectTrial, Stage), CalibrateError> {
        let next = self.fit(&raced.reached, &raced.free)?;
        let next = self.beyond_the_window(next, home, &raced.free)?;
        let n_stage = stage.effective_n(&self.data);
        // The gain is the effect's only if the stage's own physics, refitted from where the
        // effect's fit ended, does not reach it: the rough play or limit may have led the
        // free keys out of a poor minimum, which is no evidence for the effect.
        // The null fit can only lower the reference's cost: an effect that fails against
        // the stage fails against it too, and needs no null fit.
        let null = if Gain::of(&self.data, &stage.fit, &n_stage, &next.fit).passes() {
            let fitted = values(&next.scene, &stage.free)?;
            let pairs: Vec<(String, f64)> = stage.free.iter().cloned().zip(fitted).collect();
            Some(self.fit_quick(&keys::set(&stage.scene, &pairs)?, &stage.free, vec![])?)
        } else {
            None
        };
        let reference = match &null {
            Some(null) if null.fit.cost < stage.fit.cost => null,
            _ => stage,
        };
        let n_ref = reference.effective_n(&self.data);
        let trial = self.trial(home, reference, &n_ref, &next)?;
        let trial = match (&null, self.simulator_judges() && trial.accepted) {
            (Some(null), true) => self.against_the_simulators_null(home, trial, null, &next)?,
            _ => trial,
        };
        Ok((trial, next))
    }

    /// Where the simulator judges, an effect's trial that passes against a null fitted on
    /// the reduced base weighed again against the null refitted through the simulator
    /// itself (the stage's keys from where the effect's fit ended, the effect off): the
    /// two engines' optima differ, and an effect whose extra keys only move the stage's
    /// keys to where the simulator would have them anyway has no evidence of its own.
    /// The weaker of the two gains is the effect's.
    fn against_the_simulators_null(
        &self,
        home: &effects::Home,
        trial: EffectTrial,
        null: &Stage,
        next: &Stage,
    ) -> Result<EffectTrial, CalibrateError> {
        let refitted = self.through_simulator(&null.reached, &null.free)?;
        let n_ref = refitted.effective_n(&self.data);
        let again = self.trial(home, &refitted, &n_ref, next)?;
        Ok(if again.delta_aic < trial.delta_aic {
            again
        } else {
            trial
        })
    }

    /// An effect the model has, weighed against its absence: the stage's other keys fitted
    /// with the effect's key at its off value (from the stage and from the beliefs,
    /// raced), and the stage's gain over that (its key counted as fitted).
    pub fn weigh_present(
        &self,
        stage: &Stage,
        home: &effects::Home,
    ) -> Result<Presence, CalibrateError> {
        let without = home
            .off_values()
            .expect("only effects that can be taken out are weighed");
        let keys = home.keys();
        let free: Vec<String> = stage
            .free
            .iter()
            .filter(|k| !keys.contains(&k.as_str()))
            .cloned()
            .collect();
        let off_scene = keys::set(&stage.scene, &without)?;
        let believed = keys::set(&self.with_beliefs(&stage.scene)?, &without)?;
        let off = self.fit_quick(&off_scene, &free, vec![values(&believed, &free)?])?;
        let n_off = off.effective_n(&self.data);
        let gain = if free.len() < stage.free.len() || self.simulator_judges() {
            self.gain(&off, &n_off, stage)?
        } else {
            Gain::of_prediction(&self.data, &off.fit, &n_off, &stage.fit.predicted)
        };
        Ok(Presence { gain, off })
    }

    /// The wheel geometry searched on the wheels' odometry (their measured turns through
    /// the rolling law against the tracked pose, over the pose's windows: no dynamics) and
    /// confirmed through the simulator: the stage replayed with the geometry must fit the
    /// recording better than without it. Its evidence is the odometry's: the geometry
    /// against the configured one on the pose. `None` where the recording has no wheel
    /// turns to read (the geometry is then fitted through the simulator, as other
    /// effects are).
    pub fn geometry_by_odometry(
        &self,
        stage: &Stage,
        home: &effects::Home,
    ) -> Result<Option<(EffectTrial, Stage, Vec<super::KeyFit>)>, CalibrateError> {
        use super::odometry::{Odometry, KEYS};
        let Some(turns) = self.wheel_turns.clone() else {
            return Ok(None);
        };
        let others: Vec<String> = self
            .data
            .output_names
            .iter()
            .filter(|n| !["x_m", "y_m", "heading_rad"].contains(&n.as_str()))
            .cloned()
            .collect();
        let pose = self.data.without_outputs(&others);
        if pose.output_names.len() < 3 {
            return Ok(None);
        }
        let offs = home.off_values().expect("the geometry can be taken out");
        let off_of = |key: &str| {
            offs.iter()
                .find(|(k, _)| k == key)
                .map(|(_, v)| *v)
                .expect("the geometry's keys")
        };
        let configured = [off_of(KEYS[0]), off_of(KEYS[1]), off_of(KEYS[2])];
        let windows = self.windows.as_ref().and_then(|w| w.for_dataset(&pose));
        let model = WindowedOdometry {
            odometry: Odometry::new(turns, configured),
            windows,
        };
        let weights = tracker_weights(&pose);
        let settings = |free: Vec<usize>| FitSettings {
            free,
            weighting: Weighting::outputs_only(weights.clone()),
            max_iterations: MAX_ITERATIONS,
            starts: vec![configured.to_vec()],
        };
        let fail = |e: FitError| CalibrateError::Fit {
            file: self.rec.path.clone(),
            message: format!("the wheels' odometry: {e}"),
        };
        let on = fit_predictor(&model, &pose, &settings(vec![0, 1, 2])).map_err(fail)?;
        // The configured geometry: nothing free, its cost and outputs.
        let off = fit_predictor_quick(&model, &pose, &settings(vec![]), false).map_err(fail)?;
        let n_off = effective_n(&pose, &off.predicted);
        let gain = Gain::of(&pose, &off, &n_off, &on);
        // Through the simulator: the stage with the geometry, its free keys refitted.
        let pairs: Vec<(String, f64)> = KEYS
            .iter()
            .map(|k| k.to_string())
            .zip(on.params.iter().copied())
            .collect();
        let with = self.fit_quick(&keys::set(&stage.scene, &pairs)?, &stage.free, vec![])?;
        // Confirmed where the model's pose fits better with it: the wheels' speeds, read
        // through the configured geometry, do not see it.
        let confirmed = self.pose_cost(&with.fit.predicted) < self.pose_cost(&stage.fit.predicted);
        let distinct =
            (0..3).any(|i| on.std[i].is_some_and(|s| (on.params[i] - configured[i]).abs() > s));
        let gain = Gain {
            delta_aic: wald_delta_aic(&on, &configured),
            reduction: gain.reduction,
        };
        let specs = model.odometry.param_specs();
        let at_bound = (0..3)
            .find_map(|i| crate::ident::bound_reached(on.params[i], specs[i].lo, specs[i].hi));
        let trial = EffectTrial {
            accepted: gain.passes() && confirmed && distinct && at_bound.is_none(),
            ..EffectTrial::of(home, on.params[2], on.std[2], at_bound, &gain)
        };
        let fits = KEYS
            .iter()
            .enumerate()
            .map(|(i, k)| super::KeyFit {
                key: k.to_string(),
                before: keys::get(self.belief, k).unwrap_or(configured[i]),
                after: on.params[i],
                fitted: on.params[i],
                std: on.std[i],
                at_bound: None,
                held: false,
                confounded: false,
                trades_with: vec![],
            })
            .collect();
        Ok(Some((trial, with, fits)))
    }

    /// The evidence for the effect fitted in `next` against `reference`, whose effective
    /// residual counts are `n_ref`. Accepted only where the gain passes the rule and the
    /// key is an estimate: not at a bound, determined by the recording, and further from
    /// its off value than its standard deviation (a strength the recording cannot tell
    /// from none is no finding).
    pub(super) fn trial(
        &self,
        home: &effects::Home,
        reference: &Stage,
        n_ref: &[f64],
        next: &Stage,
    ) -> Result<EffectTrial, CalibrateError> {
        let gain = self.gain(reference, n_ref, next)?;
        let i = next.free.len() - 1;
        let value = next.fit.params[i];
        let std = next.fit.std[i];
        // Each of the effect's keys (the strength key last): an estimate where none is at
        // a bound, and the effect told from none where one of them lies further from its
        // off value than its standard deviation.
        let n = home.also.len() + 1;
        let offs: Vec<f64> = home
            .also
            .iter()
            .map(|c| c.off)
            .chain([home.off.unwrap_or(0.0)])
            .collect();
        let slots = next.free.len() - n..next.free.len();
        let at_bound = next
            .at_bound(i)
            .or_else(|| slots.clone().find_map(|j| next.at_bound(j)));
        let distinct = slots
            .zip(&offs)
            .any(|(j, off)| next.fit.std[j].is_some_and(|s| (next.fit.params[j] - off).abs() > s))
            && std.is_some();
        Ok(EffectTrial {
            accepted: gain.passes() && at_bound.is_none() && distinct,
            ..EffectTrial::of(home, value, std, at_bound, &gain)
        })
    }
}

/// The better of two fits of the same keys from two starts (the lower cost; the first on a
/// tie).
fn better_fit(a: Stage, b: Stage) -> Stage {
    if b.fit.cost < a.fit.cost {
        b
    } else {
        a
    }
}

/// The odometry model with its pose compared over the calibration's windows.
struct WindowedOdometry {
    odometry: super::odometry::Odometry,
    windows: Option<super::pose_windows::PoseWindows>,
}

impl Predictor for WindowedOdometry {
    fn param_specs(&self) -> &[ParamSpec] {
        self.odometry.param_specs()
    }

    fn predict(
        &self,
        p: &[f64],
        data: &Dataset,
    ) -> Result<Vec<Vec<f64>>, crate::ident::model::Diverged> {
        let mut y = self.odometry.predict(p, data)?;
        if let Some(w) = &self.windows {
            w.simulated(&mut y);
        }
        Ok(y)
    }
}

/// The values of `free` keys in `scene`.
fn values(scene: &Scene, free: &[String]) -> Result<Vec<f64>, CalibrateError> {
    free.iter().map(|k| keys::get(scene, k)).collect()
}

/// The evidence for a fitted geometry: its distance from the configured one in its own
/// covariance (the Wald statistic, the likelihood ratio's measure where the odometry's
/// residual is as correlated as a pose over a window is), less what the rule asks of
/// three keys, as an AIC gain. The effective-sample likelihood gain counts a window's
/// drift as one sample and asks far more.
fn wald_delta_aic(on: &Fit, configured: &[f64; 3]) -> f64 {
    let deviation =
        nalgebra::DVector::from_iterator(3, (0..3).map(|i| on.params[i] - configured[i]));
    let wald = on
        .covariance
        .clone()
        .pseudo_inverse(1e-30)
        .map(|inv| (deviation.transpose() * inv * &deviation)[(0, 0)])
        .unwrap_or(0.0);
    wald - 2.0 * 3.0
}

/// Each pose output's weight: one over a tracker's noise (a motion-capture or map pose:
/// 2 mm, 5 mrad, as the fitting vehicle assumes where a rig does not say). The odometry's
/// residual is that noise and the encoders' counts, not the outputs' spread, which
/// turning on the spot gives the heading alone.
fn tracker_weights(pose: &Dataset) -> Vec<f64> {
    pose.output_names
        .iter()
        .map(|n| match n.as_str() {
            "heading_rad" => 1.0 / TRACKER_HEADING_NOISE_RAD,
            _ => 1.0 / TRACKER_POSITION_NOISE_M,
        })
        .collect()
}
