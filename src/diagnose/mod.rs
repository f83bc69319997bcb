//! Diagnosis: when the nominal model, its parameters fitted, still disagrees with a
//! recording, locate where, name the missing physics from the contract's vocabulary, fit
//! it, and show the improvement.
//!
//! 1. **Baseline**: identify the rig's nominal model (its default free parameters).
//! 2. **Locate**: the baseline residual's energy by operating regime (`regimes`).
//! 3. **Hypothesise**: every vocabulary effect that applies to the structure, as an
//!    optional block of the same model.
//! 4. **Fit and select**: each candidate is fitted with the nominal free parameters, from
//!    two starting values of its own parameter, with the baseline's output weights. A
//!    candidate is significant when its AIC gain, computed with the *effective* number of
//!    independent residuals (the baseline residual is coloured, so N overstates the
//!    evidence), exceeds [`MIN_DELTA_AIC`] and it removes at least [`MIN_RSS_REDUCTION`] of
//!    the residual. The most significant is accepted and the search repeats once for a
//!    second effect.
//!
//! This file is the face: the rules' thresholds, the structure's effect blocks shared by
//! the search's parts, and the re-exports. A run is `run.rs` ([`diagnose`]), what it gives
//! `result.rs` ([`Diagnosis`] and the contract's JSON).

mod candidate;
pub(crate) mod evidence;
pub mod plots;
pub mod prove;
mod regimes;
pub mod report;
mod result;
pub(crate) mod round;
mod run;
mod scales;
mod search;
pub mod terms;

pub use evidence::relative_errors;
pub use result::{Alternative, Candidate, Diagnosis, Finding, Unexplained, UNEXPLAINED_REDUCTION};
pub use run::{diagnose, DiagnoseOptions, MIN_INPUT_CHANGES};

use crate::ident::effects::Effect;
use crate::ident::fit::Fit;
use crate::ident::Structure;
use scales::Scales;

/// Smallest gain in AIC (with the effective sample count) that counts as evidence.
pub const MIN_DELTA_AIC: f64 = 10.0;
/// Smallest share of the baseline's residual sum of squares an effect must remove.
pub const MIN_RSS_REDUCTION: f64 = 0.03;
/// Fewest samples a diagnosis will decide on.
pub const MIN_SAMPLES: usize = 100;
/// Rounds of the search: each adds at most one effect, so a diagnosis names at most
/// this many. Two keep a diagnosis of many records affordable; `calibrate` goes on.
pub const ROUNDS: usize = 2;

impl Structure {
    fn applicable(&self) -> Vec<Effect> {
        match self {
            Structure::Rotary(m) => m.applicable(),
            Structure::Linear(m) => m.applicable(),
            Structure::Vehicle(m) => m.applicable(),
            _ => vec![],
        }
    }

    /// Nominal parameters an effect's block makes identifiable, beyond the nominal free set.
    fn newly_identifiable(&self, e: Effect, outputs: &[String]) -> Vec<usize> {
        match self {
            Structure::Rotary(m) => m.newly_identifiable(e, outputs),
            _ => vec![],
        }
    }

    fn with_effect(&self, e: Effect, start: f64, lo: f64, hi: f64, speed_max: f64) -> Structure {
        match self {
            Structure::Rotary(m) => Structure::Rotary(m.with_effect(e, start, lo, hi, speed_max)),
            Structure::Linear(m) => Structure::Linear(m.with_effect(e, start, lo, hi, speed_max)),
            Structure::Vehicle(m) => Structure::Vehicle(m.with_effect(e, start, lo, hi, speed_max)),
            other => other.clone(),
        }
    }
}

/// A stage of the search: the structure as it stands and its fit.
struct Stage {
    structure: Structure,
    fit: Fit,
}
