//! The physical blocks of the AGV, free of rapier, files and the CLI. Each has its
//! parameters (immutable during a run), its state (what is integrated) and a step or a
//! force law that can be tested alone. Block diagram order:
//! battery -> DCMC (or a velocity-commanded base controller) -> motor -> gearbox (backlash) -> wheel/tyre -> chassis.

pub mod base_controller;
pub mod battery;
pub mod castor;
pub mod chassis;
pub mod dcmc;
pub mod drivetrain;
pub mod gearbox;
pub mod manoeuvre;
pub mod motor;
pub mod speed_loop;
pub mod term;
pub mod tyre;
pub mod tyre_presets;
pub mod wheel;

/// Standard gravity, m/s^2.
pub const GRAVITY_M_S2: f64 = 9.81;

/// Limiting a value between bounds that come from parameters and state: where a runaway
/// value (or an infinite parameter) has made the bounds NaN or crossed, the result is NaN
/// rather than a panic, and the simulation's divergence check stops the run with an error
/// that says so.
pub trait Bounded {
    /// `self` within `[lo, hi]`; NaN if the bounds are NaN or crossed.
    fn bounded(self, lo: f64, hi: f64) -> f64;
}

impl Bounded for f64 {
    fn bounded(self, lo: f64, hi: f64) -> f64 {
        if lo <= hi {
            self.clamp(lo, hi)
        } else {
            f64::NAN
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Bounded;

    #[test]
    fn bounds_that_ran_away_give_nan_not_a_panic() {
        assert_eq!(2.0.bounded(-1.0, 1.0), 1.0);
        assert!(0.0.bounded(f64::NAN, f64::NAN).is_nan());
        assert!(0.0.bounded(1.0, -1.0).is_nan());
        assert!(f64::NAN.bounded(-1.0, 1.0).is_nan());
    }
}
