//! Which model structure a rig and a recording get (`--model` or the rig's kind), built
//! with each belief as uncertain as the rig states.

use crate::record::channels as chan;
use crate::rig::keys::alias;

use std::path::Path;
use std::str::FromStr;

use super::model::GreyBox;
use super::models::coast_down::CoastDown;
use super::models::dcmc_pair::{Case, DcmcPair};
use super::models::falling_weight::FallingWeight;
use super::models::linear_axis::LinearAxis;
use super::models::rotary_axis::{AxisInput, RotaryAxis, TorqueCommand};
use super::models::vehicle::Vehicle;
use super::IdentError;
use crate::record::Recording;
use crate::rig::{Rig, RigKind};

/// The model structures `identify` offers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModelChoice {
    /// The rig's drive axis (rotary or linear, voltage-, demand- or current-driven, open or
    /// closed loop).
    DriveAxis,
    /// The falling-weight test (motor off the vehicle).
    FallingWeight,
    /// The coast-down test.
    CoastDown,
    /// Thesis case 1.
    Gain,
    /// Thesis case 2-I.
    P,
    /// Thesis case 2-II.
    Pi,
}

impl ModelChoice {
    /// Every model's name, as the command line takes it.
    pub const NAMES: [&'static str; 6] = [
        "drive-axis",
        "falling-weight",
        "coast-down",
        "gain",
        "p",
        "pi",
    ];
}

impl FromStr for ModelChoice {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Ok(match s {
            "drive-axis" => ModelChoice::DriveAxis,
            "falling-weight" => ModelChoice::FallingWeight,
            "coast-down" => ModelChoice::CoastDown,
            "gain" => ModelChoice::Gain,
            "p" => ModelChoice::P,
            "pi" => ModelChoice::Pi,
            _ => {
                return Err(format!(
                    "unknown model `{s}`: expected one of {}",
                    ModelChoice::NAMES.join(", ")
                ))
            }
        })
    }
}

/// A concrete model structure.
#[derive(Debug, Clone)]
pub enum Structure {
    /// A rotary drive axis.
    Rotary(RotaryAxis),
    /// A linear drive axis.
    Linear(LinearAxis),
    /// The thesis's DCMC structures on two lifted drives.
    Pair(DcmcPair),
    /// The falling-weight test.
    Falling(FallingWeight),
    /// The coast-down test.
    Coast(CoastDown),
    /// The whole vehicle.
    Vehicle(Vehicle),
}

impl Structure {
    /// The structure as a grey-box model, mutably.
    pub fn model_mut(&mut self) -> &mut dyn GreyBox {
        match self {
            Structure::Rotary(m) => m,
            Structure::Linear(m) => m,
            Structure::Pair(m) => m,
            Structure::Falling(m) => m,
            Structure::Coast(m) => m,
            Structure::Vehicle(m) => m,
        }
    }

    /// The structure as a grey-box model.
    pub fn model(&self) -> &dyn GreyBox {
        match self {
            Structure::Rotary(m) => m,
            Structure::Linear(m) => m,
            Structure::Pair(m) => m,
            Structure::Falling(m) => m,
            Structure::Coast(m) => m,
            Structure::Vehicle(m) => m,
        }
    }
}

/// Each parameter's belief as uncertain as the rig states (`[uncertainty_pct]`): a
/// parameter named by a rig key the rig gives a percentage for is held by that much
/// instead of the default ([`model::DEFAULT_BELIEF_SD_REL`]), and a positive one's search
/// reaches at least [`BELIEF_SPAN_SD`] standard deviations of that belief either side (a
/// guessed inductance, 100 %, may be several times off, beyond the factor of 3 a
/// tens-of-percent belief is searched in).
pub fn state_beliefs(model: &mut dyn GreyBox, rig: &Rig) {
    for spec in model.params_mut() {
        if let Some(pct) = rig.uncertainty_pct(&spec.name) {
            *spec = spec.clone().stated_belief(pct / 100.0);
        }
    }
}

/// How many of a stated belief's standard deviations (log scale) a positive parameter's
/// search spans either side of it, at least.
pub const BELIEF_SPAN_SD: f64 = 3.0;

/// Chooses and builds the model structure for a rig and a recording, each belief as
/// uncertain as the rig states ([`state_beliefs`]).
pub fn build_structure(
    rig: &Rig,
    rig_path: &Path,
    rec: &Recording,
    choice: Option<ModelChoice>,
) -> Result<Structure, IdentError> {
    let mut s = structure_of(rig, rig_path, rec, choice)?;
    state_beliefs(s.model_mut(), rig);
    Ok(s)
}

/// The model a recording is fitted with when none is named: its experiment's, else its
/// rig's (a drive pair's by its controller's kind).
fn default_choice(rig: &Rig, rec: &Recording) -> ModelChoice {
    match rec.meta.get("experiment").map(String::as_str) {
        Some("falling-weight") => ModelChoice::FallingWeight,
        Some("coast-down") => ModelChoice::CoastDown,
        _ => match rig.rig {
            RigKind::DrivePair => match rig.text(alias::CONTROLLER_KIND.key()) {
                Some("p") => ModelChoice::P,
                Some("pi") => ModelChoice::Pi,
                _ => ModelChoice::Gain,
            },
            _ => ModelChoice::DriveAxis,
        },
    }
}

/// The whole-vehicle model of a recording driven by motor voltages; its tyres creep
/// where the recording has a pose.
fn vehicle_structure(rig: &Rig, rig_path: &Path, rec: &Recording) -> Result<Vehicle, IdentError> {
    if rec.column(chan::LEFT_VOLTAGE_V).is_none() || rec.column(chan::RIGHT_VOLTAGE_V).is_none() {
        return Err(IdentError::Mismatch {
            file: rec.path.clone(),
            message: "the whole-vehicle model is driven by `left_voltage_V` and `right_voltage_V`; recordings driven through the motor controller (`demand_fwd_pct`, `demand_turn_pct`) or by velocity commands (`cmd_linear_m_s`, `cmd_angular_rad_s`) are not supported yet; `agvsim calibrate --scene SCENE --recording REC --effects all` fits them through the simulator and finds missing physics there".into(),
        });
    }
    let mut m = Vehicle::from_rig(rig, rig_path)?;
    m.creeping_tyres = [chan::X_M, chan::Y_M, chan::HEADING_RAD]
        .iter()
        .any(|c| rec.column(c).is_some());
    Ok(m)
}

/// The model structure for a rig and a recording.
fn structure_of(
    rig: &Rig,
    rig_path: &Path,
    rec: &Recording,
    choice: Option<ModelChoice>,
) -> Result<Structure, IdentError> {
    let choice = choice.unwrap_or_else(|| default_choice(rig, rec));
    if rec.rig != rig.rig {
        return Err(IdentError::Mismatch {
            file: rec.path.clone(),
            message: format!(
                "the recording is for rig `{}` but {} describes a `{}`",
                rec.rig,
                rig_path.display(),
                rig.rig
            ),
        });
    }
    let wrong_rig = |want: RigKind| IdentError::WrongRig {
        model: format!("{choice:?}").to_lowercase(),
        want,
        rig: rig_path.to_owned(),
        have: rig.rig,
    };
    Ok(match choice {
        ModelChoice::DriveAxis => {
            if rig.rig == RigKind::Vehicle {
                return Ok(Structure::Vehicle(vehicle_structure(rig, rig_path, rec)?));
            }
            if rig.rig != RigKind::DriveAxis {
                return Err(wrong_rig(RigKind::DriveAxis));
            }
            if rig.is_linear() {
                let force_input = rec.column(chan::FORCE_N).is_some()
                    && rec.column(chan::COMMAND_V).is_none()
                    && rec.column(chan::REFERENCE_M).is_none();
                let mut m = LinearAxis::from_rig(rig, rig_path, force_input)?;
                m.disturbance_input = rec.column(chan::DISTURBANCE_FORCE_N).is_some();
                Structure::Linear(m)
            } else {
                let has = |c: &str| rec.column(c).is_some();
                let input = if has(chan::VOLTAGE_V) {
                    AxisInput::Voltage
                } else if has(chan::DEMAND_PCT) {
                    AxisInput::Demand
                } else if let Some(c) = TorqueCommand::from_columns(rig, rig_path, has)? {
                    AxisInput::Torque(c)
                } else {
                    return Err(IdentError::Mismatch {
                        file: rec.path.clone(),
                        message: "no input column: a rotary drive axis needs `voltage_V`, `demand_pct`, `torque_Nm`, `command_V` (with the rig's drive.torque_per_volt_Nm_V) or `reference_rad` (with its [feedback])".into(),
                    });
                };
                Structure::Rotary(RotaryAxis::from_rig(rig, rig_path, input)?)
            }
        }
        ModelChoice::FallingWeight => {
            if rig.rig != RigKind::DriveAxis {
                return Err(wrong_rig(RigKind::DriveAxis));
            }
            Structure::Falling(FallingWeight::from_rig(rig, rig_path)?)
        }
        ModelChoice::CoastDown => {
            if rig.rig != RigKind::DriveAxis {
                return Err(wrong_rig(RigKind::DriveAxis));
            }
            let w0 = rec
                .column(chan::MOTOR_SPEED_RAD_S)
                .and_then(|c| c.iter().flatten().next().copied())
                .unwrap_or(1.0);
            Structure::Coast(CoastDown::from_rig(rig, rig_path, w0)?)
        }
        ModelChoice::Gain | ModelChoice::P | ModelChoice::Pi => {
            if rig.rig != RigKind::DrivePair {
                return Err(wrong_rig(RigKind::DrivePair));
            }
            let case = match choice {
                ModelChoice::Gain => Case::Gain,
                ModelChoice::P => Case::P,
                _ => Case::Pi,
            };
            Structure::Pair(DcmcPair::from_rig(rig, rig_path, case)?)
        }
    })
}
