//! The screen of one form: the stage linearised (its weighted residual and its derivatives
//! in the stage's free parameters), the form's columns by simulation, and least squares
//! fitted on the even time blocks and judged on the odd ones.

use rayon::prelude::*;

use super::{drifting_key, start_vector, Screened, HELD_OUT_BLOCKS, SCREEN_STEP};
use crate::diagnose::Stage;
use crate::ident::data::Dataset;
use crate::ident::fit;
use crate::ident::models::rotary_axis::{RotaryAxis, TermCoefficient, TermForm};
use crate::model::term::Family;

/// The stage linearised: its weighted residual, which held-out block each residual lies
/// in, and the derivatives of the residual in the stage's free parameters.
pub(super) struct Linearised<'a> {
    stage: &'a Stage,
    residual: Vec<f64>,
    /// Whether each residual lies in a fitting (even) block.
    fitting: Vec<bool>,
    /// The residual's derivative in each free parameter of the stage.
    jacobian: Vec<Vec<f64>>,
}

impl<'a> Linearised<'a> {
    pub(super) fn at(data: &'a Dataset, stage: &'a Stage) -> Option<Linearised<'a>> {
        let w = &stage.fit.weighting.outputs;
        let residual = fit::residuals(data, &stage.fit.predicted, w);
        let fitting = fitting_rows(data);
        let model = stage.structure.model();
        let specs = model.params();
        let p = &stage.fit.params;
        let jacobian: Vec<Vec<f64>> = stage
            .fit
            .free
            .par_iter()
            .map(|&i| {
                let s = &specs[i];
                let scale = if p[i] != 0.0 {
                    p[i].abs()
                } else if s.hi.is_finite() && s.hi > 0.0 {
                    s.hi
                } else {
                    1.0
                };
                // The model's own difference step where it is wider (a play makes the
                // outputs rough on the scale of an integration step).
                let h = s.fd_step.max(1e-5) * scale;
                let mut q = p.clone();
                q[i] += h;
                let y = model.predict(&q, data).ok()?;
                Some(difference(&fit::residuals(data, &y, w), &residual, h))
            })
            .collect::<Option<_>>()?;
        Some(Linearised {
            stage,
            residual,
            fitting,
            jacobian,
        })
    }

    /// One form's screen: its coefficients' columns by simulation, fitted with the
    /// stage's on the fitting blocks and judged on the held-out ones.
    pub(super) fn screen(
        &self,
        m: &RotaryAxis,
        form: TermForm,
        ceilings: &[f64],
        data: &Dataset,
    ) -> Option<Screened> {
        let w = &self.stage.fit.weighting.outputs;
        let coefficients = form.coefficients(ceilings);
        let (with, indices) = m.with_term(form, &coefficients);
        let base = start_vector(&self.stage.fit.params, form, &coefficients);
        let mut columns: Vec<Vec<f64>> = Vec::new();
        for (&i, c) in indices.iter().zip(&coefficients) {
            let h = SCREEN_STEP * c.hi;
            let mut q = base.clone();
            q[i] = h;
            use crate::ident::model::Predictor;
            let y = with.predict(&q, data).ok()?;
            columns.push(difference(&fit::residuals(data, &y, w), &self.residual, h));
        }
        let judged = judge_columns(&self.jacobian, &columns, &self.residual, &self.fitting)?;
        let start = judged.starts(&coefficients);
        Some(Screened {
            family: form.family.name(),
            order: form.order,
            drifting: if form.family == Family::TimeDrift {
                drifting_key(form.drifting)
            } else {
                ""
            },
            held_out_reduction_pct: 100.0 * judged.held_out_reduction,
            reduction_pct: 100.0 * judged.reduction,
            form: Some(form),
            start,
        })
    }
}

/// A form's columns judged beside a stage's: what they remove of the residual.
pub(crate) struct Judged {
    /// Share of the held-out rows' residual removed (fitted on the others).
    pub held_out_reduction: f64,
    /// Share of the whole residual removed (fitted on every row).
    pub reduction: f64,
    /// The form's coefficients fitted on every row.
    pub coefficients: Vec<f64>,
}

/// A form's `columns` (the residual's derivatives in its coefficients) fitted by least
/// squares beside the stage's `jacobian` (its derivatives in the stage's free
/// parameters) on the rows `fitting` marks and judged on the others, then fitted on
/// every row: against the stage's parameters alone refitted alike, so that what a refit
/// of the stage absorbs is not credited to the form. `None` where a system has no
/// solution.
pub(crate) fn judge_columns(
    jacobian: &[Vec<f64>],
    columns: &[Vec<f64>],
    residual: &[f64],
    fitting: &[bool],
) -> Option<Judged> {
    let all: Vec<&[f64]> = jacobian
        .iter()
        .chain(columns)
        .map(|c| c.as_slice())
        .collect();
    let nominal: Vec<&[f64]> = jacobian.iter().map(|c| c.as_slice()).collect();
    let held_rows: Vec<bool> = fitting.iter().map(|f| !f).collect();
    let every: Vec<bool> = vec![true; residual.len()];
    let with_term = least_squares(&all, residual, fitting)?;
    let without = least_squares(&nominal, residual, fitting)?;
    let held = |beta: &[f64], cols: &[&[f64]]| rss(cols, beta, residual, &held_rows);
    let held_out_reduction = 1.0 - held(&with_term, &all) / held(&without, &nominal).max(1e-300);
    let whole = least_squares(&all, residual, &every)?;
    let whole_nominal = least_squares(&nominal, residual, &every)?;
    let reduction = 1.0
        - rss(&all, &whole, residual, &every)
            / rss(&nominal, &whole_nominal, residual, &every).max(1e-300);
    Some(Judged {
        held_out_reduction,
        reduction,
        coefficients: whole[nominal.len()..].to_vec(),
    })
}

impl Judged {
    /// The coefficients fitted on every row, each clamped into its search: where a fit of
    /// the form starts.
    pub(crate) fn starts(&self, coefficients: &[TermCoefficient]) -> Vec<f64> {
        self.coefficients
            .iter()
            .zip(coefficients)
            .map(|(b, c)| b.clamp(c.lo, c.hi))
            .collect()
    }
}

/// Whether each residual of `data` (output by output, present samples only) lies in a
/// fitting (even) time block of [`HELD_OUT_BLOCKS`].
pub(crate) fn fitting_rows(data: &Dataset) -> Vec<bool> {
    let rows = data.len().max(1);
    let mut fitting = Vec::new();
    for col in &data.outputs {
        for (k, y) in col.iter().enumerate() {
            if y.is_some() {
                fitting.push((k * HELD_OUT_BLOCKS / rows).is_multiple_of(2));
            }
        }
    }
    fitting
}

/// `(a - b) / h`, element by element.
pub(crate) fn difference(a: &[f64], b: &[f64], h: f64) -> Vec<f64> {
    a.iter().zip(b).map(|(a, b)| (a - b) / h).collect()
}

/// The coefficients `beta` minimising `|r + X beta|` over the rows `use_row`, the columns
/// scaled to unit length first (the stage's parameters and a term's coefficients differ by
/// orders of magnitude); `None` where the system has no solution.
fn least_squares(columns: &[&[f64]], r: &[f64], use_row: &[bool]) -> Option<Vec<f64>> {
    let n = columns.len();
    if n == 0 {
        return Some(vec![]);
    }
    let norms: Vec<f64> = columns
        .iter()
        .map(|c| {
            c.iter()
                .zip(use_row)
                .filter(|(_, u)| **u)
                .map(|(v, _)| v * v)
                .sum::<f64>()
                .sqrt()
                .max(1e-300)
        })
        .collect();
    let mut a = nalgebra::DMatrix::<f64>::zeros(n, n);
    let mut g = nalgebra::DVector::<f64>::zeros(n);
    for k in 0..r.len() {
        if !use_row[k] {
            continue;
        }
        for i in 0..n {
            let xi = columns[i][k] / norms[i];
            g[i] -= xi * r[k];
            for j in i..n {
                a[(i, j)] += xi * columns[j][k] / norms[j];
            }
        }
    }
    for i in 0..n {
        for j in 0..i {
            a[(i, j)] = a[(j, i)];
        }
        // A whisper of ridge: columns the record cannot tell apart get no wild values.
        a[(i, i)] += 1e-10;
    }
    let beta = a.svd(true, true).solve(&g, 1e-12).ok()?;
    Some((0..n).map(|i| beta[i] / norms[i]).collect())
}

/// `|r + X beta|^2` over the rows `use_row`.
fn rss(columns: &[&[f64]], beta: &[f64], r: &[f64], use_row: &[bool]) -> f64 {
    (0..r.len())
        .filter(|&k| use_row[k])
        .map(|k| {
            let e = r[k] + columns.iter().zip(beta).map(|(c, b)| c[k] * b).sum::<f64>();
            e * e
        })
        .sum()
}
