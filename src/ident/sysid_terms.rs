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

/// SysId's three terms.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Terms {
    /// Static friction voltage kS, V.
    pub ks_v: f64,
    /// Velocity gain kV, V per unit of speed.
    pub kv: f64,
    /// Acceleration gain kA, V per unit of speed per second.
    pub ka: f64,
}

/// The drive's parameters the terms are made of.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DcDrive {
    /// Armature resistance, ohm.
    pub resistance_ohm: f64,
    /// Torque constant, N m/A (= back-EMF constant, V s/rad).
    pub torque_constant_nm_a: f64,
    /// Coulomb friction at the motor shaft, N m.
    pub coulomb_nm: f64,
    /// Viscous friction at the motor shaft, N m s/rad.
    pub viscous_nm_s_rad: f64,
    /// Inertia at the motor shaft, kg m^2.
    pub inertia_kg_m2: f64,
    /// Motor radians per unit of the measured speed.
    pub motor_rad_per_unit: f64,
}

impl DcDrive {
    /// SysId's terms of this drive (the module's equations).
    pub fn terms(&self) -> Terms {
        let (r, k, n) = (
            self.resistance_ohm,
            self.torque_constant_nm_a,
            self.motor_rad_per_unit,
        );
        Terms {
            ks_v: r * self.coulomb_nm / k,
            kv: (k + r * self.viscous_nm_s_rad / k) * n,
            ka: r * self.inertia_kg_m2 * n / k,
        }
    }
}

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::motor::MotorParams;

    /// The motor block's own steady state and acceleration obey the terms: at a terminal
    /// voltage V the steady speed is (V - kS) / kV, and from rest with the current settled
    /// the acceleration is (V - kS) / kA.
    #[test]
    fn a_dc_motors_steady_speed_and_start_obey_its_terms() {
        let motor = MotorParams {
            coulomb_nm: 0.05,
            ..MotorParams::default()
        };
        let j = 3e-3;
        let drive = DcDrive {
            resistance_ohm: motor.resistance_ohm,
            torque_constant_nm_a: motor.torque_constant_nm_a,
            coulomb_nm: motor.coulomb_nm,
            viscous_nm_s_rad: motor.viscous_nm_s_rad,
            inertia_kg_m2: j,
            motor_rad_per_unit: 1.0,
        };
        let t = drive.terms();
        let v = 12.0;
        let (r, k, b) = (
            motor.resistance_ohm,
            motor.torque_constant_nm_a,
            motor.viscous_nm_s_rad,
        );
        // Steady state: K (V - K w) / R = Tc + b w.
        let w = (motor.stall_torque_nm(v) - motor.coulomb_nm)
            / (b + motor.electrical_damping_nm_s_rad());
        assert!(((v - t.ks_v) / t.kv - w).abs() < 1e-9 * w, "{t:?}");
        // From rest, current settled at V / R: J dw/dt = K V / R - Tc.
        let acc = (k * v / r - motor.coulomb_nm) / j;
        assert!(((v - t.ks_v) / t.ka - acc).abs() < 1e-9 * acc);
    }
}
