//! The scene: the composition of the blocks' declared parameters (each block's section is
//! its parameter struct, declared in its own module with units, defaults, ranges and
//! meanings), the run settings, the world and the claims.
//!
//! Defaults are the thesis's machine (see `shared/spec/seed-digest.md`); values the
//! thesis does not give are marked *assumed* in the declarations. Unknown keys are
//! rejected so that a typo never silently falls back to a default.

use serde::{Deserialize, Serialize};

use super::ExpectSpec;
use crate::firmware::ControllerParams;
use crate::model::base_controller::BaseParams;
use crate::model::battery::BatteryParams;
use crate::model::castor::CastorParams;
use crate::model::chassis::{ChassisParams, PayloadParams, Pose};
use crate::model::dcmc::DcmcParams;
use crate::model::gearbox::GearboxParams;
use crate::model::motor::MotorParams;
use crate::model::tyre::TyreChoice;
use crate::model::wheel::WheelParams;
use crate::sensing::bumper::ObstacleParams;
use crate::sensing::coil::SensorParams;
use crate::sensing::wire::WireParams;
use crate::world::FloorParams;

/// A whole scene: vehicle, floor, wire, obstacles and run settings.
#[derive(Debug, Clone, Deserialize, Serialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct Scene {
    /// Free text shown in summaries.
    pub description: String,
    /// How the run is simulated and recorded.
    pub sim: SimSettings,
    /// The bare vehicle.
    pub chassis: ChassisParams,
    /// Load on the platform.
    pub payload: PayloadParams,
    /// The four castor idlers.
    pub castors: CastorParams,
    /// The drive motors (both sides).
    pub motor: MotorParams,
    /// The gear trains (both sides).
    pub gearbox: GearboxParams,
    /// The drive wheels (both sides).
    pub wheel: WheelParams,
    /// A term outside the vocabulary in both drivetrains (all coefficients zero: none).
    #[serde(skip_serializing_if = "crate::model::term::TermParams::is_off")]
    pub term: crate::model::term::TermParams,
    /// The drive tyres.
    pub tyre: TyreChoice,
    /// The floor's surfaces.
    pub floor: FloorParams,
    /// The battery and the bridges' limits.
    pub battery: BatteryParams,
    /// The wheelchair motor controller.
    pub dcmc: DcmcParams,
    /// A velocity-commanded base: base controller limits and the motor drivers' speed
    /// loops (driven by `cmd_linear_m_s`, `cmd_angular_rad_s`).
    pub base: BaseParams,
    /// The guide-wire pick-up coils.
    pub sensors: SensorParams,
    /// The firmware.
    pub controller: ControllerParams,
    /// What a velocity-commanded base drives in a run (`controller.kind = "velocity"`).
    #[serde(skip_serializing_if = "crate::model::manoeuvre::ManoeuvreParams::is_default")]
    pub manoeuvre: crate::model::manoeuvre::ManoeuvreParams,
    /// The guide wire.
    pub wire: WireParams,
    /// Initial pose of the drive-axle midpoint, world frame.
    pub start: Pose,
    /// Fixed obstacles on the floor.
    pub obstacles: Vec<ObstacleParams>,
    /// What a run of the scene as written shows (checked by `agvsim run` and the tests).
    #[serde(skip_serializing_if = "ExpectSpec::is_empty")]
    pub expect: ExpectSpec,
    /// `[uncertainty_pct]`: how far a value is believed, one standard deviation in percent
    /// of it, by quoted scene key (`"chassis.mass_kg" = 10`). A calibration holds a key the
    /// recording cannot determine near its value by this belief; an unstated key is free.
    #[serde(skip_serializing_if = "std::collections::BTreeMap::is_empty")]
    pub uncertainty_pct: std::collections::BTreeMap<String, f64>,
}

/// Which parts of the model are switched on (the thesis's three levels plus ours).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Fidelity {
    /// Thesis level 1: ideal (linearised) position feedback, continuous controller, no slip.
    Linear,
    /// Thesis level 2: real sensor law, sample and hold, computation delay, PWM filter, no slip.
    Nonlinear,
    /// Thesis level 3: level 2 plus ADC quantisation, integer arithmetic and gear backlash.
    Complex,
    /// Level 3 on the rapier chassis with tyres (slip) and castors.
    #[default]
    Full,
}

impl crate::param::Value for Fidelity {}

impl Fidelity {
    /// Every level, simplest first.
    pub const ALL: [Fidelity; 4] = [
        Fidelity::Linear,
        Fidelity::Nonlinear,
        Fidelity::Complex,
        Fidelity::Full,
    ];

    /// The level's name in a scene.
    pub fn name(self) -> &'static str {
        match self {
            Fidelity::Linear => "linear",
            Fidelity::Nonlinear => "nonlinear",
            Fidelity::Complex => "complex",
            Fidelity::Full => "full",
        }
    }
}

/// What `sim.fidelity` takes.
fn fidelity_levels() -> String {
    "`linear`, `nonlinear`, `complex`, `full`".into()
}

/// Default of `sim.max_steps`: 10^7 physics steps, 2.8 hours simulated at the 1 ms step,
/// a minute or two of work.
pub const DEFAULT_MAX_STEPS: u64 = 10_000_000;

crate::declare_params! {
    /// How a run is simulated and recorded (scene section `[sim]`).
    #[derive(Debug, Clone)]
    pub struct SimSettings in "sim" {
        /// Which parts of the model are switched on: the thesis's `linear`, `nonlinear`
        /// and `complex` levels, or `full` (rapier chassis, tyres and castors).
        fidelity: Fidelity = Fidelity::Full, "", other(fidelity_levels);
        /// Simulated time.
        duration_s: f64 = 10.0, "s", Positive;
        /// Physics (rapier) step. The drivetrain sub-steps inside it as its stiffness
        /// needs.
        dt_s: f64 = 0.001, "s", open_closed(0.0, 0.01);
        /// Seed of the sensor-noise generator.
        seed: u64 = 1, "", Integer;
        /// Interval between rows of the recording.
        record_interval_s: f64 = 0.01, "s", Positive;
        /// Wheels lifted off the floor (lab identification rig): the chassis stays put.
        wheels_lifted: bool = false, "", other(crate::param::true_or_false);
        /// Most physics steps (`duration_s / dt_s`) a run may take: a guard against a
        /// typo that asks for days of simulated time; raise it for a run that needs more.
        max_steps: u64 = DEFAULT_MAX_STEPS, "", Positive;
    }
}
