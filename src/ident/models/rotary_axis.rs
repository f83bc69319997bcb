//! A rotary drive axis with the wheel lifted: DC motor, rigid gear train, wheel; driven by
//! a terminal voltage or by a demand through a controller gain (the rig's `[controller]`).
//!
//! `L di/dt = V - R i - K w`, `(Jm + Jw/N^2) dw/dt = K i - b w`, `dtheta/dt = w`, with all
//! viscous friction `b` referred to the motor shaft, as the rig format defines it.

use std::path::Path;

use crate::ident::data::Dataset;
use crate::ident::model::{GreyBox, OutputKind, ParamSpec};
use crate::rig::{Rig, RigError};

/// What drives the armature.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum AxisInput {
    /// `voltage_V`.
    Voltage,
    /// `demand_pct` x `controller.gain_V_pct`.
    Demand,
}

pub const R: usize = 0;
pub const L: usize = 1;
pub const K: usize = 2;
pub const JM: usize = 3;
pub const JW: usize = 4;
pub const B: usize = 5;
pub const GAIN: usize = 6;

/// The nominal rotary axis.
#[derive(Debug, Clone)]
pub struct RotaryAxis {
    specs: Vec<ParamSpec>,
    pub input: AxisInput,
    /// Motor turns per wheel turn (known exactly from the tooth counts).
    pub ratio: f64,
    /// Speeds come from an encoder (count difference over the sample interval).
    pub encoder: bool,
}

impl RotaryAxis {
    pub fn from_rig(rig: &Rig, path: &Path, input: AxisInput) -> Result<RotaryAxis, RigError> {
        let need = |k: &str| rig.require(k, path, "the rotary drive-axis model needs it");
        let mut specs = vec![
            ParamSpec::positive("motor.resistance_ohm", need("motor.resistance_ohm")?),
            ParamSpec::positive("motor.inductance_H", need("motor.inductance_H")?),
            ParamSpec::positive(
                "motor.torque_constant_Nm_A",
                need("motor.torque_constant_Nm_A")?,
            ),
            ParamSpec::positive(
                "motor.rotor_inertia_kg_m2",
                need("motor.rotor_inertia_kg_m2")?,
            ),
            ParamSpec::positive(
                "wheel.inertia_kg_m2",
                rig.get("wheel.inertia_kg_m2").unwrap_or(0.0).max(1e-12),
            ),
            ParamSpec::positive("motor.viscous_Nm_s_rad", need("motor.viscous_Nm_s_rad")?),
        ];
        if input == AxisInput::Demand {
            specs.push(ParamSpec::positive(
                "controller.gain_V_pct",
                rig.require("controller.gain_V_pct", path, "demand_pct is the input")?,
            ));
        }
        Ok(RotaryAxis {
            specs,
            input,
            ratio: rig.get("gearbox.ratio").unwrap_or(1.0),
            encoder: rig.get("sensors.motor_encoder_counts_per_rev").is_some(),
        })
    }

    /// Total inertia at the motor shaft, kg m^2.
    pub fn inertia_at_motor(&self, p: &[f64]) -> f64 {
        p[JM] + p[JW] / (self.ratio * self.ratio)
    }

    /// Terminal voltage for an input value, V.
    pub fn voltage(&self, p: &[f64], u: f64) -> f64 {
        match self.input {
            AxisInput::Voltage => u,
            AxisInput::Demand => p[GAIN] * u,
        }
    }

    /// Mechanical time constant J / (b + K^2/R), s.
    pub fn mechanical_time_constant_s(&self, p: &[f64]) -> f64 {
        self.inertia_at_motor(p) / (p[B] + p[K] * p[K] / p[R])
    }
}

impl GreyBox for RotaryAxis {
    fn name(&self) -> String {
        match self.input {
            AxisInput::Voltage => "rotary drive axis, voltage-driven".into(),
            AxisInput::Demand => "rotary drive axis, demand through a controller gain".into(),
        }
    }

    fn params(&self) -> &[ParamSpec] {
        &self.specs
    }

    fn default_free(&self, outputs: &[String]) -> Vec<usize> {
        // Only the sum of the inertias is seen through a rigid gear train: the wheel's stays
        // at the rig value and the rotor's absorbs the difference. Without a current
        // measurement R and L are not separable from K and J, so they stay fixed.
        let mut free = if outputs.iter().any(|o| o == "current_A") {
            vec![R, L, K, JM, B]
        } else {
            vec![K, JM, B]
        };
        if self.input == AxisInput::Demand {
            free.push(GAIN);
        }
        free
    }

    fn input_names(&self) -> Vec<String> {
        match self.input {
            AxisInput::Voltage => vec!["voltage_V".into()],
            AxisInput::Demand => vec!["demand_pct".into()],
        }
    }

    fn output_names(&self) -> Vec<String> {
        [
            "motor_speed_rad_s",
            "current_A",
            "motor_angle_rad",
            "wheel_angle_rad",
        ]
        .map(String::from)
        .to_vec()
    }

    fn n_states(&self) -> usize {
        3
    }

    fn initial_state(&self, _p: &[f64], data: &Dataset) -> Vec<f64> {
        let angle = data
            .first_measured("motor_angle_rad")
            .or_else(|| {
                data.first_measured("wheel_angle_rad")
                    .map(|a| a * self.ratio)
            })
            .unwrap_or(0.0);
        vec![0.0, 0.0, angle]
    }

    fn max_step_s(&self, p: &[f64]) -> f64 {
        (0.5 * p[L] / p[R]).min(0.2 * self.mechanical_time_constant_s(p))
    }

    fn derivatives(&self, p: &[f64], x: &[f64], u: &[f64], _held: &[f64], dx: &mut [f64]) {
        let v = self.voltage(p, u[0]);
        dx[0] = (v - p[R] * x[0] - p[K] * x[1]) / p[L];
        dx[1] = (p[K] * x[0] - p[B] * x[1]) / self.inertia_at_motor(p);
        dx[2] = x[1];
    }

    fn output_kind(&self, name: &str) -> OutputKind {
        if name == "motor_speed_rad_s" && self.encoder {
            OutputKind::IntervalRate(2)
        } else {
            OutputKind::Instant
        }
    }

    fn output(&self, _p: &[f64], name: &str, x: &[f64], _u: &[f64], _held: &[f64]) -> f64 {
        match name {
            "motor_speed_rad_s" => x[1],
            "current_A" => x[0],
            "motor_angle_rad" => x[2],
            "wheel_angle_rad" => x[2] / self.ratio,
            _ => f64::NAN,
        }
    }
}
