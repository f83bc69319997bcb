//! Output-error fitting: Levenberg-Marquardt on the simulated outputs of a grey-box model,
//! within physical bounds, each believed parameter held towards the rig's belief by its
//! prior (a maximum a posteriori fit), with a covariance that holds on real records
//! (`covariance`: a block sandwich over the residual's correlation time, combined with
//! the priors).
//!
//! Positive-bounded parameters are searched on a log scale (so a step can never make a
//! resistance negative and relative precision is uniform); others on a linear scale
//! normalised by their nominal magnitude. The Jacobian is by forward differences, one
//! simulation per free parameter, in parallel. The search is `lm`, the covariance
//! `uncertainty`, the problem in its search coordinates `problem`; this module holds the
//! weighting and the starts.

use nalgebra::{DMatrix, DVector};

use super::data::Dataset;
use super::model::{GreyBox, ParamSpec, Predictor};

mod lm;
mod problem;
mod uncertainty;
use lm::*;
use problem::{Coord, Problem};
pub use uncertainty::MIN_COVARIANCE_BLOCKS;
use uncertainty::*;

/// How a fit weighs what it minimises: each output's residuals by its weight, and each
/// believed parameter's squared standardised distance from its belief by `prior`.
///
/// With the output weights at 1 / (each output's residual RMS) the weighted residuals have
/// unit variance, and `prior` = N / N_eff, the measured cells over the residual's
/// effective number of independent samples: a coloured residual (model mismatch, slow
/// disturbances) is worth far fewer samples than it has, and the beliefs must weigh
/// against what the record is worth, not against its row count ([`Weighting::prior_for`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Weighting {
    /// Per-output weights (1 / expected residual RMS, the output's unit), in the dataset's
    /// output order.
    pub outputs: Vec<f64>,
    /// Weight of the beliefs' squared standardised deviations; 0: no priors.
    pub prior: f64,
    /// Which parameters' beliefs count (indices into the model's parameters); `None`:
    /// every believed one. A fit holds only what the record cannot determine better than
    /// the belief ([`Fit::held_by_belief`]): a determined parameter's estimate is then the
    /// record's alone, whatever the belief.
    pub holding: Option<Vec<usize>>,
}

impl Weighting {
    /// Output weights alone, no priors.
    pub fn outputs_only(outputs: Vec<f64>) -> Weighting {
        Weighting {
            outputs,
            prior: 0.0,
            holding: None,
        }
    }

    /// Whether the belief of parameter `i` counts.
    pub fn holds(&self, i: usize) -> bool {
        self.holding.as_ref().is_none_or(|h| h.contains(&i))
    }

    /// The beliefs' part of the cost at `p` (unweighted): squared [`belief_deviations`]
    /// over the parameters this weighting holds.
    pub fn belief_sq(&self, specs: &[ParamSpec], p: &[f64]) -> f64 {
        self.belief_deviations(specs, p).map(|d| d * d).sum()
    }

    /// [`belief_deviations`] over the parameters this weighting holds.
    pub fn belief_deviations<'a>(
        &'a self,
        specs: &'a [ParamSpec],
        p: &'a [f64],
    ) -> impl Iterator<Item = f64> + 'a {
        belief_deviations(specs, p)
            .filter(|(i, _)| self.holds(*i))
            .map(|(_, d)| d)
    }

    /// The prior weight that puts the beliefs on the scale of what the record is worth at
    /// `predicted`: the weighted residual sum of squares there over the residual's
    /// effective number of independent samples (each output's residual decorrelation,
    /// [`super::weighting::effective_n`]).
    pub fn prior_for(data: &Dataset, predicted: &[Vec<f64>], outputs: &[f64]) -> f64 {
        let rss = sum_sq(&residuals(data, predicted, outputs));
        let n_eff: f64 = super::weighting::effective_n(data, predicted).iter().sum();
        if rss > 0.0 && n_eff > 0.0 {
            rss / n_eff
        } else {
            0.0
        }
    }
}

/// Settings of one fit.
#[derive(Debug, Clone)]
pub struct FitSettings {
    /// Indices of the free parameters.
    pub free: Vec<usize>,
    /// How outputs and beliefs are weighed.
    pub weighting: Weighting,
    /// Iteration limit of each start.
    pub max_iterations: usize,
    /// Full parameter vectors to start from; the best result wins.
    pub starts: Vec<Vec<f64>>,
}

/// The result of a fit.
#[derive(Debug, Clone)]
pub struct Fit {
    /// All parameters, fitted where free.
    pub params: Vec<f64>,
    /// Indices of the free parameters.
    pub free: Vec<usize>,
    /// Standard deviation of each free parameter, the record and the belief together;
    /// `None` where neither determines it (no prior, and a direction of the data's
    /// information that is numerically zero).
    pub std: Vec<Option<f64>>,
    /// What the record alone determines of each free parameter (its standard deviation
    /// without the prior); `None` where it does not determine it at all.
    pub data_std: Vec<Option<f64>>,
    /// The prior's standard deviation of each free parameter (physical units, at the
    /// fitted value); `None`: no belief holds it.
    pub prior_std: Vec<Option<f64>>,
    /// Covariance of the free parameters (physical units).
    pub covariance: DMatrix<f64>,
    /// What the fit minimised: the weighted residual sum of squares plus the weighted
    /// beliefs' deviations (`weighting.prior x prior_sq`).
    pub cost: f64,
    /// Sum of the believed parameters' squared standardised deviations from their beliefs
    /// (the priors' part of -2 ln posterior).
    pub prior_sq: f64,
    /// Number of residuals (measured output cells).
    pub n_residuals: usize,
    /// Rows of the blocks the covariance treats as independent (the residual's
    /// correlation time, in samples; 1 for a white residual).
    pub correlation_rows: usize,
    /// Solver iterations.
    pub iterations: usize,
    /// Model simulations.
    pub evaluations: usize,
    /// Whether the step or the gain fell below the tolerance.
    pub converged: bool,
    /// Index of the start that won.
    pub start_index: usize,
    /// The outputs at the fitted parameters, `[output][row]`.
    pub predicted: Vec<Vec<f64>>,
    /// The weighting used.
    pub weighting: Weighting,
    /// A direction of the free parameters (search coordinates, unit length, in the order
    /// of `free`) that neither the record nor a belief determines, where there is one: the
    /// parameters with a large share of it can only be told apart by holding one.
    pub undetermined_direction: Option<Vec<f64>>,
}

impl Fit {
    /// The weighted residual sum of squares alone (the cost less the beliefs' part).
    pub fn rss(&self) -> f64 {
        self.cost - self.weighting.prior * self.prior_sq
    }

    /// Whether free parameter `slot` is held by its belief rather than determined by the
    /// record: its prior is tighter than what the record alone determines (the estimate is
    /// more belief than data), or the record does not determine it at all.
    pub fn held_by_belief(&self, slot: usize) -> bool {
        match (self.prior_std[slot], self.data_std[slot]) {
            (Some(prior), Some(data)) => data > prior,
            (Some(_), None) => true,
            (None, _) => false,
        }
    }
}

/// Why a fit could not be done.
#[derive(Debug, thiserror::Error)]
pub enum FitError {
    /// The model diverges at its starting parameters.
    #[error("the model diverges at its starting parameters (t = {t_s} s); check the rig's values")]
    DivergesAtStart {
        /// When, s.
        t_s: f64,
    },
    /// More free parameters than the record has residuals.
    #[error("{free} free parameters but only {residuals} measured output values")]
    TooFewData {
        /// Free parameters.
        free: usize,
        /// Residuals the record has.
        residuals: usize,
    },
    /// No start was given.
    #[error("no starting point simulates over the record")]
    NoStart,
}

/// Weighted residuals `w_j (y - yhat)` over every measured cell, output by output.
pub fn residuals(data: &Dataset, predicted: &[Vec<f64>], weights: &[f64]) -> Vec<f64> {
    let mut r = Vec::with_capacity(data.measured_cells());
    for (j, col) in data.outputs.iter().enumerate() {
        for (k, y) in col.iter().enumerate() {
            if let Some(y) = y {
                r.push(weights[j] * (y - predicted[j][k]));
            }
        }
    }
    r
}

/// What a fit minimises, for `model` at `p` on `data` (infinite where the model diverges):
/// the weighted residual sum of squares plus the weighted beliefs, for searches that place
/// one parameter.
pub fn cost_at(model: &dyn GreyBox, p: &[f64], data: &Dataset, w: &Weighting) -> f64 {
    super::activity::count_evaluation();
    model
        .predict(p, data)
        .map(|y| {
            sum_sq(&residuals(data, &y, &w.outputs)) + w.prior * w.belief_sq(model.params(), p)
        })
        .unwrap_or(f64::INFINITY)
}

/// Each believed parameter's index and distance from its belief in standard deviations:
/// on the log scale for a positive-bounded parameter (a log-normal belief), linearly
/// otherwise.
pub fn belief_deviations<'a>(
    specs: &'a [ParamSpec],
    p: &'a [f64],
) -> impl Iterator<Item = (usize, f64)> + 'a {
    specs.iter().zip(p).enumerate().filter_map(|(i, (s, &v))| {
        let rel = s.belief_sd_rel?;
        Some((
            i,
            match coord_of(s) {
                Coord::Log => (v / s.nominal).ln() / rel.ln_1p(),
                Coord::Linear { .. } => (v - s.nominal) / (rel * s.nominal.abs()),
            },
        ))
    })
}

/// Each free parameter's prior standard deviation in the search coordinate.
fn prior_sd_z(
    specs: &[ParamSpec],
    free: &[usize],
    coords: &[Coord],
    w: &Weighting,
) -> Vec<Option<f64>> {
    free.iter()
        .zip(coords)
        .map(|(&i, c)| {
            let rel = specs[i].belief_sd_rel.filter(|_| w.holds(i))?;
            Some(match c {
                Coord::Log => rel.ln_1p(),
                Coord::Linear { scale } => rel * specs[i].nominal.abs() / scale,
            })
        })
        .collect()
}

/// Smallest finite-difference step of the covariance's Jacobian in the search coordinate
/// (0.1 % of a log-scaled parameter).
pub const COVARIANCE_FD_STEP: f64 = 1e-3;

fn sum_sq(r: &[f64]) -> f64 {
    r.iter().map(|v| v * v).sum()
}

/// Fits the free parameters from each start and keeps the best.
pub fn fit(model: &dyn GreyBox, data: &Dataset, s: &FitSettings) -> Result<Fit, FitError> {
    fit_predictor(model, data, s)
}

/// [`fit`] with the starts raced: [`RACE_ITERATIONS`] from each, then the leader alone to
/// convergence. For starts that differ in one placed parameter on a fitted model (a
/// candidate effect on a converged baseline), where the ranking after a few iterations
/// is the final one; from widely spread starts (an identification from perturbed beliefs)
/// a slow start can overtake, so [`fit`] runs them all.
pub fn fit_raced(model: &dyn GreyBox, data: &Dataset, s: &FitSettings) -> Result<Fit, FitError> {
    best_of_starts(model, data, s, true, true)
}

/// The parameters and cost of a fit, without its uncertainty: for the intermediate fits of
/// a search (a profile, an alternation), where the covariance's extra Jacobian would be
/// thrown away.
#[derive(Debug, Clone)]
pub struct Minimum {
    /// All parameters at the minimum.
    pub params: Vec<f64>,
    /// Weighted residual sum of squares there.
    pub cost: f64,
}

/// [`fit`] without the covariance.
pub fn minimise(model: &dyn GreyBox, data: &Dataset, s: &FitSettings) -> Result<Minimum, FitError> {
    best_of_starts(model, data, s, false, false).map(|f| Minimum {
        params: f.params,
        cost: f.cost,
    })
}

/// [`fit`] for any [`Predictor`]: the simulator replaying a record as well as a grey box.
pub fn fit_predictor(
    model: &dyn Predictor,
    data: &Dataset,
    s: &FitSettings,
) -> Result<Fit, FitError> {
    best_of_starts(model, data, s, true, false)
}

/// [`fit_predictor`] without the covariance (its standard deviations `None`): for the
/// intermediate fits of a search, whose uncertainty would be thrown away (`race`: the
/// starts raced, as [`fit_raced`] races them).
pub fn fit_predictor_quick(
    model: &dyn Predictor,
    data: &Dataset,
    s: &FitSettings,
    race: bool,
) -> Result<Fit, FitError> {
    best_of_starts(model, data, s, false, race)
}

/// [`fit_predictor`] with the starts raced, as [`fit_raced`] races them.
pub fn fit_predictor_raced(
    model: &dyn Predictor,
    data: &Dataset,
    s: &FitSettings,
) -> Result<Fit, FitError> {
    best_of_starts(model, data, s, true, true)
}

/// Runs the solver from each start and keeps the lowest cost; the covariance (one more
/// Jacobian) only when `uncertainty` is asked for.
fn best_of_starts(
    model: &dyn Predictor,
    data: &Dataset,
    s: &FitSettings,
    uncertainty: bool,
    race: bool,
) -> Result<Fit, FitError> {
    let n_res = data.measured_cells();
    if n_res <= s.free.len() {
        return Err(FitError::TooFewData {
            free: s.free.len(),
            residuals: n_res,
        });
    }
    let problem = |start: &[f64]| Problem {
        model,
        data,
        base: start.to_vec(),
        free: s.free.clone(),
        coords: coords(model.param_specs(), &s.free),
        weighting: &s.weighting,
    };
    if !race || s.starts.len() == 1 {
        let fits = each_start(&s.starts, &problem, s.max_iterations, uncertainty)?;
        return Ok(lowest(fits));
    }
    // A race: a few iterations from every start (enough for each to reach the bottom of
    // its basin's steep part), then only the leader to convergence.
    let raced = each_start(
        &s.starts,
        &problem,
        RACE_ITERATIONS.min(s.max_iterations),
        false,
    )?;
    let spent = raced
        .iter()
        .fold((0, 0), |(i, e), f| (i + f.iterations, e + f.evaluations));
    let leader = lowest(raced);
    let rest = s.max_iterations.saturating_sub(leader.iterations);
    let mut f = run_lm(&problem(&leader.params), rest, uncertainty)?;
    f.start_index = leader.start_index;
    f.iterations += spent.0;
    f.evaluations += spent.1;
    Ok(f)
}

/// The solver run from each start for `iterations`: every fit that could be made (with its
/// start's index), or the first start's error when none could. The starts run at once
/// (each fit depends on its start alone, so the result is the same as one after another):
/// a fit's Jacobian keeps the workers busy only while it has columns left, and its trial
/// steps are one evaluation at a time.
fn each_start<'a>(
    starts: &[Vec<f64>],
    problem: &(dyn Fn(&[f64]) -> Problem<'a> + Sync),
    iterations: usize,
    uncertainty: bool,
) -> Result<Vec<Fit>, FitError> {
    use rayon::prelude::*;
    let mut fits = Vec::new();
    let mut first_error = None;
    let outcomes: Vec<Result<Fit, FitError>> = starts
        .par_iter()
        .map(|start| run_lm(&problem(start), iterations, uncertainty))
        .collect();
    for (si, outcome) in outcomes.into_iter().enumerate() {
        match outcome {
            Ok(mut f) => {
                f.start_index = si;
                fits.push(f);
            }
            Err(e) => {
                first_error.get_or_insert(e);
            }
        }
    }
    if fits.is_empty() {
        return Err(first_error.unwrap_or(FitError::NoStart));
    }
    Ok(fits)
}

/// The fit of lowest cost (the earlier start on a tie) of a non-empty list.
fn lowest(fits: Vec<Fit>) -> Fit {
    fits.into_iter()
        .reduce(|best, f| if f.cost < best.cost { f } else { best })
        .expect("each_start returns at least one fit")
}

/// Relative cost decrease below which a step counts as no progress (two in a row end the
/// search).
pub const SMALL_GAIN: f64 = 1e-4;

/// Iterations every start of a multi-start fit is given before only the leader goes on.
pub const RACE_ITERATIONS: usize = 3;

/// Relative distance from a search bound within which a fitted value counts as on it.
pub const AT_BOUND_REL: f64 = 1e-3;

/// The bound `value` sits on, if any (relative to the bound's size, or absolutely for a
/// bound at zero).
pub fn bound_reached(value: f64, lo: f64, hi: f64) -> Option<f64> {
    [lo, hi]
        .into_iter()
        .filter(|b| b.is_finite())
        .find(|b| (value - b).abs() <= AT_BOUND_REL * b.abs().max(1e-12))
}
