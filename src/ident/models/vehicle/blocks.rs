//! The simulator's blocks the vehicle model assembles (motor, gear train with its play,
//! wheel bearings, no-slip body, tyres, castors, battery and bridges), built from one
//! parameter vector as named values.

use crate::ident::effects::{self, Effect};
use crate::ident::models::rotary_axis::drivetrain_blocks;
use crate::model::battery::BatteryParams;
use crate::model::chassis::NoSlipBody;
use crate::model::drivetrain::DrivetrainParams;
use crate::model::GRAVITY_M_S2;

use super::{Vehicle, IZ, LAT_STIFFNESS, LOAD_FRACTION, LONG_STIFFNESS, MASS, RW, TRACK};

// The vehicle's drive parameters sit where [`drivetrain_blocks`] reads them.
const _: () = {
    use crate::ident::models::{rotary_axis as axis, vehicle as v};
    assert!(v::R == axis::R && v::L == axis::L && v::K == axis::K);
    assert!(v::JM == axis::JM && v::JW == axis::JW && v::B == axis::B);
};

/// The castor-drag block: the idlers' rolling drag, lumped at a distance from the axle.
#[derive(Debug, Clone, Copy)]
pub(super) struct CastorDrag {
    /// Drag force while rolling, N.
    pub drag_n: f64,
    /// The castors' distance from the drive-axle midpoint, m.
    pub lever_m: f64,
}

/// The blocks at one parameter vector's values.
#[derive(Debug, Clone, Copy)]
pub(super) struct VehicleBlocks {
    /// Each side's motor (with Coulomb friction when switched on), gear train and wheel
    /// ([`drivetrain_blocks`]).
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
    pub castors: Option<CastorDrag>,
    /// The bridges' voltage limit, V (the voltage-saturation block).
    pub drive_limit_v: Option<f64>,
    /// The battery both bridges draw on, with duty-setting bridges (the battery-sag block).
    pub battery: Option<BatteryParams>,
}

impl Vehicle {
    /// The blocks at the parameter values `p`.
    #[inline]
    pub(super) fn blocks(&self, p: &[f64]) -> VehicleBlocks {
        let value = |e: Effect| self.effect(e).map(|i| p[i]);
        let castors = match self.effects.values(Effect::CastorDrag, p) {
            Some(&[lever_m, drag_n]) => Some(CastorDrag { drag_n, lever_m }),
            _ => None,
        };
        let drivetrain = drivetrain_blocks(p, self.ratio, &self.effects, p[RW]);
        let play = self.effect(Effect::Backlash).is_some();
        // What turns with a wheel: behind a play the wheel alone, through rigid gears the
        // rotor too.
        let wheel_side_kg_m2 = if play {
            drivetrain.wheel.inertia_kg_m2
        } else {
            drivetrain.wheel.inertia_kg_m2 + drivetrain.reflected_motor_inertia()
        };
        VehicleBlocks {
            drivetrain,
            play,
            body: NoSlipBody {
                mass_kg: p[MASS],
                yaw_inertia_kg_m2: p[IZ],
                cg_ahead_m: 0.0,
                track_width_m: p[TRACK],
                wheel_radius_m: p[RW],
                wheel_inertia_kg_m2: wheel_side_kg_m2,
            },
            drive_wheel_load_n: p[LOAD_FRACTION] * p[MASS] * GRAVITY_M_S2 / 2.0,
            tyre_stiffness_per_n: [p[LONG_STIFFNESS], p[LAT_STIFFNESS]],
            peak_mu: value(Effect::WheelSlip),
            castors,
            drive_limit_v: value(Effect::VoltageSaturation),
            battery: value(Effect::BatterySag).map(|r| effects::sagging_battery(self.supply_v, r)),
        }
    }
}
