//! How a model's simulated outputs match a recording: normalised fit, loss, and the
//! residual checks, per output.

use std::collections::BTreeMap;

use nalgebra::DMatrix;
use serde::Serialize;

use super::data::Dataset;
use super::resid::{self, CorrelationCheck};

/// Residual checks of one output.
#[derive(Debug, Clone, Serialize)]
pub struct OutputChecks {
    /// The output's name.
    pub output: String,
    /// Autocorrelation of its residual (whiteness).
    pub whiteness: CorrelationCheck,
    /// Cross-correlation with each input.
    pub independence: Vec<(String, CorrelationCheck)>,
}

/// How a model with given parameters matches one recording.
#[derive(Debug, Clone, Serialize)]
pub struct Evaluation {
    /// The recording's name.
    pub recording: String,
    /// Rows compared.
    pub n_samples: usize,
    /// Normalised fit per output, %: 100 (1 - |y - yhat| / |y - mean y|).
    pub fit_pct: BTreeMap<String, f64>,
    /// Mean of the per-output fits, %.
    pub fit_pct_mean: f64,
    /// RMS of the residual per output (output units).
    pub rms: BTreeMap<String, f64>,
    /// Loss V: determinant of the residual covariance (the mean square for one output).
    pub loss: f64,
    /// Residual checks per output.
    pub checks: Vec<OutputChecks>,
    /// Simulated outputs, `[output][row]` (not serialised).
    #[serde(skip)]
    pub predicted: Vec<Vec<f64>>,
    /// The dataset compared (for plots; not serialised).
    #[serde(skip)]
    pub data: Option<Dataset>,
}

pub use super::data::constant_value;

/// Normalised fit, %, over the measured cells: `100 (1 - |y - yhat| / |y - mean y|)`.
/// NaN for a column without spread ([`constant_value`]): the ratio has no meaning there
/// (it was -inf for a stuck encoder), and the column is left out of every mean.
pub fn fit_pct(measured: &[Option<f64>], predicted: &[f64]) -> f64 {
    let pairs: Vec<(f64, f64)> = measured
        .iter()
        .zip(predicted)
        .filter_map(|(y, p)| y.map(|y| (y, *p)))
        .collect();
    // Scaled by the largest magnitude, so that outputs near 1e300 do not overflow
    // their squares (the ratio is unchanged).
    let scale = pairs
        .iter()
        .map(|(y, p)| y.abs().max(p.abs()))
        .fold(0.0_f64, f64::max);
    if scale == 0.0 || !scale.is_finite() {
        return f64::NAN;
    }
    let mean = pairs.iter().map(|p| p.0 / scale).sum::<f64>() / pairs.len().max(1) as f64;
    let err: f64 = pairs
        .iter()
        .map(|(y, p)| (y / scale - p / scale).powi(2))
        .sum::<f64>()
        .sqrt();
    let spread: f64 = pairs
        .iter()
        .map(|(y, _)| (y / scale - mean).powi(2))
        .sum::<f64>()
        .sqrt();
    // No spread: every measured cell one value. Checked on the values, not only the
    // computed spread, which rounding leaves a hair above zero for some constants.
    if spread == 0.0 || constant_value(measured).is_some() {
        return f64::NAN;
    }
    100.0 * (1.0 - err / spread)
}

/// Mean over outputs of the normalised fit, %, over the outputs a fit scores (NaN when
/// none: every column without spread).
pub fn fit_pct_mean(data: &Dataset, predicted: &[Vec<f64>]) -> f64 {
    let f: Vec<f64> = data
        .outputs
        .iter()
        .zip(predicted)
        .map(|(y, p)| fit_pct(y, p))
        .filter(|f| !f.is_nan())
        .collect();
    if f.is_empty() {
        return f64::NAN;
    }
    f.iter().sum::<f64>() / f.len() as f64
}

/// Loss V: determinant of the residual covariance over rows where all outputs are measured
/// (the product of per-output mean squares where no row has them all).
fn loss(data: &Dataset, predicted: &[Vec<f64>]) -> f64 {
    let m = data.outputs.len();
    let rows: Vec<usize> = (0..data.len())
        .filter(|&k| data.outputs.iter().all(|c| c[k].is_some()))
        .collect();
    let e = |j: usize, k: usize| data.outputs[j][k].map(|y| y - predicted[j][k]);
    if rows.len() > m {
        let cov = DMatrix::from_fn(m, m, |i, j| {
            rows.iter()
                .map(|&k| e(i, k).unwrap() * e(j, k).unwrap())
                .sum::<f64>()
                / rows.len() as f64
        });
        cov.determinant()
    } else {
        (0..m)
            .map(|j| {
                let v: Vec<f64> = (0..data.len()).filter_map(|k| e(j, k)).collect();
                v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64
            })
            .product()
    }
}

/// Fit, loss and residual checks of predicted outputs against a dataset.
pub fn evaluate(data: &Dataset, predicted: Vec<Vec<f64>>, max_lag: usize) -> Evaluation {
    let mut fit = BTreeMap::new();
    let mut rms = BTreeMap::new();
    let mut checks = Vec::new();
    for (j, name) in data.output_names.iter().enumerate() {
        fit.insert(name.clone(), fit_pct(&data.outputs[j], &predicted[j]));
        let (rows, e) = data.measured_residual(j, &predicted[j]);
        rms.insert(
            name.clone(),
            (e.iter().map(|v| v * v).sum::<f64>() / e.len().max(1) as f64).sqrt(),
        );
        let lag = max_lag.min(e.len() / 4).max(1);
        let independence = data
            .input_names
            .iter()
            .enumerate()
            .map(|(i, n)| {
                let u: Vec<f64> = rows.iter().map(|&k| data.inputs[i][k]).collect();
                (n.clone(), resid::independence(&u, &e, lag))
            })
            .collect();
        checks.push(OutputChecks {
            output: name.clone(),
            whiteness: resid::whiteness(&e, lag),
            independence,
        });
    }
    let mean = fit.values().sum::<f64>() / fit.len().max(1) as f64;
    Evaluation {
        recording: data.name.clone(),
        n_samples: data.len(),
        fit_pct: fit,
        fit_pct_mean: mean,
        rms,
        loss: loss(data, &predicted),
        checks,
        predicted,
        data: Some(data.clone()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_column_without_spread_has_no_fit_and_huge_values_do_not_overflow() {
        let stuck = [Some(0.25), Some(0.25), None, Some(0.25)];
        assert_eq!(constant_value(&stuck), Some(0.25));
        assert!(fit_pct(&stuck, &[0.25, 0.25, 0.0, 0.25]).is_nan());
        assert!(fit_pct(&stuck, &[0.1, 0.2, 0.0, 0.3]).is_nan());
        assert_eq!(constant_value(&[Some(1.0)]), None);
        // 100 (1 - |e| / |y - mean|) for y = (0, 1, 2), yhat = y + (0.1, -0.1, 0):
        // |e| = sqrt(0.02), |y - mean| = sqrt(2): 90 %. The same scaled by 1e300.
        let y = [Some(0.0), Some(1.0), Some(2.0)];
        let p = [0.1, 0.9, 2.0];
        assert!((fit_pct(&y, &p) - 90.0).abs() < 1e-9);
        let big: Vec<Option<f64>> = y.iter().map(|v| v.map(|v| v * 1e300)).collect();
        let pbig: Vec<f64> = p.iter().map(|v| v * 1e300).collect();
        assert!((fit_pct(&big, &pbig) - 90.0).abs() < 1e-9);
    }
}
