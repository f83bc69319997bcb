//! The falling-weight test: the motor off the vehicle, open-circuited, a mass on a cord
//! wound on a pulley on its shaft. The weight accelerates the rotor until it lands; the
//! rotor then coasts to rest on its own friction. The fall gives (J + m r^2) against the
//! known weight torque, the coast gives J against the friction, and the open-circuit
//! terminal voltage gives the back-EMF constant.

use crate::record::channels as chan;
use crate::rig::blocks::FallingWeight as TestSetup;
use crate::rig::blocks::Instruments;
use std::path::Path;

use std::sync::OnceLock;

use crate::ident::data::Dataset;
use crate::ident::model::{Binding, Dynamics, GreyBox, OutputKind, ParamSpec};
use crate::model::motor::MotorParams;
use crate::model::GRAVITY_M_S2;
use crate::param::KeyTable;
use crate::rig::{Rig, RigError};

/// The rotor's inertia.
const INERTIA: &str = MotorParams::rotor_inertia_kg_m2.key();
/// Its Coulomb friction.
const COULOMB: &str = MotorParams::coulomb_nm.key();
/// Its back-EMF constant.
const BACK_EMF: &str = MotorParams::torque_constant_nm_a.key();
/// Its viscous friction.
const VISCOUS: &str = MotorParams::viscous_nm_s_rad.key();

/// The motor's keys (its block is all the test's parameters set).
fn motor_keys() -> &'static KeyTable<MotorParams> {
    static TABLE: OnceLock<KeyTable<MotorParams>> = OnceLock::new();
    TABLE.get_or_init(|| KeyTable::<MotorParams>::new().block(|m| m, |m| m))
}

/// The falling-weight test's model: the motor, a mass on a pulley.
#[derive(Debug, Clone)]
pub struct FallingWeight {
    specs: Vec<ParamSpec>,
    binding: Binding<MotorParams>,
    /// The falling mass, kg.
    pub mass_kg: f64,
    /// The pulley's radius on the motor shaft, m.
    pub pulley_radius_m: f64,
    /// How far the mass falls before it lands, m.
    pub drop_m: f64,
    /// The speed is an encoder's (count difference over the sample interval).
    pub encoder: bool,
}

impl FallingWeight {
    /// The test a rig describes.
    pub fn from_rig(rig: &Rig, path: &Path) -> Result<FallingWeight, RigError> {
        let why = "the falling-weight model needs the motor and the [falling_weight] set-up";
        let need = |k: &str| rig.require(k, path, why);
        let specs = vec![
            ParamSpec::positive(INERTIA, need(INERTIA)?),
            ParamSpec::positive(
                COULOMB,
                rig.get(COULOMB).filter(|v| *v > 0.0).unwrap_or(0.01),
            ),
            ParamSpec::positive(BACK_EMF, need(BACK_EMF)?),
            ParamSpec::friction(
                VISCOUS,
                need(VISCOUS)?,
                crate::rig::electrical_damping(rig)
                    .unwrap_or(rig.get(INERTIA).unwrap_or(1e-4) / 0.01),
            ),
        ];
        Ok(FallingWeight {
            binding: Binding::new(motor_keys(), &specs),
            specs,
            mass_kg: need(TestSetup::mass_kg.key())?,
            pulley_radius_m: need(TestSetup::pulley_radius_m.key())?,
            drop_m: need(TestSetup::drop_m.key())?,
            encoder: rig
                .get(Instruments::motor_encoder_counts_per_rev.key())
                .is_some(),
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

    fn params_mut(&mut self) -> &mut [ParamSpec] {
        &mut self.specs
    }

    /// Inertia, Coulomb and viscous friction, and Kv when the back-EMF is recorded. The
    /// viscous term must be free: over the speeds of a fall it is comparable with the
    /// Coulomb level, and a wrong fixed value biases the Coulomb estimate.
    fn default_free(&self, outputs: &[String]) -> Vec<usize> {
        if outputs.iter().any(|o| o == "back_emf_V") {
            self.indices_of(&[INERTIA, COULOMB, BACK_EMF, VISCOUS])
        } else {
            self.indices_of(&[INERTIA, COULOMB, VISCOUS])
        }
    }

    fn input_names(&self) -> Vec<String> {
        vec![]
    }

    fn output_names(&self) -> Vec<String> {
        vec![chan::MOTOR_SPEED_RAD_S.into(), "back_emf_V".into()]
    }
}

impl Dynamics for FallingWeight {
    type Blocks = MotorParams;
    type Output = FallingOutput;

    fn blocks(&self, p: &[f64]) -> MotorParams {
        self.binding.apply(&MotorParams::default(), p)
    }

    fn n_states(&self) -> usize {
        2
    }

    fn initial_state(&self, _m: &MotorParams, _data: &Dataset) -> Vec<f64> {
        vec![0.0, 0.0]
    }

    fn max_step_s(&self, _m: &MotorParams) -> f64 {
        5e-4
    }

    fn derivatives(&self, m: &MotorParams, x: &[f64], _u: &[f64], _held: &[f64], dx: &mut [f64]) {
        let (drive, j) = if self.falling(x[1]) {
            let r = self.pulley_radius_m;
            (
                self.mass_kg * GRAVITY_M_S2 * r,
                m.rotor_inertia_kg_m2 + self.mass_kg * r * r,
            )
        } else {
            (0.0, m.rotor_inertia_kg_m2)
        };
        dx[0] = rotor_acceleration(x[0], drive, m.coulomb_nm, m.viscous_nm_s_rad, j);
        dx[1] = x[0];
    }

    fn after_step(&self, _m: &MotorParams, before: &[f64], x: &mut [f64]) {
        // Friction stops the rotor; it never reverses it.
        if before[0] > 0.0 && x[0] <= 0.0 && !self.falling(x[1]) {
            x[0] = 0.0;
        }
    }

    fn output_of(&self, name: &str) -> FallingOutput {
        match name {
            chan::MOTOR_SPEED_RAD_S => FallingOutput::MotorSpeed,
            "back_emf_V" => FallingOutput::BackEmf,
            _ => FallingOutput::Other,
        }
    }

    fn output_kind(&self, o: FallingOutput) -> OutputKind {
        if o == FallingOutput::MotorSpeed && self.encoder {
            OutputKind::IntervalRate(1)
        } else {
            OutputKind::Instant
        }
    }

    fn output(
        &self,
        m: &MotorParams,
        o: FallingOutput,
        x: &[f64],
        _u: &[f64],
        _held: &[f64],
    ) -> f64 {
        match o {
            FallingOutput::MotorSpeed => x[0],
            FallingOutput::BackEmf => m.back_emf_v(x[0]),
            FallingOutput::Other => f64::NAN,
        }
    }
}

/// What a falling-weight recording's output column is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FallingOutput {
    /// `motor_speed_rad_s`.
    MotorSpeed,
    /// `back_emf_V`: the motor's back EMF at its speed.
    BackEmf,
    /// A column the model does not produce.
    Other,
}
