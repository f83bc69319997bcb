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

use std::path::Path;

use crate::ident::data::Dataset;
use crate::ident::effects::{self, Effect};
use crate::ident::model::{GreyBox, OutputKind, ParamSpec};
use crate::model::chassis::NoSlipBody;
use crate::model::gearbox::GearboxParams;
use crate::model::tyre::{steady_slip_force, ContactKinematics};
use crate::model::GRAVITY_M_S2;
use crate::rig::{Rig, RigError};

use super::rotary_axis::{BACKLASH_FD_STEP, WHEEL_SHARE_PARAM};

pub const R: usize = 0;
pub const L: usize = 1;
pub const K: usize = 2;
pub const JM: usize = 3;
pub const JW: usize = 4;
pub const B: usize = 5;
pub const MASS: usize = 6;
pub const IZ: usize = 7;
pub const RW: usize = 8;
pub const TRACK: usize = 9;
pub const LOAD_FRACTION: usize = 10;
pub const LONG_STIFFNESS: usize = 11;
pub const LAT_STIFFNESS: usize = 12;

/// Tyre slip stiffnesses per newton of load assumed when the rig does not say (the
/// simulator's hard-compound preset): they only set the small creep of a tyre below its
/// friction limit.
pub const DEFAULT_LONG_STIFFNESS_PER_N: f64 = 30.0;
pub const DEFAULT_LAT_STIFFNESS_PER_N: f64 = 25.0;
/// Share of the weight on the drive wheels when the rig does not give it.
pub const DEFAULT_DRIVE_LOAD_FRACTION: f64 = 0.6;
/// Ground speed below which slip is measured against this speed instead (m/s): keeps
/// slip finite at standstill and the tyre's stiffness bounded for explicit integration.
pub const SLIP_SPEED_FLOOR_M_S: f64 = 0.2;

/// Name of the castor-drag block's nuisance parameter: the castors' distance from the
/// drive-axle midpoint, m.
pub const CASTOR_LEVER_PARAM: &str = "castor_drag.lever_m";

/// States per side: current, motor speed, motor angle, wheel speed, wheel angle.
const SIDE: usize = 5;
/// First chassis state: forward speed, lateral speed, yaw rate, x, y, heading.
const BODY: usize = 2 * SIDE;

/// The vehicle with any effects switched on.
#[derive(Debug, Clone)]
pub struct Vehicle {
    specs: Vec<ParamSpec>,
    /// Motor turns per wheel turn.
    pub ratio: f64,
    /// Motor speeds come from encoders (count differences over the sample interval).
    pub encoder: bool,
    /// Supply voltage the rig states, V.
    pub supply_v: f64,
    pub effects: effects::EffectSlots,
    /// Smoothing speeds of Coulomb friction (rad/s, motor) and castor drag (m/s).
    pub coulomb_eps_rad_s: f64,
    pub drag_eps_m_s: f64,
    /// Tracker noise (rig `[sensors]`, else 2 mm and 5 mrad): weights of the start-pose
    /// alignment.
    pub tracker_position_noise_m: f64,
    pub tracker_heading_noise_rad: f64,
    /// Whether the nominal model keeps the tyres' creep between wheels and floor (a
    /// tracked pose sees it) or lets the wheels roll without slip (wheel encoders and a
    /// gyro alone cannot tell creep from the wheels' own motion, and the rolling body has
    /// no stiff tyre mode to integrate). The wheel-slip block brings the tyres either way.
    pub creeping_tyres: bool,
}

impl Vehicle {
    pub fn from_rig(rig: &Rig, path: &Path) -> Result<Vehicle, RigError> {
        let need = |k: &str| rig.require(k, path, "the whole-vehicle model needs it");
        let l = need("motor.inductance_H")?;
        if l == 0.0 {
            return Err(crate::rig::zero_refused(
                path,
                "motor.inductance_H",
                "the model integrates the armature current, so it needs the inductance; if it is negligible, give a value well below the resistance times the sample interval (e.g. 1e-5 H)",
            ));
        }
        let specs = vec![
            ParamSpec::positive("motor.resistance_ohm", need("motor.resistance_ohm")?),
            ParamSpec::new("motor.inductance_H", l, l / 3.0, 3.0 * l),
            ParamSpec::positive(
                "motor.torque_constant_Nm_A",
                need("motor.torque_constant_Nm_A")?,
            ),
            ParamSpec::positive(
                "motor.rotor_inertia_kg_m2",
                need("motor.rotor_inertia_kg_m2")?,
            ),
            // Zero: lumped into the rotor's (the two are seen only as their sum without
            // gear play).
            ParamSpec::positive(
                "wheel.inertia_kg_m2",
                need("wheel.inertia_kg_m2")?.max(1e-12),
            ),
            ParamSpec::friction(
                "motor.viscous_Nm_s_rad",
                need("motor.viscous_Nm_s_rad")?,
                crate::rig::electrical_damping(rig).unwrap_or(1.0),
            ),
            ParamSpec::positive("chassis.mass_kg", need("chassis.mass_kg")?),
            ParamSpec::positive(
                "chassis.yaw_inertia_kg_m2",
                need("chassis.yaw_inertia_kg_m2")?,
            ),
            {
                // Measured with a ruler: a few percent is a generous bound.
                let r = need("wheel.radius_m")?;
                ParamSpec::new("wheel.radius_m", r, 0.8 * r, 1.25 * r)
            },
            {
                let t = need("chassis.track_width_m")?;
                ParamSpec::new("chassis.track_width_m", t, 0.8 * t, 1.25 * t)
            },
            ParamSpec::new(
                "chassis.drive_load_fraction",
                rig.get("chassis.drive_load_fraction")
                    .unwrap_or(DEFAULT_DRIVE_LOAD_FRACTION),
                0.05,
                1.0,
            ),
            ParamSpec::positive(
                "tyre.longitudinal_stiffness_per_N",
                DEFAULT_LONG_STIFFNESS_PER_N,
            ),
            ParamSpec::positive("tyre.lateral_stiffness_per_N", DEFAULT_LAT_STIFFNESS_PER_N),
        ];
        Ok(Vehicle {
            specs,
            ratio: rig.require("gearbox.ratio", path, "the whole-vehicle model needs it")?,
            encoder: rig.get("sensors.motor_encoder_counts_per_rev").is_some(),
            supply_v: rig.get("supply.voltage_V").unwrap_or(24.0),
            effects: effects::EffectSlots::default(),
            coulomb_eps_rad_s: 1.0,
            drag_eps_m_s: 0.01,
            tracker_position_noise_m: rig.get("sensors.tracker_position_noise_m").unwrap_or(0.002),
            tracker_heading_noise_rad: rig
                .get("sensors.tracker_heading_noise_rad")
                .unwrap_or(0.005),
            creeping_tyres: true,
        })
    }

    /// Effects that can act on the vehicle.
    /// The effects diagnosis may look for. Castor drag only where castors carry weight:
    /// a rig whose drive wheels carry all of it (`drive_load_fraction = 1`, a tank or a
    /// competition drivetrain) has no castor to drag, and on a straight run castor drag is
    /// the same constant force as Coulomb friction, which it would otherwise stand in for.
    pub fn applicable(&self) -> Vec<Effect> {
        let castors_carry_load = self.specs[LOAD_FRACTION].nominal < 1.0;
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
        let spec = ParamSpec::new(effect.param_name(false), start, lo, hi);
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
                let t = self.specs[TRACK].nominal;
                m.specs
                    .push(ParamSpec::new(CASTOR_LEVER_PARAM, 0.5 * t, 0.0, 3.0 * t));
                m.specs.push(spec);
            }
            _ => m.specs.push(spec),
        }
        m.effects.add(effect, m.specs.len() - 1);
        m.coulomb_eps_rad_s = (effects::COULOMB_SMOOTHING_FRACTION * max_speed).max(1e-3);
        let ground = max_speed / self.ratio * self.specs[RW].nominal;
        m.drag_eps_m_s = (effects::COULOMB_SMOOTHING_FRACTION * ground).max(1e-4);
        m
    }

    fn effect(&self, e: Effect) -> Option<usize> {
        self.effects.get(e)
    }

    /// Longest integration step, s, with the tyres' slip measured against a contact speed
    /// of `slip_denominator_m_s` (at least the floor of a tyre at rest).
    fn step_bound(&self, p: &[f64], slip_denominator_m_s: f64) -> f64 {
        let n2 = self.ratio * self.ratio;
        let mut h = p[L] / p[R];
        if let Some(play) = self.effect(Effect::Backlash) {
            let rate = self.gearbox(p, play).mesh_rate(p[JM] * n2, p[JW]);
            h = h.min(0.3 / rate);
        }
        if self.effect(Effect::WheelSlip).is_none() && !self.creeping_tyres {
            // Rolling without slip: no tyre between wheel and floor to resolve.
            return h;
        }
        let load = self.drive_wheel_load_n(p);
        // The tyre's slip force is a stiff damper on the rim speed: explicit RK4 needs
        // h lambda below 2.8; at 2 the fast mode still decays monotonically enough, as it
        // does physically, while the slow dynamics are integrated accurately.
        let rim_damping = load * p[LONG_STIFFNESS] / slip_denominator_m_s;
        let wheel_j = if self.effect(Effect::Backlash).is_some() {
            p[JW]
        } else {
            p[JW] + p[JM] * n2
        };
        let lambda_long = rim_damping * p[RW] * p[RW] / wheel_j;
        let lambda_lat = 2.0 * load * p[LAT_STIFFNESS] / slip_denominator_m_s / p[MASS];
        h.min(2.0 / lambda_long.max(lambda_lat))
    }

    /// The gear train of the backlash block (play at index `play`).
    fn gearbox(&self, p: &[f64], play: usize) -> GearboxParams {
        super::rotary_axis::play_gearbox(self.ratio, p[play])
    }

    /// Normal load on each drive wheel, N.
    pub fn drive_wheel_load_n(&self, p: &[f64]) -> f64 {
        p[LOAD_FRACTION] * p[MASS] * GRAVITY_M_S2 / 2.0
    }

    /// Inertia at a motor shaft of its motor, gear and wheel, kg m^2.
    pub fn drivetrain_inertia_at_motor(&self, p: &[f64]) -> f64 {
        p[JM] + p[JW] / (self.ratio * self.ratio)
    }

    /// Forward time constant of the vehicle on its motors, s.
    pub fn mechanical_time_constant_s(&self, p: &[f64]) -> f64 {
        let n2 = self.ratio * self.ratio;
        let j = self.drivetrain_inertia_at_motor(p) + 0.5 * p[MASS] * p[RW] * p[RW] / n2;
        j / (p[B] + p[K] * p[K] / p[R])
    }

    /// Terminal voltages of the two motors from the commands and the currents, V.
    fn terminal_voltages(&self, p: &[f64], cmd: [f64; 2], current: [f64; 2]) -> [f64; 2] {
        let mut v = cmd;
        if let Some(i) = self.effect(Effect::VoltageSaturation) {
            v = v.map(|v| v.clamp(-p[i], p[i]));
        }
        if let Some(i) = self.effect(Effect::BatterySag) {
            // Both bridges draw on one battery: duty d = V / V_rated, bus current sum d i.
            let d = v.map(|v| (v / self.supply_v).clamp(-1.0, 1.0));
            let bus = self.supply_v - p[i] * (d[0] * current[0] + d[1] * current[1]);
            v = [d[0] * bus, d[1] * bus];
        }
        v
    }
}

impl Vehicle {
    /// Torque the gear train delivers to each wheel's axle (N m) and the inertia turning
    /// with the wheel there (kg m^2), writing the motor side's speed rate when a gear play
    /// separates motor and wheel. Rigid gears: the motor's torque less its viscous
    /// friction, times the ratio, with the rotor's inertia times the ratio squared.
    fn wheel_side(&self, p: &[f64], x: &[f64], drive: [f64; 2], dx: &mut [f64]) -> ([f64; 2], f64) {
        let n = self.ratio;
        let mut torque = [0.0; 2];
        let inertia = match self.effect(Effect::Backlash) {
            None => {
                for side in 0..2 {
                    let wm = x[side * SIDE + 1];
                    torque[side] = n * (drive[side] - p[B] * wm);
                }
                p[JW] + p[JM] * n * n
            }
            Some(play) => {
                let g = self.gearbox(p, play);
                let share = p[play - 1];
                let (b_motor, b_wheel) = (p[B] * (1.0 - share), p[B] * share * n * n);
                for side in 0..2 {
                    let s = side * SIDE;
                    let (wm, wm_angle, ww) = (x[s + 1], x[s + 2], x[s + 3]);
                    let tooth = g.tooth_contact_torque(wm_angle / n - x[s + 4], wm / n - ww);
                    dx[s + 1] = (drive[side] - b_motor * wm - tooth / n) / p[JM];
                    torque[side] = tooth - b_wheel * ww;
                }
                p[JW]
            }
        };
        (torque, inertia)
    }

    /// Wheels that roll without slipping: the chassis and everything turning with the
    /// wheels accelerate together (the simulator's no-slip body, centre of mass at the
    /// axle), the wheel speeds following the chassis's motion.
    fn rolling(&self, p: &[f64], x: &[f64], drive: [f64; 2], dx: &mut [f64]) {
        let (torque, wheel_inertia) = self.wheel_side(p, x, drive, dx);
        let body = NoSlipBody {
            mass_kg: p[MASS],
            yaw_inertia_kg_m2: p[IZ],
            cg_ahead_m: 0.0,
            track_width_m: p[TRACK],
            wheel_radius_m: p[RW],
            wheel_inertia_kg_m2: wheel_inertia,
        };
        let (fwd, yaw_rate) = (x[BODY], x[BODY + 2]);
        let drag = self.castor_drag(p, fwd, 0.0, yaw_rate);
        let [acc, yaw_acc] = body.accelerations(fwd, yaw_rate, torque, [drag[0], drag[2]]);
        let rim_acc = body.rim_speeds_m_s(acc, yaw_acc);
        for (side, rim_acc) in rim_acc.iter().enumerate() {
            let s = side * SIDE;
            let wheel_acc = rim_acc / p[RW];
            if self.effect(Effect::Backlash).is_some() {
                dx[s + 3] = wheel_acc;
                dx[s + 4] = x[s + 3];
            } else {
                dx[s + 1] = self.ratio * wheel_acc;
                dx[s + 3] = 0.0;
                dx[s + 4] = x[s + 1] / self.ratio;
            }
        }
        dx[BODY] = acc;
        dx[BODY + 1] = 0.0;
        dx[BODY + 2] = yaw_acc;
    }

    /// Wheels and chassis joined by the tyres' slip forces: their creep, and with the
    /// wheel-slip block their grip limited by the friction coefficient `mu`.
    fn slipping(&self, p: &[f64], x: &[f64], drive: [f64; 2], mu: Option<f64>, dx: &mut [f64]) {
        let (fwd, lat, yaw_rate) = (x[BODY], x[BODY + 1], x[BODY + 2]);
        let load = self.drive_wheel_load_n(p);
        let (torque, wheel_inertia) = self.wheel_side(p, x, drive, dx);
        let backlash = self.effect(Effect::Backlash).is_some();
        let mut force = [[0.0; 2]; 2];
        for side in 0..2 {
            let s = side * SIDE;
            let ww = if backlash {
                x[s + 3]
            } else {
                x[s + 1] / self.ratio
            };
            // Left wheel at +track/2 in the chassis frame (y to the left).
            let offset = if side == 0 { -0.5 } else { 0.5 } * p[TRACK];
            let kin = ContactKinematics {
                forward_m_s: fwd + yaw_rate * offset,
                lateral_m_s: lat,
                rim_m_s: ww * p[RW],
            };
            let f = steady_slip_force(
                kin,
                load,
                [p[LONG_STIFFNESS], p[LAT_STIFFNESS]],
                SLIP_SPEED_FLOOR_M_S,
                mu,
            );
            // The ground pushes the chassis forward by f[0] and resists the wheel by f[0] R.
            let wheel_acc = (torque[side] - f[0] * p[RW]) / wheel_inertia;
            if backlash {
                dx[s + 3] = wheel_acc;
                dx[s + 4] = ww;
            } else {
                dx[s + 1] = self.ratio * wheel_acc;
                dx[s + 3] = 0.0;
                dx[s + 4] = ww;
            }
            force[side] = f;
        }
        let drag = self.castor_drag(p, fwd, lat, yaw_rate);
        let fx = force[0][0] + force[1][0] + drag[0];
        let fy = force[0][1] + force[1][1] + drag[1];
        let yaw_torque = (force[1][0] - force[0][0]) * 0.5 * p[TRACK] + drag[2];
        dx[BODY] = fx / p[MASS] + lat * yaw_rate;
        dx[BODY + 1] = fy / p[MASS] - fwd * yaw_rate;
        dx[BODY + 2] = yaw_torque / p[IZ];
    }

    /// The castor-drag block's forward and lateral force (N) and yaw moment (N m) on the
    /// chassis; zero without the block. The idlers' rolling drag is lumped at a distance
    /// `lever` from the axle midpoint: it opposes their contact's motion over the floor,
    /// which is the chassis's motion plus the turn's sweep, so it resists turning as well.
    fn castor_drag(&self, p: &[f64], fwd: f64, lat: f64, yaw_rate: f64) -> [f64; 3] {
        let Some(d) = self.effect(Effect::CastorDrag) else {
            return [0.0; 3];
        };
        let lever = p[d - 1];
        let sweep = yaw_rate * lever;
        let eps = self.drag_eps_m_s;
        let speed = (fwd * fwd + lat * lat + sweep * sweep + eps * eps).sqrt();
        [
            -p[d] * fwd / speed,
            -p[d] * lat / speed,
            -p[d] * lever * sweep / speed,
        ]
    }
}

impl GreyBox for Vehicle {
    fn name(&self) -> String {
        "whole vehicle (two motors, gears, tyres, chassis), voltage-driven".into()
    }

    fn params(&self) -> &[ParamSpec] {
        &self.specs
    }

    fn default_free(&self, outputs: &[String]) -> Vec<usize> {
        let has = |n: &str| outputs.iter().any(|o| o == n);
        let motor_seen = [
            "left_motor_speed_rad_s",
            "right_motor_speed_rad_s",
            "left_current_A",
            "right_current_A",
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
            let mut free = vec![K, MASS];
            if has("yaw_rate_rad_s") || has("heading_rad") {
                free.extend([IZ, TRACK]);
            }
            return free;
        }
        // R and K separate through the torque per volt K/R and the back-EMF damping K^2/R
        // (the viscous friction is small beside it). L is weakly seen at vehicle sample
        // rates; the wheel's inertia only in sum with the rotor's; the load fraction and
        // the tyre stiffnesses only through the small creep of a rolling tyre.
        vec![R, K, JM, B, MASS, IZ, RW, TRACK]
    }

    fn unexcited(&self, data: &Dataset) -> Vec<usize> {
        // The same voltage on both sides throughout: the model never turns.
        if data.inputs[0] == data.inputs[1] {
            vec![IZ, TRACK]
        } else {
            Vec::new()
        }
    }

    fn input_names(&self) -> Vec<String> {
        vec!["left_voltage_V".into(), "right_voltage_V".into()]
    }

    fn output_names(&self) -> Vec<String> {
        [
            "x_m",
            "y_m",
            "heading_rad",
            "left_motor_speed_rad_s",
            "right_motor_speed_rad_s",
            "left_wheel_speed_m_s",
            "right_wheel_speed_m_s",
            "yaw_rate_rad_s",
            "left_current_A",
            "right_current_A",
        ]
        .map(String::from)
        .to_vec()
    }

    fn n_states(&self) -> usize {
        BODY + 6
    }

    fn initial_state(&self, _p: &[f64], data: &Dataset) -> Vec<f64> {
        // At rest; the pose where the tracker first saw the vehicle.
        let mut x = vec![0.0; self.n_states()];
        x[BODY + 3] = data.first_measured("x_m").unwrap_or(0.0);
        x[BODY + 4] = data.first_measured("y_m").unwrap_or(0.0);
        x[BODY + 5] = data.first_measured("heading_rad").unwrap_or(0.0);
        x
    }

    fn max_step_s(&self, p: &[f64]) -> f64 {
        self.step_bound(p, SLIP_SPEED_FLOOR_M_S)
    }

    /// The tyre's stiffness falls as the contact speed rises (slip is measured against
    /// it), so a moving vehicle allows longer steps than one at rest. The slowest contact
    /// at the interval's start is taken at half its speed: no record's sample interval is
    /// long enough for a vehicle to lose half its speed within it.
    fn max_step_at(&self, p: &[f64], x: &[f64]) -> f64 {
        let (fwd, yaw_rate) = (x[BODY], x[BODY + 2]);
        let sweep = (yaw_rate * 0.5 * p[TRACK]).abs();
        let slowest = (fwd.abs() - sweep).abs();
        self.step_bound(p, (0.5 * slowest).hypot(SLIP_SPEED_FLOOR_M_S))
    }

    fn input_delay_s(&self, p: &[f64]) -> f64 {
        self.effect(Effect::TransportDelay).map_or(0.0, |i| p[i])
    }

    /// The order of one evaluation: terminal voltages (saturation, sag), each side's
    /// armature and motor torque (Coulomb friction), then the wheels and the chassis,
    /// rolling without slip (the simulator's no-slip body) unless the wheel-slip block puts
    /// the tyres' slip forces between them, then the pose.
    fn derivatives(&self, p: &[f64], x: &[f64], u: &[f64], _held: &[f64], dx: &mut [f64]) {
        let v = self.terminal_voltages(p, [u[0], u[1]], [x[0], x[SIDE]]);
        let mut drive = [0.0; 2];
        for (side, drive) in drive.iter_mut().enumerate() {
            let s = side * SIDE;
            let (i, wm) = (x[s], x[s + 1]);
            dx[s] = crate::model::motor::armature_current_rate(p[R], p[L], p[K], v[side], i, wm);
            *drive = p[K] * i;
            if let Some(c) = self.effect(Effect::CoulombFriction) {
                *drive -= effects::smooth_coulomb(p[c], wm, self.coulomb_eps_rad_s);
            }
            dx[s + 2] = wm;
        }
        match self.effect(Effect::WheelSlip) {
            Some(mu) => self.slipping(p, x, drive, Some(p[mu]), dx),
            None if self.creeping_tyres => self.slipping(p, x, drive, None, dx),
            None => self.rolling(p, x, drive, dx),
        }
        let (fwd, lat, heading) = (x[BODY], x[BODY + 1], x[BODY + 5]);
        let (sin, cos) = heading.sin_cos();
        dx[BODY + 3] = fwd * cos - lat * sin;
        dx[BODY + 4] = fwd * sin + lat * cos;
        dx[BODY + 5] = x[BODY + 2];
    }

    /// The vehicle starts where the tracker first saw it, but that reading is as noisy as
    /// any other: a start heading 5 mrad off swings the whole path by 5 mrad, 10 mm at 2 m.
    /// The start pose is therefore fitted, in closed form, to each simulation: the small
    /// rigid motion (rotation about the start point, then shift) that best aligns the
    /// simulated pose with the tracked one, positions and heading weighted by the tracker's
    /// noise. This is the least-squares optimum over three nuisance parameters, at no cost
    /// in simulations.
    fn align_outputs(&self, data: &Dataset, y: &mut [Vec<f64>]) {
        let (Some(jx), Some(jy)) = (data.output_index("x_m"), data.output_index("y_m")) else {
            return;
        };
        let jh = data.output_index("heading_rad");
        let (wp, wh) = (
            1.0 / (self.tracker_position_noise_m * self.tracker_position_noise_m),
            1.0 / (self.tracker_heading_noise_rad * self.tracker_heading_noise_rad),
        );
        let (xs, ys) = (y[jx][0], y[jy][0]);
        // Linearised in the rotation a: x' = x - a (y - ys) + dx, y' = y + a (x - xs) + dy,
        // heading' = heading + a. Normal equations for (a, dx, dy).
        let mut n = nalgebra::Matrix3::<f64>::zeros();
        let mut b = nalgebra::Vector3::<f64>::zeros();
        for k in 0..data.len() {
            if let (Some(mx), Some(my)) = (data.outputs[jx][k], data.outputs[jy][k]) {
                let (rx, ry) = (-(y[jy][k] - ys), y[jx][k] - xs);
                for (row, resid) in [
                    (nalgebra::Vector3::new(rx, 1.0, 0.0), mx - y[jx][k]),
                    (nalgebra::Vector3::new(ry, 0.0, 1.0), my - y[jy][k]),
                ] {
                    n += wp * row * row.transpose();
                    b += wp * row * resid;
                }
            }
            if let Some(jh) = jh {
                if let Some(mh) = data.outputs[jh][k] {
                    let row = nalgebra::Vector3::new(1.0, 0.0, 0.0);
                    n += wh * row * row.transpose();
                    b += wh * row * (mh - y[jh][k]);
                }
            }
        }
        let Some(sol) = n.lu().solve(&b) else {
            return;
        };
        let (a, dx, dy) = (sol[0], sol[1], sol[2]);
        if !(a.is_finite() && dx.is_finite() && dy.is_finite()) {
            return;
        }
        let (sin, cos) = a.sin_cos();
        for k in 0..data.len() {
            let (px, py) = (y[jx][k] - xs, y[jy][k] - ys);
            y[jx][k] = xs + cos * px - sin * py + dx;
            y[jy][k] = ys + sin * px + cos * py + dy;
            if let Some(jh) = jh {
                y[jh][k] += a;
            }
        }
    }

    fn output_kind(&self, name: &str) -> OutputKind {
        match name {
            "left_motor_speed_rad_s" if self.encoder => OutputKind::IntervalRate(2),
            "right_motor_speed_rad_s" if self.encoder => OutputKind::IntervalRate(SIDE + 2),
            _ => OutputKind::Instant,
        }
    }

    fn output(&self, p: &[f64], name: &str, x: &[f64], _u: &[f64], _held: &[f64]) -> f64 {
        let wheel = |s: usize| {
            if self.effect(Effect::Backlash).is_some() {
                x[s + 3]
            } else {
                x[s + 1] / self.ratio
            }
        };
        match name {
            "x_m" => x[BODY + 3],
            "y_m" => x[BODY + 4],
            "heading_rad" => x[BODY + 5],
            "left_motor_speed_rad_s" => x[1],
            "right_motor_speed_rad_s" => x[SIDE + 1],
            "left_wheel_speed_m_s" => wheel(0) * p[RW],
            "right_wheel_speed_m_s" => wheel(SIDE) * p[RW],
            "yaw_rate_rad_s" => x[BODY + 2],
            "left_current_A" => x[0],
            "right_current_A" => x[SIDE],
            _ => f64::NAN,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ident::model::simulate;

    fn rig() -> Rig {
        Rig::parse(
            r#"rig = "vehicle"
[motor]
resistance_ohm = 0.35
inductance_H = 0.0008
torque_constant_Nm_A = 0.063
rotor_inertia_kg_m2 = 2.0e-4
viscous_Nm_s_rad = 1.0e-4
[gearbox]
ratio = 23.41
[wheel]
radius_m = 0.075
inertia_kg_m2 = 0.02
[chassis]
mass_kg = 120.0
yaw_inertia_kg_m2 = 14.0
track_width_m = 0.5
drive_load_fraction = 0.6
"#,
            Path::new("test.rig.toml"),
        )
        .unwrap()
    }

    /// Constant voltages for `duration` s, sampled every 10 ms.
    fn run(model: &Vehicle, p: &[f64], v: [f64; 2], duration: f64) -> (Dataset, Vec<Vec<f64>>) {
        let n = (duration / 0.01) as usize + 1;
        let outputs = [
            "x_m",
            "y_m",
            "heading_rad",
            "left_motor_speed_rad_s",
            "right_motor_speed_rad_s",
        ];
        let data = Dataset {
            name: "test".into(),
            t_s: (0..n).map(|k| k as f64 * 0.01).collect(),
            input_names: model.input_names(),
            inputs: vec![vec![v[0]; n], vec![v[1]; n]],
            output_names: outputs.map(String::from).to_vec(),
            outputs: vec![vec![Some(0.0); n]; outputs.len()],
            segment_starts: vec![0],
        };
        let y = simulate(model, p, &data).unwrap();
        (data, y)
    }

    /// Castor drag is a candidate only while castors carry part of the weight.
    #[test]
    fn castor_drag_is_looked_for_only_where_castors_carry_weight() {
        let path = Path::new("r.rig.toml");
        let with_castors = Vehicle::from_rig(&rig(), path).unwrap();
        assert!(with_castors.applicable().contains(&Effect::CastorDrag));
        let mut all_on_drive = rig();
        all_on_drive.chassis.as_mut().unwrap().drive_load_fraction = Some(1.0);
        let tank = Vehicle::from_rig(&all_on_drive, path).unwrap();
        assert!(!tank.applicable().contains(&Effect::CastorDrag));
        assert!(tank.applicable().contains(&Effect::CoulombFriction));
    }

    /// Straight run at constant voltage: with no force needed at constant speed, the motor
    /// settles at K V / (K^2 + R b), the tyres stop creeping, and the vehicle moves at the
    /// rim speed, straight along x.
    #[test]
    fn straight_run_settles_at_the_motor_law_and_rolls_without_creep() {
        let m = Vehicle::from_rig(&rig(), Path::new("test.rig.toml")).unwrap();
        let p = m.nominal();
        let (_, y) = run(&m, &p, [12.0, 12.0], 6.0);
        let w = 0.063 * 12.0 / (0.063 * 0.063 + 0.35 * 1.0e-4);
        let last = y[3].len() - 1;
        assert!((y[3][last] - w).abs() < 1e-3 * w, "{} vs {w}", y[3][last]);
        let ground = w / 23.41 * 0.075;
        let speed = (y[0][last] - y[0][last - 100]) / 1.0;
        assert!(
            (speed - ground).abs() < 1e-3 * ground,
            "{speed} vs {ground}"
        );
        assert!(y[1][last].abs() < 1e-9 && y[2][last].abs() < 1e-9);
    }

    /// Opposite voltages spin the vehicle on the spot at 2 r w / (N track).
    #[test]
    fn opposite_voltages_turn_on_the_spot() {
        let m = Vehicle::from_rig(&rig(), Path::new("test.rig.toml")).unwrap();
        let p = m.nominal();
        let (_, y) = run(&m, &p, [-6.0, 6.0], 4.0);
        let last = y[2].len() - 1;
        let w = y[4][last];
        let yaw_rate = (y[2][last] - y[2][last - 100]) / 1.0;
        let expected = 2.0 * w / 23.41 * 0.075 / 0.5;
        assert!(
            (yaw_rate - expected).abs() < 1e-3 * expected,
            "{yaw_rate} vs {expected}"
        );
        assert!(y[0][last].abs() < 1e-6 && y[1][last].abs() < 1e-6);
    }

    /// With the wheel-slip block, the floor limits traction: a full-voltage start cannot
    /// accelerate the vehicle faster than mu times the drive wheels' share of g (and, the
    /// wheels spinning, keeps at least the law's sliding share of it), while without the
    /// block the same start accelerates far harder.
    #[test]
    fn friction_limit_caps_the_acceleration() {
        let nominal = Vehicle::from_rig(&rig(), Path::new("test.rig.toml")).unwrap();
        let slip = nominal.with_effect(Effect::WheelSlip, 0.1, 0.05, 4.0, 300.0);
        let mut p = nominal.nominal();
        p.push(0.1);
        let cap = 0.1 * 0.6 * GRAVITY_M_S2;
        let peak_accel = |y: &[Vec<f64>]| {
            let v: Vec<f64> = y[0].windows(2).map(|w| (w[1] - w[0]) / 0.01).collect();
            v.windows(2)
                .map(|w| (w[1] - w[0]) / 0.01)
                .fold(0.0, f64::max)
        };
        let (_, y) = run(&slip, &p, [24.0, 24.0], 1.0);
        let a = peak_accel(&y);
        // A spinning wheel keeps sin(c pi / 2) of the peak grip (the law's full-slide end).
        let sliding = (crate::model::tyre::SATURATION_SHAPE * std::f64::consts::FRAC_PI_2).sin();
        assert!(
            a <= cap * 1.01 && a > 0.99 * sliding * cap,
            "{a} vs cap {cap}"
        );
        let (_, y) = run(&nominal, &nominal.nominal(), [24.0, 24.0], 1.0);
        assert!(peak_accel(&y) > 2.0 * cap);
    }

    /// The nominal wheels roll without slipping (the simulator's no-slip body); the
    /// wheel-slip block's tyres, with grip to spare, only creep: slip F / (C N), which for a
    /// tyre pulling half its load at the default stiffness C = 30 is 1.7 %. On a turning
    /// start the two agree on motor speeds and pose within 2 % of each output's range.
    #[test]
    fn rolling_and_gripping_tyres_agree_where_nothing_slides() {
        let mut rolling = Vehicle::from_rig(&rig(), Path::new("test.rig.toml")).unwrap();
        rolling.creeping_tyres = false;
        let gripping = rolling.with_effect(Effect::WheelSlip, 4.0, 0.05, 4.0, 300.0);
        let p = rolling.nominal();
        let mut pg = p.clone();
        pg.push(4.0);
        let (_, a) = run(&rolling, &p, [6.0, 9.0], 4.0);
        let (_, b) = run(&gripping, &pg, [6.0, 9.0], 4.0);
        for j in 0..a.len() {
            let range = a[j].iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let worst = a[j]
                .iter()
                .zip(&b[j])
                .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
            assert!(worst < 0.02 * range, "output {j}: {worst} of {range}");
        }
    }

    /// A record joined from two tests is simulated test by test, each from rest: the same
    /// as simulating each alone (to rounding: the second test's times are shifted).
    #[test]
    fn joined_tests_are_simulated_each_from_rest() {
        let m = Vehicle::from_rig(&rig(), Path::new("test.rig.toml")).unwrap();
        let p = m.nominal();
        let (da, ya) = run(&m, &p, [6.0, 6.0], 1.0);
        let (db, yb) = run(&m, &p, [-3.0, 4.0], 1.0);
        let mut joined = da.clone();
        let shift = da.t_s[da.len() - 1] + 0.01;
        joined.t_s.extend(db.t_s.iter().map(|t| t + shift));
        for (u, v) in joined.inputs.iter_mut().zip(&db.inputs) {
            u.extend(v);
        }
        for (y, v) in joined.outputs.iter_mut().zip(&db.outputs) {
            y.extend(v);
        }
        joined.segment_starts = vec![0, da.len()];
        let y = simulate(&m, &p, &joined).unwrap();
        for j in 0..y.len() {
            let expected: Vec<f64> = ya[j].iter().chain(&yb[j]).copied().collect();
            let scale = expected.iter().fold(1e-12f64, |m, v| m.max(v.abs()));
            for (k, (a, b)) in y[j].iter().zip(&expected).enumerate() {
                assert!(
                    (a - b).abs() <= 1e-9 * scale,
                    "output {j} row {k}: {a} vs {b}"
                );
            }
        }
    }
}
