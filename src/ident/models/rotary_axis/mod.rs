//! A rotary drive axis with the wheel lifted: DC motor, rigid gear train, wheel; driven by
//! a terminal voltage or by a demand through a controller gain (the rig's `[controller]`).
//!
//! `L di/dt = V - R i - K w`, `(Jm + Jw/N^2) dw/dt = K i - b w`, `dtheta/dt = w`, with all
//! viscous friction `b` referred to the motor shaft, as the rig format defines it. The laws
//! are the simulator's blocks (`crate::model`), assembled in [`dynamics`].

mod dynamics;

pub(crate) use dynamics::{drivetrain_blocks, drivetrain_state};

use std::path::Path;

use crate::ident::effects::{self, Effect};
use crate::ident::model::ParamSpec;
use crate::model::gearbox::GearboxParams;
use crate::rig::{Rig, RigError};

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
        if has("torque_Nm") {
            return Ok(Some(TorqueCommand {
                per_volt_nm_v: 1.0,
                limit: f64::INFINITY,
                column: "torque_Nm",
                feedback: None,
            }));
        }
        let closed = has("reference_rad");
        if !has("command_V") && !closed {
            return Ok(None);
        }
        let why = if closed {
            "reference_rad is the input of a position loop into a current amplifier"
        } else {
            "command_V drives a current amplifier"
        };
        let feedback = if closed {
            match rig.text("feedback.kind") {
                Some("position_velocity_cascade") => Some(WheelCascade {
                    kp_1_s: need("feedback.kp_1_s", "the position loop gain")?,
                    kv_v_s_rad: need(
                        "feedback.kv_V_s_rad",
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
            per_volt_nm_v: need("drive.torque_per_volt_Nm_V", why)?,
            limit: rig.get("drive.limit_V").unwrap_or(f64::INFINITY),
            column: "command_V",
            feedback,
        }))
    }
}

pub const R: usize = 0;
pub const L: usize = 1;
pub const K: usize = 2;
pub const JM: usize = 3;
pub const JW: usize = 4;
pub const B: usize = 5;
pub const GAIN: usize = 6;

/// Tooth contact of the backlash block, referred to the wheel (not in the rig; the fit
/// is insensitive to it once it is stiff against the sample rate).
pub const TOOTH_STIFFNESS_NM_RAD: f64 = 5000.0;
pub const TOOTH_DAMPING_NM_S_RAD: f64 = 3.0;
/// Longest RK4 step against the tooth mesh's rate ([`GearboxParams::mesh_rate`]), as
/// `h * rate`: the standard the electrical mode is held to (`h <= L / R`). What limits the
/// accuracy through a play is the timing of the teeth meeting and parting, which the
/// integrator places by splitting the step there ([`GreyBox::event_fraction`]). Measured
/// on the one-physics test's 0.05 rad play (8 s of multisine voltage): the outputs lie
/// within 0.35 % of their range of a 100 times finer integration, as they did at 0.3
/// without the split (0.38 %), at a third of the steps; the simulator's within 0.31 %.
pub const MESH_STEP_RATE: f64 = 1.0;

/// The backlash block's gear train: the fitted play between teeth of the identification
/// models' fixed mesh stiffness and damping.
#[inline]
pub fn play_gearbox(ratio: f64, backlash_rad: f64) -> GearboxParams {
    GearboxParams {
        ratio,
        backlash_rad,
        tooth_stiffness_nm_rad: TOOTH_STIFFNESS_NM_RAD,
        tooth_damping_nm_s_rad: TOOTH_DAMPING_NM_S_RAD,
    }
}
/// Share of the viscous friction on the wheel side of the play when the backlash block is
/// on (the rig gives only the total); a parameter of the block, held at this value.
pub const WHEEL_SIDE_VISCOUS_SHARE: f64 = 0.3;
/// Finite-difference step (search coordinate) of every parameter once a play is modelled.
pub const BACKLASH_FD_STEP: f64 = 1e-3;
/// Name of the backlash block's nuisance parameter.
pub const WHEEL_SHARE_PARAM: &str = "backlash.wheel_viscous_share";

/// Ceiling of the search of a viscous friction believed zero, N m s/rad: the motor's own
/// electrical damping K^2/R; behind a torque amplifier (no back-EMF braking) the rotor
/// inertia over 10 ms, a mechanical time constant no drive train is shorter than.
fn viscous_ceiling(rig: &Rig, torque_driven: bool) -> f64 {
    let inertial = rig.get("motor.rotor_inertia_kg_m2").unwrap_or(1e-4) / 0.01;
    match crate::rig::electrical_damping(rig) {
        Some(d) if !torque_driven => d,
        _ => inertial,
    }
}

/// The rotary axis with any effects switched on.
#[derive(Debug, Clone)]
pub struct RotaryAxis {
    specs: Vec<ParamSpec>,
    pub input: AxisInput,
    /// Motor turns per wheel turn (known exactly from the tooth counts).
    pub ratio: f64,
    /// Speeds come from an encoder (count difference over the sample interval).
    pub encoder: bool,
    /// Supply voltage the rig states, V (PWM reference of the battery-sag block).
    pub supply_v: f64,
    /// Effects switched on, with the index of each one's parameter.
    pub effects: effects::EffectSlots,
    /// Smoothing speed of Coulomb friction, rad/s.
    pub coulomb_eps_rad_s: f64,
}

impl RotaryAxis {
    pub fn from_rig(rig: &Rig, path: &Path, input: AxisInput) -> Result<RotaryAxis, RigError> {
        let torque_driven = matches!(input, AxisInput::Torque(_));
        let need = |k: &str| match (torque_driven, rig.get(k)) {
            (_, Some(v)) => Ok(v),
            // Behind a current amplifier the armature's values do not act: placeholders
            // the report leaves out.
            (true, None) => Ok(1.0),
            (false, None) => rig.require(k, path, "the rotary drive-axis model needs it"),
        };
        let mut specs = vec![
            ParamSpec::positive("motor.resistance_ohm", need("motor.resistance_ohm")?),
            // The inductance is weakly seen at sample rates far below R/L; a fit left free
            // would chase it towards zero, and the integration with it. Beliefs are tens of
            // percent off, so a factor of 3 is a generous physical bound.
            {
                let l = need("motor.inductance_H")?;
                if l == 0.0 && !torque_driven {
                    return Err(crate::rig::zero_refused(
                        path,
                        "motor.inductance_H",
                        "the model integrates the armature current, so it needs the inductance; if it is negligible, give a value well below the resistance times the sample interval (e.g. 1e-5 H)",
                    ));
                }
                let l = if torque_driven {
                    l.clamp(1e-6, 1e-3)
                } else {
                    l
                };
                ParamSpec::new("motor.inductance_H", l, l / 3.0, 3.0 * l)
            },
            ParamSpec::positive(
                "motor.torque_constant_Nm_A",
                need("motor.torque_constant_Nm_A")?,
            ),
            ParamSpec::positive(
                "motor.rotor_inertia_kg_m2",
                rig.require(
                    "motor.rotor_inertia_kg_m2",
                    path,
                    "the rotary drive-axis model needs it",
                )?,
            ),
            ParamSpec::positive(
                "wheel.inertia_kg_m2",
                rig.get("wheel.inertia_kg_m2").unwrap_or(0.0).max(1e-12),
            ),
            ParamSpec::friction(
                "motor.viscous_Nm_s_rad",
                rig.require(
                    "motor.viscous_Nm_s_rad",
                    path,
                    "the rotary drive-axis model needs it",
                )?,
                viscous_ceiling(rig, torque_driven),
            ),
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
            supply_v: rig.get("supply.voltage_V").unwrap_or(24.0),
            effects: effects::EffectSlots::default(),
            coulomb_eps_rad_s: 1.0,
        })
    }

    /// Effects that can act on a lifted rotary axis with this input.
    pub fn applicable(&self) -> Vec<Effect> {
        let mut e = vec![
            Effect::Backlash,
            Effect::CoulombFriction,
            Effect::FrictionAsymmetry,
            Effect::Offset,
        ];
        match self.input {
            // A current amplifier commands the torque: the supply's limits and sag act on
            // the armature, not on the torque.
            AxisInput::Torque(c) => {
                // In closed loop a dead time would sit inside the loop, which this model
                // does not place.
                if c.feedback.is_none() {
                    e.push(Effect::TransportDelay);
                }
            }
            AxisInput::Voltage | AxisInput::Demand => e.extend([
                Effect::VoltageSaturation,
                Effect::BatterySag,
                Effect::TransportDelay,
            ]),
        }
        if self.input == AxisInput::Demand {
            e.push(Effect::SpeedFeedback);
        }
        e
    }

    /// The motor torque a torque amplifier gives for a held command, N m.
    fn commanded_torque(c: &TorqueCommand, command: f64) -> f64 {
        c.per_volt_nm_v * command.clamp(-c.limit, c.limit)
    }

    /// This model with one more effect, its parameter starting at `start` within
    /// `[lo, hi]`. `max_speed` sets the Coulomb smoothing.
    pub fn with_effect(
        &self,
        effect: Effect,
        start: f64,
        lo: f64,
        hi: f64,
        max_speed: f64,
    ) -> RotaryAxis {
        let mut m = self.clone();
        let first = m.specs.len();
        let spec = ParamSpec::new(effect.param_name(false), start, lo, hi);
        if effect == Effect::Backlash {
            // Teeth meeting and parting make the output a rough function of every
            // parameter on the scale of an integration step: differences for the Jacobian
            // must be wider than that roughness.
            for s in &mut m.specs {
                s.fd_step = s.fd_step.max(BACKLASH_FD_STEP);
            }
            // The block's nuisance parameter comes first; the play is always the last.
            m.specs.push(ParamSpec::new(
                WHEEL_SHARE_PARAM,
                WHEEL_SIDE_VISCOUS_SHARE,
                0.0,
                0.95,
            ));
            m.specs.push(spec.with_fd_step(2e-3));
        } else {
            m.specs.push(spec);
        }
        m.effects.add(effect, first..m.specs.len());
        m.coulomb_eps_rad_s = (effects::COULOMB_SMOOTHING_FRACTION * max_speed).max(1e-3);
        m
    }

    /// Nominal parameters an effect's block makes identifiable beyond the default free set:
    /// with a play, the motor runs free on its own inertia and electrical damping `K^2/R`
    /// while the teeth are apart, which separates the two inertias, and R from K even
    /// without a current.
    pub fn newly_identifiable(&self, effect: Effect, outputs: &[String]) -> Vec<usize> {
        let has_current = outputs.iter().any(|o| o == "current_A");
        match effect {
            // The wheel's inertia is seen apart from the rotor's once the teeth separate.
            Effect::Backlash if has_current || self.torque_command().is_some() => vec![JW],
            Effect::Backlash => vec![R, JW],
            _ => vec![],
        }
    }

    fn effect(&self, e: Effect) -> Option<usize> {
        self.effects.get(e)
    }

    /// The torque amplifier's command, when a torque (not a voltage) drives the axis.
    pub fn torque_command(&self) -> Option<TorqueCommand> {
        match self.input {
            AxisInput::Torque(c) => Some(c),
            _ => None,
        }
    }

    /// Total inertia at the motor shaft, kg m^2.
    pub fn inertia_at_motor(&self, p: &[f64]) -> f64 {
        p[JM] + p[JW] / (self.ratio * self.ratio)
    }

    /// Terminal voltage for an input value, V (before the effects' blocks).
    pub fn voltage(&self, p: &[f64], u: f64) -> f64 {
        self.command_voltage(self.blocks(p).demand_gain_v_pct, u)
    }

    /// The voltage an input value commands, V: a voltage itself, a demand through the
    /// DCMC's gain (V/pct); none behind a torque amplifier.
    #[inline]
    fn command_voltage(&self, demand_gain_v_pct: f64, u: f64) -> f64 {
        match self.input {
            AxisInput::Voltage => u,
            AxisInput::Demand => demand_gain_v_pct * u,
            AxisInput::Torque(_) => 0.0,
        }
    }

    /// Mechanical time constant J / (b + K^2/R), s.
    pub fn mechanical_time_constant_s(&self, p: &[f64]) -> f64 {
        // Behind a torque amplifier the back-EMF does not damp the motor.
        let electrical = match self.input {
            AxisInput::Torque(_) => 0.0,
            _ => p[K] * p[K] / p[R],
        };
        self.inertia_at_motor(p) / (p[B] + electrical)
    }
}
