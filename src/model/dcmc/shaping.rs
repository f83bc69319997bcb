//! The demand shaping in the DCMC's microprocessor: each side's forward part through its
//! first-order lag, the turn part through its own, then the rate limits (the units'
//! acceleration settings), each only where the unit has it.

use super::{Dcmc, DcmcKind, DcmcParams, DcmcState};
use crate::model::Bounded;

impl DcmcParams {
    /// The unit's acceleration setting as a rate limit per side, if either side has one
    /// (a side set to 0 is unlimited).
    pub fn ramp(&self) -> Option<DcmcRamp> {
        (self.ramp_left_pct_s > 0.0 || self.ramp_right_pct_s > 0.0).then_some(DcmcRamp {
            left_pct_s: positive_or_unlimited(self.ramp_left_pct_s),
            right_pct_s: positive_or_unlimited(self.ramp_right_pct_s),
        })
    }

    /// The unit's turn acceleration setting, pct/s, if it has one.
    pub fn turn_ramp(&self) -> Option<f64> {
        (self.turn_ramp_pct_s > 0.0).then_some(self.turn_ramp_pct_s)
    }

    /// The unit's demand lags, if it has any.
    pub fn response(&self) -> Option<DcmcResponse> {
        (self.response_time_left_s > 0.0
            || self.response_time_right_s > 0.0
            || self.turn_response_time_s > 0.0)
            .then_some(DcmcResponse {
                left_time_constant_s: self.response_time_left_s,
                right_time_constant_s: self.response_time_right_s,
                turn_time_constant_s: self.turn_response_time_s,
            })
    }

    /// The unit with its lags and rate limits taken out (what a linearisation sees).
    pub fn without_shaping(&self) -> DcmcParams {
        DcmcParams {
            ramp_left_pct_s: 0.0,
            ramp_right_pct_s: 0.0,
            turn_ramp_pct_s: 0.0,
            response_time_left_s: 0.0,
            response_time_right_s: 0.0,
            turn_response_time_s: 0.0,
            ..*self
        }
    }
}

/// A rate limit of 0 means "no limit".
fn positive_or_unlimited(rate: f64) -> f64 {
    if rate > 0.0 {
        rate
    } else {
        f64::INFINITY
    }
}

/// Rate limit of each side's demand, percent of full demand per second: a wheelchair
/// controller's acceleration setting. Large demand steps ramp slowly; small corrections
/// pass almost at once, which a linear lag cannot do.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DcmcRamp {
    /// Left side's rate, pct/s.
    pub left_pct_s: f64,
    /// Right side's rate, pct/s.
    pub right_pct_s: f64,
}

impl DcmcRamp {
    /// Rates (left, right), pct/s.
    pub fn rates_pct_s(&self) -> [f64; 2] {
        [self.left_pct_s, self.right_pct_s]
    }

    /// A side's ramped value after `dt`: moves towards `raw` by at most `max_rate dt`.
    pub fn ramped(ramped: f64, raw: f64, max_rate: f64, dt: f64) -> f64 {
        let step = max_rate * dt;
        ramped + (raw - ramped).bounded(-step, step)
    }
}

/// First-order lags of the demand in the DCMC's microprocessor: each side's forward part
/// has its own (the thesis's two sides differ by 12 %), the turn part one of its own.
/// Time constants in seconds; 0 passes that part at once.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DcmcResponse {
    /// Left side's forward lag, s.
    pub left_time_constant_s: f64,
    /// Right side's forward lag, s.
    pub right_time_constant_s: f64,
    /// The turn demand's lag, s.
    pub turn_time_constant_s: f64,
}

impl DcmcResponse {
    /// A side's shaped request after `dt` with the raw request held: the lag's exact
    /// discretisation, `y + (x - y)(1 - exp(-dt / tau))`.
    pub fn shaped_request(time_constant_s: f64, shaped: f64, raw: f64, dt: f64) -> f64 {
        if time_constant_s <= 0.0 {
            return raw;
        }
        shaped + (raw - shaped) * (1.0 - (-dt / time_constant_s).exp())
    }

    /// Time constants of the forward part (left, right), s.
    pub fn time_constants_s(&self) -> [f64; 2] {
        [self.left_time_constant_s, self.right_time_constant_s]
    }
}

impl Dcmc {
    /// Each side's request from the demands: its forward part through that side's lag,
    /// its turn part through the turn lag, then the sum through the ramp (each only if
    /// modelled). Keeps the stages in the state.
    pub(super) fn shape(
        &self,
        s: &mut DcmcState,
        forward_pct: f64,
        turn_pct: f64,
        dt: f64,
    ) -> [f64; 2] {
        let (fwd, turn) = match self.params.kind {
            DcmcKind::Gain | DcmcKind::GainPi => (
                self.params.gain_voltages(forward_pct, 0.0),
                self.params.gain_voltages(0.0, turn_pct),
            ),
            DcmcKind::P | DcmcKind::Pi => (
                self.params.speed_setpoints(forward_pct, 0.0),
                self.params.speed_setpoints(0.0, turn_pct),
            ),
        };
        let (tau_fwd, tau_turn) = self.params.response().map_or(([0.0; 2], 0.0), |r| {
            (r.time_constants_s(), r.turn_time_constant_s)
        });
        for i in 0..2 {
            s.forward_request[i] =
                DcmcResponse::shaped_request(tau_fwd[i], s.forward_request[i], fwd[i], dt);
            // The turn ramp limits each side's turn part at the same rate, so the two move
            // together (equal and opposite).
            let turn_i = match self.params.turn_ramp() {
                Some(rate) => DcmcRamp::ramped(
                    s.turn_request[i],
                    turn[i],
                    rate * self.params.turn_request_per_pct(),
                    dt,
                ),
                None => turn[i],
            };
            s.turn_request[i] =
                DcmcResponse::shaped_request(tau_turn, s.turn_request[i], turn_i, dt);
        }
        let mut x = [0, 1].map(|i| s.forward_request[i] + s.turn_request[i]);
        if let Some(r) = self.params.ramp() {
            let rates = r.rates_pct_s();
            for (i, xi) in x.iter_mut().enumerate() {
                let rate = rates[i] * self.params.request_per_pct().abs();
                *xi = DcmcRamp::ramped(s.shaped_request[i], *xi, rate, dt);
            }
        }
        s.shaped_request = x;
        x
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::{dcmc, input};
    use super::super::{DcmcInput, DcmcOutput, DcmcState};

    #[test]
    fn response_lag_reaches_63_percent_after_one_time_constant_per_side() {
        let mut d = dcmc();
        d.params.response_time_left_s = 0.6;
        d.params.response_time_right_s = 0.3;
        let mut s = DcmcState::default();
        d.step(&mut s, &input(0.0, 0.0, 0.0), 0.001);
        let dt = 0.001;
        let mut t = 0.6;
        let mut at = |until: f64, s: &mut DcmcState| {
            let mut out = DcmcOutput::default();
            while t < until - 1e-12 {
                t += dt;
                out = d.step(s, &input(t, 50.0, 0.0), dt);
            }
            out
        };
        // From the first demand at 0.6 s: the right side (0.3 s) at one time constant.
        let v = at(0.9, &mut s);
        let full = 50.0 * 0.235;
        let share = 1.0 - (-1.0f64).exp();
        assert!((v.voltage_v[1] / full - share).abs() < 0.01, "right {v:?}");
        assert!(
            (v.voltage_v[0] / full - (1.0 - (-0.5f64).exp())).abs() < 0.01,
            "left {v:?}"
        );
        let before = at(1.2, &mut s);
        assert!(
            (before.voltage_v[0] / full - share).abs() < 0.01,
            "left {before:?}"
        );
        // The turn part passes at once (no turn lag): a turn step shows in full.
        let v = d.step(&mut s, &input(1.201, 50.0, 10.0), dt);
        let turn_volts = 10.0 * 0.12;
        assert!((v.voltage_v[1] - before.voltage_v[1] - turn_volts).abs() < 0.01 * turn_volts);
        // Disabling resets the lags: the next enable starts from zero again.
        d.step(
            &mut s,
            &DcmcInput {
                enabled: false,
                ..input(1.3, 0.0, 0.0)
            },
            dt,
        );
        assert_eq!(s.shaped_request, [0.0; 2]);
        assert_eq!(s.forward_request, [0.0; 2]);
    }

    #[test]
    fn ramp_passes_small_steps_at_once_and_limits_large_ones() {
        let mut d = dcmc();
        d.params.ramp_left_pct_s = 100.0;
        d.params.ramp_right_pct_s = 100.0;
        let mut s = DcmcState::default();
        d.step(&mut s, &input(0.0, 0.0, 0.0), 0.001);
        // A 50 % step at 100 %/s takes 0.5 s: halfway after 0.25 s.
        let mut out = DcmcOutput::default();
        for k in 1..=250 {
            out = d.step(&mut s, &input(0.6 + k as f64 * 1e-3, 50.0, 0.0), 1e-3);
        }
        assert!((out.voltage_v[0] - 25.0 * 0.235).abs() < 1e-6, "{out:?}");
        // A 0.1 % correction is through within 1 ms.
        let before = s.shaped_request;
        for k in 1..=260 {
            d.step(&mut s, &input(0.85 + k as f64 * 1e-3, 50.0, 0.0), 1e-3);
        }
        let out = d.step(&mut s, &input(1.2, 50.0, 0.1), 1e-3);
        assert!((out.voltage_v[1] - (50.0 * 0.235 + 0.1 * 0.12)).abs() < 1e-9);
        assert!(before[0] < s.shaped_request[0]);
    }
}
