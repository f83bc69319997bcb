//! The search: Levenberg-Marquardt from a start, damped Gauss-Newton steps kept inside the
//! bounds by an active set, each parameter on its own scale (log for positive-bounded ones).

use super::*;

/// How each free parameter is searched ([`coord_of`]).
pub(super) fn coords(specs: &[ParamSpec], free: &[usize]) -> Vec<Coord> {
    free.iter().map(|&i| coord_of(&specs[i])).collect()
}

/// How a parameter is searched: a positive-bounded one on a log scale, others linearly,
/// scaled by their belief (or by their range when the belief is zero).
pub(super) fn coord_of(spec: &ParamSpec) -> Coord {
    if spec.lo > 0.0 {
        Coord::Log
    } else {
        Coord::Linear {
            scale: if spec.nominal != 0.0 {
                spec.nominal.abs()
            } else if spec.hi.is_finite() && spec.hi > 0.0 {
                0.1 * spec.hi
            } else {
                1e-9
            },
        }
    }
}

/// The residuals and outputs at the start `z` (parameters `start_p`); an error saying
/// when the simulation diverges where it does not run.
pub(super) fn start(
    pb: &Problem,
    z: &[f64],
    start_p: &[f64],
) -> Result<(Vec<f64>, Vec<Vec<f64>>), FitError> {
    pb.simulated(z).ok_or_else(|| {
        let t_s = pb
            .model
            .predict(start_p, pb.data)
            .err()
            .map(|d| d.t_s)
            .unwrap_or(f64::NAN);
        FitError::DivergesAtStart { t_s }
    })
}

/// The damped Gauss-Newton step `dz = -(J'J + lambda diag(J'J))^-1 J'r` for the damped
/// matrix `a` and gradient `g`, with parameters at a bound (`zlo`, `zhi`) that the step
/// would push through held there (an active set): a clamped component would otherwise
/// bend every other component of the step. `None` where the system has no solution.
pub(super) fn bounded_step(
    a: &DMatrix<f64>,
    g: &DVector<f64>,
    z: &[f64],
    zlo: &[f64],
    zhi: &[f64],
) -> Option<DVector<f64>> {
    let n = z.len();
    let mut held = vec![false; n];
    loop {
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
    }
}

/// Levenberg-Marquardt's damped normal matrix: `J'J + lambda diag(J'J)`, each diagonal
/// term at least 1e-12 so that a parameter the data do not touch still takes a step.
pub(super) fn damped(h: &DMatrix<f64>, lambda: f64) -> DMatrix<f64> {
    let mut a = h.clone();
    for i in 0..a.nrows() {
        a[(i, i)] += lambda * h[(i, i)].max(1e-12);
    }
    a
}

/// The largest change of any coordinate between two points.
pub(super) fn largest_move(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max)
}

/// Damped steps an iteration may try before it gives up (each damping whose system has
/// no solution counts as one).
const TRIES_PER_ITERATION: usize = 12;

/// A damped step to try: the point it reaches and the damping it was solved with.
struct Trial {
    z: Vec<f64>,
    lambda: f64,
}

/// A trial point simulated: its residuals, outputs and cost (`None`: it does not simulate).
type Simulated = Option<(Vec<f64>, Vec<Vec<f64>>, f64)>;

/// The next step to try from damping `lambda`, with `tries` left: a damping whose system
/// has no solution is raised tenfold, using a try. `None`: no tries left.
fn next_trial(
    pb: &Problem,
    (h, g): (&DMatrix<f64>, &DVector<f64>),
    z: &[f64],
    (zlo, zhi): (&[f64], &[f64]),
    lambda: &mut f64,
    tries: &mut usize,
) -> Option<Trial> {
    while *tries > 0 {
        *tries -= 1;
        let Some(step) = bounded_step(&damped(h, *lambda), g, z, zlo, zhi) else {
            *lambda *= 10.0;
            continue;
        };
        let z_new: Vec<f64> = z.iter().zip(step.iter()).map(|(a, b)| a - b).collect();
        // Keep z inside the bounds so the clamp does not hide a wasted step.
        return Some(Trial {
            z: pb.to_z(&pb.to_p(&z_new)),
            lambda: *lambda,
        });
    }
    None
}

/// `first` simulated, and `second` beside it where a worker is free (else after it, and
/// only where `first` does not lower `cost`: the search then tries `second` next). The
/// search is the same as one trial after another; a second trial simulated while the first
/// succeeds is thrown away. `None` for a second not simulated.
fn simulate_pair(
    pb: &Problem,
    first: &Trial,
    second: Option<&Trial>,
    cost: f64,
) -> (Simulated, Option<Simulated>) {
    let simulate = |t: &Trial| {
        pb.simulated(&t.z).map(|(r, y)| {
            let c = sum_sq(&r);
            (r, y, c)
        })
    };
    let first_lowers = std::sync::atomic::AtomicBool::new(false);
    rayon::join(
        || {
            let out = simulate(first);
            if out.as_ref().is_some_and(|o| o.2 < cost) {
                first_lowers.store(true, std::sync::atomic::Ordering::Release);
            }
            out
        },
        || {
            let second = second?;
            (!first_lowers.load(std::sync::atomic::Ordering::Acquire)).then(|| simulate(second))
        },
    )
}

/// A damped step that lowered the cost: where it reached, its residuals, outputs and cost.
struct Accepted {
    z: Vec<f64>,
    residuals: Vec<f64>,
    predicted: Vec<Vec<f64>>,
    cost: f64,
}

/// One iteration's damped steps from `z` (the normal matrix and gradient `h`, `g`), the
/// damping raised eightfold after each that does not lower `cost`, at most
/// [`TRIES_PER_ITERATION`] of them: the first that lowers it (`lambda` then lowered
/// fivefold from its damping), and the evaluations the search one trial after another
/// would have made.
fn damped_steps(
    pb: &Problem,
    normal: (&DMatrix<f64>, &DVector<f64>),
    z: &[f64],
    bounds: (&[f64], &[f64]),
    lambda: &mut f64,
    cost: f64,
) -> (Option<Accepted>, usize) {
    let mut tries = TRIES_PER_ITERATION;
    let mut evaluations = 0;
    while let Some(first) = next_trial(pb, normal, z, bounds, lambda, &mut tries) {
        // The trial that follows should this one fail, solved now and simulated beside it
        // on a worker that would otherwise wait.
        let (mut lambda_after, mut tries_after) = (first.lambda * 8.0, tries);
        let second = (lambda_after <= 1e12)
            .then(|| next_trial(pb, normal, z, bounds, &mut lambda_after, &mut tries_after))
            .flatten();
        let (first_outcome, second_outcome) = simulate_pair(pb, &first, second.as_ref(), cost);
        for (trial, outcome) in [(Some(first), Some(first_outcome)), (second, second_outcome)] {
            let (Some(trial), Some(outcome)) = (trial, outcome) else {
                return (None, evaluations);
            };
            evaluations += 1;
            if let Some((residuals, predicted, c)) = outcome.filter(|o| o.2 < cost) {
                *lambda = (trial.lambda * 0.2).max(1e-12);
                let z = trial.z;
                return (
                    Some(Accepted {
                        z,
                        residuals,
                        predicted,
                        cost: c,
                    }),
                    evaluations,
                );
            }
            *lambda = trial.lambda * 8.0;
            if *lambda > 1e12 {
                return (None, evaluations);
            }
        }
        // Both failed: the search goes on from the second's damping (raised above).
        tries = tries_after;
    }
    (None, evaluations)
}

/// Levenberg-Marquardt from the problem's start: damped Gauss-Newton steps kept inside
/// the bounds, at most `max_iterations` of them, then the free parameters' covariance when
/// `uncertainty` is asked.
pub(super) fn run_lm(
    pb: &Problem,
    max_iterations: usize,
    uncertainty: bool,
) -> Result<Fit, FitError> {
    let start_p = pb.to_p(&pb.to_z(&pb.base));
    let mut z = pb.to_z(&start_p);
    let (mut r, mut predicted) = start(pb, &z, &start_p)?;
    let mut cost = sum_sq(&r);
    let mut lambda = 1e-3;
    let mut evaluations = 1;
    let mut iterations = 0;
    let mut converged = z.is_empty();
    let mut small_steps = 0;
    let n = z.len();
    // The bounds in the search's coordinates: fixed for the whole search.
    let (zlo, zhi) = pb.z_bounds();
    let under_way = crate::ident::activity::begin_fit(max_iterations);
    while iterations < max_iterations && !converged {
        iterations += 1;
        under_way.iteration();
        let jac = pb.jacobian(&z, &r);
        evaluations += n;
        let h = jac.transpose() * &jac;
        let g = jac.transpose() * DVector::from_vec(r.clone());
        let (accepted, tried) = damped_steps(pb, (&h, &g), &z, (&zlo, &zhi), &mut lambda, cost);
        evaluations += tried;
        let improved = accepted.is_some();
        if let Some(a) = accepted {
            let rel = (cost - a.cost) / cost.max(1e-300);
            let moved = largest_move(&a.z, &z);
            (z, r, predicted, cost) = (a.z, a.residuals, a.predicted, a.cost);
            // Improvements far below any statistical meaning, two in a row, end the
            // search as surely as a zero step does: a relative gain of 1e-4 is worth
            // n_eff x 1e-4 in AIC, under 1 for the few thousand independent residuals of
            // a record, a tenth of the evidence diagnosis asks of an effect. Going on
            // only crawls along a valley the data do not determine, and into its bounds
            // (a vehicle's mass and rotor inertia took 99 iterations to reach theirs).
            small_steps = if rel < SMALL_GAIN { small_steps + 1 } else { 0 };
            if rel < 1e-10 || moved < 1e-9 || small_steps >= 2 {
                converged = true;
            }
        }
        if !improved {
            // No step lowers the cost: a (local) minimum to the solver's precision.
            converged = true;
        }
    }
    let p = pb.to_p(&z);
    let n_data = pb.data.measured_cells();
    let prior_sq = pb.weighting.belief_sq(pb.model.param_specs(), &p);
    let uncertainty = if uncertainty {
        let jac = pb.jacobian_central(&z, &r);
        evaluations += 2 * n;
        covariance(pb, &p, &jac, &r[..n_data])
    } else {
        Uncertainty::unknown(n)
    };
    Ok(Fit {
        params: p,
        free: pb.free.clone(),
        std: uncertainty.std,
        data_std: uncertainty.data_std,
        prior_std: uncertainty.prior_std,
        covariance: uncertainty.covariance,
        cost,
        prior_sq,
        n_residuals: n_data,
        correlation_rows: uncertainty.correlation_rows,
        undetermined_direction: uncertainty.weakest,
        iterations,
        evaluations,
        converged,
        start_index: 0,
        predicted,
        weighting: pb.weighting.clone(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_step_through_a_bound_holds_that_parameter_and_solves_for_the_others_without_it() {
        // Coupled: the free step is (1/3, 1/3); with the first held at its lower bound
        // (z - step would go below it) the second solves alone: 1/2, not 1/3.
        let a = DMatrix::from_row_slice(2, 2, &[2.0, 1.0, 1.0, 2.0]);
        let g = DVector::from_vec(vec![1.0, 1.0]);
        let free = bounded_step(&a, &g, &[5.0, 5.0], &[0.0, 0.0], &[10.0, 10.0]).unwrap();
        assert!((free[0] - 1.0 / 3.0).abs() < 1e-12 && (free[1] - 1.0 / 3.0).abs() < 1e-12);
        let held = bounded_step(&a, &g, &[0.0, 5.0], &[0.0, 0.0], &[10.0, 10.0]).unwrap();
        assert_eq!(held[0], 0.0);
        assert!((held[1] - 0.5).abs() < 1e-12, "{held}");
        // A step away from the bound it sits on is taken.
        let away = bounded_step(&a, &(-g), &[0.0, 5.0], &[0.0, 0.0], &[10.0, 10.0]).unwrap();
        assert!((away[0] + 1.0 / 3.0).abs() < 1e-12);
    }

    #[test]
    fn damping_adds_lambda_times_the_diagonal_floored_at_1e_12() {
        let h = DMatrix::from_row_slice(2, 2, &[4.0, 1.0, 1.0, 0.0]);
        let a = damped(&h, 0.5);
        assert_eq!(a[(0, 0)], 6.0);
        assert_eq!(a[(0, 1)], 1.0);
        assert_eq!(a[(1, 1)], 0.5e-12);
    }
}
