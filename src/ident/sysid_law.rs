//! SysId's terms of a physical model (the law; [`super::sysid_terms`] states them for a
//! fit): what a permanent-magnet DC drive's parameters imply
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

use serde::Serialize;

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
