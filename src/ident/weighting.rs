//! What each output of a record can show, and what a residual is worth: each output's
//! noise level estimated from the record itself, the residual's effective number of
//! independent samples, and from them the weights of a fit ([`super::fit::Weighting`]).
//!
//! Real records break what synthetic ones keep: an output a test does not excite is its
//! sensor's noise, and a residual that is neither white nor from the true model is worth
//! far fewer samples than it has rows.

use super::data::Dataset;

/// Autocorrelation below which a residual counts as decorrelated.
pub const DECORRELATED: f64 = 0.05;

/// The first lag at which the autocorrelation of `e` falls below [`DECORRELATED`] (at
/// least 1; at most a quarter of the series, or 500 samples).
pub fn decorrelation_lag(e: &[f64]) -> usize {
    let n = e.len();
    if n < 4 {
        return 1;
    }
    let m = e.iter().sum::<f64>() / n as f64;
    let var: f64 = e.iter().map(|v| (v - m).powi(2)).sum();
    if var == 0.0 {
        return 1;
    }
    let last = (n / 4).min(500);
    for lag in 1..last {
        let r: f64 = (0..n - lag)
            .map(|k| (e[k] - m) * (e[k + lag] - m))
            .sum::<f64>()
            / var;
        if r < DECORRELATED {
            return lag;
        }
    }
    last.max(1)
}

/// Each output's residual `y - yhat` over its measured cells.
fn residual_of(col: &[Option<f64>], predicted: &[f64]) -> Vec<f64> {
    col.iter()
        .zip(predicted)
        .filter_map(|(y, p)| y.map(|y| y - p))
        .collect()
}

/// Effective number of independent residuals per output: N / (1 + 2 sum of the residual's
/// autocorrelation over lags until it first falls below [`DECORRELATED`]).
pub fn effective_n(data: &Dataset, predicted: &[Vec<f64>]) -> Vec<f64> {
    data.outputs
        .iter()
        .enumerate()
        .map(|(j, col)| {
            let e = residual_of(col, &predicted[j]);
            (e.len() as f64 / correlation_factor(&e)).max(1.0)
        })
        .collect()
}

/// How many samples of `e` count as one independent sample: `1 + 2 sum` of its
/// autocorrelation over lags until it first falls below [`DECORRELATED`] (at most 500
/// lags, a quarter of the series); 1 for a white or constant series.
pub fn correlation_factor(e: &[f64]) -> f64 {
    let n = e.len() as f64;
    let m = e.iter().sum::<f64>() / n.max(1.0);
    let var: f64 = e.iter().map(|v| (v - m).powi(2)).sum();
    if var == 0.0 {
        return 1.0;
    }
    let mut sum = 0.0;
    for lag in 1..(e.len() / 4).min(500) {
        let r: f64 = (0..e.len() - lag)
            .map(|k| (e[k] - m) * (e[k + lag] - m))
            .sum::<f64>()
            / var;
        if r < DECORRELATED {
            break;
        }
        sum += r;
    }
    1.0 + 2.0 * sum
}

/// An output's measurement noise, one standard deviation in its unit, from the record
/// alone: the second differences of consecutive measured samples within each test,
/// `sqrt(mean(d2^2) / 6)` (for white noise on a signal smooth over three samples,
/// `var(y[k+1] - 2 y[k] + y[k-1]) = 6 sigma^2`). A smooth signal's own curvature adds to
/// it, so this is an upper estimate of the noise; `None` with fewer than three samples.
pub fn noise_level(data: &Dataset, output: usize) -> Option<f64> {
    let col = &data.outputs[output];
    let mut sum = 0.0;
    let mut count = 0usize;
    for seg in data.segments() {
        let y: Vec<f64> = col[seg].iter().flatten().copied().collect();
        for w in y.windows(3) {
            let d2 = w[2] - 2.0 * w[1] + w[0];
            sum += d2 * d2;
            count += 1;
        }
    }
    (count > 0).then(|| (sum / count as f64 / 6.0).sqrt())
}

/// Each output's weight for a fit after one at `predicted`: 1 / its residual RMS, the
/// maximum-likelihood weight of outputs with unknown noise levels, but never above 1 / its
/// noise level ([`noise_level`]): a model cannot fit an output better than its sensor
/// measures it, and an output fitted to below its noise would otherwise count for more
/// than it can show.
pub fn output_weights(data: &Dataset, predicted: &[Vec<f64>]) -> Vec<f64> {
    data.outputs
        .iter()
        .enumerate()
        .map(|(j, col)| {
            let e = residual_of(col, &predicted[j]);
            let rms = (e.iter().map(|v| v * v).sum::<f64>() / e.len().max(1) as f64).sqrt();
            let noise = noise_level(data, j).unwrap_or(0.0);
            1.0 / rms.max(noise).max(1e-12)
        })
        .collect()
}

/// Each output weighted by its spread (1 / its standard deviation about its mean), so
/// outputs in different units count alike: the weights of a fit's first pass, before any
/// residual is known.
pub fn spread_weights(data: &Dataset) -> Vec<f64> {
    data.outputs
        .iter()
        .map(|col| {
            let v: Vec<f64> = col.iter().flatten().copied().collect();
            let mean = v.iter().sum::<f64>() / v.len().max(1) as f64;
            let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / v.len().max(1) as f64;
            1.0 / var.sqrt().max(1e-12)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dataset(y: Vec<f64>) -> Dataset {
        Dataset {
            name: "t".into(),
            t_s: (0..y.len()).map(|k| k as f64 * 0.01).collect(),
            input_names: vec![],
            inputs: vec![],
            output_names: vec!["y".into()],
            outputs: vec![y.into_iter().map(Some).collect()],
            segment_starts: vec![0],
        }
    }

    /// White noise of known sigma on a slow sine: the estimate is within the sampling
    /// error of the variance of 2,000 second differences (a few percent), not the signal's
    /// size.
    #[test]
    fn the_noise_level_of_a_smooth_signal_is_its_sensor_noise() {
        let mut state = 12345u64;
        let mut gauss = || {
            // Box-Muller on a 64-bit LCG: reproducible without a dependency.
            let mut u = || {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
            };
            let (a, b) = (u(), u());
            (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
        };
        let sigma = 0.02;
        let y: Vec<f64> = (0..2000)
            .map(|k| 3.0 * (k as f64 * 0.002).sin() + sigma * gauss())
            .collect();
        let est = noise_level(&dataset(y), 0).unwrap();
        assert!(
            (est / sigma - 1.0).abs() < 0.08,
            "estimated {est}, true {sigma}"
        );
    }

    /// A residual that is a slow drift is worth a handful of samples; white noise all of
    /// them.
    #[test]
    fn a_drifting_residual_is_worth_few_samples() {
        let n = 1000;
        let drift: Vec<Option<f64>> = (0..n).map(|k| Some((k as f64 / 200.0).sin())).collect();
        let data = Dataset {
            outputs: vec![drift],
            ..dataset(vec![0.0; n])
        };
        let neff = effective_n(&data, &[vec![0.0; n]])[0];
        assert!(neff < 20.0, "{neff}");
        assert!(
            decorrelation_lag(&(0..n).map(|k| (k as f64 / 200.0).sin()).collect::<Vec<_>>()) > 50
        );
    }
}
