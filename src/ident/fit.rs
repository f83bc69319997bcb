//! Output-error fitting: Levenberg-Marquardt on the simulated outputs of a grey-box model,
//! within physical bounds, with the parameter covariance from the Jacobian and the residual
//! variance.
//!
//! Positive-bounded parameters are searched on a log scale (so a step can never make a
//! resistance negative and relative precision is uniform); others on a linear scale
//! normalised by their nominal magnitude. The Jacobian is by forward differences, one
//! simulation per free parameter, in parallel.

use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

use super::data::Dataset;
use super::model::{GreyBox, ParamSpec, Predictor};

/// How a free parameter is searched.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Coord {
    Log,
    Linear { scale: f64 },
}

/// Settings of one fit.
#[derive(Debug, Clone)]
pub struct FitSettings {
    /// Indices of the free parameters.
    pub free: Vec<usize>,
    /// Per-output weights (1 / expected residual RMS), in the dataset's output order.
    pub weights: Vec<f64>,
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
    /// Standard deviation of each free parameter; `None` where the data do not determine
    /// it (a direction of the Fisher information that is numerically zero).
    pub std: Vec<Option<f64>>,
    /// Covariance of the free parameters (physical units).
    pub covariance: DMatrix<f64>,
    /// Weighted residual sum of squares.
    pub cost: f64,
    /// Number of residuals (measured output cells).
    pub n_residuals: usize,
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
    /// The per-output weights used.
    pub weights: Vec<f64>,
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

/// Weighted residual sum of squares of `model` at `p` on `data` (infinite where the model
/// diverges): the cost the fits minimise, for searches that place one parameter.
pub fn cost_at(model: &dyn GreyBox, p: &[f64], data: &Dataset, weights: &[f64]) -> f64 {
    super::activity::count_evaluation();
    model
        .predict(p, data)
        .map(|y| sum_sq(&residuals(data, &y, weights)))
        .unwrap_or(f64::INFINITY)
}

struct Problem<'a> {
    model: &'a dyn Predictor,
    data: &'a Dataset,
    base: Vec<f64>,
    free: Vec<usize>,
    coords: Vec<Coord>,
    weights: &'a [f64],
}

impl Problem<'_> {
    fn to_z(&self, p: &[f64]) -> Vec<f64> {
        self.free
            .iter()
            .zip(&self.coords)
            .map(|(&i, c)| match c {
                Coord::Log => p[i].ln(),
                Coord::Linear { scale } => p[i] / scale,
            })
            .collect()
    }

    fn to_p(&self, z: &[f64]) -> Vec<f64> {
        let specs = self.model.param_specs();
        let mut p = self.base.clone();
        for ((&i, c), zi) in self.free.iter().zip(&self.coords).zip(z) {
            let v = match c {
                Coord::Log => zi.exp(),
                Coord::Linear { scale } => zi * scale,
            };
            p[i] = v.clamp(specs[i].lo, specs[i].hi);
        }
        p
    }

    /// Bounds of the search coordinates.
    fn z_bounds(&self) -> (Vec<f64>, Vec<f64>) {
        let specs = self.model.param_specs();
        let z = |c: &Coord, v: f64| match c {
            Coord::Log => v.ln(),
            Coord::Linear { scale } => v / scale,
        };
        let lo = self
            .free
            .iter()
            .zip(&self.coords)
            .map(|(&i, c)| z(c, specs[i].lo))
            .collect();
        let hi = self
            .free
            .iter()
            .zip(&self.coords)
            .map(|(&i, c)| z(c, specs[i].hi))
            .collect();
        (lo, hi)
    }

    /// dp/dz for each free parameter at p.
    fn dp_dz(&self, p: &[f64]) -> Vec<f64> {
        self.free
            .iter()
            .zip(&self.coords)
            .map(|(&i, c)| match c {
                Coord::Log => p[i],
                Coord::Linear { scale } => *scale,
            })
            .collect()
    }

    fn residuals(&self, z: &[f64]) -> Option<Vec<f64>> {
        self.simulated(z).map(|(r, _)| r)
    }

    /// The weighted residuals at `z` and the outputs they come from.
    fn simulated(&self, z: &[f64]) -> Option<(Vec<f64>, Vec<Vec<f64>>)> {
        let p = self.to_p(z);
        super::activity::count_evaluation();
        let y = self.model.predict(&p, self.data).ok()?;
        let r = residuals(self.data, &y, self.weights);
        r.iter().all(|v| v.is_finite()).then_some((r, y))
    }

    fn jacobian(&self, z: &[f64], r0: &[f64]) -> DMatrix<f64> {
        let cols: Vec<Vec<f64>> = (0..z.len())
            .into_par_iter()
            .map(|c| {
                let step = self.model.param_specs()[self.free[c]].fd_step;
                let h = step * z[c].abs().max(1.0);
                let mut zc = z.to_vec();
                zc[c] += h;
                let (h, r) = match self.residuals(&zc) {
                    Some(r) => (h, r),
                    None => {
                        // At a bound or a divergence edge, difference backwards.
                        zc[c] = z[c] - h;
                        match self.residuals(&zc) {
                            Some(r) => (-h, r),
                            None => return vec![0.0; r0.len()],
                        }
                    }
                };
                r.iter().zip(r0).map(|(a, b)| (a - b) / h).collect()
            })
            .collect();
        DMatrix::from_fn(r0.len(), z.len(), |i, j| cols[j][i])
    }
}

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
        weights: &s.weights,
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
/// start's index), or the first start's error when none could.
fn each_start<'a>(
    starts: &[Vec<f64>],
    problem: &dyn Fn(&[f64]) -> Problem<'a>,
    iterations: usize,
    uncertainty: bool,
) -> Result<Vec<Fit>, FitError> {
    let mut fits = Vec::new();
    let mut first_error = None;
    for (si, start) in starts.iter().enumerate() {
        match run_lm(&problem(start), iterations, uncertainty) {
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

/// How each free parameter is searched: positive-bounded ones on a log scale, others
/// linearly, scaled by their belief (or by their range when the belief is zero).
fn coords(specs: &[ParamSpec], free: &[usize]) -> Vec<Coord> {
    free.iter()
        .map(|&i| {
            if specs[i].lo > 0.0 {
                Coord::Log
            } else {
                Coord::Linear {
                    scale: if specs[i].nominal != 0.0 {
                        specs[i].nominal.abs()
                    } else if specs[i].hi.is_finite() && specs[i].hi > 0.0 {
                        0.1 * specs[i].hi
                    } else {
                        1e-9
                    },
                }
            }
        })
        .collect()
}

fn run_lm(pb: &Problem, max_iterations: usize, uncertainty: bool) -> Result<Fit, FitError> {
    let start_p = pb.to_p(&pb.to_z(&pb.base));
    let mut z = pb.to_z(&start_p);
    let (mut r, mut predicted) = match pb.simulated(&z) {
        Some(ry) => ry,
        None => {
            let t_s = pb
                .model
                .predict(&start_p, pb.data)
                .err()
                .map(|d| d.t_s)
                .unwrap_or(f64::NAN);
            return Err(FitError::DivergesAtStart { t_s });
        }
    };
    let mut cost = sum_sq(&r);
    let mut lambda = 1e-3;
    let mut evaluations = 1;
    let mut iterations = 0;
    let mut converged = z.is_empty();
    let mut small_steps = 0;
    let n = z.len();
    while iterations < max_iterations && !converged {
        iterations += 1;
        super::activity::count_iteration();
        let jac = pb.jacobian(&z, &r);
        evaluations += n;
        let h = jac.transpose() * &jac;
        let g = jac.transpose() * DVector::from_vec(r.clone());
        let mut improved = false;
        for _ in 0..12 {
            let mut a = h.clone();
            for i in 0..n {
                a[(i, i)] += lambda * h[(i, i)].max(1e-12);
            }
            // Damped Gauss-Newton: dz = -(J'J + lambda diag(J'J))^-1 J'r, with parameters
            // at a bound that the step would push through held there (an active set): a
            // clamped component would otherwise bend every other component of the step.
            let (zlo, zhi) = pb.z_bounds();
            let mut held = vec![false; n];
            let step = loop {
                let mut a = a.clone();
                let mut g = g.clone();
                for i in (0..n).filter(|&i| held[i]) {
                    for j in 0..n {
                        a[(i, j)] = 0.0;
                        a[(j, i)] = 0.0;
                    }
                    a[(i, i)] = 1.0;
                    g[i] = 0.0;
                }
                let Some(step) = (match a.clone().cholesky() {
                    Some(c) => Some(c.solve(&g)),
                    None => a.lu().solve(&g),
                }) else {
                    break None;
                };
                let tol = 1e-9;
                let pushed: Vec<usize> = (0..n)
                    .filter(|&i| {
                        !held[i]
                            && ((z[i] <= zlo[i] + tol && step[i] > 0.0)
                                || (z[i] >= zhi[i] - tol && step[i] < 0.0))
                    })
                    .collect();
                if pushed.is_empty() {
                    break Some(step);
                }
                for i in pushed {
                    held[i] = true;
                }
            };
            let Some(step) = step else {
                lambda *= 10.0;
                continue;
            };
            let z_new: Vec<f64> = z.iter().zip(step.iter()).map(|(a, b)| a - b).collect();
            // Keep z inside the bounds so the clamp does not hide a wasted step.
            let z_new = pb.to_z(&pb.to_p(&z_new));
            evaluations += 1;
            if let Some((r_new, y_new)) = pb.simulated(&z_new) {
                let c_new = sum_sq(&r_new);
                if c_new < cost {
                    let rel = (cost - c_new) / cost.max(1e-300);
                    let moved = z_new
                        .iter()
                        .zip(&z)
                        .map(|(a, b)| (a - b).abs())
                        .fold(0.0, f64::max);
                    z = z_new;
                    r = r_new;
                    predicted = y_new;
                    cost = c_new;
                    lambda = (lambda * 0.2).max(1e-12);
                    improved = true;
                    // Improvements far below any statistical meaning, two in a row, end
                    // the search as surely as a zero step does: a relative gain of 1e-4 is
                    // worth n_eff x 1e-4 in AIC, under 1 for the few thousand independent
                    // residuals of a record, a tenth of the evidence diagnosis asks of an
                    // effect. Going on only crawls along a valley the data do not
                    // determine, and into its bounds (a vehicle's mass and rotor inertia
                    // took 99 iterations to reach theirs).
                    small_steps = if rel < SMALL_GAIN { small_steps + 1 } else { 0 };
                    if rel < 1e-10 || moved < 1e-9 || small_steps >= 2 {
                        converged = true;
                    }
                    break;
                }
            }
            lambda *= 8.0;
            if lambda > 1e12 {
                break;
            }
        }
        if !improved {
            // No step lowers the cost: a (local) minimum to the solver's precision.
            converged = true;
        }
    }
    let p = pb.to_p(&z);
    let (std, covariance) = if uncertainty {
        let jac = pb.jacobian(&z, &r);
        evaluations += n;
        covariance(pb, &p, &jac, cost, r.len())
    } else {
        (vec![None; n], DMatrix::zeros(n, n))
    };
    Ok(Fit {
        params: p,
        free: pb.free.clone(),
        std,
        covariance,
        cost,
        n_residuals: r.len(),
        iterations,
        evaluations,
        converged,
        start_index: 0,
        predicted,
        weights: pb.weights.to_vec(),
    })
}

/// Covariance of the free parameters: sigma^2 (J'J)^-1 with sigma^2 = RSS / (N - d),
/// through the SVD so that directions the data do not determine are reported, not inverted.
fn covariance(
    pb: &Problem,
    p: &[f64],
    jac: &DMatrix<f64>,
    cost: f64,
    n_res: usize,
) -> (Vec<Option<f64>>, DMatrix<f64>) {
    let d = jac.ncols();
    if d == 0 {
        return (vec![], DMatrix::zeros(0, 0));
    }
    let sigma2 = cost / (n_res - d).max(1) as f64;
    let svd = jac.clone().svd(false, true);
    let v_t = svd.v_t.expect("asked for V");
    let s_max = svd.singular_values.max();
    let mut cov_z = DMatrix::zeros(d, d);
    let mut undetermined = vec![false; d];
    for (k, &s) in svd.singular_values.iter().enumerate() {
        let row = v_t.row(k);
        if s > 1e-9 * s_max && s > 0.0 {
            cov_z += row.transpose() * row / (s * s);
        } else {
            for i in 0..d {
                if row[i].abs() > 1e-3 {
                    undetermined[i] = true;
                }
            }
        }
    }
    cov_z *= sigma2;
    let scale = pb.dp_dz(p);
    let cov = DMatrix::from_fn(d, d, |i, j| scale[i] * scale[j] * cov_z[(i, j)]);
    let std = (0..d)
        .map(|i| (!undetermined[i]).then(|| cov[(i, i)].max(0.0).sqrt()))
        .collect();
    (std, cov)
}

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
