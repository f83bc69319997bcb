//! The staged search of a calibration: the free keys fitted through the simulator (a
//! stage), an effect's key screened on a stage (scanned with the stage's keys held), an
//! effect tried on a stage (its key fitted with the stage's), an effect the scene has
//! weighed against its absence, and the evidence that decides each.
//!
//! The face holds the problem, its stage and the constants; the parts add to
//! [`Problem`]: [`stages`] (fitting the keys), [`judge`] (the simulator's say),
//! [`races`] (an effect against a stage) and [`geometry`] (the wheels' odometry).

mod geometry;
mod judge;
mod races;
mod stages;

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
    /// The reduced base's defect the fits on it carry ([`Problem::correct_at`]); retaken
    /// where a settled fit ends ([`Problem::defect_followed`]).
    pub defect: std::sync::Mutex<Option<super::defect::Defect>>,
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

/// Refits at most with the defect retaken where the last ended ([`Problem::defect_followed`]):
/// on the proof's clean base the second refit moved the keys a hundredth as far as the first.
pub(super) const DEFECT_ITERATIONS: usize = 5;

/// A key's move between two refits, in its standard deviations, below which the defect
/// has settled ([`Problem::defect_followed`]).
pub(super) const DEFECT_SETTLED_SD: f64 = 0.1;

/// Restarts of the first stage's fit at most ([`Problem::first_stage`]).
const MAX_RESTARTS: usize = 3;

/// Share of its cost a restart must remove for another to follow.
const RESTART_GAIN: f64 = 0.01;

/// Iteration limit of each fit through the simulator.
pub(super) const MAX_ITERATIONS: usize = 30;

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
            defect: std::sync::Mutex::new(self.defect()),
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
        self.defect
            .lock()
            .expect("no fit panics holding it")
            .clone()
    }

    /// Whether the fits run on the reduced base carrying a defect (a defect on the
    /// simulator would correct nothing: [`SceneReplay`] adds it on the reduced base only).
    pub fn carries_defect(&self) -> bool {
        self.engine.is_reduced() && self.defect().is_some()
    }

    /// Carries `defect` (none: `None`) from now on.
    pub fn carry_defect(&self, defect: Option<super::defect::Defect>) {
        *self.defect.lock().expect("no fit panics holding it") = defect;
    }

    /// Takes the reduced base's defect at `scene`'s keys ([`super::defect`]): from then on
    /// every fit on the reduced base predicts what the simulator replays there. `false`
    /// (and no defect) where either diverged.
    pub fn correct_at(&self, scene: &Scene) -> Result<bool, CalibrateError> {
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
        let taken = defect.is_some();
        self.carry_defect(defect);
        Ok(taken)
    }
}

/// The values of `free` keys in `scene`.
fn values(scene: &Scene, free: &[String]) -> Result<Vec<f64>, CalibrateError> {
    free.iter().map(|k| keys::get(scene, k)).collect()
}
