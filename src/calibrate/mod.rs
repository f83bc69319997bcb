//! Calibration: the simulator itself fitted to a recording. The scene's values are the
//! beliefs; the free scene keys are fitted by output error through [`crate::replay`] (the
//! simulator at the scene's fidelity, driven by the recording's inputs), with the same
//! Levenberg-Marquardt fitter and statistics as `identify`. The result is a scene: what
//! was fitted goes back into the file the user runs, and the fit is shown before and after
//! in the simulation itself.

pub mod base_limits;
pub mod defect;
pub mod diagnosis;
pub mod effects;
mod faithful;
mod first;
pub mod keys;
pub mod odometry;
pub mod pose_windows;
pub mod prove;
mod rounds;
mod search;
pub mod terms;
pub mod validation;
pub mod write;

use crate::model::base_controller::BaseParams;
use crate::model::chassis::ChassisParams;
use crate::model::motor::MotorParams;
use crate::model::wheel::WheelParams;
use crate::param::ParamKey;
use std::path::PathBuf;

use crate::ident::data::Dataset;

use crate::ident::effects::Effect;
use crate::ident::fit::Weighting;
use crate::ident::model::{Diverged, ParamSpec, Predictor};
use crate::ident::weighting::spread_weights;
use crate::record::Recording;
use crate::replay::{replay, replay_with, Drive, Engine, Replay, ReplayError};
use crate::rig::RigKind;
use crate::scene::Scene;
use search::{Problem, Stage};

/// Why a calibration cannot be done.
#[derive(Debug, thiserror::Error)]
pub enum CalibrateError {
    /// The recording could not be replayed.
    #[error(transparent)]
    Replay(#[from] ReplayError),
    /// A key that cannot be read, set or fitted, or an effect without a home here (the message names it).
    #[error("{0}")]
    Key(String),
    /// The recording lacks what calibration needs.
    #[error("{file}: {message}")]
    Recording {
        /// The recording.
        file: PathBuf,
        /// What it lacks.
        message: String,
    },
    /// The recording cannot be fitted (the message names it).
    #[error("{0}")]
    Data(String),
    /// The fit through the simulator failed.
    #[error("{file}: the fit failed: {message}")]
    Fit {
        /// The recording fitted.
        file: PathBuf,
        /// Why the fit failed.
        message: String,
    },
}

/// The contract's outputs per rig: what a real rig measures, and what a calibration fits.
pub fn contract_outputs(rig: RigKind) -> &'static [&'static str] {
    match rig {
        RigKind::DriveAxis => &[
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
pub fn default_free(rig: RigKind) -> &'static [ParamKey] {
    match rig {
        RigKind::Vehicle => &[
            MotorParams::torque_constant_nm_a,
            MotorParams::resistance_ohm,
            ChassisParams::mass_kg,
            ChassisParams::yaw_inertia_kg_m2,
        ],
        _ => &[
            MotorParams::resistance_ohm,
            MotorParams::torque_constant_nm_a,
            MotorParams::rotor_inertia_kg_m2,
            MotorParams::viscous_nm_s_rad,
        ],
    }
}

/// The keys a recording fits by default: [`default_free`], but for a vehicle driven by
/// velocity commands the chassis mass and yaw inertia and its drivers' speed-loop gains
/// (the loops hide the motor's torque constant and resistance behind their set-points).
pub fn default_free_of(rec: &Recording) -> &'static [ParamKey] {
    let velocity = crate::replay::Drive::Velocity
        .columns()
        .iter()
        .all(|c| rec.column(c).is_some());
    if rec.rig == RigKind::Vehicle && velocity {
        &[
            ChassisParams::mass_kg,
            ChassisParams::yaw_inertia_kg_m2,
            BaseParams::speed_kp_v_s_rad,
            BaseParams::speed_ki_v_rad,
        ]
    } else {
        default_free(rec.rig)
    }
}

/// The simulator replaying a recording, as a model the fitter can fit: its parameters are
/// scene keys.
pub struct SceneReplay<'a> {
    scene: Scene,
    rec: &'a Recording,
    specs: Vec<ParamSpec>,
    /// The pose compared over windows ([`pose_windows`]), where the data's pose is.
    windows: Option<pose_windows::PoseWindows>,
    /// What each evaluation replays on: the simulator, or the reduced base.
    engine: Engine,
    /// Added to the reduced base's predictions: the simulator's replay minus its own at
    /// one set of keys ([`defect::Defect`]); `None` on the simulator.
    defect: Option<defect::Defect>,
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
                    return Ok(ParamSpec {
                        rough: true,
                        ..ParamSpec::new(k, v, -range, *range).with_fd_step(1e-2)
                    });
                }
                if !(v.is_finite() && v > 0.0) {
                    return Err(CalibrateError::Key(format!(
                        "--free {k}: the scene's value is {v}; a fitted key needs a positive starting value (set one with --set {k}=...)"
                    )));
                }
                Ok(ParamSpec {
                    rough: true,
                    ..ParamSpec::positive(k, v).with_fd_step(1e-2)
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(SceneReplay {
            scene: scene.clone(),
            rec,
            specs,
            windows: None,
            engine: Engine::Simulator,
            defect: None,
        })
    }

    /// The same model with `defect` added to each prediction where it replays on the
    /// reduced base.
    pub fn corrected(mut self, defect: Option<defect::Defect>) -> Self {
        self.defect = defect;
        self
    }

    /// The same model replayed on `engine`.
    pub fn on(mut self, engine: Engine) -> Self {
        self.engine = engine;
        self
    }

    /// The same model with its pose outputs as motions over `windows` (the dataset it is
    /// fitted to has its measured pose so: [`pose_windows::PoseWindows::measured`]).
    pub fn windowed(mut self, windows: Option<pose_windows::PoseWindows>) -> Self {
        self.windows = windows;
        self
    }

    /// The same model with the beliefs of `belief` (the user's scene) on the keys in
    /// `believed` (the user's free keys) that it states an uncertainty for
    /// (`[uncertainty_pct]`): each is believed at that scene's value, as uncertain as
    /// stated, its search range widened to hold [`crate::ident::BELIEF_SPAN_SD`] standard
    /// deviations of it (as [`crate::ident::state_beliefs`] does for a rig). Any other key
    /// (an effect's strength, a key whose uncertainty the scene does not state) has no
    /// belief: the recording alone decides it.
    pub fn believing(
        mut self,
        belief: &Scene,
        believed: &[String],
    ) -> Result<Self, CalibrateError> {
        for spec in &mut self.specs {
            spec.belief_sd_rel = None;
            let Some(pct) = belief.uncertainty_pct.get(&spec.name) else {
                continue;
            };
            if !believed.contains(&spec.name) {
                continue;
            }
            let b = keys::get(belief, &spec.name)?;
            if !(b.is_finite() && b > 0.0) {
                continue;
            }
            spec.nominal = b;
            *spec = spec.clone().stated_belief(pct / 100.0);
        }
        Ok(self)
    }

    /// The same model with the search window of each of `free` (the user's free keys)
    /// anchored at `belief`'s value, a factor of 10 either way, wherever the fit starts:
    /// a key a fit left at the edge stays at the edge of the same window, so that a bound
    /// reached is reported as one, not walked past by the next fit.
    pub fn anchored(mut self, belief: &Scene, free: &[String]) -> Result<Self, CalibrateError> {
        for spec in &mut self.specs {
            // A stated belief's window is its own ([`SceneReplay::believing`]).
            if !free.contains(&spec.name)
                || spec.lo <= 0.0
                || belief.uncertainty_pct.contains_key(&spec.name)
            {
                continue;
            }
            let b = keys::get(belief, &spec.name)?;
            if b.is_finite() && b > 0.0 {
                spec.lo = spec.lo.max(0.1 * b).min(spec.nominal);
                spec.hi = spec.hi.min(10.0 * b).max(spec.nominal);
            }
        }
        Ok(self)
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
        let r = replay_with(&scene, self.rec, self.engine).map_err(|e| match e {
            ReplayError::Diverged { t_s, .. } => Diverged { t_s },
            _ => fail(),
        })?;
        let mut y = data
            .output_names
            .iter()
            .map(|n| r.output(n).map(|o| o.simulated.clone()).ok_or_else(fail))
            .collect::<Result<Vec<_>, _>>()?;
        if let Some(w) = &self.windows {
            w.simulated(&mut y);
        }
        if let (Engine::ReducedBase, Some(d)) = (self.engine, &self.defect) {
            d.correct(&mut y);
        }
        Ok(y)
    }
}

/// One fitted key.
#[derive(Debug, Clone, PartialEq)]
pub struct KeyFit {
    /// The dotted scene key.
    pub key: String,
    /// The scene's value (for an effect's key the scene did not set, the value its physics
    /// had: a tyre compound's friction).
    pub before: f64,
    /// The value the calibrated scene holds: the fitted one where it is an estimate
    /// ([`KeyFit::calibrated`]), else the scene's.
    pub after: f64,
    /// Where the fit ended, estimate or not.
    pub fitted: f64,
    /// Standard deviation of the fitted value; `None` where the record does not determine it.
    pub std: Option<f64>,
    /// The bound the search ended on, if it did: then `after` is no estimate, and the
    /// scene keeps its value (the belief or the model's structure is wrong).
    pub at_bound: Option<f64>,
    /// Held by its stated belief (`[uncertainty_pct]`): the recording determines it less
    /// well than the belief does, so `after` is more belief than data.
    pub held: bool,
    /// The recording cannot tell it apart from the other keys (a combination of them is
    /// all it shows): held at the scene's value while the others were fitted.
    pub confounded: bool,
    /// The other fitted keys it trades off against: each with the correlation of the two
    /// estimates, where its size reaches [`TRADE_OFF_CORRELATION`] (the recording shows
    /// their combination far better than either).
    pub trades_with: Vec<(String, f64)>,
}

/// The correlation of two fitted keys from which the report says they trade off: at
/// 0.99 the combination along the pair's long axis is determined seven times better than
/// either key alone (`1 / sqrt(1 - r^2)`), and a model that lacks something moves them
/// together along it.
pub const TRADE_OFF_CORRELATION: f64 = 0.99;

impl KeyFit {
    /// Whether the fit is an estimate the calibrated scene takes: not at a bound of its
    /// search, determined by the recording, and its standard deviation smaller than its
    /// value (a mass of 235 +- 294 kg says the recording cannot tell it from nothing).
    pub fn calibrated(&self) -> bool {
        self.at_bound.is_none() && self.std.is_some_and(|s| s < self.fitted.abs())
    }
}

/// An effect the scene had and the recording does not support, taken out.
#[derive(Debug, Clone, PartialEq)]
pub struct Removal {
    /// The effect.
    pub effect: Effect,
    /// The key that held its strength.
    pub key: String,
    /// The scene's value before.
    pub was: f64,
    /// The value that takes the physics out (written into the scene).
    pub off: f64,
}

/// An effect tried: its key fitted through the simulator with the scene's keys, and the
/// evidence the recording gives for it (the diagnosis's rule: an AIC gain above
/// [`crate::diagnose::MIN_DELTA_AIC`] with the effective sample count, at least
/// [`crate::diagnose::MIN_RSS_REDUCTION`] of
/// the residual removed, and the key not at a bound of its search).
#[derive(Debug, Clone, PartialEq)]
pub struct EffectTrial {
    /// The effect.
    pub effect: Effect,
    /// The scene key holding its strength.
    pub key: String,
    /// Its fitted value (the key's unit).
    pub value: f64,
    /// Its standard deviation; `None` where the record does not determine it.
    pub std: Option<f64>,
    /// The bound its search ended on, if it did: then the value is no estimate.
    pub at_bound: Option<f64>,
    /// Likelihood gain over its AIC penalty, with the effective sample count.
    pub delta_aic: f64,
    /// Share of the weighted residual removed, %.
    pub rss_reduction_pct: f64,
    /// Whether the evidence rule accepted it (written into the scene).
    pub accepted: bool,
    /// An effect the scene had that the recording does not support: taken out (its key
    /// at its off value).
    pub removed: bool,
    /// Only raced (its key scanned, then fitted with the others for a few iterations), not
    /// fitted to convergence: the round's full trials went to effects whose races gained
    /// more.
    pub raced_only: bool,
    /// Supported by the recording's fit but not confirmed (so not added): the simulator
    /// replays the recording no better with it (found on the reduced base), or the
    /// validation recordings replay no better with it.
    pub unconfirmed: Option<Unconfirmed>,
    /// An effect the scene has, supported by the recording at the scene's strength (weighed
    /// against its absence) without being refined.
    pub kept: bool,
    /// The AIC gain of the model with the effect over the model without it, where the
    /// backward pass weighed its absence.
    pub against_absence: Option<f64>,
    /// Its place among the accepted effects (1: the first accepted), where it was.
    pub accepted_as: Option<usize>,
    /// The key's value in the scene where the scene already had the effect on (then an
    /// accepted trial refines it); `None` where the effect is new to the scene.
    pub scene_value: Option<f64>,
}

impl EffectTrial {
    /// The trial of `home`'s effect with its strength key at `value`, weighed by
    /// `gain`; not (yet) accepted, removed, raced only, kept or weighed against absence.
    fn of(
        home: &effects::Home,
        value: f64,
        std: Option<f64>,
        at_bound: Option<f64>,
        gain: &crate::diagnose::evidence::Gain,
    ) -> EffectTrial {
        EffectTrial {
            effect: home.effect,
            key: home.key.to_string(),
            value,
            std,
            at_bound,
            delta_aic: gain.delta_aic,
            rss_reduction_pct: 100.0 * gain.reduction,
            accepted: false,
            removed: false,
            raced_only: false,
            unconfirmed: None,
            kept: false,
            against_absence: None,
            accepted_as: None,
            scene_value: home.in_scene.then_some(home.start),
        }
    }
}

/// What did not confirm an effect the recording's fit supported.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unconfirmed {
    /// Found on the reduced base, the simulator replays the recording no better with it.
    Simulator,
    /// The validation recordings replay no better with it.
    Validation,
}

/// A key set (not fitted) to switch an accepted effect's physics on.
#[derive(Debug, Clone, PartialEq)]
pub struct Switch {
    /// The effect switched on.
    pub effect: Effect,
    /// The dotted scene key set.
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
    pub effects: effects::Choice,
    /// Other recordings of the machine (joined): an effect is added only where it also
    /// improves their replay (a finding the other runs do not confirm is fitted noise or
    /// the fitted run's own circumstance).
    pub validate: Option<Recording>,
}

/// A calibration's result.
#[derive(Debug, Clone)]
pub struct Calibration {
    /// The fitted keys: the free ones, then the accepted effects'.
    pub keys: Vec<KeyFit>,
    /// Each effect tried, as last fitted (an accepted one as it was accepted).
    pub effects: Vec<EffectTrial>,
    /// The search for a term outside the vocabulary, where one ran (every effect offered,
    /// a lifted drive on the simulator: [`terms::searched`]).
    pub terms: Option<terms::TermSearch>,
    /// Keys set to switch the accepted effects on.
    pub switches: Vec<Switch>,
    /// Effects the scene had that the recording does not support, taken out.
    pub removed: Vec<Removal>,
    /// The outputs fitted (the contract's outputs the recording has and excites).
    pub outputs: Vec<String>,
    /// Outputs the recording has but does not excite, left out of the fit, with why.
    pub left_out: Vec<crate::ident::LeftOut>,
    /// The recording replayed on the original and on the calibrated scene.
    pub before: Replay,
    /// The recording replayed on the calibrated scene.
    pub after: Replay,
    /// The calibrated scene (the original with the fitted keys changed).
    pub scene: Scene,
    /// The scene with its free keys fitted and no effect tried yet: the nominal model
    /// fitted, which `diagnose` calls the baseline.
    pub baseline: Scene,
    /// Solver iterations in all (the keys' fit, the effects' races and fits, the
    /// settling).
    pub iterations: usize,
}

/// The drive wheels' geometry as calibrated, beside what the odometry is configured with.
#[derive(Debug, Clone, PartialEq)]
pub struct WheelGeometry {
    /// Effective rolling radii (left, right), m, each with its standard deviation.
    pub radii_m: [(f64, Option<f64>); 2],
    /// Effective track, m, with its standard deviation.
    pub track_m: (f64, Option<f64>),
    /// The radius and the wheel separation the odometry and the base controller use, m.
    pub configured_m: (f64, f64),
}

impl WheelGeometry {
    /// UMBmark's `Ed`: the right wheel's effective diameter over the left's.
    pub fn ed(&self) -> f64 {
        self.radii_m[1].0 / self.radii_m[0].0
    }

    /// UMBmark's `Eb`: the effective track over the configured wheel separation.
    pub fn eb(&self) -> f64 {
        self.track_m.0 / self.configured_m.1
    }

    /// The geometry as `diff_drive_controller`'s multipliers of the configured values
    /// (ros2_control's `wheel_separation_multiplier`, `left_wheel_radius_multiplier`,
    /// `right_wheel_radius_multiplier`): the controller and its odometry then work with
    /// the effective track and radii. Where its file already has multipliers, the new ones
    /// are these times the old.
    pub fn controller_multipliers(&self) -> ControllerMultipliers {
        ControllerMultipliers {
            wheel_separation: self.eb(),
            left_wheel_radius: self.radii_m[0].0 / self.configured_m.0,
            right_wheel_radius: self.radii_m[1].0 / self.configured_m.0,
        }
    }
}

/// `diff_drive_controller`'s geometry multipliers (dimensionless), named as its
/// parameters without the `_multiplier` suffix.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControllerMultipliers {
    /// `wheel_separation_multiplier`: effective track over the configured separation.
    pub wheel_separation: f64,
    /// `left_wheel_radius_multiplier`: the left wheel's effective radius over the
    /// configured radius.
    pub left_wheel_radius: f64,
    /// `right_wheel_radius_multiplier`: the right wheel's, likewise.
    pub right_wheel_radius: f64,
}

impl Calibration {
    /// The wheel geometry, where the calibration fitted it (the `wheel_geometry` effect,
    /// or its keys freed).
    pub fn wheel_geometry(&self) -> Option<WheelGeometry> {
        let fit = |key: &str| self.keys.iter().find(|k| k.key == key && k.calibrated());
        let (l, r, t) = (
            fit(WheelParams::left_rolling_radius_m.key())?,
            fit(WheelParams::right_rolling_radius_m.key())?,
            fit(ChassisParams::track_width_m.key())?,
        );
        let s = &self.scene;
        Some(WheelGeometry {
            radii_m: [(l.after, l.std), (r.after, r.std)],
            track_m: (t.after, t.std),
            configured_m: (
                s.base.wheel_radius_m.unwrap_or(s.wheel.radius_m),
                s.base.wheel_separation_m.unwrap_or(t.before),
            ),
        })
    }

    /// The effects accepted, in the order they were, each with its key's final value.
    pub fn accepted_in_order(&self) -> Vec<(Effect, f64)> {
        let mut accepted: Vec<&EffectTrial> = self.effects.iter().filter(|t| t.accepted).collect();
        accepted.sort_by_key(|t| t.accepted_as.unwrap_or(usize::MAX));
        accepted.iter().map(|t| (t.effect, t.value)).collect()
    }
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
    progress(match engine {
        Engine::Simulator => "replaying the recording on the scene as written",
        Engine::ReducedBase => "replaying the recording on the scene as written (the reduced base; the simulator's replay at the end)",
    });
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
    let explore = search::exploration_rows(rec).map(|rows| (rec.prefix(rows), data.prefix(rows)));
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
        match problem.engine {
            Engine::Simulator => "the simulator",
            Engine::ReducedBase => "the reduced base (each effect accepted confirmed through the simulator)",
        },
        free.len() + 1,
    ));
    // What the recording shows without dynamics (a base's limits, its wheels' geometry)
    // first: no mass or gain is to explain it.
    let found = first::found_first(&problem, scene, &tried, driven, progress)?;
    let mut fitted = free.clone();
    fitted.extend(found.extra_free.iter().cloned());
    let stage = faithful::faithful_first_stage(&mut problem, &found.scene, &fitted, progress)?;
    let baseline = stage.scene.clone();
    if problem.rejudge(&stage)? {
        progress(JUDGED_BY_THE_SIMULATOR);
    }
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
    Ok(match engine {
        Engine::Simulator => (first_look, replay(calibrated, rec)?),
        Engine::ReducedBase => {
            let (b, a) = rayon::join(|| replay(scene, rec), || replay(calibrated, rec));
            (b?, a?)
        }
    })
}

/// Said when the simulator takes over judging the evidence ([`search::Problem::rejudge`]).
pub(crate) const JUDGED_BY_THE_SIMULATOR: &str = "the reduced base and the simulator disagree here by more than a tenth of the residual: the evidence for each effect, and the keys at the end, from the simulator's replays";

/// What the fits replay on: a vehicle driven by velocity commands on the reduced base
/// ([`crate::sim::reduced`]: the same laws without rapier, the tooth mesh's sub-steps and
/// the castors' bodies), where the scene allows it; everything else on the simulator.
fn engine_for(scene: &Scene, rec: &Recording) -> Engine {
    let velocity = crate::replay::drive_of(rec).is_ok_and(|d| d == Drive::Velocity);
    let reducible = velocity
        && rec.rig == RigKind::Vehicle
        && crate::sim::reduced::ReducedBase::new(scene).is_ok();
    if reducible {
        Engine::ReducedBase
    } else {
        Engine::Simulator
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
        tracked_pose: ["x_m", "y_m", "heading_rad"].iter().all(|c| {
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
    for key in problem
        .held
        .lock()
        .expect("no fit panics holding it")
        .iter()
    {
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
    fn the_controllers_multipliers_are_the_effective_geometry_over_the_configured() {
        // A 0.4 m, 0.08 m drawing; the right wheel rolls on 1 % less, the track is 2 %
        // wider: ros2_control scales the drawing's values by these to match.
        let g = WheelGeometry {
            radii_m: [(0.08, None), (0.0792, None)],
            track_m: (0.408, None),
            configured_m: (0.08, 0.4),
        };
        let m = g.controller_multipliers();
        assert!((m.wheel_separation - 1.02).abs() < 1e-12, "{m:?}");
        assert!((m.left_wheel_radius - 1.0).abs() < 1e-12, "{m:?}");
        assert!((m.right_wheel_radius - 0.99).abs() < 1e-12, "{m:?}");
    }

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
