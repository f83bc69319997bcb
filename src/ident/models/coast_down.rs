//! The coast-down test: wheels lifted, the motor run up at full voltage, then the power cut;
//! the recording starts at the cut. With the total inertia known (rig), the decay gives the
//! viscous damping and the Coulomb friction: `J dw/dt = -b w - Tc sign(w)`.

use crate::record::channels as chan;
use crate::rig::blocks::Instruments;
use std::path::Path;

use std::sync::OnceLock;

use crate::ident::data::Dataset;
use crate::ident::model::{Binding, Dynamics, GreyBox, OutputKind, ParamSpec};
use crate::model::motor::MotorParams;
use crate::model::wheel::WheelParams;
use crate::param::KeyTable;
use crate::rig::{Rig, RigError};

use super::falling_weight::rotor_acceleration;

/// The drive train's viscous friction at the motor.
const VISCOUS: &str = MotorParams::viscous_nm_s_rad.key();
/// Its Coulomb friction at the motor.
const COULOMB: &str = MotorParams::coulomb_nm.key();
/// The speed at the cut.
const INITIAL_SPEED: &str = "initial_speed_rad_s";

crate::declare_params! {
    /// Where the record starts (section `coast`).
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct CoastStart in "coast" {
        /// Motor speed when the power is cut.
        initial_speed_rad_s: f64 = 0.0, "rad/s", Finite;
    }
}

/// What the coast-down's parameters set: the motor and wheel, and the start.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CoastParams {
    /// The motor (inertia, friction).
    pub motor: MotorParams,
    /// The wheel (inertia).
    pub wheel: WheelParams,
    /// The speed at the cut.
    pub start: CoastStart,
}

fn coast_keys() -> &'static KeyTable<CoastParams> {
    static TABLE: OnceLock<KeyTable<CoastParams>> = OnceLock::new();
    TABLE.get_or_init(|| {
        KeyTable::<CoastParams>::new()
            .block(|c| &c.motor, |c| &mut c.motor)
            .block(|c| &c.wheel, |c| &mut c.wheel)
            .block(|c| &c.start, |c| &mut c.start)
    })
}

/// The coast-down test's model.
#[derive(Debug, Clone)]
pub struct CoastDown {
    specs: Vec<ParamSpec>,
    binding: Binding<CoastParams>,
    /// Motor turns per wheel turn.
    pub ratio: f64,
    /// The speed is an encoder's.
    pub encoder: bool,
}

impl CoastDown {
    /// The test a rig describes, the record starting at `initial_speed` (rad/s).
    pub fn from_rig(rig: &Rig, path: &Path, initial_speed: f64) -> Result<CoastDown, RigError> {
        let why = "the coast-down model needs the inertias and a starting friction";
        let need = |k: &str| rig.require(k, path, why);
        let specs = vec![
            ParamSpec::friction(
                VISCOUS,
                need(VISCOUS)?,
                crate::rig::electrical_damping(rig).unwrap_or(
                    rig.get(MotorParams::rotor_inertia_kg_m2.key())
                        .unwrap_or(1e-4)
                        / 0.01,
                ),
            ),
            ParamSpec::positive(
                COULOMB,
                rig.get(COULOMB).filter(|v| *v > 0.0).unwrap_or(0.01),
            ),
            ParamSpec::positive(INITIAL_SPEED, initial_speed.abs().max(1e-3))
                .setting(CoastStart::initial_speed_rad_s.key()),
            ParamSpec::positive(
                MotorParams::rotor_inertia_kg_m2.key(),
                need(MotorParams::rotor_inertia_kg_m2.key())?,
            ),
            ParamSpec::positive(
                WheelParams::inertia_kg_m2.key(),
                rig.get(WheelParams::inertia_kg_m2.key())
                    .unwrap_or(0.0)
                    .max(1e-12),
            ),
        ];
        Ok(CoastDown {
            binding: Binding::new(coast_keys(), &specs),
            specs,
            ratio: rig.gear_ratio(path)?,
            encoder: rig
                .get(Instruments::motor_encoder_counts_per_rev.key())
                .is_some(),
        })
    }

    fn inertia(&self, c: &CoastParams) -> f64 {
        c.motor.rotor_inertia_kg_m2 + c.wheel.inertia_kg_m2 / (self.ratio * self.ratio)
    }
}

impl GreyBox for CoastDown {
    fn name(&self) -> String {
        "coast-down test (wheel lifted, power cut at t = 0)".into()
    }

    fn params(&self) -> &[ParamSpec] {
        &self.specs
    }

    fn params_mut(&mut self) -> &mut [ParamSpec] {
        &mut self.specs
    }

    fn default_free(&self, _outputs: &[String]) -> Vec<usize> {
        self.indices_of(&[VISCOUS, COULOMB, INITIAL_SPEED])
    }

    fn input_names(&self) -> Vec<String> {
        vec![]
    }

    fn output_names(&self) -> Vec<String> {
        vec![chan::MOTOR_SPEED_RAD_S.into()]
    }
}

impl Dynamics for CoastDown {
    type Blocks = CoastParams;
    /// The one output: the motor's speed, whatever the column's name.
    type Output = ();

    fn blocks(&self, p: &[f64]) -> CoastParams {
        self.binding.apply(&CoastParams::default(), p)
    }

    fn n_states(&self) -> usize {
        2
    }

    fn initial_state(&self, c: &CoastParams, _data: &Dataset) -> Vec<f64> {
        vec![c.start.initial_speed_rad_s, 0.0]
    }

    fn max_step_s(&self, c: &CoastParams) -> f64 {
        (0.1 * self.inertia(c) / c.motor.viscous_nm_s_rad).min(2e-3)
    }

    fn derivatives(&self, c: &CoastParams, x: &[f64], _u: &[f64], _held: &[f64], dx: &mut [f64]) {
        let m = &c.motor;
        dx[0] = rotor_acceleration(x[0], 0.0, m.coulomb_nm, m.viscous_nm_s_rad, self.inertia(c));
        dx[1] = x[0];
    }

    fn after_step(&self, _c: &CoastParams, before: &[f64], x: &mut [f64]) {
        if before[0] > 0.0 && x[0] <= 0.0 {
            x[0] = 0.0;
        }
    }

    fn output_of(&self, _name: &str) {}

    fn output_kind(&self, _o: ()) -> OutputKind {
        if self.encoder {
            OutputKind::IntervalRate(1)
        } else {
            OutputKind::Instant
        }
    }

    fn output(&self, _c: &CoastParams, _o: (), x: &[f64], _u: &[f64], _held: &[f64]) -> f64 {
        x[0]
    }
}
