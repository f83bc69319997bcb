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

/// Normalised fit, %, over the measured cells.
pub fn fit_pct(measured: &[Option<f64>], predicted: &[f64]) -> f64 {
    let pairs: Vec<(f64, f64)> = measured
        .iter()
        .zip(predicted)
        .filter_map(|(y, p)| y.map(|y| (y, *p)))
        .collect();
    let mean = pairs.iter().map(|p| p.0).sum::<f64>() / pairs.len().max(1) as f64;
    let err: f64 = pairs
        .iter()
        .map(|(y, p)| (y - p).powi(2))
        .sum::<f64>()
        .sqrt();
    let spread: f64 = pairs
        .iter()
        .map(|(y, _)| (y - mean).powi(2))
        .sum::<f64>()
        .sqrt();
    if spread == 0.0 {
        return if err == 0.0 { 100.0 } else { f64::NEG_INFINITY };
    }
    100.0 * (1.0 - err / spread)
}

/// Mean over outputs of the normalised fit, %.
pub fn fit_pct_mean(data: &Dataset, predicted: &[Vec<f64>]) -> f64 {
    let f: Vec<f64> = data
        .outputs
        .iter()
        .zip(predicted)
        .map(|(y, p)| fit_pct(y, p))
        .collect();
    f.iter().sum::<f64>() / f.len().max(1) as f64
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
        let rows: Vec<usize> = (0..data.len())
            .filter(|&k| data.outputs[j][k].is_some())
            .collect();
        let e: Vec<f64> = rows
            .iter()
            .filter_map(|&k| data.outputs[j][k].map(|y| y - predicted[j][k]))
            .collect();
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
