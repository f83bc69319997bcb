//! PWM outputs to the DCMC: duty counts to a demand in percent, through the 100 Hz
//! (-3 dB) first-order low-pass filter that turns the PWM into an analogue level.

/// Percent of full demand per duty count away from half duty (236 - 127 = 109 counts is
/// full forward).
pub const PCT_PER_COUNT: f64 = 100.0 / 109.0;
/// Duty counts per percent of demand.
pub const COUNTS_PER_PCT: f64 = 109.0 / 100.0;

/// Demand in percent for a duty register value.
pub fn duty_to_pct(duty: f64) -> f64 {
    (duty - super::HALF_DUTY as f64) * PCT_PER_COUNT
}

/// First-order low-pass filter, discretised exactly for a held input.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PwmFilter {
    /// Corner (-3 dB) frequency, Hz.
    pub corner_hz: f64,
}

impl PwmFilter {
    /// Filter output after `h` seconds with the input held.
    pub fn step(&self, state: f64, input: f64, h: f64) -> f64 {
        let a = (-2.0 * std::f64::consts::PI * self.corner_hz * h).exp();
        input + (state - input) * a
    }
}
