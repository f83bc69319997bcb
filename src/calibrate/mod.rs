//! Calibration: the simulator itself fitted to a recording. The scene's values are the
//! beliefs; the free scene keys are fitted by output error through [`crate::replay`] (the
//! simulator at the scene's fidelity, driven by the recording's inputs), with the same
//! Levenberg-Marquardt fitter and statistics as `identify`. The result is a scene: what
//! was fitted goes back into the file the user runs, and the fit is shown before and after
//! in the simulation itself.
//!
//! This file is the face: the errors, the default keys and outputs per recording kind, and
//! the re-exports. A run's order is in `run.rs` ([`calibrate_telling`]), the simulator as a
//! fitted model in `scene_replay.rs` ([`SceneReplay`]), what a run gives in `result.rs`
//! ([`Calibration`]), the effect rounds in `rounds.rs` and `search/` (stages, the
//! simulator as judge, races, the wheels' odometry), the first stage in `first.rs` and
//! `faithful.rs`, the output in `write.rs`.

mod adequacy;
pub mod base_limits;
mod defect;
pub mod diagnosis;
pub mod effects;
mod faithful;
mod first;
pub mod keys;
pub mod odometry;
mod pose_windows;
pub mod prove;
mod result;
mod rounds;
mod run;
mod scene_replay;
mod search;
mod terms;
pub mod validation;
pub mod write;

use crate::model::base_controller::BaseParams;
use crate::model::chassis::ChassisParams;
use crate::model::motor::MotorParams;
use crate::param::ParamKey;
use crate::record::channels as chan;
use std::path::PathBuf;

use crate::record::Recording;
use crate::replay::ReplayError;
use crate::rig::RigKind;

pub use result::{
    Calibration, ControllerMultipliers, EffectTrial, KeyFit, Removal, Switch, Unconfirmed,
    WheelGeometry, TRADE_OFF_CORRELATION,
};
pub(crate) use run::JUDGED_BY_THE_SIMULATOR;
pub use run::{calibrate, calibrate_telling, Request, HELD_STEP_SHARE};
pub use scene_replay::SceneReplay;
pub use search::JUDGE_SHARE;

/// Why a calibration cannot be done.
#[derive(Debug, thiserror::Error)]
pub enum CalibrateError {
    /// The recording could not be replayed.
    #[error(transparent)]
    Replay(#[from] ReplayError),
    /// A key that cannot be read, set or fitted, or an effect without a home here (the message names it).
    #[error("{0}")]
    Key(String),
    /// The recording lacks what calibration needs.
    #[error("{file}: {message}")]
    Recording {
        /// The recording.
        file: PathBuf,
        /// What it lacks.
        message: String,
    },
    /// The recording cannot be fitted (the message names it).
    #[error("{0}")]
    Data(String),
    /// The fit through the simulator failed.
    #[error("{file}: the fit failed: {message}")]
    Fit {
        /// The recording fitted.
        file: PathBuf,
        /// Why the fit failed.
        message: String,
    },
}

/// The contract's outputs per rig: what a real rig measures, and what a calibration fits.
pub fn contract_outputs(rig: RigKind) -> &'static [&'static str] {
    match rig {
        RigKind::DriveAxis => &[
            chan::MOTOR_SPEED_RAD_S,
            chan::MOTOR_ANGLE_RAD,
            chan::WHEEL_ANGLE_RAD,
            chan::CURRENT_A,
        ],
        _ => &[
            chan::X_M,
            chan::Y_M,
            chan::HEADING_RAD,
            chan::LEFT_MOTOR_SPEED_RAD_S,
            chan::RIGHT_MOTOR_SPEED_RAD_S,
            chan::SENSOR_LEFT_ADC,
            chan::SENSOR_RIGHT_ADC,
            chan::LEFT_WHEEL_SPEED_M_S,
            chan::RIGHT_WHEEL_SPEED_M_S,
            chan::YAW_RATE_RAD_S,
        ],
    }
}

/// The scene keys a calibration fits by default, per recording kind: those the record
/// determines and a scene is most often wrong about.
///
/// - a lifted drive (`drive_axis`, `drive_pair`): the armature resistance, the torque
///   constant, the rotor inertia and the viscous friction, which set the motor's gain,
///   its time constant and its current;
/// - a `vehicle`: the torque constant and resistance (the drive's gain) and the chassis
///   mass and yaw inertia (how fast it answers in speed and in turn).
pub fn default_free(rig: RigKind) -> &'static [ParamKey] {
    match rig {
        RigKind::Vehicle => &[
            MotorParams::torque_constant_nm_a,
            MotorParams::resistance_ohm,
            ChassisParams::mass_kg,
            ChassisParams::yaw_inertia_kg_m2,
        ],
        _ => &[
            MotorParams::resistance_ohm,
            MotorParams::torque_constant_nm_a,
            MotorParams::rotor_inertia_kg_m2,
            MotorParams::viscous_nm_s_rad,
        ],
    }
}

/// A velocity-commanded base's keys fitted by default: what its recordings show of the
/// chassis (mass, yaw inertia) and of its drivers' speed loops.
pub const VELOCITY_BASE_FREE: [ParamKey; 4] = [
    ChassisParams::mass_kg,
    ChassisParams::yaw_inertia_kg_m2,
    BaseParams::speed_kp_v_s_rad,
    BaseParams::speed_ki_v_rad,
];

/// The keys a recording fits by default: [`default_free`], but for a vehicle driven by
/// velocity commands the chassis mass and yaw inertia and its drivers' speed-loop gains
/// (the loops hide the motor's torque constant and resistance behind their set-points).
pub fn default_free_of(rec: &Recording) -> &'static [ParamKey] {
    let velocity = crate::replay::Drive::Velocity
        .columns()
        .iter()
        .all(|c| rec.column(c).is_some());
    if rec.rig == RigKind::Vehicle && velocity {
        &VELOCITY_BASE_FREE
    } else {
        default_free(rec.rig)
    }
}
