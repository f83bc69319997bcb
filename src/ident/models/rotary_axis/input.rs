//! What drives a rotary axis: a voltage, a demand through the controller's gain, or a
//! torque amplifier's command (with the position loop that made it, if recorded in closed
//! loop).

use crate::record::channels as chan;
use crate::rig::blocks::{CurrentAmplifier, PositionLoop};
use crate::rig::{Rig, RigError};
use std::path::Path;

/// What drives the axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum AxisInput {
    /// `voltage_V` on the armature.
    Voltage,
    /// `demand_pct` x `controller.gain_V_pct` on the armature.
    Demand,
    /// A current (torque) amplifier: the motor torque is commanded, so the armature's
    /// resistance, inductance and back-EMF do not act. `torque_Nm` directly
    /// (`per_volt_nm_v` = 1), or `command_V` x `drive.torque_per_volt_Nm_V`.
    Torque(TorqueCommand),
}

/// Where a torque amplifier's command comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TorqueCommand {
    /// Motor torque per unit of the input column, N m per V (1 for `torque_Nm`).
    pub per_volt_nm_v: f64,
    /// Command limit, in the input column's unit (infinite when the rig gives none).
    pub limit: f64,
    /// The column the command is recorded in.
    pub column: &'static str,
    /// The position loop that produced the command from `reference_rad`, if recorded in
    /// closed loop: then the command is an output and the reference the input.
    pub feedback: Option<WheelCascade>,
}

/// command = kv (kp (reference - wheel angle) - wheel speed), the contract's
/// position-velocity cascade on the load side of a rotary axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WheelCascade {
    /// Position gain, 1/s.
    pub kp_1_s: f64,
    /// V per rad/s of the wheel.
    pub kv_v_s_rad: f64,
}

impl TorqueCommand {
    /// The torque command a recording's columns and the rig describe, if it has one:
    /// `torque_Nm`, `command_V` through `drive.torque_per_volt_Nm_V`, or `reference_rad`
    /// through the rig's `[feedback]` loop into that amplifier.
    pub fn from_columns(
        rig: &Rig,
        path: &Path,
        has: impl Fn(&str) -> bool,
    ) -> Result<Option<TorqueCommand>, RigError> {
        let need = |k: &str, why: &str| rig.require(k, path, why);
        if has(chan::TORQUE_NM) {
            return Ok(Some(TorqueCommand {
                per_volt_nm_v: 1.0,
                limit: f64::INFINITY,
                column: chan::TORQUE_NM,
                feedback: None,
            }));
        }
        let closed = has(chan::REFERENCE_RAD);
        if !has(chan::COMMAND_V) && !closed {
            return Ok(None);
        }
        let why = if closed {
            "reference_rad is the input of a position loop into a current amplifier"
        } else {
            "command_V drives a current amplifier"
        };
        let feedback = if closed {
            match rig.text(PositionLoop::kind.key()) {
                Some("position_velocity_cascade") => Some(WheelCascade {
                    kp_1_s: need(PositionLoop::kp_1_s.key(), "the position loop gain")?,
                    kv_v_s_rad: need(
                        PositionLoop::kv_v_s_rad.key(),
                        "the velocity loop gain of a rotary axis, V per rad/s of the wheel",
                    )?,
                }),
                other => {
                    return Err(RigError::Invalid {
                        file: path.to_owned(),
                        message: format!(
                            "feedback.kind = {}: the recording gives reference_rad, so the rig must say how the command was made from it (\"position_velocity_cascade\")",
                            other.map_or("(missing)".into(), |k| format!("\"{k}\""))
                        ),
                    })
                }
            }
        } else {
            None
        };
        Ok(Some(TorqueCommand {
            per_volt_nm_v: need(CurrentAmplifier::torque_per_volt_nm_v.key(), why)?,
            limit: rig
                .get(CurrentAmplifier::limit_v.key())
                .unwrap_or(f64::INFINITY),
            column: chan::COMMAND_V,
            feedback,
        }))
    }
}
