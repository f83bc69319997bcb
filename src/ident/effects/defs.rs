//! Each effect of the vocabulary declared once: the contract's name and parameter with
//! its unit, the key of the fitting models and of the scene its strength sets, where the
//! diagnosis scans that strength, and the words a report gives the fitted value. What
//! differs in behaviour (how a model's block acts, where a calibration starts the effect)
//! stays in the compiler's exhaustive matches beside that behaviour.

use super::Effect;
use crate::model::base_controller::BaseParams;
use crate::model::battery::BatteryParams;
use crate::model::castor::CastorParams;
use crate::model::chassis::ChassisParams;
use crate::model::dcmc::DcmcParams;
use crate::model::gearbox::GearboxParams;
use crate::model::motor::MotorParams;
use crate::model::tyre::TyreChoice;
use crate::numtext::quantity;
use crate::param::ParamKey;

/// One effect, declared.
#[derive(Debug)]
pub struct EffectDef {
    /// The effect.
    pub effect: Effect,
    /// The contract's name (`backlash`).
    pub name: &'static str,
    /// The contract's parameter name (`backlash_rad`).
    pub param: ByAxis,
    /// The parameter's unit; `""` for a ratio or a friction coefficient.
    pub unit: ByAxis,
    /// The key of a fitting model's blocks that the strength sets: the simulator's own key
    /// where the scene has the physics (a rotary axis, the vehicle), the linear axis's
    /// effect block otherwise. (The fitting models' own blocks are named by text here, as
    /// the vocabulary sits below the models; a test holds each to its handle.)
    pub key: ByAxis,
    /// The scene key that sets the strength in the simulator (where a calibration fits it),
    /// by its handle.
    pub scene_key: ParamKey,
    /// Where the diagnosis scans the strength before its local search.
    pub grid: Grid,
    /// Which end of the search is the physics vanishing: a fit ending near it did not
    /// find the effect, whatever its gain (its block's other physics earned it).
    pub null_bound: NullBound,
    /// The scene key's value at which the physics is absent (where a calibration takes
    /// it out).
    pub off: Off,
    /// The fitted strength `v` in words, with its unit (`linear`: on a linear axis).
    pub describe: fn(v: f64, linear: bool) -> String,
}

/// A name on a rotary axis or a vehicle, and on a linear axis.
#[derive(Debug, Clone, Copy)]
pub struct ByAxis {
    /// On a rotary axis or a vehicle.
    pub rotary: &'static str,
    /// On a linear axis.
    pub linear: &'static str,
}

impl ByAxis {
    /// The same name on every axis.
    const fn both(name: &'static str) -> ByAxis {
        ByAxis {
            rotary: name,
            linear: name,
        }
    }

    /// The name on the axis (`linear`: a linear axis).
    pub fn on(self, linear: bool) -> &'static str {
        if linear {
            self.linear
        } else {
            self.rotary
        }
    }
}

/// The diagnosis's scan of a strength: `n` points from `from` to `to`, spaced evenly on a
/// log or a linear scale, and the bounds `[lo, hi]` of the search that follows.
#[derive(Debug, Clone, Copy)]
pub struct Grid {
    /// Log (ratios between points equal) or linear.
    pub spacing: Spacing,
    /// The first point.
    pub from: Scaled,
    /// The last point.
    pub to: Scaled,
    /// How many points.
    pub n: usize,
    /// The search's lower bound.
    pub lo: Scaled,
    /// The search's upper bound.
    pub hi: Scaled,
}

/// How a grid's points are spaced.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Spacing {
    /// Equal ratios between neighbours.
    Log,
    /// Equal differences.
    Linear,
}

/// Which end of an effect's search is the physics vanishing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NullBound {
    /// Neither: every value is the physics present (a limit, a ratio, a signed bias).
    Neither,
    /// Near the lower bound (within a factor 1.5 of a positive one): a play of 0.1 mrad.
    Lower,
    /// Near the upper bound (within a factor 1.5): grip vanishes as a limit when the
    /// friction coefficient grows without bound.
    Upper,
}

/// The value of an effect's scene key at which its physics is absent.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Off {
    /// This value (no play, no friction, the same friction both ways).
    At(f64),
    /// A drive limit at the largest voltage command, clipping none of them; none where
    /// the drive is not commanded in volts (a limit under a DCMC's or a base's loops is
    /// the hardware's: nothing to take out).
    LargestVoltageCommand,
    /// None: the physics is always there (a tyre always has a finite grip).
    Never,
}

/// A number times a scale of the record (`times` alone for [`Scale::One`]).
#[derive(Debug, Clone, Copy)]
pub struct Scaled {
    /// The factor.
    pub times: f64,
    /// The record's scale it multiplies.
    pub of: Scale,
}

/// A scale of the record a grid is placed by (the diagnosis measures each).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scale {
    /// 1: a grid in the parameter's own unit.
    One,
    /// The record's effort: the largest motor torque (N m) or force (N) the supply drives.
    Effort,
    /// The largest drive voltage, V.
    SupplyV,
    /// The sample interval, s.
    SampleS,
    /// The sample interval, s, at least a millisecond.
    SampleAtLeastMsS,
    /// The speed loop's natural integral gain, V/rad: the largest voltage over the largest
    /// speed over the mechanical time constant.
    SpeedLoopGain,
    /// The weight on the floor, N.
    WeightN,
}

/// `times` x `of`.
const fn x(times: f64, of: Scale) -> Scaled {
    Scaled { times, of }
}

/// `times` in the parameter's own unit.
const fn n(times: f64) -> Scaled {
    x(times, Scale::One)
}

/// A log-spaced grid.
const fn log(from: Scaled, to: Scaled, n: usize, lo: Scaled, hi: Scaled) -> Grid {
    Grid {
        spacing: Spacing::Log,
        from,
        to,
        n,
        lo,
        hi,
    }
}

/// A linearly spaced grid.
const fn lin(from: Scaled, to: Scaled, n: usize, lo: Scaled, hi: Scaled) -> Grid {
    Grid {
        spacing: Spacing::Linear,
        ..log(from, to, n, lo, hi)
    }
}

/// The declaration of `e`.
pub fn def(e: Effect) -> &'static EffectDef {
    match e {
        Effect::Backlash => &BACKLASH,
        Effect::CoulombFriction => &COULOMB_FRICTION,
        Effect::FrictionAsymmetry => &FRICTION_ASYMMETRY,
        Effect::Offset => &OFFSET,
        Effect::WheelSlip => &WHEEL_SLIP,
        Effect::VoltageSaturation => &VOLTAGE_SATURATION,
        Effect::BatterySag => &BATTERY_SAG,
        Effect::TransportDelay => &TRANSPORT_DELAY,
        Effect::SpeedFeedback => &SPEED_FEEDBACK,
        Effect::CastorDrag => &CASTOR_DRAG,
        Effect::WheelGeometry => &WHEEL_GEOMETRY,
        Effect::BaseLimits => &BASE_LIMITS,
    }
}

static BACKLASH: EffectDef = EffectDef {
    effect: Effect::Backlash,
    name: "backlash",
    param: ByAxis::both("backlash_rad"),
    unit: ByAxis::both("rad"),
    key: ByAxis::both(GearboxParams::backlash_rad.key()),
    scene_key: GearboxParams::backlash_rad,
    // Play has narrow basins (a wrong play shifts every engagement): a fine scan.
    grid: log(n(0.002), n(0.4), 48, n(1e-4), n(1.0)),
    null_bound: NullBound::Lower,
    off: Off::At(0.0),
    describe: |v, _| {
        format!(
            "gear backlash of about {:.1} degrees ({v:.4} rad) of total play at the wheel",
            v.to_degrees()
        )
    },
};

static COULOMB_FRICTION: EffectDef = EffectDef {
    effect: Effect::CoulombFriction,
    name: "coulomb_friction",
    param: ByAxis {
        rotary: "coulomb_torque_Nm",
        linear: "coulomb_force_N",
    },
    unit: ByAxis {
        rotary: "N m",
        linear: "N",
    },
    key: ByAxis {
        rotary: MotorParams::coulomb_nm.key(),
        linear: "effect.coulomb_force_N",
    },
    scene_key: MotorParams::coulomb_nm,
    grid: log(
        x(1e-3, Scale::Effort),
        x(0.2, Scale::Effort),
        16,
        x(1e-6, Scale::Effort),
        x(1.0, Scale::Effort),
    ),
    null_bound: NullBound::Lower,
    off: Off::At(0.0),
    describe: |v, linear| {
        if linear {
            format!("Coulomb friction of about {v:.2} N opposing the motion")
        } else {
            format!(
                "Coulomb friction of about {} at the motor shaft (brushes, bearings)",
                quantity(v, 3, "N m")
            )
        }
    },
};

static FRICTION_ASYMMETRY: EffectDef = EffectDef {
    effect: Effect::FrictionAsymmetry,
    name: "friction_asymmetry",
    param: ByAxis::both("viscous_ratio"),
    unit: ByAxis::both(""),
    key: ByAxis {
        rotary: MotorParams::viscous_ratio.key(),
        linear: "effect.viscous_ratio",
    },
    scene_key: MotorParams::viscous_ratio,
    grid: log(n(0.4), n(2.5), 13, n(0.1), n(10.0)),
    null_bound: NullBound::Neither,
    off: Off::At(1.0),
    describe: |v, _| direction_of_viscous_friction(v),
};

static OFFSET: EffectDef = EffectDef {
    effect: Effect::Offset,
    name: "offset",
    param: ByAxis {
        rotary: "offset_Nm",
        linear: "offset_N",
    },
    unit: ByAxis {
        rotary: "N m",
        linear: "N",
    },
    key: ByAxis {
        rotary: MotorParams::offset_nm.key(),
        linear: "effect.offset_N",
    },
    scene_key: MotorParams::offset_nm,
    grid: lin(
        x(-0.05, Scale::Effort),
        x(0.05, Scale::Effort),
        13,
        x(-1.0, Scale::Effort),
        x(1.0, Scale::Effort),
    ),
    null_bound: NullBound::Neither,
    off: Off::At(0.0),
    describe: |v, linear| {
        if linear {
            format!("a constant bias force of {v:.2} N (gravity component, cable, sensor bias)")
        } else {
            format!(
                "a constant bias torque of {} at the motor shaft",
                quantity(v, 3, "N m")
            )
        }
    },
};

static WHEEL_SLIP: EffectDef = EffectDef {
    effect: Effect::WheelSlip,
    name: "wheel_slip",
    param: ByAxis::both("peak_mu"),
    unit: ByAxis::both(""),
    key: ByAxis::both(TyreChoice::peak_mu.key()),
    scene_key: TyreChoice::peak_mu,
    grid: log(n(0.15), n(2.0), 14, n(0.05), n(4.0)),
    null_bound: NullBound::Upper,
    off: Off::Never,
    describe: |v, _| {
        format!(
            "wheel slip: the tyres' grip limited by a peak floor friction coefficient of about {v:.2}"
        )
    },
};

static VOLTAGE_SATURATION: EffectDef = EffectDef {
    effect: Effect::VoltageSaturation,
    name: "voltage_saturation",
    param: ByAxis::both("limit_V"),
    unit: ByAxis::both("V"),
    key: ByAxis::both(BatteryParams::drive_limit_v.key()),
    scene_key: BatteryParams::drive_limit_v,
    grid: lin(
        x(0.4, Scale::SupplyV),
        x(1.0, Scale::SupplyV),
        13,
        x(0.2, Scale::SupplyV),
        x(2.0, Scale::SupplyV),
    ),
    null_bound: NullBound::Neither,
    off: Off::LargestVoltageCommand,
    describe: |v, _| format!("the drive voltage clipped at about {v:.2} V by the supply"),
};

static BATTERY_SAG: EffectDef = EffectDef {
    effect: Effect::BatterySag,
    name: "battery_sag",
    param: ByAxis::both("internal_resistance_ohm"),
    unit: ByAxis::both("ohm"),
    key: ByAxis::both(BatteryParams::internal_resistance_ohm.key()),
    scene_key: BatteryParams::internal_resistance_ohm,
    grid: log(n(0.003), n(2.0), 14, n(1e-5), n(5.0)),
    null_bound: NullBound::Lower,
    off: Off::At(0.0),
    describe: |v, _| {
        format!(
            "the supply sagging with current through about {:.0} mohm of internal resistance",
            1000.0 * v
        )
    },
};

static TRANSPORT_DELAY: EffectDef = EffectDef {
    effect: Effect::TransportDelay,
    name: "transport_delay",
    param: ByAxis::both("delay_s"),
    unit: ByAxis::both("s"),
    key: ByAxis {
        rotary: DcmcParams::command_delay_s.key(),
        linear: "effect.delay_s",
    },
    scene_key: DcmcParams::command_delay_s,
    grid: log(
        x(0.1, Scale::SampleS),
        x(30.0, Scale::SampleAtLeastMsS),
        16,
        n(1e-6),
        n(0.5),
    ),
    null_bound: NullBound::Lower,
    off: Off::At(0.0),
    describe: |v, _| {
        format!(
            "a dead time of about {:.1} ms between command and actuation",
            1000.0 * v
        )
    },
};

static SPEED_FEEDBACK: EffectDef = EffectDef {
    effect: Effect::SpeedFeedback,
    name: "speed_feedback",
    param: ByAxis::both("integral_gain"),
    unit: ByAxis::both("V/rad"),
    key: ByAxis::both(DcmcParams::ki_v_rad.key()),
    scene_key: DcmcParams::ki_v_rad,
    grid: log(
        x(1e-5, Scale::SpeedLoopGain),
        x(0.3, Scale::SpeedLoopGain),
        16,
        x(1e-7, Scale::SpeedLoopGain),
        x(10.0, Scale::SpeedLoopGain),
    ),
    null_bound: NullBound::Lower,
    off: Off::At(0.0),
    describe: |v, _| {
        format!("the motor controller closing its own speed loop with integral gain {v:.4} V/rad")
    },
};

static CASTOR_DRAG: EffectDef = EffectDef {
    effect: Effect::CastorDrag,
    name: "castor_drag",
    param: ByAxis::both("drag_N"),
    unit: ByAxis::both("N"),
    key: ByAxis::both("castor_drag.drag_N"),
    // The scene sets castor drag as the castors' rolling resistance.
    scene_key: CastorParams::rolling_resistance,
    grid: log(
        x(1e-3, Scale::WeightN),
        x(0.1, Scale::WeightN),
        14,
        x(1e-5, Scale::WeightN),
        x(0.5, Scale::WeightN),
    ),
    null_bound: NullBound::Lower,
    off: Off::At(0.0),
    describe: |v, _| {
        format!("drag of about {v:.1} N from the idler castors opposing the chassis's motion")
    },
};

static WHEEL_GEOMETRY: EffectDef = EffectDef {
    effect: Effect::WheelGeometry,
    name: "wheel_geometry",
    param: ByAxis::both("track_m"),
    unit: ByAxis::both("m"),
    key: ByAxis::both(ChassisParams::track_width_m.key()),
    scene_key: ChassisParams::track_width_m,
    // Not a fitting model's effect (no model lists it as applicable): its keys are the
    // vehicle's nominal wheel radius and track; the calibration tries it.
    grid: lin(n(0.9), n(1.1), 11, n(0.5), n(2.0)),
    null_bound: NullBound::Lower,
    off: Off::At(0.0),
    describe: |v, _| {
        format!(
            "wheel geometry other than configured: an effective track of {} (with the wheels' effective rolling radii)",
            quantity(v, 5, "m")
        )
    },
};

static BASE_LIMITS: EffectDef = EffectDef {
    effect: Effect::BaseLimits,
    name: "base_limits",
    param: ByAxis::both("max_angular_rad_s"),
    unit: ByAxis::both("rad/s"),
    key: ByAxis::both(BaseParams::max_angular_rad_s.key()),
    scene_key: BaseParams::max_angular_rad_s,
    // Not a fitting model's effect either: the calibration reads the base controller's
    // limits off a velocity-commanded recording and fits them.
    grid: log(n(0.1), n(10.0), 11, n(1e-3), n(100.0)),
    null_bound: NullBound::Lower,
    off: Off::At(0.0),
    describe: |v, _| {
        format!(
            "the base controller's limits: commanded motion beyond them never reached the wheels (yaw rate within {})",
            quantity(v, 3, "rad/s")
        )
    },
};

/// A ratio of forward to backward viscous friction in words, naming the stronger
/// direction (a ratio of 0.68 is friction 1.47 times as strong backwards).
fn direction_of_viscous_friction(ratio: f64) -> String {
    if (ratio - 1.0).abs() < 0.005 {
        format!("viscous friction the same both ways (forward/backward ratio {ratio:.2})")
    } else if ratio > 1.0 {
        format!("viscous friction {ratio:.2} times as strong forwards as backwards")
    } else {
        format!(
            "viscous friction {:.2} times as strong backwards as forwards (forward/backward ratio {ratio:.2})",
            1.0 / ratio
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each effect's declaration is its own (the match in [`def`] cannot send one effect to
    /// another's), its name unique in the vocabulary, its grid a grid.
    #[test]
    fn each_effect_has_its_own_declaration() {
        let mut names = std::collections::BTreeSet::new();
        for e in Effect::ALL {
            let d = def(e);
            assert_eq!(d.effect, e);
            assert!(names.insert(d.name), "{} twice", d.name);
            assert!(d.grid.n >= 2, "{}: a grid of {} points", d.name, d.grid.n);
            assert!(!(d.describe)(1.0, false).is_empty());
        }
    }
}
