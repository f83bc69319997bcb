//! Feedforward gains the way WPILib's SysId reports them: kS, kV, kA (and kG for an
//! elevator or an arm), from ordinary least squares on the discrete-time dynamics of one
//! speed,
//!
//! `v[k+1] = alpha v[k] + beta u[k] + gamma sgn(v[k])  (+ delta, or + delta cos(theta[k]) + epsilon sin(theta[k]))`,
//!
//! which is the zero-order-hold discretisation of `u = kS sgn(v) + kV v + kA dv/dt (+ kG ...)`
//! over the mean sample period `T`: `kS = -gamma/beta`, `kV = (1 - alpha)/beta`,
//! `kA = T (alpha - 1) / (beta ln alpha)`, `kG = -delta/beta` (elevator) or
//! `hypot(delta, epsilon)/beta` with offset `atan2(epsilon, -delta)` (arm). Standard
//! deviations come from the regression's covariance by the delta method.
//!
//! Pairs are taken within one test (never across the gap between two tests) and only where
//! the speed at `k` is above a motion threshold: standing still, the stuck machine does not
//! obey the sliding law.

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

/// What the gravity term looks like.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Gravity {
    /// Flywheels, drivetrains: no gravity term.
    None,
    /// A constant (elevator): kG.
    Constant,
    /// `kG cos(angle + offset)` (arm).
    Arm,
}

/// One test's samples: times (s), input voltage (V), speed (any unit per second) and, for
/// an arm, the angle (rad).
#[derive(Debug, Clone, Default)]
pub struct Series {
    /// Sample times, s.
    pub t_s: Vec<f64>,
    /// Input voltage, V.
    pub voltage_v: Vec<f64>,
    /// Speed, in the log's unit per second.
    pub speed: Vec<f64>,
    /// An arm's angle, rad (empty otherwise).
    pub angle_rad: Vec<f64>,
}

/// A gain with its standard deviation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Gain {
    /// The estimate.
    pub value: f64,
    /// Its standard deviation.
    pub std: f64,
}

/// The gains of one fit. Units: V, V per (speed unit), V per (speed unit per second).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Feedforward {
    /// Static friction voltage kS, V.
    pub ks_v: Gain,
    /// Velocity gain kV, V per speed unit.
    pub kv_v_s_per_unit: Gain,
    /// Acceleration gain kA, V per speed unit per second.
    pub ka_v_s2_per_unit: Gain,
    /// Gravity voltage kG of an elevator or arm, V.
    pub kg_v: Option<Gain>,
    /// The arm's angle offset, rad.
    pub arm_offset_rad: Option<f64>,
    /// Coefficient of determination of the regression.
    pub r_squared: f64,
    /// RMS residual of the predicted next speed.
    pub rmse: f64,
    /// Sample period used for the discretisation (mean over the pairs), s.
    pub sample_time_s: f64,
    /// Speed below which a sample was left out.
    pub motion_threshold: f64,
    /// Sample pairs regressed.
    pub pairs: usize,
}

/// Why the gains cannot be computed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FeedforwardError {
    /// Too few moving samples.
    #[error("too few moving samples for SysId's regression: {pairs} pairs above the motion threshold {threshold:.4} for {unknowns} unknowns (the machine hardly moved)")]
    TooFew {
        /// Pairs above the motion threshold.
        pairs: usize,
        /// The motion threshold.
        threshold: f64,
        /// Unknowns of the regression.
        unknowns: usize,
    },
    /// The regression is singular (the reason).
    #[error("the regression is singular: {0} (the tests do not separate friction, speed and acceleration; SysId asks for at least two steady speeds and one acceleration)")]
    Singular(&'static str),
    /// The fitted pole is not that of a stable machine (its value).
    #[error("the fitted discrete pole alpha = {0:.6} is not in (0, 1): no stable first-order machine fits these samples")]
    Unstable(f64),
}

/// The motion threshold SysId's idea asks for, taken here as 2 % of the largest speed.
pub fn default_threshold(tests: &[Series]) -> f64 {
    let peak = tests
        .iter()
        .flat_map(|s| s.speed.iter())
        .fold(0.0f64, |m, v| m.max(v.abs()));
    0.02 * peak
}

/// The regressors of pair `k` of a series.
fn regressors(s: &Series, k: usize, gravity: Gravity) -> Vec<f64> {
    let v = s.speed[k];
    let mut x = vec![v, s.voltage_v[k], v.signum()];
    match gravity {
        Gravity::None => {}
        Gravity::Constant => x.push(1.0),
        Gravity::Arm => {
            x.push(s.angle_rad[k].cos());
            x.push(s.angle_rad[k].sin());
        }
    }
    x
}

/// Every step of the tests that starts moving faster than `threshold`: its regressors,
/// the speed after it, and the steps' summed duration (s).
fn moving_steps(
    tests: &[Series],
    gravity: Gravity,
    threshold: f64,
) -> (Vec<Vec<f64>>, Vec<f64>, f64) {
    let mut rows: Vec<Vec<f64>> = Vec::new();
    let mut next = Vec::new();
    let mut dt_sum = 0.0;
    for s in tests {
        for k in 0..s.t_s.len().saturating_sub(1) {
            if s.speed[k].abs() <= threshold {
                continue;
            }
            rows.push(regressors(s, k, gravity));
            next.push(s.speed[k + 1]);
            dt_sum += s.t_s[k + 1] - s.t_s[k];
        }
    }
    (rows, next, dt_sum)
}

/// Fits the gains to the tests together (they share the machine).
pub fn fit(
    tests: &[Series],
    gravity: Gravity,
    threshold: f64,
) -> Result<Feedforward, FeedforwardError> {
    let unknowns = match gravity {
        Gravity::None => 3,
        Gravity::Constant => 4,
        Gravity::Arm => 5,
    };
    let (rows, next, dt_sum) = moving_steps(tests, gravity, threshold);
    let n = rows.len();
    if n < 3 * unknowns {
        return Err(FeedforwardError::TooFew {
            pairs: n,
            threshold,
            unknowns,
        });
    }
    let x = DMatrix::from_fn(n, unknowns, |i, j| rows[i][j]);
    let y = DVector::from_vec(next);
    let xtx = x.transpose() * &x;
    let inv = xtx
        .clone()
        .try_inverse()
        .filter(|m| m.iter().all(|v| v.is_finite()))
        .ok_or(FeedforwardError::Singular("X'X has no inverse"))?;
    let theta = &inv * (x.transpose() * &y);
    let residual = &y - &x * &theta;
    let rss = residual.norm_squared();
    let mean = y.mean();
    let tss: f64 = y.iter().map(|v| (v - mean).powi(2)).sum();
    let sigma2 = rss / (n - unknowns) as f64;
    let cov = inv * sigma2;
    let (alpha, beta, gamma) = (theta[0], theta[1], theta[2]);
    if !(alpha > 0.0 && alpha < 1.0) {
        return Err(FeedforwardError::Unstable(alpha));
    }
    if beta == 0.0 {
        return Err(FeedforwardError::Singular(
            "beta, the voltage's effect, is zero",
        ));
    }
    let dt = dt_sum / n as f64;
    let ln_a = alpha.ln();
    let ka = dt * (alpha - 1.0) / (beta * ln_a);
    // Gradients of each gain with respect to (alpha, beta, gamma, delta, epsilon).
    let mut g_ks = vec![0.0; unknowns];
    g_ks[1] = gamma / (beta * beta);
    g_ks[2] = -1.0 / beta;
    let mut g_kv = vec![0.0; unknowns];
    g_kv[0] = -1.0 / beta;
    g_kv[1] = -(1.0 - alpha) / (beta * beta);
    let mut g_ka = vec![0.0; unknowns];
    g_ka[0] = dt / beta * (ln_a - (alpha - 1.0) / alpha) / (ln_a * ln_a);
    g_ka[1] = -ka / beta;
    let std = |g: &[f64]| {
        let g = DVector::from_column_slice(g);
        (g.transpose() * &cov * &g)[(0, 0)].max(0.0).sqrt()
    };
    let gain = |value: f64, g: &[f64]| Gain { value, std: std(g) };
    let (kg_v, arm_offset_rad) = match gravity {
        Gravity::None => (None, None),
        Gravity::Constant => {
            let delta = theta[3];
            let mut g = vec![0.0; unknowns];
            g[1] = delta / (beta * beta);
            g[3] = -1.0 / beta;
            (Some(gain(-delta / beta, &g)), None)
        }
        Gravity::Arm => {
            let (delta, eps) = (theta[3], theta[4]);
            let h = delta.hypot(eps);
            let mut g = vec![0.0; unknowns];
            g[1] = -h / (beta * beta);
            if h > 0.0 {
                g[3] = delta / (h * beta);
                g[4] = eps / (h * beta);
            }
            (Some(gain(h / beta, &g)), Some(eps.atan2(-delta)))
        }
    };
    Ok(Feedforward {
        ks_v: gain(-gamma / beta, &g_ks),
        kv_v_s_per_unit: gain((1.0 - alpha) / beta, &g_kv),
        ka_v_s2_per_unit: gain(ka, &g_ka),
        kg_v,
        arm_offset_rad,
        r_squared: if tss > 0.0 { 1.0 - rss / tss } else { 1.0 },
        rmse: (rss / n as f64).sqrt(),
        sample_time_s: dt,
        motion_threshold: threshold,
        pairs: n,
    })
}

/// One line per gain, with its unit (`unit`: the speed's unit, e.g. `m/s`).
pub fn render(ff: &Feedforward, unit: &str) -> String {
    let dist = unit.trim_end_matches("/s");
    let mut s = format!(
        "  kS = {:.4} +- {:.4} V\n  kV = {:.5} +- {:.5} V/({unit})\n  kA = {:.5} +- {:.5} V/({unit}/s)\n",
        ff.ks_v.value,
        ff.ks_v.std,
        ff.kv_v_s_per_unit.value,
        ff.kv_v_s_per_unit.std,
        ff.ka_v_s2_per_unit.value,
        ff.ka_v_s2_per_unit.std
    );
    if let Some(kg) = ff.kg_v {
        s += &format!("  kG = {:.4} +- {:.4} V\n", kg.value, kg.std);
    }
    if let Some(o) = ff.arm_offset_rad {
        s += &format!("  arm offset = {o:.4} rad\n");
    }
    s += &format!(
        "  r^2 = {:.4}, RMSE = {}, {} samples above {}, T = {:.4} s\n",
        ff.r_squared,
        crate::numtext::quantity(ff.rmse, 3, &format!("{dist}/s")),
        ff.pairs,
        crate::numtext::quantity(ff.motion_threshold, 3, &format!("{dist}/s")),
        ff.sample_time_s
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A first-order machine with friction, stepped exactly (zero-order hold): the
    /// regression gives back its gains.
    fn machine(ks: f64, kv: f64, ka: f64, kg: f64, volts: &[f64], dt: f64) -> Series {
        let a = (-kv / ka * dt).exp();
        let mut s = Series::default();
        let mut v: f64 = 0.0;
        for (k, u) in volts.iter().enumerate() {
            s.t_s.push(k as f64 * dt);
            s.voltage_v.push(*u);
            s.speed.push(v);
            s.angle_rad.push(0.0);
            // The zero-order-hold step of kA dv/dt = u - kS sgn(v) - kV v - kG.
            v = a * v + (1.0 - a) * (u - kg - ks * v.signum() * f64::from(u8::from(v != 0.0))) / kv;
        }
        s
    }

    #[test]
    fn exact_discrete_data_give_the_gains_back() {
        let dt = 0.005;
        let ramp: Vec<f64> = (0..2000).map(|k| 0.25 * k as f64 * dt).collect();
        let step: Vec<f64> = vec![7.0; 600];
        let neg: Vec<f64> = step.iter().map(|u| -u).collect();
        for (kg, gravity) in [(0.0, Gravity::None), (0.4, Gravity::Constant)] {
            let tests = [
                machine(0.3, 2.5, 0.4, kg, &ramp, dt),
                machine(0.3, 2.5, 0.4, kg, &step, dt),
                machine(0.3, 2.5, 0.4, kg, &neg, dt),
            ];
            let ff = fit(&tests, gravity, default_threshold(&tests)).unwrap();
            assert!((ff.ks_v.value - 0.3).abs() < 1e-6, "{ff:?}");
            assert!((ff.kv_v_s_per_unit.value - 2.5).abs() < 1e-6, "{ff:?}");
            assert!((ff.ka_v_s2_per_unit.value - 0.4).abs() < 1e-6, "{ff:?}");
            if gravity == Gravity::Constant {
                assert!((ff.kg_v.unwrap().value - 0.4).abs() < 1e-6, "{ff:?}");
            }
        }
    }

    #[test]
    fn a_machine_that_never_moves_is_refused() {
        let s = Series {
            t_s: (0..100).map(|k| k as f64 * 0.01).collect(),
            voltage_v: vec![1.0; 100],
            speed: vec![0.0; 100],
            angle_rad: vec![0.0; 100],
        };
        assert!(matches!(
            fit(&[s], Gravity::None, 0.0),
            Err(FeedforwardError::TooFew { .. })
        ));
    }
}
