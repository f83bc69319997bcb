//! The simulator: one `Sim` runs every fidelity level; `Sim::step` fixes the order in which
//! the blocks act (see its doc comment). Observers (CSV, Rerun, metrics) read
//! [`Snapshot`]s; the physics knows nothing of them.

mod command_delay;
mod cycle;
pub mod expectation;
pub mod linearize;
pub mod metrics;
mod params;
pub mod reduced;
mod snapshot;
mod step;
mod summary;

pub use crate::scene::Features;
pub use params::{SimParams, MAX_SUBSTEPS};
pub use snapshot::{CastorSnapshot, SideSnapshot, Snapshot};

use rand::SeedableRng;
use rand_pcg::Pcg64;

use crate::firmware::FirmwareState;
use crate::model::base_controller::BaseState;
use crate::model::chassis::{NoSlipState, Pose};
use crate::model::dcmc::{DcmcOutput, DcmcState};
use crate::model::drivetrain::DrivetrainState;
use crate::model::tyre::{TyreOutput, TyreState};
use crate::scene::Scene;
use crate::world::engine::Engine;

/// Errors a run can stop with.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// The scene cannot be set up (the message names the keys).
    #[error("cannot set up the simulation: {message}")]
    Setup {
        /// What cannot be set up and which keys to check.
        message: String,
    },
    /// A state left the physical range.
    #[error("the simulation diverged at t = {t_s:.4} s: {what} is {} (not finite or beyond any physical range); {suspects}", crate::param::plain_number(*.value))]
    Diverged {
        /// When, s.
        t_s: f64,
        /// Which state.
        what: String,
        /// Its value.
        value: f64,
        /// What to check: the scene's values furthest from the thesis machine's, when the
        /// run knows its scene.
        suspects: String,
    },
}

impl SimError {
    /// The error with the scene's likeliest culprits named (the numeric keys furthest,
    /// in orders of magnitude, from the thesis machine's values).
    pub fn naming_suspects(self, scene: &Scene) -> SimError {
        match self {
            SimError::Diverged {
                t_s, what, value, ..
            } => {
                let far = crate::scene::keys::furthest_from_default(scene, 3);
                let suspects = if far.is_empty() {
                    "try a smaller sim.dt_s or check the scene's stiffness and gains".to_string()
                } else {
                    format!(
                        "the values furthest from the thesis machine's are the likely cause: {}",
                        far.join(", ")
                    )
                };
                SimError::Diverged {
                    t_s,
                    what,
                    value,
                    suspects,
                }
            }
            other => other,
        }
    }
}

/// How the motors are driven in a run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Actuation {
    /// The firmware (P-D, Open Day or open loop) through the PWM filter and the DCMC.
    Firmware,
    /// Forward and turn demand straight into the DCMC, pct.
    Demand {
        /// Forward demand, pct.
        forward_pct: f64,
        /// Turn demand, pct.
        turn_pct: f64,
    },
    /// Motor terminal voltages (left, right), V, bypassing the DCMC (still clipped to what
    /// the battery can give).
    Voltage([f64; 2]),
    /// A velocity command into the base controller (a ROS robot's `/cmd_vel`), whose
    /// drivers' speed loops set the motor voltages (bypassing the DCMC).
    Velocity {
        /// Forward speed, m/s.
        linear_m_s: f64,
        /// Yaw rate, rad/s (positive: turning left).
        angular_rad_s: f64,
    },
    /// Both motors open-circuited (power cut).
    Open,
}

/// The chassis in whichever form the fidelity level uses.
#[derive(Clone)]
enum Body {
    /// Wheels lifted off the floor: the chassis stays where it is.
    Lifted(Pose),
    /// Thesis levels: rolls without slip.
    NoSlip(NoSlipState),
    /// Our level: rapier chassis with tyres and castors.
    Rapier(Box<Engine>),
}

/// What the last step computed, kept for snapshots.
#[derive(Debug, Clone, Copy, Default)]
struct LastStep {
    sensors_adc: [f64; 2],
    rear_sensors_adc: [f64; 2],
    demand_pct: [f64; 2],
    dcmc: DcmcOutput,
    /// Motor terminal voltages actually applied (left, right), V.
    motor_v: [f64; 2],
    battery_v: f64,
    battery_current_a: f64,
    tyre: [TyreOutput; 2],
    castor_force_n: [[f64; 2]; 4],
    bumper: bool,
}

/// A running simulation: the parameters (immutable) and everything that evolves. A clone
/// is a saved state: stepped with the same inputs, it gives the same numbers as the
/// original from that instant on.
#[derive(Clone)]
pub struct Sim {
    params: SimParams,
    actuation: Actuation,
    t_s: f64,
    steps: u64,
    drive: [DrivetrainState; 2],
    tyres: [TyreState; 2],
    castor_tyres: [TyreState; 4],
    body: Body,
    dcmc: DcmcState,
    base: BaseState,
    firmware: FirmwareState,
    /// PWM filter outputs (forward, turn), duty counts.
    pwm_filtered: [f64; 2],
    rng: Pcg64,
    last: LastStep,
    /// External commands in their dead time (`dcmc.command_delay_s` > 0).
    command_delay: Option<command_delay::CommandDelay>,
    /// Whether the guide-wire coils are read each step (see [`Sim::without_coils`]).
    coils_read: bool,
}

impl Sim {
    /// A simulation of a validated scene, at rest at the scene's start pose.
    pub fn new(scene: &Scene) -> Result<Sim, SimError> {
        Sim::from_params(SimParams::from_scene(scene)?)
    }

    /// A simulation from run parameters, at rest at the start pose.
    pub fn from_params(params: SimParams) -> Result<Sim, SimError> {
        let body = if params.sim.wheels_lifted {
            Body::Lifted(params.start)
        } else if params.features.tyres_and_castors {
            Body::Rapier(Box::new(Engine::new(
                &params.chassis,
                params.castors.clone(),
                params.outline_m(),
                params.start,
                params.sim.dt_s,
                &params.obstacles,
            )))
        } else {
            Body::NoSlip(NoSlipState {
                pose: params.start,
                speed_m_s: 0.0,
                yaw_rate_rad_s: 0.0,
            })
        };
        let firmware = params.firmware.initial_state();
        let half = crate::firmware::HALF_DUTY as f64;
        Ok(Sim {
            rng: Pcg64::seed_from_u64(params.sim.seed),
            actuation: Actuation::Firmware,
            t_s: 0.0,
            steps: 0,
            drive: [DrivetrainState::at_rest(); 2],
            tyres: [TyreState::default(); 2],
            castor_tyres: [TyreState::default(); 4],
            body,
            dcmc: DcmcState::default(),
            base: BaseState::default(),
            firmware,
            pwm_filtered: [half, half],
            command_delay: (params.dcmc.params.command_delay_s > 0.0).then(|| {
                command_delay::CommandDelay::new(
                    params.dcmc.params.command_delay_s,
                    Actuation::Firmware,
                )
            }),
            last: LastStep {
                battery_v: params.battery.open_circuit_v,
                ..LastStep::default()
            },
            params,
            coils_read: true,
        })
    }

    /// The same simulation with its guide-wire coils unread: their readings stay 0 and the
    /// firmware sees no wire. For a run that nothing steers by the wire and whose coil
    /// readings nobody looks at (a replay driven by a recording's voltages, demands or
    /// velocity commands, comparing other outputs): the field of every wire segment at
    /// both coils is a tenth of a step's work, and changes nothing else.
    pub fn without_coils(mut self) -> Sim {
        self.coils_read = false;
        self
    }

    /// The run parameters.
    pub fn params(&self) -> &SimParams {
        &self.params
    }

    /// Changes how the motors are driven from the next step on, or, with a command dead
    /// time (`dcmc.command_delay_s`), from the step it arrives in.
    pub fn set_actuation(&mut self, a: Actuation) {
        match &mut self.command_delay {
            Some(d) => d.push(self.t_s, a),
            None => self.actuation = a,
        }
    }

    /// Reads a periodic term's phase at the motor angles `measured_rad` (left, right) from
    /// now on: each side's term acts at its simulated angle plus the difference (see
    /// [`crate::model::drivetrain::TermState::phase_correction_rad`]). A replay calls it at
    /// each row of a recording with an encoder; a run never does.
    pub fn read_term_phase_at(&mut self, measured_rad: [f64; 2]) {
        for (d, m) in self.drive.iter_mut().zip(measured_rad) {
            d.term.phase_correction_rad = m - d.motor.angle_rad;
        }
    }

    /// Simulated time so far, s.
    pub fn time_s(&self) -> f64 {
        self.t_s
    }

    /// Pose of the drive-axle midpoint.
    pub fn pose(&self) -> Pose {
        match &self.body {
            Body::Lifted(p) => *p,
            Body::NoSlip(s) => s.pose,
            Body::Rapier(e) => e.pose(),
        }
    }

    /// Drive wheels' rim speeds (left, right), m/s: what encoders on the wheels would
    /// measure (tyre slip unseen).
    pub fn rim_speeds_m_s(&self) -> [f64; 2] {
        // The encoders' counts read with the configured radius, as odometry reads them.
        let r = self.params.odometry_radius_m;
        self.drive.map(|w| w.wheel_speed_rad_s * r)
    }

    /// Drivetrain states (left, right).
    pub fn drivetrains(&self) -> &[DrivetrainState; 2] {
        &self.drive
    }

    /// Runs until `duration_s`, calling `observe` after every step.
    pub fn run_for(
        &mut self,
        duration_s: f64,
        mut observe: impl FnMut(&Sim),
    ) -> Result<(), SimError> {
        let steps = (duration_s / self.params.sim.dt_s).round() as u64;
        for _ in 0..steps {
            self.step()?;
            observe(self);
        }
        Ok(())
    }
}
