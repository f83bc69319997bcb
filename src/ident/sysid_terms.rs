//! SysId's terms of a physical model: what a permanent-magnet DC drive's parameters imply
//! for WPILib SysId's `V = kS sgn(v) + kV v + kA dv/dt`, so that a diagnosed model can be
//! read beside SysId's own regression of the same record.
//!
//! A drive whose motor turns `n` rad per unit of the measured speed `v` (1 for the motor's
//! own speed in rad/s; `ratio / radius` for a wheel's rim speed in m/s) obeys, with the
//! inductance's fast transient over,
//!
//! `V = R i + K n v`,  `K i = Tc sgn(v) + b n v + J n dv/dt`,
//!
//! so `kS = R Tc / K` (V), `kV = (K + R b / K) n` (V per unit of speed) and
//! `kA = R J n / K` (V per unit of acceleration), where `J` is the inertia at the motor
//! shaft (rotor, gear and wheel, and a vehicle's share of its mass).

use nalgebra::DVector;
use serde::Serialize;

use super::fit::Fit;
use super::model::GreyBox;
pub use super::sysid_law::{DcDrive, Terms};

/// The terms of a fitted model with their standard deviations.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FittedTerms {
    /// The terms at the fitted parameters.
    pub value: Terms,
    /// Their standard deviations by the delta method through the fit's covariance (the
    /// record and the beliefs together); `None` where a parameter they depend on is
    /// undetermined.
    pub std: Option<Terms>,
    /// The unit of speed they are per (`m/s`, `rad/s`).
    pub speed_unit: &'static str,
}

/// SysId's terms of `model` as `f` fitted it, per `speed_unit`, if the model is a DC drive
/// it can state them for ([`GreyBox::sysid_terms`]).
pub fn of_fit(model: &dyn GreyBox, f: &Fit, speed_unit: &'static str) -> Option<FittedTerms> {
    let value = model.sysid_terms(&f.params, speed_unit)?;
    let as_vec = |t: Terms| DVector::from_vec(vec![t.ks_v, t.kv, t.ka]);
    let base = as_vec(value);
    let d = f.free.len();
    let mut g = nalgebra::DMatrix::zeros(3, d);
    for (c, &i) in f.free.iter().enumerate() {
        let h = 1e-6 * f.params[i].abs().max(1e-12);
        let mut p = f.params.clone();
        p[i] += h;
        let moved = as_vec(model.sysid_terms(&p, speed_unit)?);
        for r in 0..3 {
            g[(r, c)] = (moved[r] - base[r]) / h;
        }
    }
    let depends_on_undetermined =
        (0..d).any(|c| f.std[c].is_none() && (0..3).any(|r| g[(r, c)] != 0.0));
    let cov = &g * &f.covariance * g.transpose();
    let sd = |r: usize| cov[(r, r)].max(0.0).sqrt();
    Some(FittedTerms {
        value,
        std: (!depends_on_undetermined).then(|| Terms {
            ks_v: sd(0),
            kv: sd(1),
            ka: sd(2),
        }),
        speed_unit,
    })
}
