//! The contract's vocabulary of missing physics, as optional blocks of the identification
//! models. Each effect is declared once in `defs.rs` ([`EffectDef`]: its contract name and
//! parameter, unit, keys, the diagnosis's grid and its words) and brings, where needed,
//! its own state; the physical laws are the simulator's own (`crate::model`).

mod defs;

pub use defs::{ByAxis, EffectDef, Grid, NullBound, Off, Scale, Scaled, Spacing};

use crate::ident::model::ParamSpec;
use crate::model::battery::BatteryParams;

/// One effect of the vocabulary.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Effect {
    /// Dead band in the gear train between motor and wheel.
    Backlash,
    /// Constant-magnitude friction opposing motion.
    CoulombFriction,
    /// Viscous friction that differs by direction.
    FrictionAsymmetry,
    /// A constant bias torque or force.
    Offset,
    /// Tyre force limited by the floor's friction.
    WheelSlip,
    /// Drive voltage clipped by the supply.
    VoltageSaturation,
    /// Supply voltage dropping with current.
    BatterySag,
    /// Dead time between command and actuation.
    TransportDelay,
    /// The motor controller's own speed loop with integral action.
    SpeedFeedback,
    /// Drag from the idler castors.
    CastorDrag,
    /// The drive wheels' effective rolling radii and the track differ from those the
    /// odometry and the base controller are configured with (UMBmark's systematic errors:
    /// unequal wheel diameters, an uncertain wheelbase).
    WheelGeometry,
    /// A velocity-commanded base's controller passes commands within speed and
    /// acceleration limits (`diff_drive_controller`'s `max_velocity`, `max_acceleration`):
    /// commanded motion the wheels never reach.
    BaseLimits,
}

impl Effect {
    /// The whole vocabulary.
    pub const ALL: [Effect; 12] = [
        Effect::Backlash,
        Effect::CoulombFriction,
        Effect::FrictionAsymmetry,
        Effect::Offset,
        Effect::WheelSlip,
        Effect::VoltageSaturation,
        Effect::BatterySag,
        Effect::TransportDelay,
        Effect::SpeedFeedback,
        Effect::CastorDrag,
        Effect::WheelGeometry,
        Effect::BaseLimits,
    ];

    /// The effect's declaration: its names, units, keys, grid and words.
    pub fn def(self) -> &'static EffectDef {
        defs::def(self)
    }

    /// The contract's name.
    pub fn name(self) -> &'static str {
        self.def().name
    }

    /// The contract's parameter name (rotary or linear axis).
    pub fn param_name(self, linear: bool) -> &'static str {
        self.def().param.on(linear)
    }

    /// The unit of the contract's parameter ([`Effect::param_name`]); `""` for a ratio
    /// or a friction coefficient.
    pub fn unit(self, linear: bool) -> &'static str {
        self.def().unit.on(linear)
    }

    /// The key of a fitting model's blocks that the effect's strength sets
    /// ([`EffectDef::key`]).
    pub fn key(self, linear: bool) -> &'static str {
        self.def().key.on(linear)
    }

    /// The scene key that sets the effect's strength in the simulator (where a
    /// calibration fits it): the fitting model's key ([`Effect::key`]), but for castor
    /// drag, which the scene sets as the castors' rolling resistance.
    pub fn scene_key(self) -> crate::param::ParamKey {
        self.def().scene_key
    }

    /// The effect's strength as a fit's parameter: the vocabulary's name, setting the
    /// model's key ([`Effect::key`]), starting at `start` within `[lo, hi]`.
    pub fn param(self, linear: bool, start: f64, lo: f64, hi: f64) -> ParamSpec {
        ParamSpec::new(self.param_name(linear), start, lo, hi).setting(self.key(linear))
    }

    /// The effect by its contract name.
    pub fn from_name(s: &str) -> Option<Effect> {
        Effect::ALL.into_iter().find(|e| e.name() == s)
    }

    /// The vocabulary's names, comma-separated (for help and errors).
    pub fn vocabulary() -> String {
        Effect::ALL.map(|e| e.name()).join(", ")
    }
}

/// A word that is not an effect of the vocabulary, or `all`/`none` given with names.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EffectNameError {
    /// Not a vocabulary name.
    #[error("--effects {0}: not an effect of the contract's vocabulary ({voc})", voc = Effect::vocabulary())]
    Unknown(String),
    /// `all` or `none` beside other names.
    #[error("--effects {0}: give `{0}` alone, or name the effects")]
    NotAlone(String),
}

impl std::str::FromStr for Effect {
    type Err = EffectNameError;

    fn from_str(s: &str) -> Result<Effect, EffectNameError> {
        Effect::from_name(s.trim()).ok_or_else(|| EffectNameError::Unknown(s.trim().to_string()))
    }
}

/// Which effects a diagnosis or a calibration tries.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum Choice {
    /// Every effect of the vocabulary the record can show (`--effects all`, the default).
    #[default]
    All,
    /// None: the nominal model (or the scene's keys) only (`--effects none`).
    None,
    /// These, each of which the record must be able to show.
    Named(Vec<Effect>),
}

impl Choice {
    /// The effects named on the command line: `all`, `none`, or vocabulary names
    /// (repeats dropped). No names at all is `all`.
    pub fn parse(names: &[String]) -> Result<Choice, EffectNameError> {
        for (word, choice) in [("all", Choice::All), ("none", Choice::None)] {
            if names.iter().any(|n| n.trim() == word) {
                return if names.len() == 1 {
                    Ok(choice)
                } else {
                    Err(EffectNameError::NotAlone(word.to_string()))
                };
            }
        }
        let mut out: Vec<Effect> = vec![];
        for n in names {
            let e: Effect = n.parse()?;
            if !out.contains(&e) {
                out.push(e);
            }
        }
        Ok(if out.is_empty() {
            Choice::All
        } else {
            Choice::Named(out)
        })
    }

    /// Whether the choice lets `e` be tried (when the record can show it).
    pub fn admits(&self, e: Effect) -> bool {
        match self {
            Choice::All => true,
            Choice::None => false,
            Choice::Named(list) => list.contains(&e),
        }
    }
}

/// The effects switched on in a model, each with the positions of its parameters in the
/// model's parameter vector: an effect's nuisance parameters first, its strength (the
/// contract's parameter) last. Indexed by the effect, so a model's every evaluation finds
/// its blocks at once.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct EffectSlots([Option<(usize, usize)>; Effect::ALL.len()]);

impl EffectSlots {
    /// Switches an effect on with its parameters at `params`.
    pub fn add(&mut self, effect: Effect, params: std::ops::Range<usize>) {
        debug_assert!(!params.is_empty());
        self.0[effect as usize] = Some((params.start, params.end));
    }

    /// The position of an effect's strength parameter, if it is on.
    #[inline]
    pub fn get(&self, effect: Effect) -> Option<usize> {
        self.0[effect as usize].map(|(_, end)| end - 1)
    }

    /// An effect's parameter values in `p`, in the order the effect names them, if it is
    /// on: what a model destructures into named values.
    #[inline]
    pub fn values<'a>(&self, effect: Effect, p: &'a [f64]) -> Option<&'a [f64]> {
        self.0[effect as usize].map(|(start, end)| &p[start..end])
    }
}

/// Speed below which Coulomb friction is ramped (tanh) rather than switched, as a fraction
/// of the record's largest speed: a set-valued law cannot be differentiated for fitting.
pub const COULOMB_SMOOTHING_FRACTION: f64 = 0.005;

/// Coulomb friction, smoothed: `Tc tanh(w / eps)`, the motor block's law
/// ([`crate::model::motor::coulomb_torque_nm`]) with the fit's smoothing speed.
pub fn smooth_coulomb(level: f64, speed: f64, eps: f64) -> f64 {
    crate::model::motor::coulomb_torque_nm(level, speed, eps)
}

/// Viscous friction torque that differs by direction: the motor block's law
/// ([`crate::model::motor::viscous_coefficient`]), `b+ / b- = ratio` around the mean `b`.
pub fn asymmetric_viscous(b: f64, ratio: f64, speed: f64) -> f64 {
    crate::model::motor::viscous_coefficient(b, ratio, speed) * speed
}

/// The battery-sag block's battery: the rig's supply voltage open-circuit, sagging by
/// its internal resistance (ohm) under the bridges' current, the bridges setting their
/// duty against the supply voltage (so the sag scales every command) and no other limit.
pub fn sagging_battery(supply_v: f64, internal_resistance_ohm: f64) -> BatteryParams {
    BatteryParams {
        open_circuit_v: supply_v,
        internal_resistance_ohm,
        drive_limit_v: f64::INFINITY,
        low_voltage_fault_v: 0.0,
        bridge_rated_v: supply_v,
    }
}

/// What stands between a recorded command and a motor's terminals in the fitting models:
/// the bridges' limit (the voltage-saturation block), the sagging battery (the
/// battery-sag block) and a dead time (the transport-delay block), each only when its
/// effect is on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SupplyBlocks {
    /// The bridges' voltage limit, V.
    pub drive_limit_v: Option<f64>,
    /// The battery the bridges draw on, with duty-setting bridges.
    pub battery: Option<BatteryParams>,
    /// Dead time between the command and the drive, s (0: none).
    pub delay_s: f64,
}

impl SupplyBlocks {
    /// The blocks of the effects switched on in `slots`, from the declared battery (its
    /// limit and internal resistance), the DCMC (its command delay) and the rig's supply
    /// voltage.
    #[inline]
    pub fn of(
        slots: &EffectSlots,
        battery: &BatteryParams,
        command_delay_s: f64,
        supply_v: f64,
    ) -> SupplyBlocks {
        let on = |e: Effect| slots.get(e).is_some();
        SupplyBlocks {
            drive_limit_v: on(Effect::VoltageSaturation).then_some(battery.drive_limit_v),
            battery: on(Effect::BatterySag)
                .then(|| sagging_battery(supply_v, battery.internal_resistance_ohm)),
            delay_s: if on(Effect::TransportDelay) {
                command_delay_s
            } else {
                0.0
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ident::models::linear_axis::LinearEffects;
    use crate::ident::models::vehicle::blocks::{CastorDrag, CreepTyre};
    use crate::model::tyre::TyreChoice;

    #[test]
    fn each_effects_key_is_its_fitting_blocks_declared_key() {
        let linear = [
            (Effect::CoulombFriction, LinearEffects::coulomb_force_n),
            (Effect::FrictionAsymmetry, LinearEffects::viscous_ratio),
            (Effect::Offset, LinearEffects::offset_n),
            (Effect::TransportDelay, LinearEffects::delay_s),
        ];
        for (effect, handle) in linear {
            assert_eq!(effect.key(true), handle.key(), "{effect:?}");
        }
        assert_eq!(Effect::CastorDrag.key(false), CastorDrag::drag_n.key());
        // The fitting vehicle's tyre and the scene's share the key.
        assert_eq!(Effect::WheelSlip.key(false), CreepTyre::peak_mu.key());
        assert_eq!(Effect::WheelSlip.scene_key(), TyreChoice::peak_mu);
    }
}
