//! Residual checks, as MATLAB's `resid`: is what the model leaves white (autocorrelation of
//! the residual), and is it independent of the input (cross-correlation)? Both with the
//! 99 % confidence band of the null hypothesis.

use serde::Serialize;

/// Two-sided 99 % quantile of the standard normal distribution.
pub const Z_99: f64 = 2.5758;

/// A correlation function over a lag range with its confidence band.
#[derive(Debug, Clone, Serialize)]
pub struct CorrelationCheck {
    /// Lags, samples.
    pub lags: Vec<i64>,
    /// Normalised correlation at each lag.
    pub values: Vec<f64>,
    /// Half-width of the 99 % band.
    pub band: f64,
    /// Lags outside the band.
    pub outside: usize,
    /// At most 5 % of the lags (at least one allowed) outside the band, and none beyond
    /// twice the band (a 5.2-sigma excursion, which white noise practically never makes).
    pub passes: bool,
}

fn demean(x: &[f64]) -> Vec<f64> {
    let m = x.iter().sum::<f64>() / x.len().max(1) as f64;
    x.iter().map(|v| v - m).collect()
}

/// Normalised correlation sum_k a_k b_{k+lag} / sqrt(sum a^2 sum b^2).
fn correlation(a: &[f64], b: &[f64], lag: i64) -> f64 {
    let n = a.len() as i64;
    let norm = (a.iter().map(|v| v * v).sum::<f64>() * b.iter().map(|v| v * v).sum::<f64>()).sqrt();
    if norm == 0.0 {
        return 0.0;
    }
    let mut s = 0.0;
    for k in 0..n {
        let j = k + lag;
        if j >= 0 && j < n {
            s += a[k as usize] * b[j as usize];
        }
    }
    s / norm
}

fn check(lags: Vec<i64>, values: Vec<f64>, band: f64) -> CorrelationCheck {
    let outside = values.iter().filter(|v| v.abs() > band).count();
    let allowed = ((lags.len() as f64) * 0.05).floor().max(1.0) as usize;
    let passes = outside <= allowed && values.iter().all(|v| v.abs() <= 2.0 * band);
    CorrelationCheck {
        lags,
        values,
        band,
        outside,
        passes,
    }
}

/// Autocorrelation of the residual at lags 1..=max_lag. Under whiteness each value is
/// approximately N(0, 1/N).
pub fn whiteness(e: &[f64], max_lag: usize) -> CorrelationCheck {
    let e = demean(e);
    let lags: Vec<i64> = (1..=max_lag as i64).collect();
    let values = lags.iter().map(|&l| correlation(&e, &e, l)).collect();
    check(lags, values, Z_99 / (e.len() as f64).sqrt())
}

/// Cross-correlation between input u and residual e at lags -max_lag..=max_lag (positive
/// lag: the input leads). If e is independent of u, each value is approximately
/// N(0, P/N) with P = sum_k r_u(k) r_e(k) over the lag range.
pub fn independence(u: &[f64], e: &[f64], max_lag: usize) -> CorrelationCheck {
    let u = demean(u);
    let e = demean(e);
    let m = max_lag as i64;
    let lags: Vec<i64> = (-m..=m).collect();
    let values = lags.iter().map(|&l| correlation(&u, &e, l)).collect();
    let p: f64 = (-m..=m)
        .map(|k| correlation(&u, &u, k) * correlation(&e, &e, k))
        .sum();
    check(lags, values, Z_99 * (p.max(1e-12) / u.len() as f64).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};

    fn noise(n: usize, seed: u64) -> Vec<f64> {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
        (0..n).map(|_| StandardNormal.sample(&mut rng)).collect()
    }

    #[test]
    fn white_noise_passes_and_a_filtered_residual_fails() {
        let e = noise(4000, 1);
        assert!(whiteness(&e, 25).passes);
        // A first-order filter (pole 0.8) makes neighbouring residuals correlate at 0.8.
        let mut f = e.clone();
        for k in 1..f.len() {
            f[k] += 0.8 * f[k - 1];
        }
        let w = whiteness(&f, 25);
        assert!(
            !w.passes && (w.values[0] - 0.8).abs() < 0.05,
            "{:?}",
            &w.values[..3]
        );
    }

    #[test]
    fn a_residual_that_echoes_the_input_is_caught_at_its_lag() {
        let u = noise(4000, 2);
        let e0 = noise(4000, 3);
        assert!(independence(&u, &e0, 20).passes);
        let e: Vec<f64> = (0..4000)
            .map(|k| e0[k] + if k >= 3 { 0.3 * u[k - 3] } else { 0.0 })
            .collect();
        let c = independence(&u, &e, 20);
        assert!(!c.passes);
        let peak = c
            .lags
            .iter()
            .zip(&c.values)
            .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
            .unwrap();
        assert_eq!(*peak.0, 3);
    }
}
