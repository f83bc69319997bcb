//! The falling-weight test: the motor off the vehicle, open-circuited, a mass on a cord
//! wound on a pulley on its shaft. The weight accelerates the rotor until it lands; the
//! rotor then coasts to rest on its own friction. The fall gives (J + m r^2) against the
//! known weight torque, the coast gives J against the friction, and the open-circuit
//! terminal voltage gives the back-EMF constant.

use std::path::Path;

use crate::ident::data::Dataset;
use crate::ident::model::{GreyBox, OutputKind, ParamSpec};
use crate::model::GRAVITY_M_S2;
use crate::rig::{Rig, RigError};

pub const J: usize = 0;
pub const TC: usize = 1;
pub const K: usize = 2;
pub const B: usize = 3;

#[derive(Debug, Clone)]
pub struct FallingWeight {
    specs: Vec<ParamSpec>,
    pub mass_kg: f64,
    pub pulley_radius_m: f64,
    pub drop_m: f64,
    pub encoder: bool,
}

impl FallingWeight {
    pub fn from_rig(rig: &Rig, path: &Path) -> Result<FallingWeight, RigError> {
        let why = "the falling-weight model needs the motor and the [falling_weight] set-up";
        let need = |k: &str| rig.require(k, path, why);
        Ok(FallingWeight {
            specs: vec![
                ParamSpec::positive(
                    "motor.rotor_inertia_kg_m2",
                    need("motor.rotor_inertia_kg_m2")?,
                ),
                ParamSpec::positive(
                    "motor.coulomb_Nm",
                    rig.get("motor.coulomb_Nm")
                        .filter(|v| *v > 0.0)
                        .unwrap_or(0.01),
                ),
                ParamSpec::positive(
                    "motor.torque_constant_Nm_A",
                    need("motor.torque_constant_Nm_A")?,
                ),
                ParamSpec::friction(
                    "motor.viscous_Nm_s_rad",
                    need("motor.viscous_Nm_s_rad")?,
                    crate::rig::electrical_damping(rig)
                        .unwrap_or(rig.get("motor.rotor_inertia_kg_m2").unwrap_or(1e-4) / 0.01),
                ),
            ],
            mass_kg: need("falling_weight.mass_kg")?,
            pulley_radius_m: need("falling_weight.pulley_radius_m")?,
            drop_m: need("falling_weight.drop_m")?,
            encoder: rig.get("sensors.motor_encoder_counts_per_rev").is_some(),
        })
    }

    fn falling(&self, angle_rad: f64) -> bool {
        angle_rad * self.pulley_radius_m < self.drop_m
    }
}

/// Acceleration of a rotor of inertia `j` under a driving torque and Coulomb plus viscous
/// friction; at standstill the rotor stays put unless the drive beats the friction.
pub fn rotor_acceleration(speed: f64, drive_nm: f64, coulomb_nm: f64, viscous: f64, j: f64) -> f64 {
    if speed == 0.0 {
        if drive_nm.abs() <= coulomb_nm {
            return 0.0;
        }
        return (drive_nm - coulomb_nm * drive_nm.signum()) / j;
    }
    (drive_nm - coulomb_nm * speed.signum() - viscous * speed) / j
}

impl GreyBox for FallingWeight {
    fn name(&self) -> String {
        "falling-weight test (motor off the vehicle, open circuit)".into()
    }

    fn params(&self) -> &[ParamSpec] {
        &self.specs
    }

    /// Inertia, Coulomb and viscous friction, and Kv when the back-EMF is recorded. The
    /// viscous term must be free: over the speeds of a fall it is comparable with the
    /// Coulomb level, and a wrong fixed value biases the Coulomb estimate.
    fn default_free(&self, outputs: &[String]) -> Vec<usize> {
        if outputs.iter().any(|o| o == "back_emf_V") {
            vec![J, TC, K, B]
        } else {
            vec![J, TC, B]
        }
    }

    fn input_names(&self) -> Vec<String> {
        vec![]
    }

    fn output_names(&self) -> Vec<String> {
        vec!["motor_speed_rad_s".into(), "back_emf_V".into()]
    }

    fn n_states(&self) -> usize {
        2
    }

    fn initial_state(&self, _p: &[f64], _data: &Dataset) -> Vec<f64> {
        vec![0.0, 0.0]
    }

    fn max_step_s(&self, _p: &[f64]) -> f64 {
        5e-4
    }

    fn derivatives(&self, p: &[f64], x: &[f64], _u: &[f64], _held: &[f64], dx: &mut [f64]) {
        let (drive, j) = if self.falling(x[1]) {
            let r = self.pulley_radius_m;
            (self.mass_kg * GRAVITY_M_S2 * r, p[J] + self.mass_kg * r * r)
        } else {
            (0.0, p[J])
        };
        dx[0] = rotor_acceleration(x[0], drive, p[TC], p[B], j);
        dx[1] = x[0];
    }

    fn after_step(&self, _p: &[f64], before: &[f64], x: &mut [f64]) {
        // Friction stops the rotor; it never reverses it.
        if before[0] > 0.0 && x[0] <= 0.0 && !self.falling(x[1]) {
            x[0] = 0.0;
        }
    }

    fn output_kind(&self, name: &str) -> OutputKind {
        if name == "motor_speed_rad_s" && self.encoder {
            OutputKind::IntervalRate(1)
        } else {
            OutputKind::Instant
        }
    }

    fn output(&self, p: &[f64], name: &str, x: &[f64], _u: &[f64], _held: &[f64]) -> f64 {
        match name {
            "motor_speed_rad_s" => x[0],
            "back_emf_V" => p[K] * x[0],
            _ => f64::NAN,
        }
    }
}
