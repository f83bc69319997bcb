//! Grey-box identification from recordings: pick a model structure for the rig, fit its free
//! parameters by output error (Levenberg-Marquardt, `fit`), and report each parameter with
//! its standard deviation, the loss, FPE and AIC, the fit per output and the residual
//! checks (`resid`), on the estimation recording and optionally on a validation one.
//!
//! This file is the face: the errors, the options and the re-exports. Which model a rig
//! and recording get is `structure.rs`, a run (starts, weighted fit, the record's checks)
//! `run.rs`, what it reports `identification.rs`.

pub mod activity;
pub mod data;
pub mod effects;
pub mod evaluate;
pub mod fit;
mod identification;
pub mod model;
pub mod models;
mod parameters;
pub mod plots;
pub mod report;
pub mod resid;
mod run;
mod structure;
mod sysid_law;
pub mod sysid_regression;
pub mod sysid_terms;
pub mod weighting;

use std::path::PathBuf;

use crate::record::RecordingError;
use crate::rig::{RigError, RigKind};
use fit::FitError;

pub use data::{ignored_inputs, LeftOut};
pub use evaluate::{evaluate, fit_pct, fit_pct_mean, Evaluation, OutputChecks};
pub use fit::{bound_reached, AT_BOUND_REL};
pub use identification::{param_reports, Identification, ParamReport, StateSpaceReport};
pub use run::{
    dataset_for, fit_structure, fit_weighted, identify, model_columns, predict, starts,
    MIN_VALUES_PER_PARAMETER,
};
pub(crate) use run::{diverging_start, enough_data, finite_loss};
pub use structure::{build_structure, state_beliefs, ModelChoice, Structure, BELIEF_SPAN_SD};

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
