//! A rotary drive axis with the wheel lifted: DC motor, rigid gear train, wheel; driven by
//! a terminal voltage or by a demand through a controller gain (the rig's `[controller]`).
//!
//! `L di/dt = V - R i - K w`, `(Jm + Jw/N^2) dw/dt = K i - b w`, `dtheta/dt = w`, with all
//! viscous friction `b` referred to the motor shaft, as the rig format defines it. The laws
//! are the simulator's blocks (`crate::model`), assembled in `dynamics`; what drives the axis is
//! in `input`, the form a term outside the vocabulary is fitted in, in `term_form`.

mod dynamics;
mod input;
mod term_form;

use crate::record::channels as chan;
use crate::rig::blocks::Instruments;
use crate::rig::keys::alias;
pub use dynamics::AxisBlocks;
pub(crate) use dynamics::{drivetrain_blocks, drivetrain_state};
pub use input::{AxisInput, TorqueCommand, WheelCascade};
pub use term_form::{TermCoefficient, TermForm};

use crate::model::Bounded;
use std::path::Path;
use std::sync::OnceLock;

use crate::ident::effects::{self, Effect};
use crate::ident::model::{Binding, ParamSpec};
use crate::model::battery::BatteryParams;
use crate::model::dcmc::DcmcParams;
use crate::model::gearbox::GearboxParams;
use crate::model::motor::MotorParams;
use crate::model::term::{Family, TermParams};
use crate::model::wheel::WheelParams;
use crate::param::KeyTable;
use crate::rig::{Rig, RigError};

/// The drive train's keys a fit may move, as the rig and the scene name them.
pub const RESISTANCE: &str = MotorParams::resistance_ohm.key();
/// Armature inductance.
pub const INDUCTANCE: &str = MotorParams::inductance_h.key();
/// Torque (back-EMF) constant.
pub const TORQUE_CONSTANT: &str = MotorParams::torque_constant_nm_a.key();
/// Rotor inertia.
pub const ROTOR_INERTIA: &str = MotorParams::rotor_inertia_kg_m2.key();
/// Wheel (and output gear) inertia.
pub const WHEEL_INERTIA: &str = WheelParams::inertia_kg_m2.key();
/// All viscous friction, referred to the motor shaft.
pub const VISCOUS: &str = MotorParams::viscous_nm_s_rad.key();
/// The DCMC's volts per percent of demand (the rig's name).
pub const DEMAND_GAIN: &str = alias::CONTROLLER_GAIN_V_PCT.key();

crate::declare_params! {
    /// The backlash block's own parameter (section `backlash`).
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct PlayShare in "backlash" {
        /// Share of the viscous friction on the wheel's side of the play, in its bearings
        /// (the rig gives only the total).
        wheel_viscous_share: f64 = WHEEL_SIDE_VISCOUS_SHARE, "", closed(0.0, 0.95);
    }
}

/// What a rotary axis's parameters set, by key: the simulator's blocks (motor, gear
/// train, wheel, the DCMC's gain and speed loop, the battery) and the backlash block's own
/// share. The fit's parameters are written into it through [`axis_keys`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisParams {
    /// The motor; its Coulomb friction, direction ratio and bias are the effects'.
    pub motor: MotorParams,
    /// The gear train; its play is the backlash block's.
    pub gearbox: GearboxParams,
    /// The wheel.
    pub wheel: WheelParams,
    /// The DCMC: its forward gain for a demand input, its integral gain and command delay
    /// for the speed-feedback and transport-delay blocks.
    pub dcmc: DcmcParams,
    /// The bridges' limit and the battery's internal resistance.
    pub battery: BatteryParams,
    /// The backlash block's share of the viscous friction at the wheel.
    pub play: PlayShare,
    /// The terms outside the vocabulary (all off unless a diagnosis tries one).
    pub term: TermParams,
}

/// The rotary axis's keys.
pub fn axis_keys() -> &'static KeyTable<AxisParams> {
    static TABLE: OnceLock<KeyTable<AxisParams>> = OnceLock::new();
    TABLE.get_or_init(|| {
        KeyTable::<AxisParams>::new()
            .block(|a| &a.motor, |a| &mut a.motor)
            .block(|a| &a.gearbox, |a| &mut a.gearbox)
            .block(|a| &a.wheel, |a| &mut a.wheel)
            .block(|a| &a.dcmc, |a| &mut a.dcmc)
            .block(|a| &a.battery, |a| &mut a.battery)
            .block(|a| &a.play, |a| &mut a.play)
            .block(|a| &a.term, |a| &mut a.term)
    })
}

/// An axis with none of the effects' physics: no Coulomb friction, the same viscous
/// friction both ways, no bias, no play.
fn without_effects() -> AxisParams {
    AxisParams {
        motor: MotorParams {
            coulomb_nm: 0.0,
            viscous_ratio: 1.0,
            offset_nm: 0.0,
            ..MotorParams::default()
        },
        gearbox: GearboxParams {
            backlash_rad: 0.0,
            ..GearboxParams::default()
        },
        wheel: WheelParams::default(),
        dcmc: DcmcParams::default(),
        battery: BatteryParams::default(),
        play: PlayShare::default(),
        term: TermParams::default(),
    }
}

/// Tooth contact of the backlash block, referred to the wheel (not in the rig; the fit
/// is insensitive to it once it is stiff against the sample rate).
pub const TOOTH_STIFFNESS_NM_RAD: f64 = 5000.0;
/// Tooth damping of the backlash block, referred to the wheel, N m s/rad.
pub const TOOTH_DAMPING_NM_S_RAD: f64 = 3.0;
/// Longest RK4 step against the tooth mesh's rate ([`GearboxParams::mesh_rate`]), as
/// `h * rate`: the standard the electrical mode is held to (`h <= L / R`). What limits the
/// accuracy through a play is the timing of the teeth meeting and parting, which the
/// integrator places by splitting the step there ([`crate::ident::model::Dynamics::event_fraction`]). Measured
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
/// on (the rig gives only the total); a parameter of the block, starting at this value.
pub const WHEEL_SIDE_VISCOUS_SHARE: f64 = 0.3;
/// Finite-difference step (search coordinate) of every parameter once a play is modelled.
pub const BACKLASH_FD_STEP: f64 = 1e-3;
/// Name of the backlash block's nuisance parameter.
pub const WHEEL_SHARE_PARAM: &str = PlayShare::wheel_viscous_share.key();

/// Ceiling of the search of a viscous friction believed zero, N m s/rad: the motor's own
/// electrical damping K^2/R; behind a torque amplifier (no back-EMF braking) the rotor
/// inertia over 10 ms, a mechanical time constant no drive train is shorter than.
fn viscous_ceiling(rig: &Rig, torque_driven: bool) -> f64 {
    let inertial = rig
        .get(MotorParams::rotor_inertia_kg_m2.key())
        .unwrap_or(1e-4)
        / 0.01;
    match crate::rig::electrical_damping(rig) {
        Some(d) if !torque_driven => d,
        _ => inertial,
    }
}

/// The rotary axis with any effects switched on.
#[derive(Debug, Clone)]
pub struct RotaryAxis {
    specs: Vec<ParamSpec>,
    /// Each parameter's key in [`axis_keys`].
    binding: Binding<AxisParams>,
    /// What drives the axis.
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
    /// The term outside the vocabulary switched on, if any, with its form.
    pub term: Option<TermForm>,
}

impl RotaryAxis {
    /// The axis a rig describes, driven by `input`.
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
            ParamSpec::positive(
                MotorParams::resistance_ohm.key(),
                need(MotorParams::resistance_ohm.key())?,
            ),
            // The inductance is weakly seen at sample rates far below R/L; a fit left free
            // would chase it towards zero, and the integration with it. Beliefs are tens of
            // percent off, so a factor of 3 is a generous physical bound.
            {
                let l = need(MotorParams::inductance_h.key())?;
                if l == 0.0 && !torque_driven {
                    return Err(crate::rig::zero_refused(
                        path,
                        MotorParams::inductance_h.key(),
                        "the model integrates the armature current, so it needs the inductance; if it is negligible, give a value well below the resistance times the sample interval (e.g. 1e-5 H)",
                    ));
                }
                let l = if torque_driven {
                    l.bounded(1e-6, 1e-3)
                } else {
                    l
                };
                ParamSpec::new(MotorParams::inductance_h.key(), l, l / 3.0, 3.0 * l)
                    .believed(crate::ident::model::DEFAULT_BELIEF_SD_REL)
            },
            ParamSpec::positive(
                MotorParams::torque_constant_nm_a.key(),
                need(MotorParams::torque_constant_nm_a.key())?,
            ),
            ParamSpec::positive(
                MotorParams::rotor_inertia_kg_m2.key(),
                rig.require(
                    MotorParams::rotor_inertia_kg_m2.key(),
                    path,
                    "the rotary drive-axis model needs it",
                )?,
            ),
            ParamSpec::positive(
                WheelParams::inertia_kg_m2.key(),
                rig.get(WheelParams::inertia_kg_m2.key())
                    .unwrap_or(0.0)
                    .max(1e-12),
            ),
            ParamSpec::friction(
                MotorParams::viscous_nm_s_rad.key(),
                rig.require(
                    MotorParams::viscous_nm_s_rad.key(),
                    path,
                    "the rotary drive-axis model needs it",
                )?,
                viscous_ceiling(rig, torque_driven),
            ),
        ];
        if input == AxisInput::Demand {
            specs.push(
                ParamSpec::positive(
                    DEMAND_GAIN,
                    rig.require(DEMAND_GAIN, path, "demand_pct is the input")?,
                )
                .setting(DcmcParams::forward_gain_v_pct.key()),
            );
        }
        Ok(RotaryAxis {
            binding: Binding::new(axis_keys(), &specs),
            specs,
            input,
            ratio: rig.gear_ratio(path)?,
            encoder: rig
                .get(Instruments::motor_encoder_counts_per_rev.key())
                .is_some(),
            supply_v: rig.get(alias::SUPPLY_VOLTAGE_V.key()).unwrap_or(24.0),
            effects: effects::EffectSlots::default(),
            coulomb_eps_rad_s: 1.0,
            term: None,
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
        c.per_volt_nm_v * command.bounded(-c.limit, c.limit)
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
        let spec = effect.param(false, start, lo, hi);
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
        m.binding = Binding::new(axis_keys(), &m.specs);
        m.coulomb_eps_rad_s = (effects::COULOMB_SMOOTHING_FRACTION * max_speed).max(1e-3);
        m
    }

    /// This model with a term outside the vocabulary: its fixed choice held (`order`),
    /// its coefficients appended (the last ones) as `coefficients` says. The indices of
    /// the coefficients.
    pub fn with_term(
        &self,
        form: TermForm,
        coefficients: &[TermCoefficient],
    ) -> (RotaryAxis, Vec<usize>) {
        let mut m = self.clone();
        if let Some((name, key, value)) = form.fixed() {
            // A thermal time constant is refined by the fit (log scale, 1 s to 3 hours);
            // orders and exponents stay where the search put them.
            let (lo, hi) = match form.family {
                Family::ThermalDrift => (1.0, 1e4),
                _ => (value.min(0.0), value.max(1.0) * 2.0),
            };
            m.specs
                .push(ParamSpec::new(name, value, lo, hi).setting(key));
        }
        let first = m.specs.len();
        for c in coefficients {
            m.specs
                .push(ParamSpec::new(c.name, c.start, c.lo, c.hi).setting(c.key));
        }
        m.term = Some(form);
        m.binding = Binding::new(axis_keys(), &m.specs);
        let indices = (first..m.specs.len()).collect();
        (m, indices)
    }

    /// Nominal parameters an effect's block makes identifiable beyond the default free set:
    /// with a play, the motor runs free on its own inertia and electrical damping `K^2/R`
    /// while the teeth are apart, which separates the two inertias, and R from K even
    /// without a current.
    pub fn newly_identifiable(&self, effect: Effect, outputs: &[String]) -> Vec<usize> {
        use crate::ident::model::GreyBox;
        let has_current = outputs.iter().any(|o| o == chan::CURRENT_A);
        match effect {
            // The wheel's inertia is seen apart from the rotor's once the teeth separate.
            Effect::Backlash if has_current || self.torque_command().is_some() => {
                self.indices_of(&[WHEEL_INERTIA])
            }
            Effect::Backlash => self.indices_of(&[RESISTANCE, WHEEL_INERTIA]),
            _ => vec![],
        }
    }

    /// The parameters at the values `p`, written by key into the axis's blocks.
    pub fn declared(&self, p: &[f64]) -> AxisParams {
        self.binding.apply(&without_effects(), p)
    }

    /// Parameters whose key the axis's blocks do not have (none, unless the model is
    /// wrong; a test checks every effect).
    pub fn unbound(&self) -> Vec<&str> {
        self.binding.unbound(&self.specs)
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
    pub fn inertia_at_motor(&self, a: &AxisParams) -> f64 {
        a.motor.rotor_inertia_kg_m2 + a.wheel.inertia_kg_m2 / (self.ratio * self.ratio)
    }

    /// Terminal voltage for an input value, V (before the effects' blocks).
    pub fn voltage(&self, a: &AxisParams, u: f64) -> f64 {
        self.command_voltage(self.demand_gain_v_pct(a), u)
    }

    /// The DCMC's voltage per percent of demand, V/pct (1 for the other inputs).
    #[inline]
    fn demand_gain_v_pct(&self, a: &AxisParams) -> f64 {
        if self.input == AxisInput::Demand {
            a.dcmc.forward_gain_v_pct
        } else {
            1.0
        }
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
    pub fn mechanical_time_constant_s(&self, a: &AxisParams) -> f64 {
        let m = &a.motor;
        // Behind a torque amplifier the back-EMF does not damp the motor.
        let electrical = match self.input {
            AxisInput::Torque(_) => 0.0,
            _ => m.electrical_damping_nm_s_rad(),
        };
        self.inertia_at_motor(a) / (m.viscous_nm_s_rad + electrical)
    }
}
