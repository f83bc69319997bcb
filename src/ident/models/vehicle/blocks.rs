//! The simulator's blocks the vehicle model assembles (motor, gear train with its play,
//! wheel bearings, no-slip body, tyres, castors, battery and bridges), built from one
//! parameter vector as named values.

use std::sync::OnceLock;

use crate::ident::effects::{Effect, SupplyBlocks};
use crate::ident::models::rotary_axis::{drivetrain_blocks, PlayShare};
use crate::model::battery::BatteryParams;
use crate::model::chassis::{ChassisParams, NoSlipBody};
use crate::model::dcmc::DcmcParams;
use crate::model::drivetrain::DrivetrainParams;
use crate::model::gearbox::GearboxParams;
use crate::model::motor::MotorParams;
use crate::model::wheel::WheelParams;
use crate::model::GRAVITY_M_S2;
use crate::param::KeyTable;

use super::{Vehicle, DEFAULT_LAT_STIFFNESS_PER_N, DEFAULT_LONG_STIFFNESS_PER_N};

crate::declare_params! {
    /// The castor-drag block (section `castor_drag`): the idlers' rolling drag, lumped
    /// at a distance from the axle.
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct CastorDrag in "castor_drag" {
        /// The castors' distance from the drive-axle midpoint (not in the rig: it sets
        /// how much they resist turning).
        lever_m: f64 = 0.25, "m", NonNegative;
        /// Drag force while rolling.
        drag_n as "drag_N": f64 = 0.0, "N", NonNegative;
    }
}

crate::declare_params! {
    /// The drive tyres as the fitting vehicle sees them (section `tyre`): their creep
    /// below the friction limit, and the limit (the wheel-slip block).
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct CreepTyre in "tyre" {
        /// Longitudinal slip stiffness per newton of load (per unit slip ratio).
        long_stiffness_per_n as "long_stiffness_per_N": f64 = DEFAULT_LONG_STIFFNESS_PER_N, "1/N per unit slip", Positive;
        /// Cornering stiffness per newton of load (per rad of slip angle).
        lat_stiffness_per_n as "lat_stiffness_per_N": f64 = DEFAULT_LAT_STIFFNESS_PER_N, "1/rad", Positive;
        /// Peak friction coefficient (the wheel-slip block's strength).
        peak_mu: f64 = 1.0, "", Positive;
    }
}

/// What the vehicle's parameters set, by key: the simulator's blocks (motor, gear train,
/// wheel, chassis, battery, the DCMC's command delay) and the effects' own blocks.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VehicleParams {
    /// Each side's motor; its Coulomb friction is the effect's.
    pub motor: MotorParams,
    /// Each side's gear train; its play is the backlash block's.
    pub gearbox: GearboxParams,
    /// Each side's wheel.
    pub wheel: WheelParams,
    /// The chassis (centre of mass at the drive-axle midpoint: the rig gives no offset).
    pub chassis: ChassisParams,
    /// The tyres' creep and friction limit.
    pub tyre: CreepTyre,
    /// The bridges' limit and the battery's internal resistance.
    pub battery: BatteryParams,
    /// The DCMC's command delay (the transport-delay block).
    pub dcmc: DcmcParams,
    /// The backlash block's share of the viscous friction at the wheel.
    pub play: PlayShare,
    /// The castor-drag block.
    pub castor_drag: CastorDrag,
}

/// The vehicle's keys.
pub fn vehicle_keys() -> &'static KeyTable<VehicleParams> {
    static TABLE: OnceLock<KeyTable<VehicleParams>> = OnceLock::new();
    TABLE.get_or_init(|| {
        KeyTable::<VehicleParams>::new()
            .block(|a| &a.motor, |a| &mut a.motor)
            .block(|a| &a.gearbox, |a| &mut a.gearbox)
            .block(|a| &a.wheel, |a| &mut a.wheel)
            .block(|a| &a.chassis, |a| &mut a.chassis)
            .block(|a| &a.tyre, |a| &mut a.tyre)
            .block(|a| &a.battery, |a| &mut a.battery)
            .block(|a| &a.dcmc, |a| &mut a.dcmc)
            .block(|a| &a.play, |a| &mut a.play)
            .block(|a| &a.castor_drag, |a| &mut a.castor_drag)
    })
}

/// A vehicle with none of the effects' physics: no Coulomb friction, no play.
pub(super) fn without_effects() -> VehicleParams {
    VehicleParams {
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
        chassis: ChassisParams::default(),
        tyre: CreepTyre::default(),
        battery: BatteryParams::default(),
        dcmc: DcmcParams::default(),
        play: PlayShare::default(),
        castor_drag: CastorDrag::default(),
    }
}

/// The blocks at one parameter vector's values.
#[derive(Debug, Clone, Copy)]
pub struct VehicleBlocks {
    /// Each side's motor (with Coulomb friction when switched on), gear train and wheel
    /// (the rotary axis's `drivetrain_blocks`).
    pub drivetrain: DrivetrainParams,
    /// Whether a play separates each motor's motion from its wheel's (the backlash block).
    pub play: bool,
    /// The chassis rolling on its wheels (centre of mass at the drive-axle midpoint: the
    /// rig gives no offset), with the inertia turning with each wheel.
    pub body: NoSlipBody,
    /// Normal load on each drive wheel, N.
    pub drive_wheel_load_n: f64,
    /// The tyres' slip stiffnesses per newton of load (longitudinal per unit slip,
    /// lateral per rad).
    pub tyre_stiffness_per_n: [f64; 2],
    /// The tyres' friction limit (the wheel-slip block).
    pub peak_mu: Option<f64>,
    /// The castors' rolling drag (the castor-drag block).
    pub castors: Option<CastorDrag>,
    /// The bridges' limit, the sagging battery and the command's dead time (the
    /// supply effects' blocks).
    pub supply: SupplyBlocks,
}

impl Vehicle {
    /// The blocks of the declared parameters `a`.
    #[inline]
    pub(super) fn blocks_of(&self, a: &VehicleParams) -> VehicleBlocks {
        let on = |e: Effect| self.effect(e).is_some();
        let play = on(Effect::Backlash);
        let gearbox = GearboxParams {
            ratio: self.ratio,
            ..a.gearbox
        };
        let drivetrain = drivetrain_blocks(
            &a.motor,
            &gearbox,
            &a.wheel,
            play.then_some(&a.play),
            a.wheel.radius_m,
        );
        // What turns with a wheel: behind a play the wheel alone, through rigid gears the
        // rotor too.
        let wheel_side_kg_m2 = if play {
            drivetrain.wheel.inertia_kg_m2
        } else {
            drivetrain.wheel.inertia_kg_m2 + drivetrain.reflected_motor_inertia()
        };
        let c = &a.chassis;
        VehicleBlocks {
            drivetrain,
            play,
            body: NoSlipBody {
                mass_kg: c.mass_kg,
                yaw_inertia_kg_m2: c.yaw_inertia_kg_m2,
                cg_ahead_m: 0.0,
                track_width_m: c.track_width_m,
                wheel_radii_m: [a.wheel.radius_m; 2],
                wheel_inertia_kg_m2: wheel_side_kg_m2,
            },
            drive_wheel_load_n: c.drive_load_fraction * c.mass_kg * GRAVITY_M_S2 / 2.0,
            tyre_stiffness_per_n: [a.tyre.long_stiffness_per_n, a.tyre.lat_stiffness_per_n],
            peak_mu: on(Effect::WheelSlip).then_some(a.tyre.peak_mu),
            castors: on(Effect::CastorDrag).then_some(a.castor_drag),
            supply: SupplyBlocks::of(
                &self.effects,
                &a.battery,
                a.dcmc.command_delay_s,
                // Supply effects are applicable only with a stated supply.
                self.supply_v.unwrap_or(f64::INFINITY),
            ),
        }
    }
}
