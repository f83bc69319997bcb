//! A rotary drive axis with the wheel lifted: DC motor, rigid gear train, wheel; driven by
//! a terminal voltage or by a demand through a controller gain (the rig's `[controller]`).
//!
//! `L di/dt = V - R i - K w`, `(Jm + Jw/N^2) dw/dt = K i - b w`, `dtheta/dt = w`, with all
//! viscous friction `b` referred to the motor shaft, as the rig format defines it.

use std::path::Path;

use crate::ident::data::Dataset;
use crate::ident::effects::{self, Effect};
use crate::ident::model::{GreyBox, OutputKind, ParamSpec};
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
            match rig.feedback.as_ref().and_then(|f| f.kind.as_deref()) {
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
        m.effects.add(effect, m.specs.len() - 1);
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

    /// The gear's twist across the play (rad, the motor's angle through the ratio less
    /// the wheel's) and its rate (rad/s), from the two-inertia states.
    fn twist(&self, x: &[f64]) -> (f64, f64) {
        let n = self.ratio;
        (x[2] / n - x[4], x[1] / n - x[3])
    }

    fn gearbox(&self, p: &[f64], play: usize) -> GearboxParams {
        play_gearbox(self.ratio, p[play])
    }

    /// Friction torque at the motor shaft besides its viscous part, N m.
    fn extra_friction(&self, p: &[f64], w: f64) -> f64 {
        let mut t = 0.0;
        if let Some(i) = self.effect(Effect::CoulombFriction) {
            t += effects::smooth_coulomb(p[i], w, self.coulomb_eps_rad_s);
        }
        if let Some(i) = self.effect(Effect::Offset) {
            t -= p[i];
        }
        t
    }

    fn viscous(&self, p: &[f64], b: f64, w: f64) -> f64 {
        match self.effect(Effect::FrictionAsymmetry) {
            Some(i) => effects::asymmetric_viscous(b, p[i], w),
            None => b * w,
        }
    }

    /// The torque amplifier's command, when a torque (not a voltage) drives the axis.
    pub fn torque_command(&self) -> Option<TorqueCommand> {
        match self.input {
            AxisInput::Torque(c) => Some(c),
            _ => None,
        }
    }

    /// Wheel speed, rad/s: its own state once a play separates it from the motor.
    fn wheel_speed(&self, x: &[f64]) -> f64 {
        match self.effect(Effect::Backlash) {
            Some(_) => x[3],
            None => x[1] / self.ratio,
        }
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

impl GreyBox for RotaryAxis {
    fn name(&self) -> String {
        match self.input {
            AxisInput::Voltage => "rotary drive axis, voltage-driven".into(),
            AxisInput::Demand => "rotary drive axis, demand through a controller gain".into(),
            AxisInput::Torque(TorqueCommand { feedback: None, .. }) => {
                "rotary drive axis, current (torque) amplifier, open loop".into()
            }
            AxisInput::Torque(_) => {
                "rotary drive axis, current (torque) amplifier, position-velocity cascade".into()
            }
        }
    }

    fn params(&self) -> &[ParamSpec] {
        &self.specs
    }

    fn default_free(&self, outputs: &[String]) -> Vec<usize> {
        // Only the sum of the inertias is seen through a rigid gear train: the wheel's stays
        // at the rig value and the rotor's absorbs the difference. Without a current
        // measurement R and L are not separable from K and J, so they stay fixed.
        let mut free = if matches!(self.input, AxisInput::Torque(_)) {
            vec![JM, B]
        } else if outputs.iter().any(|o| o == "current_A") {
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
            AxisInput::Torque(TorqueCommand {
                feedback: None,
                column,
                ..
            }) => {
                vec![column.into()]
            }
            AxisInput::Torque(_) => vec!["reference_rad".into()],
        }
    }

    fn output_names(&self) -> Vec<String> {
        let mut o: Vec<String> = ["motor_speed_rad_s", "motor_angle_rad", "wheel_angle_rad"]
            .map(String::from)
            .to_vec();
        match self.input {
            // The armature current follows the command, not a law of this model.
            AxisInput::Torque(TorqueCommand {
                feedback: Some(_),
                column,
                ..
            }) => o.push(column.into()),
            AxisInput::Torque(_) => {}
            AxisInput::Voltage | AxisInput::Demand => o.insert(1, "current_A".into()),
        }
        o
    }

    fn reports(&self, i: usize) -> bool {
        !(matches!(self.input, AxisInput::Torque(_)) && [R, L, K].contains(&i))
    }

    fn n_held(&self) -> usize {
        1
    }

    fn hold(&self, _p: &[f64], _t_s: f64, x: &[f64], u: &[f64], held: &mut [f64]) {
        held[0] = match self.input {
            AxisInput::Torque(TorqueCommand {
                feedback: Some(c),
                limit,
                ..
            }) => {
                // The digital loop samples the wheel and holds its command.
                (c.kv_v_s_rad * (c.kp_1_s * (u[0] - x[4]) - self.wheel_speed(x)))
                    .clamp(-limit, limit)
            }
            _ => u[0],
        };
    }

    /// Current, motor speed, motor angle, wheel speed and angle (backlash block), and the
    /// speed-loop integral (speed-feedback block).
    fn n_states(&self) -> usize {
        6
    }

    fn initial_state(&self, _p: &[f64], data: &Dataset) -> Vec<f64> {
        let angle = data
            .first_measured("motor_angle_rad")
            .or_else(|| {
                data.first_measured("wheel_angle_rad")
                    .map(|a| a * self.ratio)
            })
            .unwrap_or(0.0);
        vec![0.0, 0.0, angle, 0.0, angle / self.ratio, 0.0]
    }

    fn max_step_s(&self, p: &[f64]) -> f64 {
        // RK4 is accurate to 2 % on a decaying mode at h = its time constant.
        let mut h = match self.input {
            AxisInput::Torque(_) => 0.2 * self.mechanical_time_constant_s(p),
            _ => (p[L] / p[R]).min(0.2 * self.mechanical_time_constant_s(p)),
        };
        if let Some(play) = self.effect(Effect::Backlash) {
            let rate = self
                .gearbox(p, play)
                .mesh_rate(p[JM] * self.ratio * self.ratio, p[JW]);
            h = h.min(MESH_STEP_RATE / rate);
        }
        h
    }

    fn input_delay_s(&self, p: &[f64]) -> f64 {
        self.effect(Effect::TransportDelay).map_or(0.0, |i| p[i])
    }

    fn event_fraction(&self, p: &[f64], before: &[f64], after: &[f64], h: f64) -> Option<f64> {
        let play = self.effect(Effect::Backlash)?;
        let (twist_before, twist_rate) = self.twist(before);
        self.gearbox(p, play)
            .flank_crossing(twist_before, self.twist(after).0, twist_rate * h)
    }

    fn derivatives(&self, p: &[f64], x: &[f64], u: &[f64], held: &[f64], dx: &mut [f64]) {
        let mut v = self.voltage(p, u[0]);
        dx[5] = 0.0;
        if let Some(i) = self.effect(Effect::SpeedFeedback) {
            // The DCMC's own loop: set-point from the demand, calibrated to the motor.
            let w_ref = v / p[K];
            v += p[i] * x[5];
            dx[5] = w_ref - x[1];
        }
        if let Some(i) = self.effect(Effect::VoltageSaturation) {
            v = v.clamp(-p[i], p[i]);
        }
        if let Some(i) = self.effect(Effect::BatterySag) {
            v = effects::bridge_voltage(v, self.supply_v, self.supply_v, p[i], x[0]);
        }
        let motor_torque = match self.input {
            AxisInput::Torque(c) => {
                dx[0] = 0.0;
                let command = if c.feedback.is_some() { held[0] } else { u[0] };
                Self::commanded_torque(&c, command)
            }
            AxisInput::Voltage | AxisInput::Demand => {
                dx[0] = crate::model::motor::armature_current_rate(p[R], p[L], p[K], v, x[0], x[1]);
                p[K] * x[0]
            }
        };
        let drive = motor_torque - self.extra_friction(p, x[1]);
        match self.effect(Effect::Backlash) {
            None => {
                dx[1] = (drive - self.viscous(p, p[B], x[1])) / self.inertia_at_motor(p);
                dx[3] = 0.0;
                dx[4] = x[1] / self.ratio;
            }
            Some(play) => {
                let n = self.ratio;
                let g = self.gearbox(p, play);
                let (twist, twist_rate) = self.twist(x);
                let tooth = g.tooth_contact_torque(twist, twist_rate);
                let share = p[play - 1];
                let b_motor = p[B] * (1.0 - share);
                let b_wheel = p[B] * share * n * n;
                dx[1] = (drive - self.viscous(p, b_motor, x[1]) - tooth / n) / p[JM];
                dx[3] = (tooth - self.viscous(p, b_wheel, x[3])) / p[JW];
                dx[4] = x[3];
            }
        }
        dx[2] = x[1];
    }

    fn output_kind(&self, name: &str) -> OutputKind {
        if name == "motor_speed_rad_s" && self.encoder {
            OutputKind::IntervalRate(2)
        } else {
            OutputKind::Instant
        }
    }

    fn output(&self, _p: &[f64], name: &str, x: &[f64], _u: &[f64], held: &[f64]) -> f64 {
        match name {
            "command_V" => held[0],
            "motor_speed_rad_s" => x[1],
            "current_A" => x[0],
            "motor_angle_rad" => x[2],
            "wheel_angle_rad" => x[4],
            _ => f64::NAN,
        }
    }
}
