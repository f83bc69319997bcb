//! The whole AGV on the floor, for identification from vehicle recordings: two DC motors
//! driving their wheels through the gear trains, and the chassis as a planar rigid body;
//! castors are free idlers carrying the rest of the weight.
//!
//! Per side (left, right): `L di/dt = V - R i - K w_m`, the motor and wheel through the
//! gear (rigid, or a play with tooth contact when the backlash block is on). With a
//! tracked pose the tyres' creep joins wheels and floor; without one (wheel encoders and a
//! gyro, as SysId logs) the nominal wheels roll without slipping, wheels and chassis
//! accelerating as the simulator's no-slip body (`NoSlipBody`, centre of mass at the
//! drive-axle midpoint, since the rig gives no offset). The tyres, and with the wheel-slip
//! block their grip limit, act through the force `F = steady_slip_force(...)` on each
//! rim, and the chassis in its own frame
//! `m (du/dt - v r) = Fx_l + Fx_r`, `m (dv/dt + u r) = Fy_l + Fy_r`,
//! `Iz dr/dt = (Fx_r - Fx_l) track / 2`. The pose `(x, y, heading)` is in the world frame.
//! The physical laws are the simulator's own (`crate::model`: armature law, gear tooth
//! contact, no-slip body, tyre slip force).
//!
//! The blocks and their keys are in `blocks`, the equations as the fit integrates them in
//! `dynamics` (how wheels, tyres and chassis move within an evaluation in `motion`), and
//! whether a record shows turning at all in `turning`.

use crate::model::chassis::ChassisParams;
use crate::model::gearbox::GearboxParams;
use crate::model::motor::MotorParams;
use crate::model::wheel::WheelParams;
use crate::model::Bounded;
use crate::record::channels as chan;
use crate::rig::blocks::Instruments;
use crate::rig::keys::alias;
use std::path::Path;

use crate::ident::data::Dataset;
use crate::ident::effects::{self, Effect};
use crate::ident::model::{Binding, GreyBox, ParamSpec, DEFAULT_BELIEF_SD_REL};
use crate::rig::{Rig, RigError};

use crate::ident::models::rotary_axis::{
    BACKLASH_FD_STEP, INDUCTANCE, RESISTANCE, ROTOR_INERTIA, TORQUE_CONSTANT, VISCOUS,
    WHEEL_SHARE_PARAM,
};

pub(crate) mod blocks;
mod dynamics;
mod motion;
mod turning;

pub use blocks::{vehicle_keys, CastorDrag, CreepTyre, VehicleBlocks, VehicleParams};
pub use turning::{Turning, NO_TURN_COMMAND_SHARE, NO_TURN_HEADING_RAD};

/// The chassis's mass.
pub const MASS: &str = ChassisParams::mass_kg.key();
/// The chassis's yaw inertia.
pub const YAW_INERTIA: &str = ChassisParams::yaw_inertia_kg_m2.key();
/// The drive wheels' radius.
pub const WHEEL_RADIUS: &str = WheelParams::radius_m.key();
/// The distance between the drive wheels.
pub const TRACK: &str = ChassisParams::track_width_m.key();
/// The share of the weight on the drive wheels.
pub const LOAD_FRACTION: &str = ChassisParams::drive_load_fraction.key();

/// Tyre slip stiffnesses per newton of load assumed when the rig does not say (the
/// simulator's hard-compound preset): they only set the small creep of a tyre below its
/// friction limit.
pub const DEFAULT_LONG_STIFFNESS_PER_N: f64 = 30.0;
/// Lateral counterpart of [`DEFAULT_LONG_STIFFNESS_PER_N`], per rad.
pub const DEFAULT_LAT_STIFFNESS_PER_N: f64 = 25.0;
/// Share of the weight on the drive wheels when the rig does not give it.
pub const DEFAULT_DRIVE_LOAD_FRACTION: f64 = 0.6;
/// Ground speed below which slip is measured against this speed instead (m/s): keeps
/// slip finite at standstill and the tyre's stiffness bounded for explicit integration.
pub const SLIP_SPEED_FLOOR_M_S: f64 = 0.2;

/// Name of the castor-drag block's nuisance parameter: the castors' distance from the
/// drive-axle midpoint, m.
pub const CASTOR_LEVER_PARAM: &str = CastorDrag::lever_m.key();

/// States per side: current, motor speed, motor angle, wheel speed, wheel angle.
const SIDE: usize = 5;
/// First chassis state: forward speed, lateral speed, yaw rate, x, y, heading.
const BODY: usize = 2 * SIDE;

/// The vehicle with any effects switched on.
#[derive(Debug, Clone)]
pub struct Vehicle {
    specs: Vec<ParamSpec>,
    /// Each parameter's key in [`vehicle_keys`].
    binding: Binding<VehicleParams>,
    /// Motor turns per wheel turn.
    pub ratio: f64,
    /// Motor speeds come from encoders (count differences over the sample interval).
    pub encoder: bool,
    /// Supply voltage the rig states, V; `None`: the rig states no supply, its voltages
    /// are what the motors get (a log of the controllers' applied voltages), and the
    /// supply's effects (a clip, a sag) have nothing to act on.
    pub supply_v: Option<f64>,
    /// Effects switched on, with the places of their parameters.
    pub effects: effects::EffectSlots,
    /// Smoothing speeds of Coulomb friction (rad/s, motor) and castor drag (m/s).
    pub coulomb_eps_rad_s: f64,
    /// Smoothing speed of castor drag, m/s.
    pub drag_eps_m_s: f64,
    /// Tracker noise (rig `[sensors]`, else 2 mm and 5 mrad): weights of the start-pose
    /// alignment.
    pub tracker_position_noise_m: f64,
    /// Heading noise of the tracker, rad.
    pub tracker_heading_noise_rad: f64,
    /// Whether the nominal model keeps the tyres' creep between wheels and floor (a
    /// tracked pose sees it) or lets the wheels roll without slip (wheel encoders and a
    /// gyro alone cannot tell creep from the wheels' own motion, and the rolling body has
    /// no stiff tyre mode to integrate). The wheel-slip block brings the tyres either way.
    pub creeping_tyres: bool,
}

impl Vehicle {
    /// The vehicle a rig describes.
    pub fn from_rig(rig: &Rig, path: &Path) -> Result<Vehicle, RigError> {
        let need = |k: &str| rig.require(k, path, "the whole-vehicle model needs it");
        let l = need(MotorParams::inductance_h.key())?;
        if l == 0.0 {
            return Err(crate::rig::zero_refused(
                path,
                MotorParams::inductance_h.key(),
                "the model integrates the armature current, so it needs the inductance; if it is negligible, give a value well below the resistance times the sample interval (e.g. 1e-5 H)",
            ));
        }
        let specs = vec![
            ParamSpec::positive(
                MotorParams::resistance_ohm.key(),
                need(MotorParams::resistance_ohm.key())?,
            ),
            ParamSpec::new(MotorParams::inductance_h.key(), l, l / 3.0, 3.0 * l)
                .believed(DEFAULT_BELIEF_SD_REL),
            ParamSpec::positive(
                MotorParams::torque_constant_nm_a.key(),
                need(MotorParams::torque_constant_nm_a.key())?,
            ),
            ParamSpec::positive(
                MotorParams::rotor_inertia_kg_m2.key(),
                need(MotorParams::rotor_inertia_kg_m2.key())?,
            ),
            // Zero: lumped into the rotor's (the two are seen only as their sum without
            // gear play).
            ParamSpec::positive(
                WheelParams::inertia_kg_m2.key(),
                need(WheelParams::inertia_kg_m2.key())?.max(1e-12),
            ),
            ParamSpec::friction(
                MotorParams::viscous_nm_s_rad.key(),
                need(MotorParams::viscous_nm_s_rad.key())?,
                crate::rig::electrical_damping(rig).unwrap_or(1.0),
            ),
            ParamSpec::positive(
                ChassisParams::mass_kg.key(),
                need(ChassisParams::mass_kg.key())?,
            ),
            ParamSpec::positive(
                ChassisParams::yaw_inertia_kg_m2.key(),
                need(ChassisParams::yaw_inertia_kg_m2.key())?,
            ),
            {
                // Measured with a ruler: a few percent is a generous bound.
                let r = need(WheelParams::radius_m.key())?;
                ParamSpec::new(WheelParams::radius_m.key(), r, 0.8 * r, 1.25 * r)
                    .believed(DEFAULT_BELIEF_SD_REL)
            },
            {
                let t = need(ChassisParams::track_width_m.key())?;
                ParamSpec::new(ChassisParams::track_width_m.key(), t, 0.8 * t, 1.25 * t)
                    .believed(DEFAULT_BELIEF_SD_REL)
            },
            ParamSpec::new(
                ChassisParams::drive_load_fraction.key(),
                rig.get(ChassisParams::drive_load_fraction.key())
                    .unwrap_or(DEFAULT_DRIVE_LOAD_FRACTION),
                0.05,
                1.0,
            ),
            ParamSpec::positive(
                CreepTyre::long_stiffness_per_n.key(),
                DEFAULT_LONG_STIFFNESS_PER_N,
            ),
            ParamSpec::positive(
                CreepTyre::lat_stiffness_per_n.key(),
                DEFAULT_LAT_STIFFNESS_PER_N,
            ),
        ];
        Ok(Vehicle {
            binding: Binding::new(vehicle_keys(), &specs),
            specs,
            ratio: rig.require(
                GearboxParams::ratio.key(),
                path,
                "the whole-vehicle model needs it",
            )?,
            encoder: rig
                .get(Instruments::motor_encoder_counts_per_rev.key())
                .is_some(),
            supply_v: rig.get(alias::SUPPLY_VOLTAGE_V.key()),
            effects: effects::EffectSlots::default(),
            coulomb_eps_rad_s: 1.0,
            drag_eps_m_s: 0.01,
            tracker_position_noise_m: rig
                .get(Instruments::tracker_position_noise_m.key())
                .unwrap_or(0.002),
            tracker_heading_noise_rad: rig
                .get(Instruments::tracker_heading_noise_rad.key())
                .unwrap_or(0.005),
            creeping_tyres: true,
        })
    }

    /// Effects that can act on the vehicle.
    /// The effects diagnosis may look for. Castor drag only where castors carry weight:
    /// a rig whose drive wheels carry all of it (`drive_load_fraction = 1`, a tank or a
    /// competition drivetrain) has no castor to drag, and on a straight run castor drag is
    /// the same constant force as Coulomb friction, which it would otherwise stand in for.
    /// The supply's effects only where the rig states a supply: voltages logged as the
    /// controllers applied them already carry its sag and its limit.
    pub fn applicable(&self) -> Vec<Effect> {
        let castors_carry_load = self.nominal_of(LOAD_FRACTION) < 1.0;
        let supplied = self.supply_v.is_some();
        [
            Effect::WheelSlip,
            Effect::Backlash,
            Effect::CastorDrag,
            Effect::CoulombFriction,
            Effect::VoltageSaturation,
            Effect::BatterySag,
            Effect::TransportDelay,
        ]
        .into_iter()
        .filter(|e| *e != Effect::CastorDrag || castors_carry_load)
        .filter(|e| supplied || !matches!(e, Effect::VoltageSaturation | Effect::BatterySag))
        .collect()
    }

    /// This model with one more effect, its parameter starting at `start` within
    /// `[lo, hi]`; `max_speed` (motor, rad/s) sets the smoothing of friction laws.
    pub fn with_effect(
        &self,
        effect: Effect,
        start: f64,
        lo: f64,
        hi: f64,
        max_speed: f64,
    ) -> Vehicle {
        let mut m = self.clone();
        let first = m.specs.len();
        let spec = effect.param(false, start, lo, hi);
        match effect {
            Effect::Backlash => {
                for s in &mut m.specs {
                    s.fd_step = s.fd_step.max(BACKLASH_FD_STEP);
                }
                m.specs
                    .push(ParamSpec::new(WHEEL_SHARE_PARAM, 0.3, 0.0, 0.95));
                m.specs.push(spec.with_fd_step(2e-3));
            }
            Effect::CastorDrag => {
                // Where the castors sit is not in the rig: their distance from the axle
                // midpoint, which sets how much they resist turning, is the block's own
                // parameter, starting at half the track.
                let t = self.nominal_of(TRACK);
                m.specs
                    .push(ParamSpec::new(CASTOR_LEVER_PARAM, 0.5 * t, 0.0, 3.0 * t));
                m.specs.push(spec);
            }
            _ => m.specs.push(spec),
        }
        m.effects.add(effect, first..m.specs.len());
        m.binding = Binding::new(vehicle_keys(), &m.specs);
        m.coulomb_eps_rad_s = (effects::COULOMB_SMOOTHING_FRACTION * max_speed).max(1e-3);
        let ground = max_speed / self.ratio * self.nominal_of(WHEEL_RADIUS);
        m.drag_eps_m_s = (effects::COULOMB_SMOOTHING_FRACTION * ground).max(1e-4);
        m
    }

    fn effect(&self, e: Effect) -> Option<usize> {
        self.effects.get(e)
    }

    /// A parameter's nominal value (one the model always has).
    fn nominal_of(&self, name: &str) -> f64 {
        self.specs
            .iter()
            .find(|s| s.name == name)
            .map_or(f64::NAN, |s| s.nominal)
    }

    /// The parameters at the values `p`, written by key into the vehicle's blocks.
    pub fn declared(&self, p: &[f64]) -> VehicleParams {
        self.binding.apply(&blocks::without_effects(), p)
    }

    /// Parameters whose key the vehicle's blocks do not have (none, unless the model is
    /// wrong; a test checks every effect).
    pub fn unbound(&self) -> Vec<&str> {
        self.binding.unbound(&self.specs)
    }

    /// Inertia at a motor shaft of its motor, gear and wheel, kg m^2.
    pub fn drivetrain_inertia_at_motor(&self, a: &VehicleParams) -> f64 {
        a.motor.rotor_inertia_kg_m2 + a.wheel.inertia_kg_m2 / (self.ratio * self.ratio)
    }

    /// Forward time constant of the vehicle on its motors, s.
    pub fn mechanical_time_constant_s(&self, a: &VehicleParams) -> f64 {
        let n2 = self.ratio * self.ratio;
        let (m, r) = (a.chassis.mass_kg, a.wheel.radius_m);
        let j = self.drivetrain_inertia_at_motor(a) + 0.5 * m * r * r / n2;
        a.motor.mechanical_time_constant_s(j)
    }

    /// Terminal voltages of the two motors from the commands and the currents, V: the
    /// bridges' limit, then both bridges' duty against one sagging battery.
    fn terminal_voltages(&self, b: &VehicleBlocks, cmd: [f64; 2], current: [f64; 2]) -> [f64; 2] {
        let mut v = cmd;
        if let Some(limit) = b.supply.drive_limit_v {
            v = v.map(|v| v.bounded(-limit, limit));
        }
        if let Some(battery) = b.supply.battery {
            // Both bridges draw on one battery.
            v = battery.bridges_output_v(v, current);
        }
        v
    }
}

impl Vehicle {
    /// Whether the rig states parameter `name`'s belief as a guess (one standard deviation
    /// of at least [`GUESS_SD_REL`] of it).
    fn belief_is_a_guess(&self, name: &str) -> bool {
        self.indices_of(&[name])
            .first()
            .and_then(|&i| self.specs[i].belief_sd_rel)
            .is_some_and(|r| r >= GUESS_SD_REL)
    }
}

/// A belief's relative standard deviation from which it is a guess, not a measurement
/// (`import wpilib` states its assumed values at 100 %).
const GUESS_SD_REL: f64 = 0.5;

impl GreyBox for Vehicle {
    fn name(&self) -> String {
        "whole vehicle (two motors, gears, tyres, chassis), voltage-driven".into()
    }

    fn params(&self) -> &[ParamSpec] {
        &self.specs
    }

    fn params_mut(&mut self) -> &mut [ParamSpec] {
        &mut self.specs
    }

    fn default_free(&self, outputs: &[String]) -> Vec<usize> {
        let has = |n: &str| outputs.iter().any(|o| o == n);
        let motor_seen = [
            chan::LEFT_MOTOR_SPEED_RAD_S,
            chan::RIGHT_MOTOR_SPEED_RAD_S,
            chan::LEFT_CURRENT_A,
            chan::RIGHT_CURRENT_A,
        ]
        .iter()
        .any(|n| has(n));
        if !motor_seen {
            // Wheel speeds and a gyro only, as SysId logs them: each side answers its
            // voltage as a first-order lag whose gain and time constant (SysId's kV and
            // kA) are all the record holds; the torque constant and the mass carry them.
            // Resistance, rotor inertia, viscous friction and wheel radius stay at the
            // rig's values: any change in them is absorbed by those two, so freeing them
            // only lets the search drift to its bounds. Turning shows the track and the
            // yaw inertia.
            let mut free = vec![TORQUE_CONSTANT, MASS];
            // An inductance the rig only assumed (a belief as loose as a guess) is freed,
            // held by that belief: the current's rise after a voltage step lags the
            // launch by L/R, a few milliseconds a 200 Hz log sees, and a wrong guess there
            // otherwise hands the lag to whichever effect shapes the launch (a play, a
            // sagging battery).
            if self.belief_is_a_guess(INDUCTANCE) {
                free.push(INDUCTANCE);
            }
            if has(chan::YAW_RATE_RAD_S) || has(chan::HEADING_RAD) {
                free.extend([YAW_INERTIA, TRACK]);
            }
            return self.indices_of(&free);
        }
        // R and K separate through the torque per volt K/R and the back-EMF damping K^2/R
        // (the viscous friction is small beside it). L is weakly seen at vehicle sample
        // rates; the wheel's inertia only in sum with the rotor's; the load fraction and
        // the tyre stiffnesses only through the small creep of a rolling tyre.
        self.indices_of(&[
            RESISTANCE,
            TORQUE_CONSTANT,
            ROTOR_INERTIA,
            VISCOUS,
            MASS,
            YAW_INERTIA,
            WHEEL_RADIUS,
            TRACK,
        ])
    }

    fn unexcited(&self, data: &Dataset) -> Vec<usize> {
        if Turning::of(data).shown() {
            Vec::new()
        } else {
            self.indices_of(&[YAW_INERTIA, TRACK])
        }
    }

    fn sysid_terms(&self, p: &[f64], speed_unit: &str) -> Option<crate::ident::sysid_law::Terms> {
        let a = self.declared(p);
        let (r, n) = (a.wheel.radius_m, self.ratio);
        let motor_rad_per_unit = match speed_unit {
            "m/s" => n / r,
            "rad/s" => 1.0,
            _ => return None,
        };
        // Each side drives half the chassis.
        let inertia =
            self.drivetrain_inertia_at_motor(&a) + 0.5 * a.chassis.mass_kg * r * r / (n * n);
        Some(
            crate::ident::sysid_law::DcDrive {
                resistance_ohm: a.motor.resistance_ohm,
                torque_constant_nm_a: a.motor.torque_constant_nm_a,
                coulomb_nm: a.motor.coulomb_nm,
                viscous_nm_s_rad: a.motor.viscous_nm_s_rad,
                inertia_kg_m2: inertia,
                motor_rad_per_unit,
            }
            .terms(),
        )
    }

    fn unexcited_outputs(&self, data: &Dataset) -> Vec<(String, String)> {
        Turning::of(data).yaw_left_out()
    }

    fn input_names(&self) -> Vec<String> {
        vec![chan::LEFT_VOLTAGE_V.into(), chan::RIGHT_VOLTAGE_V.into()]
    }

    fn output_names(&self) -> Vec<String> {
        [
            chan::X_M,
            chan::Y_M,
            chan::HEADING_RAD,
            chan::LEFT_MOTOR_SPEED_RAD_S,
            chan::RIGHT_MOTOR_SPEED_RAD_S,
            chan::LEFT_WHEEL_SPEED_M_S,
            chan::RIGHT_WHEEL_SPEED_M_S,
            chan::YAW_RATE_RAD_S,
            chan::LEFT_CURRENT_A,
            chan::RIGHT_CURRENT_A,
        ]
        .map(String::from)
        .to_vec()
    }
}

#[cfg(test)]
mod tests;
