//! The measurement noise of a proof's recording, by the sensor that measures each output.
//!
//! White noise is what the Gauss-Newton covariance assumes; real sensors' noise is coloured,
//! and an interval that holds on white noise need not hold on theirs (issue "intervals that
//! hold"). Each sensor here keeps the white case's marginal standard deviation, so the two
//! kinds differ only in their colour:
//!
//! - an **encoder** read as a speed: the count difference over the sample's interval,
//!   `(Q(θ_{k+½}) − Q(θ_{k−½})) / dt` with `θ` the true angle and `Q` a quantiser of step
//!   `q = σ·dt·√6` (the difference of two independent uniform errors has variance
//!   `q²/6`): errors of neighbouring samples correlate at −0.5, and a wheel at rest reads
//!   exactly zero;
//! - a **current sensor** behind its anti-aliasing filter: first-order low-pass noise,
//!   `n_k = a·n_{k−1} + √(1−a²)·σ·e_k`, `a = exp(−dt/τ)`, τ = 20 ms;
//! - a **gyro** (the yaw rate) behind its digital low-pass, the same with τ = 10 ms;
//! - a **motion-capture tracker** on the pose: the same with τ = 0.5 s (a marker's
//!   fit drifting over half a second, not a fresh error each sample).

use super::*;
use crate::record::channels as chan;

/// What the measurement noise of a proof's recording is like.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum SensorNoise {
    /// Independent Gaussian noise on every sample (what the covariance assumes).
    #[default]
    White,
    /// Each output's own sensor: quantised encoder speeds, a low-passed current and gyro,
    /// a tracker whose error drifts over half a second (same standard deviations as white).
    Sensors,
}

impl SensorNoise {
    /// Its name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            SensorNoise::White => "white",
            SensorNoise::Sensors => "sensors",
        }
    }
}

/// Correlation time of a current sensor's filtered noise, s.
pub const CURRENT_SENSOR_TAU_S: f64 = 0.020;
/// Correlation time of a gyro's filtered noise, s.
pub const GYRO_TAU_S: f64 = 0.010;
/// Correlation time of a motion-capture tracker's pose error, s.
pub const TRACKER_TAU_S: f64 = 0.5;

/// The sensor an output channel is measured by.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Sensor {
    /// A speed from counts of an encoder.
    Encoder,
    /// A low-passed analogue sensor with this correlation time, s.
    Filtered { tau_s: f64 },
}

fn sensor_of(channel: &str) -> Sensor {
    match channel {
        chan::X_M | chan::Y_M | chan::HEADING_RAD => Sensor::Filtered {
            tau_s: TRACKER_TAU_S,
        },
        chan::YAW_RATE_RAD_S => Sensor::Filtered { tau_s: GYRO_TAU_S },
        chan::CURRENT_A => Sensor::Filtered {
            tau_s: CURRENT_SENSOR_TAU_S,
        },
        _ => Sensor::Encoder,
    }
}

/// `truth` as the sensor of `channel` measures it ([`SensorNoise::Sensors`]), with marginal
/// standard deviation `sd_out` (the output's unit), sampled every `dt_s`.
pub(super) fn by_its_sensor(
    channel: &str,
    truth: &[f64],
    sd_out: f64,
    dt_s: f64,
    rng: &mut Pcg64,
) -> Vec<f64> {
    match sensor_of(channel) {
        Sensor::Encoder => encoder_speed(truth, sd_out, dt_s, rng),
        Sensor::Filtered { tau_s } => {
            let n = low_pass_noise(truth.len(), sd_out, dt_s, tau_s, rng);
            truth.iter().zip(n).map(|(y, e)| y + e).collect()
        }
    }
}

/// A standard normal draw.
fn gauss(rng: &mut Pcg64) -> f64 {
    StandardNormal.sample(rng)
}

/// First-order low-pass Gaussian noise of marginal standard deviation `sd` and correlation
/// time `tau_s`, started in its stationary distribution.
fn low_pass_noise(n: usize, sd: f64, dt_s: f64, tau_s: f64, rng: &mut Pcg64) -> Vec<f64> {
    let a = (-dt_s / tau_s).exp();
    let drive = sd * (1.0 - a * a).sqrt();
    let mut x: f64 = sd * gauss(rng);
    (0..n)
        .map(|k| {
            if k > 0 {
                x = a * x + drive * gauss(rng);
            }
            x
        })
        .collect()
}

/// A speed as an encoder's count difference over the sample interval centred on the
/// sample (a reading stamped at the middle of its counting interval, so that it lags the
/// speed by nothing: a count over the interval before the sample would lag it by half a
/// sample, a delay the calibration rightly finds, not noise). The angle's true advance over
/// each interval is `speed·dt`; the angle is quantised to steps of `σ·dt·√6` from a random
/// phase.
fn encoder_speed(truth: &[f64], sd: f64, dt_s: f64, rng: &mut Pcg64) -> Vec<f64> {
    if sd <= 0.0 {
        return truth.to_vec();
    }
    let q = sd * dt_s * 6f64.sqrt();
    let phase: f64 = rng.random_range(0.0..1.0);
    let count = |angle: f64| ((angle / q) + phase).floor();
    let mut angle = 0.0;
    let mut last = count(angle);
    truth
        .iter()
        .map(|y| {
            angle += y * dt_s;
            let now = count(angle);
            let reading = (now - last) * q / dt_s;
            last = now;
            reading
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sd_and_lag1(e: &[f64]) -> (f64, f64) {
        let n = e.len() as f64;
        let m = e.iter().sum::<f64>() / n;
        let var = e.iter().map(|v| (v - m).powi(2)).sum::<f64>() / n;
        let c1 = e.windows(2).map(|w| (w[0] - m) * (w[1] - m)).sum::<f64>() / n;
        (var.sqrt(), c1 / var)
    }

    #[test]
    fn an_encoders_speed_error_has_the_white_deviation_and_neighbours_correlated_at_minus_a_half() {
        // A speed sweeping many steps per sample: the quantisation errors are uniform and
        // independent, so the differenced error has variance q²/6 = σ² and lag-1
        // correlation −1/2 (an MA(1) of two equal independent terms, opposite signs).
        let mut rng = Pcg64::seed_from_u64(3);
        let dt = 0.002;
        let truth: Vec<f64> = (0..50_000)
            .map(|k| 80.0 + 30.0 * (k as f64 * 1e-3).sin())
            .collect();
        let got = encoder_speed(&truth, 0.5, dt, &mut rng);
        let e: Vec<f64> = got.iter().zip(&truth).map(|(a, b)| a - b).collect();
        let (sd, r1) = sd_and_lag1(&e);
        assert!((sd - 0.5).abs() < 0.02, "sd {sd}");
        assert!((r1 + 0.5).abs() < 0.03, "lag-1 correlation {r1}");
        // Every reading is a whole number of counts per sample.
        let q = 0.5 * dt * 6f64.sqrt();
        assert!(got
            .iter()
            .all(|v| ((v * dt / q) - (v * dt / q).round()).abs() < 1e-6));
    }

    #[test]
    fn an_encoders_speed_does_not_lag_an_accelerating_wheel() {
        // Speed 50 + 2000 t rad/s sampled at 2 ms: a count over the interval before each
        // sample would read 2 rad/s low on average (half a sample of the acceleration);
        // the centred count's mean error is the quantiser's, far below that.
        let mut rng = Pcg64::seed_from_u64(5);
        let dt = 0.002;
        let truth: Vec<f64> = (0..20_000).map(|k| 50.0 + 2000.0 * k as f64 * dt).collect();
        let got = encoder_speed(&truth, 0.5, dt, &mut rng);
        let mean_error =
            got.iter().zip(&truth).map(|(a, b)| a - b).sum::<f64>() / truth.len() as f64;
        assert!(mean_error.abs() < 0.05, "mean error {mean_error}");
    }

    #[test]
    fn an_encoder_on_a_wheel_at_rest_reads_zero() {
        let mut rng = Pcg64::seed_from_u64(1);
        assert!(encoder_speed(&[0.0; 100], 0.3, 0.01, &mut rng)
            .iter()
            .all(|v| *v == 0.0));
    }

    #[test]
    fn filtered_noise_keeps_its_deviation_and_correlates_as_its_time_constant_says() {
        // AR(1): lag-1 correlation exp(-dt/τ); with dt = 2 ms and τ = 20 ms, 0.905.
        let mut rng = Pcg64::seed_from_u64(7);
        let e = low_pass_noise(200_000, 0.1, 0.002, 0.020, &mut rng);
        let (sd, r1) = sd_and_lag1(&e);
        assert!((sd - 0.1).abs() < 0.005, "sd {sd}");
        assert!(
            (r1 - (-0.1f64).exp()).abs() < 0.01,
            "lag-1 correlation {r1}"
        );
    }
}
