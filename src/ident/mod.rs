//! Grey-box identification from recordings: pick a model structure for the rig, fit its free
//! parameters by output error (Levenberg-Marquardt, `fit`), and report each parameter with
//! its standard deviation, the loss, FPE and AIC, the fit per output and the residual
//! checks (`resid`), on the estimation recording and optionally on a validation one.

pub mod activity;
pub mod data;
pub mod effects;
pub mod evaluate;
pub mod fit;
pub mod model;
pub mod models;
pub mod plots;
pub mod sysid_law;
pub mod sysid_terms;
pub mod weighting;

pub mod report;

use crate::model::motor::MotorParams;
use crate::rig::keys::alias;
pub use data::{ignored_inputs, CONTRACT_INPUTS};
pub use fit::{bound_reached, AT_BOUND_REL};
pub mod resid;

use std::path::{Path, PathBuf};
use std::str::FromStr;

use nalgebra::DMatrix;
use rand::{Rng, SeedableRng};
use serde::Serialize;

use crate::import::wpilib::feedforward;
use crate::record::{Recording, RecordingError};
use crate::rig::{Rig, RigError, RigKind};
use data::Dataset;
pub use evaluate::{evaluate, fit_pct, fit_pct_mean, Evaluation, OutputChecks};
use fit::{Fit, FitError, FitSettings};
use model::{GreyBox, Predictor};
use models::coast_down::CoastDown;
use models::dcmc_pair::{Case, DcmcPair};
use models::falling_weight::FallingWeight;
use models::linear_axis::LinearAxis;
use models::rotary_axis::{AxisInput, RotaryAxis, TorqueCommand};
use models::vehicle::Vehicle;

/// The model structures `identify` offers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModelChoice {
    /// The rig's drive axis (rotary or linear, voltage-, demand- or current-driven, open or
    /// closed loop).
    DriveAxis,
    /// The falling-weight test (motor off the vehicle).
    FallingWeight,
    /// The coast-down test.
    CoastDown,
    /// Thesis case 1.
    Gain,
    /// Thesis case 2-I.
    P,
    /// Thesis case 2-II.
    Pi,
}

impl ModelChoice {
    /// Every model's name, as the command line takes it.
    pub const NAMES: [&'static str; 6] = [
        "drive-axis",
        "falling-weight",
        "coast-down",
        "gain",
        "p",
        "pi",
    ];
}

impl FromStr for ModelChoice {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Ok(match s {
            "drive-axis" => ModelChoice::DriveAxis,
            "falling-weight" => ModelChoice::FallingWeight,
            "coast-down" => ModelChoice::CoastDown,
            "gain" => ModelChoice::Gain,
            "p" => ModelChoice::P,
            "pi" => ModelChoice::Pi,
            _ => {
                return Err(format!(
                    "unknown model `{s}`: expected one of {}",
                    ModelChoice::NAMES.join(", ")
                ))
            }
        })
    }
}

/// A concrete model structure.
#[derive(Debug, Clone)]
pub enum Structure {
    /// A rotary drive axis.
    Rotary(RotaryAxis),
    /// A linear drive axis.
    Linear(LinearAxis),
    /// The thesis's DCMC structures on two lifted drives.
    Pair(DcmcPair),
    /// The falling-weight test.
    Falling(FallingWeight),
    /// The coast-down test.
    Coast(CoastDown),
    /// The whole vehicle.
    Vehicle(Vehicle),
}

impl Structure {
    /// The structure as a grey-box model, mutably.
    pub fn model_mut(&mut self) -> &mut dyn GreyBox {
        match self {
            Structure::Rotary(m) => m,
            Structure::Linear(m) => m,
            Structure::Pair(m) => m,
            Structure::Falling(m) => m,
            Structure::Coast(m) => m,
            Structure::Vehicle(m) => m,
        }
    }

    /// The structure as a grey-box model.
    pub fn model(&self) -> &dyn GreyBox {
        match self {
            Structure::Rotary(m) => m,
            Structure::Linear(m) => m,
            Structure::Pair(m) => m,
            Structure::Falling(m) => m,
            Structure::Coast(m) => m,
            Structure::Vehicle(m) => m,
        }
    }
}

/// Why an identification could not run.
#[derive(Debug, thiserror::Error)]
pub enum IdentError {
    /// The rig does not load or lacks what the model needs.
    #[error(transparent)]
    Rig(#[from] RigError),
    /// A recording does not load.
    #[error(transparent)]
    Recording(#[from] RecordingError),
    /// The fit could not be done.
    #[error(transparent)]
    Fit(#[from] FitError),
    /// The model asked for needs another kind of rig.
    #[error("model `{model}` needs a `{want}` rig; {} is a `{have}` rig", rig.display())]
    WrongRig {
        /// The model asked for.
        model: String,
        /// The rig kind it needs.
        want: RigKind,
        /// The rig file.
        rig: PathBuf,
        /// Its kind.
        have: RigKind,
    },
    /// A `--free` name given twice.
    #[error("--free: `{name}` is given twice; name each parameter once")]
    DuplicateParameter {
        /// The parameter.
        name: String,
    },
    /// A `--free` name that is not one of the model's parameters.
    #[error(
        "--free: `{name}` is not a parameter of the {model} model; its parameters are: {known}"
    )]
    UnknownParameter {
        /// The name given.
        name: String,
        /// The model.
        model: String,
        /// Its parameters, comma-separated.
        known: String,
    },
    /// Diagnosis asked of a recording of another kind of experiment.
    #[error("{}: diagnosis works on drive-axis (rotary or linear) and vehicle recordings; this is a {model} experiment. To fit its model (parameters with their intervals, and the residual checks that say whether the model is enough) run `agvsim identify --rig {} --recording {}`; to ask which physics a model lacks, diagnose a vehicle recording (`agvsim experiment floor-run SCENE --out DIR` writes one with its rig) or a drive axis driven by voltages", file.display(), rig.display(), file.display())]
    NotDiagnosable {
        /// The recording.
        file: PathBuf,
        /// The rig file it was given with.
        rig: PathBuf,
        /// Its model.
        model: String,
    },
    /// An `--effects` name the model cannot show.
    #[error("effect `{effect}` does not apply to the {model} model; these do: {applicable}")]
    EffectNotApplicable {
        /// The effect named.
        effect: String,
        /// The model.
        model: String,
        /// The effects that apply, comma-separated.
        applicable: String,
    },
    /// The record and the model disagree (a column, a length, a divergence).
    #[error("{}: {message}", file.display())]
    Mismatch {
        /// The recording.
        file: PathBuf,
        /// What disagrees.
        message: String,
    },
}

/// Choices for one identification.
#[derive(Debug, Clone)]
pub struct IdentifyOptions {
    /// Model structure; by default from the recording's `experiment` metadata, else the
    /// rig's kind.
    pub model: Option<ModelChoice>,
    /// Free parameters by name; by default the structure's identifiable set.
    pub free: Option<Vec<String>>,
    /// Iteration limit of each start.
    pub max_iterations: usize,
    /// Number of starts (the rig's values, then seeded log-uniform perturbations within a
    /// factor of 2).
    pub starts: usize,
    /// Largest lag of the residual checks, samples.
    pub max_lag: usize,
}

impl Default for IdentifyOptions {
    fn default() -> Self {
        IdentifyOptions {
            model: None,
            free: None,
            max_iterations: 100,
            starts: 3,
            max_lag: 25,
        }
    }
}

/// Each parameter's belief as uncertain as the rig states (`[uncertainty_pct]`): a
/// parameter named by a rig key the rig gives a percentage for is held by that much
/// instead of the default ([`model::DEFAULT_BELIEF_SD_REL`]), and a positive one's search
/// reaches at least [`BELIEF_SPAN_SD`] standard deviations of that belief either side (a
/// guessed inductance, 100 %, may be several times off, beyond the factor of 3 a
/// tens-of-percent belief is searched in).
pub fn state_beliefs(model: &mut dyn GreyBox, rig: &Rig) {
    for spec in model.params_mut() {
        if let Some(pct) = rig.uncertainty_pct(&spec.name) {
            *spec = spec.clone().stated_belief(pct / 100.0);
        }
    }
}

/// How many of a stated belief's standard deviations (log scale) a positive parameter's
/// search spans either side of it, at least.
pub const BELIEF_SPAN_SD: f64 = 3.0;

/// Chooses and builds the model structure for a rig and a recording, each belief as
/// uncertain as the rig states ([`state_beliefs`]).
pub fn build_structure(
    rig: &Rig,
    rig_path: &Path,
    rec: &Recording,
    choice: Option<ModelChoice>,
) -> Result<Structure, IdentError> {
    let mut s = structure_of(rig, rig_path, rec, choice)?;
    state_beliefs(s.model_mut(), rig);
    Ok(s)
}

/// The model a recording is fitted with when none is named: its experiment's, else its
/// rig's (a drive pair's by its controller's kind).
fn default_choice(rig: &Rig, rec: &Recording) -> ModelChoice {
    match rec.meta.get("experiment").map(String::as_str) {
        Some("falling-weight") => ModelChoice::FallingWeight,
        Some("coast-down") => ModelChoice::CoastDown,
        _ => match rig.rig {
            RigKind::DrivePair => match rig.text(alias::CONTROLLER_KIND.key()) {
                Some("p") => ModelChoice::P,
                Some("pi") => ModelChoice::Pi,
                _ => ModelChoice::Gain,
            },
            _ => ModelChoice::DriveAxis,
        },
    }
}

/// The whole-vehicle model of a recording driven by motor voltages; its tyres creep
/// where the recording has a pose.
fn vehicle_structure(rig: &Rig, rig_path: &Path, rec: &Recording) -> Result<Vehicle, IdentError> {
    if rec.column("left_voltage_V").is_none() || rec.column("right_voltage_V").is_none() {
        return Err(IdentError::Mismatch {
            file: rec.path.clone(),
            message: "the whole-vehicle model is driven by `left_voltage_V` and `right_voltage_V`; recordings driven through the motor controller (`demand_fwd_pct`, `demand_turn_pct`) or by velocity commands (`cmd_linear_m_s`, `cmd_angular_rad_s`) are not supported yet; `agvsim calibrate --scene SCENE --recording REC --effects all` fits them through the simulator and finds missing physics there".into(),
        });
    }
    let mut m = Vehicle::from_rig(rig, rig_path)?;
    m.creeping_tyres = ["x_m", "y_m", "heading_rad"]
        .iter()
        .any(|c| rec.column(c).is_some());
    Ok(m)
}

/// The model structure for a rig and a recording.
fn structure_of(
    rig: &Rig,
    rig_path: &Path,
    rec: &Recording,
    choice: Option<ModelChoice>,
) -> Result<Structure, IdentError> {
    let choice = choice.unwrap_or_else(|| default_choice(rig, rec));
    if rec.rig != rig.rig {
        return Err(IdentError::Mismatch {
            file: rec.path.clone(),
            message: format!(
                "the recording is for rig `{}` but {} describes a `{}`",
                rec.rig,
                rig_path.display(),
                rig.rig
            ),
        });
    }
    let wrong_rig = |want: RigKind| IdentError::WrongRig {
        model: format!("{choice:?}").to_lowercase(),
        want,
        rig: rig_path.to_owned(),
        have: rig.rig,
    };
    Ok(match choice {
        ModelChoice::DriveAxis => {
            if rig.rig == RigKind::Vehicle {
                return Ok(Structure::Vehicle(vehicle_structure(rig, rig_path, rec)?));
            }
            if rig.rig != RigKind::DriveAxis {
                return Err(wrong_rig(RigKind::DriveAxis));
            }
            if rig.is_linear() {
                let force_input = rec.column("force_N").is_some()
                    && rec.column("command_V").is_none()
                    && rec.column("reference_m").is_none();
                let mut m = LinearAxis::from_rig(rig, rig_path, force_input)?;
                m.disturbance_input = rec.column("disturbance_force_N").is_some();
                Structure::Linear(m)
            } else {
                let has = |c: &str| rec.column(c).is_some();
                let input = if has("voltage_V") {
                    AxisInput::Voltage
                } else if has("demand_pct") {
                    AxisInput::Demand
                } else if let Some(c) = TorqueCommand::from_columns(rig, rig_path, has)? {
                    AxisInput::Torque(c)
                } else {
                    return Err(IdentError::Mismatch {
                        file: rec.path.clone(),
                        message: "no input column: a rotary drive axis needs `voltage_V`, `demand_pct`, `torque_Nm`, `command_V` (with the rig's drive.torque_per_volt_Nm_V) or `reference_rad` (with its [feedback])".into(),
                    });
                };
                Structure::Rotary(RotaryAxis::from_rig(rig, rig_path, input)?)
            }
        }
        ModelChoice::FallingWeight => {
            if rig.rig != RigKind::DriveAxis {
                return Err(wrong_rig(RigKind::DriveAxis));
            }
            Structure::Falling(FallingWeight::from_rig(rig, rig_path)?)
        }
        ModelChoice::CoastDown => {
            if rig.rig != RigKind::DriveAxis {
                return Err(wrong_rig(RigKind::DriveAxis));
            }
            let w0 = rec
                .column("motor_speed_rad_s")
                .and_then(|c| c.iter().flatten().next().copied())
                .unwrap_or(1.0);
            Structure::Coast(CoastDown::from_rig(rig, rig_path, w0)?)
        }
        ModelChoice::Gain | ModelChoice::P | ModelChoice::Pi => {
            if rig.rig != RigKind::DrivePair {
                return Err(wrong_rig(RigKind::DrivePair));
            }
            let case = match choice {
                ModelChoice::Gain => Case::Gain,
                ModelChoice::P => Case::P,
                _ => Case::Pi,
            };
            Structure::Pair(DcmcPair::from_rig(rig, rig_path, case)?)
        }
    })
}

/// One parameter as reported.
#[derive(Debug, Clone, Serialize)]
pub struct ParamReport {
    /// The parameter's name.
    pub name: String,
    /// The rig's belief.
    pub nominal: f64,
    /// The fitted (or, if fixed, the believed) value.
    pub value: f64,
    /// Standard deviation (free parameters); `null` when the data do not determine it,
    /// and when the search ended at a bound.
    pub std: Option<f64>,
    /// Whether it was fitted.
    pub free: bool,
    /// The bound of the search the value ended on, if it did: then the value is no
    /// estimate but a sign that the belief (the rig's nominal) or the model's structure is
    /// wrong.
    pub at_bound: Option<f64>,
    /// What the record alone determines of it (its standard deviation without the
    /// belief); `null` where it does not determine it at all, or it was not fitted.
    pub data_std: Option<f64>,
    /// One standard deviation of the rig's belief, % of it; `null`: no belief holds it.
    pub belief_sd_pct: Option<f64>,
    /// Held by its belief: fitted, but the record determines it less well than the rig's
    /// belief does ([`fit::Fit::held_by_belief`]), so its value is more belief than data.
    pub held: bool,
}

/// Each reported parameter of `model` as `f` fitted it.
pub fn param_reports(model: &dyn GreyBox, f: &Fit) -> Vec<ParamReport> {
    model
        .params()
        .iter()
        .enumerate()
        .filter(|(i, _)| model.reports(*i))
        .map(|(i, s)| {
            let slot = f.free.iter().position(|&j| j == i);
            let at_bound = slot.and_then(|_| bound_reached(f.params[i], s.lo, s.hi));
            ParamReport {
                name: s.name.clone(),
                nominal: s.nominal,
                value: f.params[i],
                std: if at_bound.is_some() {
                    None
                } else {
                    slot.and_then(|k| f.std[k])
                },
                free: slot.is_some(),
                at_bound,
                data_std: slot.and_then(|k| f.data_std[k]),
                belief_sd_pct: s.belief_sd_rel.map(|r| 100.0 * r),
                held: slot.is_some_and(|k| f.held_by_belief(k)),
            }
        })
        .collect()
}

/// A continuous-time state-space model with standard deviations (thesis-style tables).
#[derive(Debug, Clone, Serialize)]
pub struct StateSpaceReport {
    /// A, row by row.
    pub a: Vec<Vec<f64>>,
    /// A's standard deviations (`None`: fixed, or not determined).
    pub a_std: Vec<Vec<Option<f64>>>,
    /// B, row by row.
    pub b: Vec<Vec<f64>>,
    /// B's standard deviations.
    pub b_std: Vec<Vec<Option<f64>>>,
}

/// The result of `identify`.
#[derive(Debug, Clone, Serialize)]
pub struct Identification {
    /// The model's name.
    pub model: String,
    /// Contract input columns of the recording the model has no use for.
    pub ignored_inputs: Vec<String>,
    /// Outputs the recording measures but does not excite, left out of the fit.
    pub left_out: Vec<LeftOut>,
    /// The rig file.
    pub rig: String,
    /// Every parameter.
    pub params: Vec<ParamReport>,
    /// Free parameters.
    pub n_free: usize,
    /// Residuals (measured output cells).
    pub n_residuals: usize,
    /// Akaike's final prediction error: V (1 + d/N) / (1 - d/N).
    pub fpe: f64,
    /// N ln V + 2 d (constants of the Gaussian likelihood dropped).
    pub aic: f64,
    /// Solver iterations.
    pub iterations: usize,
    /// Model simulations.
    pub evaluations: usize,
    /// Whether the solver converged.
    pub converged: bool,
    /// Starts tried.
    pub starts: usize,
    /// The fit on the estimation record.
    pub estimation: Evaluation,
    /// The fit on the validation record.
    pub validation: Option<Evaluation>,
    /// The thesis-style A and B (the DCMC structures).
    pub state_space: Option<StateSpaceReport>,
    /// SysId's kS, kV, kA of the same record, for comparison (voltage-driven records).
    pub feedforward: Option<feedforward::Report>,
    /// All parameters' values (not serialised).
    #[serde(skip)]
    pub fitted: Vec<f64>,
}

impl Identification {
    /// A fitted parameter value by name.
    pub fn value(&self, name: &str) -> Option<f64> {
        self.params.iter().find(|p| p.name == name).map(|p| p.value)
    }

    /// A parameter's standard deviation by name.
    pub fn std(&self, name: &str) -> Option<f64> {
        self.params
            .iter()
            .find(|p| p.name == name)
            .and_then(|p| p.std)
    }
}

/// Resolves `--free` names against the model's parameters.
fn free_indices(
    model: &dyn GreyBox,
    names: &Option<Vec<String>>,
    data: &Dataset,
) -> Result<Vec<usize>, IdentError> {
    match names {
        None => Ok(model.default_free_for(data)),
        Some(names) => {
            if let Some((_, n)) = names
                .iter()
                .enumerate()
                .find(|(i, n)| names[..*i].contains(n))
            {
                return Err(IdentError::DuplicateParameter { name: n.clone() });
            }
            names
                .iter()
                .map(|n| {
                    model
                        .param_index(n)
                        .ok_or_else(|| IdentError::UnknownParameter {
                            name: n.clone(),
                            model: model.name(),
                            known: model
                                .params()
                                .iter()
                                .map(|p| p.name.as_str())
                                .collect::<Vec<_>>()
                                .join(", "),
                        })
                })
                .collect()
        }
    }
}

/// Starting points: the nominal values, then perturbations of the free parameters by
/// log-uniform factors in [1/2, 2] (seeded, so runs repeat).
pub fn starts(nominal: &[f64], free: &[usize], count: usize) -> Vec<Vec<f64>> {
    let mut rng = rand_pcg::Pcg64::seed_from_u64(0x5eed);
    let mut out = vec![nominal.to_vec()];
    for _ in 1..count.max(1) {
        let mut p = nominal.to_vec();
        for &i in free {
            let f: f64 = rng.random_range(-1.0..1.0);
            p[i] *= 2f64.powf(f);
        }
        out.push(p);
    }
    out
}

/// Fits a structure's parameters to a dataset, in two passes:
///
/// 1. each output weighted by its spread (outputs in different units count alike), every
///    believed free parameter's belief weighed against what the residual at the start is
///    worth ([`fit::Weighting::prior_for`]);
/// 2. (several outputs, or believed free parameters) each output re-weighted by its
///    residual RMS, floored at its noise level ([`weighting::output_weights`]), and the
///    beliefs kept only for the parameters the first pass found the record determines
///    less well than the belief ([`Fit::held_by_belief`]), weighed against what the first
///    pass's residual is worth; refitted from there. A parameter the record determines is
///    then the record's estimate alone; one it cannot (a mass on a quasi-static ramp) is
///    held near its belief instead of wandering to a bound.
pub fn fit_structure(
    model: &dyn GreyBox,
    data: &Dataset,
    free: &[usize],
    opts: &IdentifyOptions,
    start_from: &[f64],
) -> Result<Fit, IdentError> {
    let starts = starts(start_from, free, opts.starts);
    Ok(fit_weighted(
        model,
        data,
        free,
        opts.max_iterations,
        starts,
    )?)
}

/// The two passes of [`fit_structure`] for any [`Predictor`] (a grey box, or the simulator
/// replaying a record), from `starts` (the first one sets the first pass's prior weight).
pub fn fit_weighted(
    model: &dyn Predictor,
    data: &Dataset,
    free: &[usize],
    max_iterations: usize,
    starts: Vec<Vec<f64>>,
) -> Result<Fit, fit::FitError> {
    let weights = weighting::spread_weights(data);
    let believed = free
        .iter()
        .any(|&i| model.param_specs()[i].belief_sd_rel.is_some());
    let prior = |predicted: &[Vec<f64>], outputs: &[f64]| {
        if believed {
            fit::Weighting::prior_for(data, predicted, outputs)
        } else {
            0.0
        }
    };
    let prior0 = starts
        .first()
        .and_then(|p| model.predict(p, data).ok())
        .map_or(0.0, |y| prior(&y, &weights));
    let settings = FitSettings {
        free: free.to_vec(),
        weighting: fit::Weighting {
            outputs: weights,
            prior: prior0,
            holding: None,
        },
        max_iterations,
        starts,
    };
    let mut f = fit::fit_predictor(model, data, &settings)?;
    if data.outputs.len() > 1 || believed {
        let holding: Vec<usize> = (0..f.free.len())
            .filter(|&slot| f.held_by_belief(slot))
            .map(|slot| f.free[slot])
            .collect();
        let outputs = weighting::output_weights(data, &f.predicted);
        let weighting = fit::Weighting {
            prior: if holding.is_empty() {
                0.0
            } else {
                prior(&f.predicted, &outputs)
            },
            outputs,
            holding: Some(holding),
        };
        let second = fit::fit_predictor(
            model,
            data,
            &FitSettings {
                free: free.to_vec(),
                weighting,
                max_iterations,
                starts: vec![f.params.clone()],
            },
        )?;
        let (iterations, evaluations) = (f.iterations, f.evaluations);
        f = second;
        f.iterations += iterations;
        f.evaluations += evaluations;
    }
    Ok(f)
}

/// Identifies the rig's model from a recording (and checks it on a validation recording).
pub fn identify(
    rig: &Rig,
    rig_path: &Path,
    rec: &Recording,
    validation: Option<&Recording>,
    opts: &IdentifyOptions,
) -> Result<Identification, IdentError> {
    if let Some(v) = validation {
        if v.rig != rec.rig {
            return Err(IdentError::Mismatch {
                file: v.path.clone(),
                message: format!(
                    "the validation recording is a `{}` recording, the one identified `{}`: validate on a recording of the same rig",
                    v.rig, rec.rig
                ),
            });
        }
    }
    let structure = build_structure(rig, rig_path, rec, opts.model)?;
    let model = structure.model();
    let (data, left_out) = dataset_for(model, rec)?;
    let free = free_indices(model, &opts.free, &data)?;
    enough_data(rec, &data, free.len())?;
    let f = fit_structure(model, &data, &free, opts, &model.nominal())
        .map_err(|e| diverging_start(rec, &data, e))?;
    let estimation = evaluate(&data, f.predicted.clone(), opts.max_lag);
    finite_loss(rec, &data, &estimation)?;
    let validation = match validation {
        Some(v) => {
            let (vdata, _) = dataset_for(model, v)?;
            let y = model
                .simulate_record(&f.params, &vdata)
                .map_err(|d| IdentError::Mismatch {
                    file: v.path.clone(),
                    message: format!("the identified model {d} on the validation recording"),
                })?;
            Some(evaluate(&vdata, y, opts.max_lag))
        }
        None => None,
    };
    let mut id = assemble(&structure, &f, estimation, validation, opts.starts);
    id.ignored_inputs = ignored_inputs(rec, &model_columns(model));
    id.left_out = left_out;
    id.feedforward = feedforward::of_recording(
        rec,
        id.value(MotorParams::torque_constant_nm_a.key()),
        id.value(MotorParams::resistance_ohm.key()),
    );
    Ok(id)
}

/// An output of a record left out of the fit, and why.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LeftOut {
    /// The output column.
    pub output: String,
    /// Why the record cannot show it ([`GreyBox::unexcited_outputs`]).
    pub why: String,
}

impl LeftOut {
    /// The outputs of `unexcited` (output, why) that `data` measures, then those whose
    /// measured cells do not spread ([`Dataset::flat_outputs`]): one rule for every fit.
    pub fn of(data: &Dataset, unexcited: Vec<(String, String)>) -> Vec<LeftOut> {
        let mut left: Vec<LeftOut> = unexcited
            .into_iter()
            .filter(|(o, _)| data.output_index(o).is_some())
            .map(|(output, why)| LeftOut { output, why })
            .collect();
        for (output, why) in data.flat_outputs() {
            if !left.iter().any(|l| l.output == output) {
                left.push(LeftOut { output, why });
            }
        }
        left
    }
}

/// The dataset a model is fitted on: its inputs and the outputs the recording measures,
/// less those the recording does not excite ([`GreyBox::unexcited_outputs`]), which are
/// returned with why.
pub fn dataset_for(
    model: &dyn GreyBox,
    rec: &Recording,
) -> Result<(Dataset, Vec<LeftOut>), IdentError> {
    let data = Dataset::from_recording(rec, &model.input_names(), &model.output_names())?;
    let left = LeftOut::of(&data, model.unexcited_outputs(&data));
    if left.len() == data.output_names.len() {
        return Err(IdentError::Mismatch {
            file: rec.path.clone(),
            message: format!(
                "no output the record excites: {}",
                left.iter()
                    .map(|l| format!("{} ({})", l.output, l.why))
                    .collect::<Vec<_>>()
                    .join("; ")
            ),
        });
    }
    let names: Vec<String> = left.iter().map(|l| l.output.clone()).collect();
    Ok((data.without_outputs(&names), left))
}

/// Measured output values needed per free parameter: below this the loss, FPE and the
/// standard deviations (which divide by `N - d`) say more about the count than the
/// machine.
pub const MIN_VALUES_PER_PARAMETER: usize = 5;

/// Refuses a record too short to fit `free` parameters.
pub(crate) fn enough_data(rec: &Recording, data: &Dataset, free: usize) -> Result<(), IdentError> {
    let n = data.measured_cells();
    let need = MIN_VALUES_PER_PARAMETER * free.max(1);
    if n < need {
        return Err(IdentError::Mismatch {
            file: rec.path.clone(),
            message: format!(
                "too few samples to fit: {n} measured output values ({} rows) for {free} free parameters; at least {need} are needed ({MIN_VALUES_PER_PARAMETER} per parameter)",
                data.len()
            ),
        });
    }
    Ok(())
}

/// A model that diverges at its starting parameters: say where in the recording, and what
/// in it could be at fault (a huge input cell, a long gap in time), not only the rig.
pub(crate) fn diverging_start(rec: &Recording, data: &Dataset, e: IdentError) -> IdentError {
    let IdentError::Fit(fit::FitError::DivergesAtStart { t_s }) = e else {
        return e;
    };
    let largest = data
        .inputs
        .iter()
        .flatten()
        .fold(0.0f64, |m, v| m.max(v.abs()));
    let gap = data
        .t_s
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(0.0f64, f64::max);
    IdentError::Mismatch {
        file: rec.path.clone(),
        message: format!(
            "the model diverges from the rig's values at t = {t_s} s of this recording: check its inputs there (largest |input| in the record {largest:e}; longest gap between samples {gap:.3} s) and the rig's values"
        ),
    }
}

/// Refuses a fit whose loss is not a finite positive number: a cell too large to square,
/// or a record the model reproduces exactly (no noise left to estimate anything from).
pub(crate) fn finite_loss(
    rec: &Recording,
    data: &Dataset,
    e: &Evaluation,
) -> Result<(), IdentError> {
    if e.loss.is_finite() && e.loss > 0.0 && e.fit_pct.values().all(|f| f.is_finite()) {
        return Ok(());
    }
    let largest = data
        .inputs
        .iter()
        .flatten()
        .copied()
        .chain(data.outputs.iter().flatten().flatten().copied())
        .fold(0.0f64, |m, v| m.max(v.abs()));
    // A determinant of residual covariances can come out a rounding error below zero.
    let why = if e.loss.is_finite() && e.loss.abs() < 1e-12 {
        "the model reproduces the record exactly, so there is no residual to estimate the noise, the standard deviations or the FPE from".to_string()
    } else {
        format!("a cell is too large for the fit's arithmetic (largest |value| {largest:e}); check the recording's inputs and outputs")
    };
    Err(IdentError::Mismatch {
        file: rec.path.clone(),
        message: format!("the fit's loss is {}: {why}", e.loss),
    })
}

fn assemble(
    structure: &Structure,
    f: &Fit,
    estimation: Evaluation,
    validation: Option<Evaluation>,
    starts: usize,
) -> Identification {
    let model = structure.model();
    let params = param_reports(model, f);
    let d = f.free.len() as f64;
    let n = estimation.n_samples as f64;
    let v = estimation.loss;
    let state_space = match structure {
        Structure::Pair(pair) => Some(state_space_report(pair, f)),
        _ => None,
    };
    Identification {
        model: model.name(),
        ignored_inputs: Vec::new(),
        left_out: Vec::new(),
        rig: String::new(),
        params,
        n_free: f.free.len(),
        n_residuals: f.n_residuals,
        fpe: v * (1.0 + d / n) / (1.0 - d / n),
        aic: n * v.ln() + 2.0 * d,
        iterations: f.iterations,
        evaluations: f.evaluations,
        converged: f.converged,
        starts,
        estimation,
        validation,
        state_space,
        feedforward: None,
        fitted: f.params.clone(),
    }
}

/// A and B of a DCMC pair with standard deviations by the delta method (A and B are
/// functions of the parameters; their covariance is G Cov G').
fn state_space_report(pair: &DcmcPair, f: &Fit) -> StateSpaceReport {
    let flatten = |p: &[f64]| {
        let (a, b) = pair.state_space(p);
        a.iter().chain(b.iter()).copied().collect::<Vec<f64>>()
    };
    let base = flatten(&f.params);
    let d = f.free.len();
    let undetermined = f.std.iter().any(|s| s.is_none());
    let mut g = DMatrix::zeros(base.len(), d);
    for (c, &i) in f.free.iter().enumerate() {
        let h = 1e-7 * f.params[i].abs().max(1e-9);
        let mut p = f.params.clone();
        p[i] += h;
        for (r, v) in flatten(&p).iter().enumerate() {
            g[(r, c)] = (v - base[r]) / h;
        }
    }
    let cov = &g * &f.covariance * g.transpose();
    let (a, b) = pair.state_space(&f.params);
    let nx = a.nrows();
    let std_of = |flat: usize| {
        // An entry that depends on an undetermined parameter is itself undetermined.
        let depends_on_undetermined = f
            .std
            .iter()
            .enumerate()
            .any(|(c, s)| s.is_none() && g[(flat, c)].abs() > 0.0);
        (!(undetermined && depends_on_undetermined)).then(|| cov[(flat, flat)].max(0.0).sqrt())
    };
    // nalgebra stores column-major: entry (r, c) of A is flat index c * nx + r.
    StateSpaceReport {
        a: (0..nx)
            .map(|r| (0..nx).map(|c| a[(r, c)]).collect())
            .collect(),
        a_std: (0..nx)
            .map(|r| (0..nx).map(|c| std_of(c * nx + r)).collect())
            .collect(),
        b: (0..nx)
            .map(|r| (0..2).map(|c| b[(r, c)]).collect())
            .collect(),
        b_std: (0..nx)
            .map(|r| (0..2).map(|c| std_of(nx * nx + c * nx + r)).collect())
            .collect(),
    }
}

/// Simulates a structure at given parameters on a recording (for diagnosis and checks).
pub fn predict(
    structure: &Structure,
    params: &[f64],
    rec: &Recording,
) -> Result<(Dataset, Vec<Vec<f64>>), IdentError> {
    let model = structure.model();
    let data = Dataset::from_recording(rec, &model.input_names(), &model.output_names())?;
    let y = model
        .simulate_record(params, &data)
        .map_err(|d| IdentError::Mismatch {
            file: rec.path.clone(),
            message: format!("the model {d}"),
        })?;
    Ok((data, y))
}

/// A model's input and output columns: what a recording's columns are checked against.
pub fn model_columns(model: &dyn GreyBox) -> Vec<String> {
    model
        .input_names()
        .into_iter()
        .chain(model.output_names())
        .collect()
}
