//! The outputs a replay compares: each recorded output the simulator can produce, with the
//! probe that reads it from a snapshot, and what a validation recording must share with the
//! fitted one.

use super::inputs::{choose_drive, Drive};
use super::ReplayError;
use crate::record::channels as chan;
use crate::record::{vehicle_columns, Recording};
use crate::rig::RigKind;
use crate::sim::Snapshot;

/// A simulator output a recording column can be compared with.
pub(super) struct Channel {
    pub(super) name: String,
    pub(super) read: fn(&Snapshot) -> f64,
    /// For an encoder-derived speed, the angle (or rim distance) whose mean rate over
    /// the sample interval ending at the row is the output ([`encoder_source`]).
    pub(super) rate_of: Option<fn(&Snapshot) -> f64>,
}

/// The quantity an encoder counts, for the outputs the contract derives from encoders:
/// `motor_speed_rad_s` (and each side's) and the wheel rim speeds are count differences
/// over the sample interval, so a row holds the *mean* speed over the interval ending at
/// it (the development set's convention, and what a rig's `sensors.motor_encoder_counts_per_rev`
/// states), not the speed at the instant: at a 25 ms interval the two differ by half an
/// interval's lag, which a fit would otherwise explain with a dead time. A gyro's yaw
/// rate and a current are read at the instant.
fn encoder_source(name: &str) -> Option<fn(&Snapshot) -> f64> {
    match name {
        chan::MOTOR_SPEED_RAD_S | chan::LEFT_MOTOR_SPEED_RAD_S => {
            Some(|s| s.sides[0].motor_angle_rad)
        }
        chan::RIGHT_MOTOR_SPEED_RAD_S => Some(|s| s.sides[1].motor_angle_rad),
        chan::LEFT_WHEEL_SPEED_M_S => Some(|s| s.sides[0].wheel_rim_distance_m),
        chan::RIGHT_WHEEL_SPEED_M_S => Some(|s| s.sides[1].wheel_rim_distance_m),
        _ => None,
    }
}

/// Reads one output from a simulator snapshot.
type Probe = fn(&Snapshot) -> f64;

/// The drive-axis outputs (the left drive of the lifted simulator).
fn axis_channels() -> Vec<(&'static str, Probe)> {
    vec![
        (chan::MOTOR_SPEED_RAD_S, |s| s.sides[0].motor_speed_rad_s),
        (chan::MOTOR_ANGLE_RAD, |s| s.sides[0].motor_angle_rad),
        (chan::WHEEL_ANGLE_RAD, |s| s.sides[0].wheel_angle_rad),
        (chan::CURRENT_A, |s| s.sides[0].current_a),
    ]
}

/// The simulator outputs this recording has columns for.
pub(super) fn channels(rec: &Recording, drive: Drive) -> (Vec<Channel>, Vec<String>) {
    let table: Vec<(&str, Probe)> = if drive.lifted() {
        axis_channels()
    } else {
        vehicle_columns()
            .into_iter()
            .filter(|c| c.name != chan::T_S)
            .map(|c| (c.name, c.value))
            .collect()
    };
    let mut found = vec![];
    let mut missing = vec![];
    for name in &rec.names {
        if drive.columns().contains(&name.as_str()) {
            continue;
        }
        match table.iter().find(|(n, _)| n == name) {
            Some((_, read))
                if !Drive::Demands.columns().contains(&name.as_str())
                    && !Drive::Velocity.columns().contains(&name.as_str()) =>
            {
                found.push(Channel {
                    name: name.clone(),
                    read: *read,
                    rate_of: encoder_source(name),
                })
            }
            _ => missing.push(name.clone()),
        }
    }
    (found, missing)
}

/// Whether `other` can validate what is fitted on `rec`: a recording of the same rig,
/// driven by the same inputs, measuring at least one output `rec` measures; the message
/// says what differs (a recording of another rig or robot would print fits of nothing).
pub fn check_validation(rec: &Recording, other: &Recording) -> Result<(), NotAValidation> {
    if other.rig != rec.rig {
        return Err(NotAValidation::OtherRig {
            other: other.rig,
            fitted: rec.rig,
        });
    }
    let (a, b) = (choose_drive(rec)?, choose_drive(other)?);
    if a != b {
        return Err(NotAValidation::OtherDrive {
            other: b.columns().join(" and "),
            fitted: a.columns().join(" and "),
        });
    }
    let (mine, _) = channels(rec, a);
    let (theirs, _) = channels(other, b);
    let common = mine
        .iter()
        .filter(|c| theirs.iter().any(|t| t.name == c.name))
        .count();
    if common == 0 {
        return Err(NotAValidation::NoCommonOutput(
            mine.iter()
                .map(|c| c.name.as_str())
                .collect::<Vec<_>>()
                .join(", "),
        ));
    }
    Ok(())
}

/// Why a recording cannot validate what was fitted on another.
#[derive(Debug, thiserror::Error)]
pub enum NotAValidation {
    /// A recording of another rig kind.
    #[error("a `{other}` recording, where the recording fitted is `{fitted}`: validate on a recording of the same rig")]
    OtherRig {
        /// The validation recording's kind.
        other: RigKind,
        /// The fitted recording's kind.
        fitted: RigKind,
    },
    /// A recording no replay can drive.
    #[error(transparent)]
    Undriven(#[from] ReplayError),
    /// A recording driven by other inputs.
    #[error("driven by {other}, where the recording fitted is driven by {fitted}: validate on a recording of the same inputs")]
    OtherDrive {
        /// The validation recording's input columns.
        other: String,
        /// The fitted recording's.
        fitted: String,
    },
    /// A recording measuring none of the fitted outputs (named).
    #[error("measures none of the outputs the recording fitted measures ({0})")]
    NoCommonOutput(String),
}
