//! What drives a replay: the recording's inputs (voltages, demands or velocity commands),
//! which of them drive it, each held from its row to the next, and what a validation
//! recording must share with the fitted one.

use super::{recording_err, ReplayError};
use crate::record::channels as chan;
use crate::record::Recording;
use crate::rig::RigKind;
use crate::scene::Scene;
use crate::sim::Actuation;

/// How the recording drives the simulator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Drive {
    /// Left and right motor voltages, V.
    Voltages,
    /// Forward and turn demand into the DCMC, pct.
    Demands,
    /// A drive axis (the left drive, wheels lifted) on its motor voltage, V.
    AxisVoltage,
    /// A drive axis on its demand into the motor controller, pct (as a forward demand,
    /// so both sides run alike and the left one is compared).
    AxisDemand,
    /// A velocity command into the base controller (a ROS robot's `/cmd_vel`): forward
    /// speed, m/s, and yaw rate, rad/s.
    Velocity,
}

impl Drive {
    /// The recording's input columns this drive reads.
    pub fn columns(self) -> &'static [&'static str] {
        match self {
            Drive::Voltages => &[chan::LEFT_VOLTAGE_V, chan::RIGHT_VOLTAGE_V],
            Drive::Demands => &[chan::DEMAND_FWD_PCT, chan::DEMAND_TURN_PCT],
            Drive::AxisVoltage => &[chan::VOLTAGE_V],
            Drive::AxisDemand => &[chan::DEMAND_PCT],
            Drive::Velocity => &[chan::CMD_LINEAR_M_S, chan::CMD_ANGULAR_RAD_S],
        }
    }

    /// Whether the motors' voltages come from the recording itself, so the DCMC (its
    /// gains and limits) takes no part in the replay.
    pub fn bypasses_dcmc(self) -> bool {
        matches!(self, Drive::Voltages | Drive::AxisVoltage)
    }

    pub(super) fn actuation(self, u: &[f64]) -> Actuation {
        match self {
            Drive::Voltages => Actuation::Voltage([u[0], u[1]]),
            Drive::Demands => Actuation::Demand {
                forward_pct: u[0],
                turn_pct: u[1],
            },
            Drive::AxisVoltage => Actuation::Voltage([u[0], 0.0]),
            Drive::AxisDemand => Actuation::Demand {
                forward_pct: u[0],
                turn_pct: 0.0,
            },
            Drive::Velocity => Actuation::Velocity {
                linear_m_s: u[0],
                angular_rad_s: u[1],
            },
        }
    }

    pub(super) fn lifted(self) -> bool {
        matches!(self, Drive::AxisVoltage | Drive::AxisDemand)
    }
}

/// The drive the recording's columns give, voltages first (then demands, then velocity
/// commands).
pub fn drive_of(rec: &Recording) -> Result<Drive, ReplayError> {
    choose_drive(rec)
}

/// The drive the recording's columns give, voltages first.
pub(super) fn choose_drive(rec: &Recording) -> Result<Drive, ReplayError> {
    let candidates: &[Drive] = match rec.rig {
        RigKind::DriveAxis => &[Drive::AxisVoltage, Drive::AxisDemand],
        RigKind::Vehicle | RigKind::Base => &[Drive::Voltages, Drive::Demands, Drive::Velocity],
        RigKind::DrivePair => &[Drive::Voltages, Drive::Demands],
    };
    candidates
        .iter()
        .copied()
        .find(|d| d.columns().iter().all(|c| rec.column(c).is_some()))
        .ok_or_else(|| {
            let wanted: Vec<String> = candidates
                .iter()
                .map(|d| d.columns().join(" and "))
                .collect();
            // Contract inputs the simulator's machine has no way to take: say why.
            let other: Vec<&str> = [chan::TORQUE_NM, chan::FORCE_N, chan::COMMAND_V, chan::REFERENCE_RAD, chan::REFERENCE_M]
                .into_iter()
                .filter(|c| rec.column(c).is_some())
                .collect();
            let why = if other.is_empty() {
                String::new()
            } else {
                format!(
                    " ({} drive a current amplifier or a position loop, which the simulated AGV, DC motors behind the DCMC, does not have; `agvsim identify` and `diagnose` fit such records with their rig)",
                    other.join(", ")
                )
            };
            recording_err(
                rec,
                format!(
                    "no input the simulator can be driven by: expected {}{why}",
                    wanted.join(", or ")
                ),
            )
        })
}

/// A note when the recording also holds velocity commands that a voltage or demand drive
/// leaves unused: two drives in one recording, and the replay follows one.
pub(super) fn unused_drive_note(rec: &Recording, drive: Drive) -> Option<String> {
    let velocity = Drive::Velocity.columns();
    let present = velocity.iter().all(|c| rec.column(c).is_some());
    (drive != Drive::Velocity && present && rec.rig == RigKind::Vehicle).then(|| {
        format!(
            "driven by {}; the velocity commands {} are in the recording too and were not used (voltages, then demands, then velocity commands: drop the columns of the drive not meant)",
            drive.columns().join(" and "),
            velocity.join(" and ")
        )
    })
}

/// The input columns, each held over missing cells (a cell before the first value is an
/// error: the start must be known).
pub(super) fn held_inputs(rec: &Recording, drive: Drive) -> Result<Vec<Vec<f64>>, ReplayError> {
    drive
        .columns()
        .iter()
        .map(|name| {
            let col = rec.column(name).unwrap_or_default();
            let mut last = None;
            col.iter()
                .enumerate()
                .map(|(i, v)| {
                    last = v.or(last);
                    last.ok_or_else(|| {
                        recording_err(
                            rec,
                            format!(
                                "input `{name}` has no value at its first row (t = {} s)",
                                rec.t_s[i]
                            ),
                        )
                    })
                })
                .collect()
        })
        .collect()
}

/// Rows at the start over which the inputs hold their first value (at least one): while
/// the command has not changed, a machine that starts from rest is still at its start.
pub(super) fn rows_before_first_command_change(inputs: &[Vec<f64>]) -> usize {
    let n = inputs.first().map_or(0, Vec::len);
    (1..n)
        .find(|&k| inputs.iter().any(|col| col[k] != col[0]))
        .unwrap_or(n)
        .max(1)
}

/// Voltage inputs beyond what the scene's drive delivers, which the bridges clip.
pub(super) fn clipped_inputs(scene: &Scene, drive: Drive, inputs: &[Vec<f64>]) -> Vec<String> {
    if !matches!(drive, Drive::Voltages | Drive::AxisVoltage) {
        return vec![];
    }
    let limit = scene
        .battery
        .drive_limit_v
        .min(scene.battery.open_circuit_v);
    let over = inputs
        .iter()
        .flatten()
        .filter(|v| v.abs() > limit * (1.0 + 1e-9))
        .count();
    let peak = inputs.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    if over == 0 {
        return vec![];
    }
    vec![format!(
        "{over} input value(s) up to {} V exceed the scene's drive (battery.drive_limit_V = {} V on a {} V battery) and were clipped to it: is the scene's battery the recording's?",
        crate::param::plain_number(peak),
        scene.battery.drive_limit_v,
        scene.battery.open_circuit_v
    )]
}
