//! The coast-down test: wheels lifted, the motor run up at full voltage, then the power cut;
//! the recording starts at the cut. With the total inertia known (rig), the decay gives the
//! viscous damping and the Coulomb friction: `J dw/dt = -b w - Tc sign(w)`.

use std::path::Path;

use crate::ident::data::Dataset;
use crate::ident::model::{GreyBox, OutputKind, ParamSpec};
use crate::rig::{Rig, RigError};

use super::falling_weight::rotor_acceleration;

pub const B: usize = 0;
pub const TC: usize = 1;
pub const W0: usize = 2;
pub const JM: usize = 3;
pub const JW: usize = 4;

#[derive(Debug, Clone)]
pub struct CoastDown {
    specs: Vec<ParamSpec>,
    pub ratio: f64,
    pub encoder: bool,
}

impl CoastDown {
    pub fn from_rig(rig: &Rig, path: &Path, initial_speed: f64) -> Result<CoastDown, RigError> {
        let why = "the coast-down model needs the inertias and a starting friction";
        let need = |k: &str| rig.require(k, path, why);
        Ok(CoastDown {
            specs: vec![
                ParamSpec::friction(
                    "motor.viscous_Nm_s_rad",
                    need("motor.viscous_Nm_s_rad")?,
                    crate::rig::electrical_damping(rig)
                        .unwrap_or(rig.get("motor.rotor_inertia_kg_m2").unwrap_or(1e-4) / 0.01),
                ),
                ParamSpec::positive(
                    "motor.coulomb_Nm",
                    rig.get("motor.coulomb_Nm")
                        .filter(|v| *v > 0.0)
                        .unwrap_or(0.01),
                ),
                ParamSpec::positive("initial_speed_rad_s", initial_speed.abs().max(1e-3)),
                ParamSpec::positive(
                    "motor.rotor_inertia_kg_m2",
                    need("motor.rotor_inertia_kg_m2")?,
                ),
                ParamSpec::positive(
                    "wheel.inertia_kg_m2",
                    rig.get("wheel.inertia_kg_m2").unwrap_or(0.0).max(1e-12),
                ),
            ],
            ratio: rig.get("gearbox.ratio").unwrap_or(1.0),
            encoder: rig.get("sensors.motor_encoder_counts_per_rev").is_some(),
        })
    }

    fn inertia(&self, p: &[f64]) -> f64 {
        p[JM] + p[JW] / (self.ratio * self.ratio)
    }
}

impl GreyBox for CoastDown {
    fn name(&self) -> String {
        "coast-down test (wheel lifted, power cut at t = 0)".into()
    }

    fn params(&self) -> &[ParamSpec] {
        &self.specs
    }

    fn default_free(&self, _outputs: &[String]) -> Vec<usize> {
        vec![B, TC, W0]
    }

    fn input_names(&self) -> Vec<String> {
        vec![]
    }

    fn output_names(&self) -> Vec<String> {
        vec!["motor_speed_rad_s".into()]
    }

    fn n_states(&self) -> usize {
        2
    }

    fn initial_state(&self, p: &[f64], _data: &Dataset) -> Vec<f64> {
        vec![p[W0], 0.0]
    }

    fn max_step_s(&self, p: &[f64]) -> f64 {
        (0.1 * self.inertia(p) / p[B]).min(2e-3)
    }

    fn derivatives(&self, p: &[f64], x: &[f64], _u: &[f64], _held: &[f64], dx: &mut [f64]) {
        dx[0] = rotor_acceleration(x[0], 0.0, p[TC], p[B], self.inertia(p));
        dx[1] = x[0];
    }

    fn after_step(&self, _p: &[f64], before: &[f64], x: &mut [f64]) {
        if before[0] > 0.0 && x[0] <= 0.0 {
            x[0] = 0.0;
        }
    }

    fn output_kind(&self, _name: &str) -> OutputKind {
        if self.encoder {
            OutputKind::IntervalRate(1)
        } else {
            OutputKind::Instant
        }
    }

    fn output(&self, _p: &[f64], _name: &str, x: &[f64], _u: &[f64], _held: &[f64]) -> f64 {
        x[0]
    }
}
