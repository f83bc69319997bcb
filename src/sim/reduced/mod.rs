//! The velocity-commanded base reduced to what its recordings show: the machine a fit of
//! a ROS robot's log evaluates hundreds of times. The same laws as [`super::Sim`]'s, in the
//! same order (command dead time, the base controller's limits, the drivers' PI loops
//! against the battery's available voltage, the armature, gear, wheels and the bristle
//! tyres, the chassis), with what costs the full simulator its time left out:
//!
//! - **no rapier**: the chassis is one planar rigid body, integrated here ([`body`]);
//! - **rigid gears** ([`drive`]): motor and wheel turn as one (`J = J_wheel + n^2 J_rotor`
//!   at the axle), so the tooth mesh's stiffness needs no sub-steps; with a play, the
//!   flanks rigid too, meeting without rebound (the simulator's tooth is a stiff spring
//!   with little damping: the ringing after each engagement is left out, the lost motion
//!   kept);
//! - **castors as trailing wheels** ([`castor`]): each held by its swivel friction until
//!   its tyre's bristles carry it, then turning to trail its swivel's motion, and dragging
//!   with its rolling resistance; no castor bodies;
//! - **a longer step**: as many of the simulator's steps as keep it within a third of the
//!   drivers' speed loop's time constant (at most four), sub-stepped where the tyres are
//!   stiff against the wheels or the chassis;
//! - no guide wire, coils, firmware or DCMC: a velocity command drives the base alone.
//!
//! `tests/one_physics.rs` holds it to the simulator on the same scenes and commands.

mod body;
mod castor;
mod drive;

use super::command_delay::CommandDelay;
use super::{Actuation, SideSnapshot, SimError, SimParams, Snapshot};
use crate::model::base_controller::{BaseInput, BaseState};
use crate::model::chassis::Pose;
use crate::model::drivetrain::DrivetrainState;
use crate::model::tyre::{Bristles, TyreParams, TyreState};
use crate::scene::Scene;
use castor::{CastorLaw, CastorState};

/// Largest share of the drivers' speed-loop time constant one step of the reduced base
/// spans: the loop acts on the speed at the step's start, so a step much shorter than the
/// loop's answer keeps that answer as the simulator's, at its 1 ms steps, has it.
const STEP_SHARE_OF_LOOP: f64 = 0.35;

/// Most simulator steps one step of the reduced base spans.
const MAX_STEP_MULTIPLE: usize = 4;

/// Largest product of a sub-step and the fastest rate of the tyres against the chassis
/// (their bristles' frequency plus their damping rate; against the wheels they act
/// implicitly and set no bound).
const SUBSTEP_RATE: f64 = 0.5;

/// How the reduced base cuts time: simulator steps per step of its own and sub-steps per
/// step. Both are whole numbers, chosen from the scene's masses, loop gains and tyres
/// ([`Stepping::of`]); a fit holds them from its start ([`ReducedBase::held`]), since a
/// whole number that changes as a key moves makes the replay jump (a base of 40 kg stepped
/// at 2 ms and one of 39 kg at 1 ms differ by a tenth of an encoder's noise), and a fit
/// reads such a jump as the key determined to a few grams.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Stepping {
    /// Simulator steps (`sim.dt_s`) one step of the reduced base spans.
    pub step_multiple: usize,
    /// Sub-steps of drivetrains and chassis per step.
    pub substeps: usize,
}

impl Stepping {
    /// The stepping a scene's own keys ask for ([`step_multiple`], [`substeps`]).
    pub fn of(scene: &Scene) -> Result<Stepping, ReducedError> {
        let p = SimParams::from_scene(scene)?;
        Ok(Stepping::of_params(&p))
    }

    fn of_params(p: &SimParams) -> Stepping {
        let step_multiple = step_multiple(p);
        let dt = p.sim.dt_s * step_multiple as f64;
        Stepping {
            step_multiple,
            substeps: substeps(p, &p.drive_tyre(p.floor.default), dt),
        }
    }

    /// This stepping held for keys that ask for `own`: kept, unless the keys have moved
    /// so far that it would step more than twice as coarsely as they ask for (a loop
    /// twice as fast, tyres twice as stiff against the chassis), where the integration's
    /// stability, not its smoothness in the keys, decides.
    fn held_for(self, own: Stepping, p: &SimParams) -> Stepping {
        let step_multiple = self.step_multiple.min(2 * own.step_multiple);
        let dt = p.sim.dt_s * step_multiple as f64;
        let needed = substeps(p, &p.drive_tyre(p.floor.default), dt);
        Stepping {
            step_multiple,
            substeps: self.substeps.max(needed.div_ceil(2)),
        }
    }
}

/// Why the reduced base cannot stand in for a scene.
#[derive(Debug, thiserror::Error)]
pub enum ReducedError {
    /// The scene's machine is not a base on the floor.
    #[error("the reduced base needs a vehicle on the floor: {0}")]
    NotABase(&'static str),
    /// The scene has physics the reduced base does not model.
    #[error("the reduced base does not model {0}")]
    Unmodelled(&'static str),
    /// The scene does not set up.
    #[error(transparent)]
    Setup(#[from] SimError),
}

/// The chassis as a planar body: pose, the axle midpoint's velocity in the body frame and
/// the yaw rate.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct BodyState {
    pose: Pose,
    /// Forward and leftward speed of the axle midpoint, m/s.
    velocity_m_s: [f64; 2],
    /// Yaw rate, rad/s.
    yaw_rate_rad_s: f64,
}

/// What the reduced base works out once from the scene.
#[derive(Debug, Clone)]
struct Fixed {
    /// The reduced base's step, s: a whole number of the simulator's (`sim.dt_s`).
    dt_s: f64,
    /// Sub-steps of drivetrains and chassis per step.
    substeps: usize,
    /// Inertia turning with each wheel and its motor as one, kg m^2 at the axle: the
    /// wheel's and the rotor's through the ratio squared.
    geared_kg_m2: f64,
    /// Whether a gear play separates motor and wheel.
    play: bool,
    /// The chassis's mass with its castors' forks and wheels (which the simulator's castor
    /// bodies carry along), kg, and its yaw inertia about its centre of gravity with them
    /// at their swivels, kg m^2.
    mass_kg: f64,
    yaw_inertia_kg_m2: f64,
    /// The drive tyres on the floor, and their bristles at each drive wheel's load.
    tyre: TyreParams,
    bristles: [Bristles; 2],
    /// The armature's decay over one sub-step, `exp(-h R / L)`.
    armature_decay: f64,
    /// Castor swivels (body frame, m) and each castor's law.
    castor_points_m: [[f64; 2]; 4],
    castors: [CastorLaw; 4],
}

/// The reduced velocity-commanded base, at rest at its start pose.
pub struct ReducedBase {
    params: SimParams,
    fixed: Fixed,
    actuation: Actuation,
    delay: Option<CommandDelay>,
    t_s: f64,
    steps: u64,
    base: BaseState,
    drive: [DrivetrainState; 2],
    tyres: [TyreState; 2],
    body: BodyState,
    /// The chassis's heading as its cosine and sine, turned on each sub-step with it.
    heading_dir: [f64; 2],
    /// Each castor's heading against the chassis and its tyre's bristles.
    castors: [CastorState; 4],
    motor_v: [f64; 2],
    battery_v: f64,
    battery_current_a: f64,
    tyre_force_n: [[f64; 2]; 2],
}

impl ReducedBase {
    /// The reduced base of a (validated) scene of a vehicle on the floor.
    pub fn new(scene: &Scene) -> Result<ReducedBase, ReducedError> {
        Self::stepped(scene, None)
    }

    /// The reduced base of `scene` stepped as `held` asks (a fit's stepping, taken at its
    /// start: [`Stepping`]), refined only where the scene's keys need steps more than
    /// twice as fine.
    pub fn held(scene: &Scene, held: Stepping) -> Result<ReducedBase, ReducedError> {
        Self::stepped(scene, Some(held))
    }

    fn stepped(scene: &Scene, held: Option<Stepping>) -> Result<ReducedBase, ReducedError> {
        if scene.sim.wheels_lifted {
            return Err(ReducedError::NotABase("the scene's wheels are lifted"));
        }
        if !scene.floor.regions.is_empty() {
            return Err(ReducedError::NotABase(
                "the floor has regions of other surfaces (the reduced base holds one floor)",
            ));
        }
        if scene.term.any() {
            return Err(ReducedError::Unmodelled(
                "a term outside the vocabulary ([term]): the simulator replays it",
            ));
        }
        let params = SimParams::from_scene(scene)?;
        let own = Stepping::of_params(&params);
        let stepping = held.map_or(own, |h| h.held_for(own, &params));
        let fixed = fixed_of(&params, stepping);
        let delay = params.dcmc.params.command_delay_s;
        let castor = CastorState::at_rest(params.castors.initial_angle_rad);
        Ok(ReducedBase {
            fixed,
            actuation: Actuation::Velocity {
                linear_m_s: 0.0,
                angular_rad_s: 0.0,
            },
            delay: (delay > 0.0).then(|| CommandDelay::new(delay, Actuation::Firmware)),
            t_s: 0.0,
            steps: 0,
            base: BaseState::default(),
            drive: [DrivetrainState::at_rest(); 2],
            tyres: [TyreState::default(); 2],
            body: BodyState {
                pose: params.start,
                ..BodyState::default()
            },
            castors: [castor; 4],
            heading_dir: {
                let (s, c) = params.start.heading_rad.sin_cos();
                [c, s]
            },
            motor_v: [0.0; 2],
            battery_v: params.battery.open_circuit_v,
            battery_current_a: 0.0,
            tyre_force_n: [[0.0; 2]; 2],
            params,
        })
    }

    /// The run parameters.
    pub fn params(&self) -> &SimParams {
        &self.params
    }

    /// The reduced base's step, s: a whole number of the simulator's steps, as many as
    /// keep each within a third of the drivers' speed-loop time constant (at most four).
    pub fn dt_s(&self) -> f64 {
        self.fixed.dt_s
    }

    /// Changes the velocity command from the next step on (or, with a dead time, from the
    /// step it arrives in). Only velocity commands drive the base; any other actuation
    /// stops it (zero command).
    pub fn set_actuation(&mut self, a: Actuation) {
        let a = match a {
            Actuation::Velocity { .. } => a,
            _ => Actuation::Velocity {
                linear_m_s: 0.0,
                angular_rad_s: 0.0,
            },
        };
        match &mut self.delay {
            Some(d) => d.push(self.t_s, a),
            None => self.actuation = a,
        }
    }

    /// One step, in the simulator's order: the command through its dead time, the base
    /// controller and the drivers' loops against the battery's available voltage, then
    /// sub-steps of the drivetrains with their tyres against the chassis's motion and of
    /// the chassis under the tyres' and castors' forces, then the battery's current.
    pub fn step(&mut self) -> Result<(), SimError> {
        let dt = self.fixed.dt_s;
        if let Some(d) = &mut self.delay {
            self.actuation = d.acting(self.t_s, dt);
        }
        let (linear_m_s, angular_rad_s) = match self.actuation {
            Actuation::Velocity {
                linear_m_s,
                angular_rad_s,
            } => (linear_m_s, angular_rad_s),
            _ => (0.0, 0.0),
        };
        let battery = self.params.battery;
        self.battery_v = battery.terminal_voltage_v(self.battery_current_a);
        let out = self.params.base.step(
            &self.params.base_geometry,
            &mut self.base,
            &BaseInput {
                linear_m_s,
                angular_rad_s,
                motor_speed_rad_s: self.drive.map(|d| d.motor.speed_rad_s),
                available_v: battery.available_drive_v(self.battery_v),
            },
            dt,
        );
        self.motor_v = out.voltage_v;
        let n = self.fixed.substeps;
        let h = dt / n as f64;
        for _ in 0..n {
            let forces = self.advance_drivetrains(h);
            self.advance_body(forces, h);
        }
        let power: f64 = (0..2)
            .map(|i| self.motor_v[i] * self.drive[i].motor.current_a)
            .sum();
        self.battery_current_a = battery.current_for_power_a(power);
        self.steps += 1;
        self.t_s = self.steps as f64 * dt;
        self.check_finite()
    }

    fn check_finite(&self) -> Result<(), SimError> {
        let b = &self.body;
        let values = [
            ("left motor speed (rad/s)", self.drive[0].motor.speed_rad_s),
            ("right motor speed (rad/s)", self.drive[1].motor.speed_rad_s),
            ("left armature current (A)", self.drive[0].motor.current_a),
            ("right armature current (A)", self.drive[1].motor.current_a),
            ("chassis speed (m/s)", b.velocity_m_s[0]),
            ("yaw rate (rad/s)", b.yaw_rate_rad_s),
            ("x (m)", b.pose.x_m),
            ("y (m)", b.pose.y_m),
        ];
        for (what, value) in values {
            if !value.is_finite() || value.abs() > 1e6 {
                return Err(SimError::Diverged {
                    t_s: self.t_s,
                    what: what.to_string(),
                    value,
                    suspects: "check the scene's gains, masses and stiffnesses".into(),
                });
            }
        }
        Ok(())
    }

    /// What the reduced base looks like now: the simulator's snapshot with the fields it
    /// has (pose, velocity, each side's voltage, current, motor and wheel motion as its
    /// encoders read them, the tyres' forces, the battery); the rest left at rest.
    pub fn snapshot(&self) -> Snapshot {
        let p = &self.params;
        let mut sides = [SideSnapshot::default(); 2];
        for (i, side) in sides.iter_mut().enumerate() {
            let d = &self.drive[i];
            *side = SideSnapshot {
                voltage_v: self.motor_v[i],
                current_a: d.motor.current_a,
                motor_speed_rad_s: d.motor.speed_rad_s,
                motor_angle_rad: d.motor.angle_rad,
                wheel_speed_rad_s: d.wheel_speed_rad_s,
                wheel_angle_rad: d.wheel_angle_rad,
                wheel_rim_m_s: d.wheel_speed_rad_s * p.odometry_radius_m,
                wheel_rim_distance_m: d.wheel_angle_rad * p.odometry_radius_m,
                backlash_gap_rad: p.drivetrain.twist(d).0,
                tyre_force_n: self.tyre_force_n[i],
                ..SideSnapshot::default()
            };
        }
        Snapshot {
            t_s: self.t_s,
            pose: self.body.pose,
            velocity_m_s: self.body.velocity_m_s,
            yaw_rate_rad_s: self.body.yaw_rate_rad_s,
            sides,
            battery_v: self.battery_v,
            battery_current_a: self.battery_current_a,
            controller_phase: "velocity",
            ..Snapshot::default()
        }
    }
}

/// What the reduced base works out once: its step and sub-steps (`stepping`), the inertia
/// on each wheel, the tyres' law on the floor, the armature's decay, the castors.
fn fixed_of(p: &SimParams, stepping: Stepping) -> Fixed {
    let d = &p.drivetrain;
    let play = d.gearbox.backlash_rad > 0.0;
    let geared_kg_m2 = d.wheel.inertia_kg_m2 + d.reflected_motor_inertia();
    let dt = p.sim.dt_s * stepping.step_multiple as f64;
    let tyre = p.drive_tyre(p.floor.default);
    let substeps = stepping.substeps;
    let h = dt / substeps as f64;
    let castor_tyre = p.castor_tyre(p.floor.default);
    let castors = p.loads.castor_n.map(|load_n| CastorLaw {
        drag_n: p.castors.rolling_resistance * load_n,
        side_n: (p.castors.swivel_friction_nm / p.castors.trail_m)
            .min(castor_tyre.peak_mu * load_n),
        trail_m: p.castors.trail_m,
        bristle_n_m: castor_tyre.bristle_stiffness_n_m(load_n)[1],
        relaxation_m: castor_tyre.relaxation_length_m,
    });
    let c = &p.chassis;
    let castor_kg = p.castors.mass_kg;
    let at_swivels: f64 = c
        .castor_points_m()
        .iter()
        .map(|q| castor_kg * ((q[0] - c.cg_m[0]).powi(2) + (q[1] - c.cg_m[1]).powi(2)))
        .sum();
    Fixed {
        mass_kg: c.mass_kg + 4.0 * castor_kg,
        yaw_inertia_kg_m2: c.yaw_inertia_kg_m2 + at_swivels,
        dt_s: dt,
        substeps,
        geared_kg_m2,
        play,
        bristles: p.loads.drive_n.map(|load| tyre.bristles(load)),
        tyre,
        armature_decay: (-h / d.motor.electrical_time_constant_s()).exp(),
        castor_points_m: p.chassis.castor_points_m(),
        castors,
    }
}

/// How many simulator steps one reduced step spans: as many as keep it within
/// [`STEP_SHARE_OF_LOOP`] of the drivers' speed loop's time constant, at most
/// [`MAX_STEP_MULTIPLE`]. The loop's time constant is the motor's answer to it at the
/// shaft, `J R / (K (kp + K))`, with `J` the rotor and what a wheel drives through the
/// gear (its wheel, and the lighter of half the chassis going straight and its share of the
/// yaw turning on the spot).
fn step_multiple(p: &SimParams) -> usize {
    let d = &p.drivetrain;
    let (r, n) = (
        p.rolling_radii_m[0].min(p.rolling_radii_m[1]),
        d.gearbox.ratio,
    );
    let c = &p.chassis;
    let half_track = 0.5 * c.track_width_m;
    let chassis_share_kg =
        (0.5 * c.mass_kg).min(c.yaw_inertia_kg_m2 / (2.0 * half_track * half_track));
    let at_wheel = d.wheel.inertia_kg_m2 + chassis_share_kg * r * r;
    let j = d.motor.rotor_inertia_kg_m2 + at_wheel / (n * n);
    let k = d.motor.torque_constant_nm_a;
    let tau = j * d.motor.resistance_ohm / (k * (p.base.speed_kp_v_s_rad + k));
    let steps = (STEP_SHARE_OF_LOOP * tau / p.sim.dt_s).floor();
    if steps.is_finite() {
        (steps as usize).clamp(1, MAX_STEP_MULTIPLE)
    } else {
        1
    }
}

/// Sub-steps of a step `dt` (s): the drive tyres' bristles against the chassis's mass
/// ([`SUBSTEP_RATE`]), the stiffer of their two directions.
fn substeps(p: &SimParams, tyre: &TyreParams, dt: f64) -> usize {
    let load = p.loads.drive_n[0].max(p.loads.drive_n[1]);
    let k = tyre.bristle_stiffness_n_m(load);
    let c = tyre.bristle_damping_n_s_m(load);
    let m = p.chassis.mass_kg;
    let chassis = (2.0 * k[0].max(k[1]) / m).sqrt() + 2.0 * c[0].max(c[1]) / m;
    ((dt * chassis / SUBSTEP_RATE).ceil() as usize).clamp(1, super::MAX_SUBSTEPS)
}
