//! A scene's simulation held in memory and stepped from outside: Python's `agvsim.Sim`
//! and `agvsim.VecSim`. The same simulator `agvsim run` drives, driven the same way unless
//! a command is given (the firmware follows the wire; a velocity-commanded base drives its
//! manoeuvre), its outputs the columns of the recording `run` writes. No files: the scene
//! comes loaded (`commands::run::live_sim` loads it as `run` does).

use crate::model::manoeuvre::Manoeuvre;
use crate::record::channels as chan;
use crate::record::{vehicle_columns, Column};
use crate::scene::Scene;
use crate::sim::{Actuation, Sim, SimError, Snapshot};

/// What drives the next steps.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Command {
    /// What `agvsim run` drives: the firmware (wire-following scenes) or the scene's
    /// manoeuvre (velocity-commanded bases).
    Scene,
    /// Forward and turn demand straight into the DCMC, pct (wire-following scenes).
    Demand {
        /// Forward demand, pct.
        forward_pct: f64,
        /// Turn demand, pct.
        turn_pct: f64,
    },
    /// A velocity command into the base controller (`/cmd_vel`; velocity-commanded bases).
    Velocity {
        /// Forward speed, m/s.
        linear_m_s: f64,
        /// Yaw rate, rad/s (positive: turning left).
        angular_rad_s: f64,
    },
}

/// A command that the scene's controller does not take.
#[derive(Debug, thiserror::Error)]
#[error("{given} commands do not drive this scene: its controller takes {takes} ({names})")]
pub struct WrongCommand {
    /// The kind of command given.
    pub given: &'static str,
    /// The kind the scene takes.
    pub takes: &'static str,
    /// The names of the scene's command (with units).
    pub names: String,
}

/// Errors of a live simulation.
#[derive(Debug, thiserror::Error)]
pub enum LiveError {
    /// The simulation could not be set up, or diverged (its scene's suspects named).
    #[error(transparent)]
    Sim(#[from] SimError),
    /// A command the scene's controller does not take.
    #[error(transparent)]
    Command(#[from] WrongCommand),
    /// A fleet given another number of commands or seeds than it has simulations.
    #[error("{given} {what} for {expected} simulations: give one per simulation")]
    Count {
        /// What was given (commands, seeds).
        what: &'static str,
        /// How many.
        given: usize,
        /// How many simulations.
        expected: usize,
    },
}

/// The names of the state [`LiveSim::state`] gives, with units, in its order.
pub const STATE_NAMES: [&str; 20] = [
    chan::X_M,
    chan::Y_M,
    chan::HEADING_RAD,
    "forward_speed_m_s",
    "lateral_speed_m_s",
    chan::YAW_RATE_RAD_S,
    "left_motor_angle_rad",
    "right_motor_angle_rad",
    chan::LEFT_MOTOR_SPEED_RAD_S,
    chan::RIGHT_MOTOR_SPEED_RAD_S,
    chan::LEFT_CURRENT_A,
    chan::RIGHT_CURRENT_A,
    chan::LEFT_WHEEL_ANGLE_RAD,
    chan::RIGHT_WHEEL_ANGLE_RAD,
    "left_wheel_speed_rad_s",
    "right_wheel_speed_rad_s",
    "left_backlash_gap_rad",
    "right_backlash_gap_rad",
    "left_slip_ratio",
    "right_slip_ratio",
];

/// The state of a snapshot in [`STATE_NAMES`]' order.
fn state_of(s: &Snapshot) -> [f64; 20] {
    let [l, r] = &s.sides;
    [
        s.pose.x_m,
        s.pose.y_m,
        s.pose.heading_rad,
        s.velocity_m_s[0],
        s.velocity_m_s[1],
        s.yaw_rate_rad_s,
        l.motor_angle_rad,
        r.motor_angle_rad,
        l.motor_speed_rad_s,
        r.motor_speed_rad_s,
        l.current_a,
        r.current_a,
        l.wheel_angle_rad,
        r.wheel_angle_rad,
        l.wheel_speed_rad_s,
        r.wheel_speed_rad_s,
        l.backlash_gap_rad,
        r.backlash_gap_rad,
        l.slip_ratio,
        r.slip_ratio,
    ]
}

/// A saved instant of a [`LiveSim`]: restored, the simulation goes on from it exactly as
/// it went on the first time.
#[derive(Clone)]
pub struct Saved {
    sim: Sim,
}

/// One scene's simulation, stepped from outside.
#[derive(Clone)]
pub struct LiveSim {
    scene: Scene,
    sim: Sim,
    /// A velocity-commanded base's manoeuvre (`None`: the scene follows a wire).
    manoeuvre: Option<Manoeuvre>,
    /// The recording's columns but time, in order.
    columns: std::sync::Arc<Vec<Column>>,
}

impl LiveSim {
    /// The scene's simulation at rest at its start pose. `manoeuvre`: a velocity-commanded
    /// base's commands read from its CSV (`None`: the scene's square or circle).
    pub fn new(scene: Scene, manoeuvre: Option<Manoeuvre>) -> Result<LiveSim, SimError> {
        let velocity = scene.controller.kind == crate::firmware::ControllerKind::Velocity;
        let manoeuvre = velocity
            .then(|| manoeuvre.unwrap_or_else(|| Manoeuvre::Shape(scene.manoeuvre.clone())));
        let sim = start(&scene, manoeuvre.is_some())?;
        let columns = vehicle_columns()
            .into_iter()
            .filter(|c| c.name != chan::T_S)
            .collect();
        Ok(LiveSim {
            scene,
            sim,
            manoeuvre,
            columns: std::sync::Arc::new(columns),
        })
    }

    /// Back to rest at the start pose, with the noise seeded by `seed` (the scene's
    /// `sim.seed` where `None`).
    pub fn reset(&mut self, seed: Option<u64>) -> Result<(), LiveError> {
        if let Some(seed) = seed {
            self.scene.sim.seed = seed;
        }
        self.sim = start(&self.scene, self.manoeuvre.is_some())?;
        Ok(())
    }

    /// Steps `n` physics steps with `command` held through them.
    pub fn step(&mut self, command: Command, n: u64) -> Result<(), LiveError> {
        let fixed = self.actuation(command)?;
        if let Some(a) = fixed {
            self.sim.set_actuation(a);
        }
        for _ in 0..n {
            if let (None, Some(m)) = (fixed, &self.manoeuvre) {
                // As `run`: the manoeuvre's command at the step's start, held a step.
                let (linear_m_s, angular_rad_s) = m.command_at(self.sim.time_s());
                self.sim.set_actuation(Actuation::Velocity {
                    linear_m_s,
                    angular_rad_s,
                });
            }
            if let Err(e) = self.sim.step() {
                return Err(e.naming_suspects(&self.scene).into());
            }
        }
        Ok(())
    }

    /// The actuation a command sets for the steps (`None`: the manoeuvre sets it each step).
    fn actuation(&self, command: Command) -> Result<Option<Actuation>, WrongCommand> {
        let velocity = self.manoeuvre.is_some();
        match (command, velocity) {
            (Command::Scene, false) => Ok(Some(Actuation::Firmware)),
            (Command::Scene, true) => Ok(None),
            (
                Command::Demand {
                    forward_pct,
                    turn_pct,
                },
                false,
            ) => Ok(Some(Actuation::Demand {
                forward_pct,
                turn_pct,
            })),
            (
                Command::Velocity {
                    linear_m_s,
                    angular_rad_s,
                },
                true,
            ) => Ok(Some(Actuation::Velocity {
                linear_m_s,
                angular_rad_s,
            })),
            (Command::Demand { .. }, true) => Err(self.wrong("demand")),
            (Command::Velocity { .. }, false) => Err(self.wrong("velocity")),
        }
    }

    fn wrong(&self, given: &'static str) -> WrongCommand {
        let [a, b] = self.command_names();
        WrongCommand {
            given,
            takes: if self.manoeuvre.is_some() {
                "velocity commands"
            } else {
                "demands"
            },
            names: format!("{a}, {b}"),
        }
    }

    /// The names of the command the scene's controller takes, with units.
    pub fn command_names(&self) -> [&'static str; 2] {
        if self.manoeuvre.is_some() {
            [chan::CMD_LINEAR_M_S, chan::CMD_ANGULAR_RAD_S]
        } else {
            [chan::DEMAND_FWD_PCT, chan::DEMAND_TURN_PCT]
        }
    }

    /// Whether the scene is a velocity-commanded base.
    pub fn is_velocity_base(&self) -> bool {
        self.manoeuvre.is_some()
    }

    /// The manoeuvre's command at `t_s` (forward m/s, yaw rate rad/s), for a
    /// velocity-commanded base.
    pub fn manoeuvre_command(&self, t_s: f64) -> Option<(f64, f64)> {
        self.manoeuvre.as_ref().map(|m| m.command_at(t_s))
    }

    /// The base's top speed: its motors' no-load speed at the drive limit, at the rim,
    /// m/s (what neither wheel can exceed).
    pub fn top_speed_m_s(&self) -> f64 {
        self.scene.top_speed_m_s(self.scene.battery.drive_limit_v)
    }

    /// The drive wheels' track, m.
    pub fn track_m(&self) -> f64 {
        self.scene.chassis.track_width_m
    }

    /// Whether the vehicle has lost its wire now (neither coil sees it; as `run`'s
    /// summary counts it).
    pub fn lost_wire(&self) -> bool {
        self.sim.snapshot().lost_wire
    }

    /// The DCMC's fault now, if it has one (it then brakes until disabled).
    pub fn dcmc_fault(&self) -> Option<&'static str> {
        self.sim.snapshot().dcmc_fault
    }

    /// The time after enabling in which a non-zero demand faults the DCMC, s
    /// (`dcmc.enable_delay_s`).
    pub fn dcmc_enable_delay_s(&self) -> f64 {
        self.sim.params().dcmc.params.enable_delay_s
    }

    /// Simulated time, s.
    pub fn time_s(&self) -> f64 {
        self.sim.time_s()
    }

    /// The physics step, s.
    pub fn dt_s(&self) -> f64 {
        self.sim.params().sim.dt_s
    }

    /// The scene as loaded (its `sim.duration_s`, `sim.record_interval_s`, ...).
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The names of [`LiveSim::outputs`], with units: the recording's columns but `t_s`.
    pub fn output_names(&self) -> Vec<&'static str> {
        self.columns.iter().map(|c| c.name).collect()
    }

    /// Decimals the recording writes each output with (its resolution in the CSV).
    pub fn output_decimals(&self) -> Vec<usize> {
        self.columns.iter().map(|c| c.decimals).collect()
    }

    /// The outputs now, in [`LiveSim::output_names`]' order (full precision).
    pub fn outputs(&self) -> Vec<f64> {
        let s = self.sim.snapshot();
        self.columns.iter().map(|c| (c.value)(&s)).collect()
    }

    /// The mechanical and electrical state now, in [`STATE_NAMES`]' order.
    pub fn state(&self) -> [f64; 20] {
        state_of(&self.sim.snapshot())
    }

    /// Everything the simulator shows now.
    pub fn snapshot(&self) -> Snapshot {
        self.sim.snapshot()
    }

    /// Saves this instant.
    pub fn save(&self) -> Saved {
        Saved {
            sim: self.sim.clone(),
        }
    }

    /// Goes back to a saved instant.
    pub fn restore(&mut self, saved: &Saved) {
        self.sim = saved.sim.clone();
    }
}

/// The scene's simulator at rest, its coils unread on a velocity base (as `run`).
fn start(scene: &Scene, velocity: bool) -> Result<Sim, SimError> {
    let sim = Sim::new(scene).map_err(|e| e.naming_suspects(scene))?;
    Ok(if velocity { sim.without_coils() } else { sim })
}

/// Many simulations stepped together on the worker threads, each on its own: the numbers
/// do not depend on the thread count.
pub struct LiveFleet {
    sims: Vec<LiveSim>,
}

/// A member of a fleet that could not step, by its index.
#[derive(Debug, thiserror::Error)]
#[error("{}{source}", index.map(|i| format!("simulation {i}: ")).unwrap_or_default())]
pub struct FleetError {
    /// Which simulation, from 0 (`None`: the fleet as a whole).
    pub index: Option<usize>,
    /// Why.
    #[source]
    pub source: LiveError,
}

impl LiveFleet {
    /// A fleet of the given simulations.
    pub fn new(sims: Vec<LiveSim>) -> LiveFleet {
        LiveFleet { sims }
    }

    /// The simulations.
    pub fn sims(&self) -> &[LiveSim] {
        &self.sims
    }

    /// Steps each simulation `n` steps with its command (one per simulation), in parallel.
    pub fn step(&mut self, commands: &[Command], n: u64) -> Result<(), FleetError> {
        use rayon::prelude::*;
        self.check_count("commands", commands.len())?;
        self.sims
            .par_iter_mut()
            .zip(commands.par_iter())
            .enumerate()
            .map(|(i, (s, c))| {
                s.step(*c, n).map_err(|source| FleetError {
                    index: Some(i),
                    source,
                })
            })
            .collect::<Vec<_>>()
            .into_iter()
            .collect()
    }

    /// Resets every simulation, the i-th seeded `seeds[i]` where given.
    pub fn reset(&mut self, seeds: Option<&[u64]>) -> Result<(), FleetError> {
        if let Some(v) = seeds {
            self.check_count("seeds", v.len())?;
        }
        for (index, s) in self.sims.iter_mut().enumerate() {
            s.reset(seeds.map(|v| v[index]))
                .map_err(|source| FleetError {
                    index: Some(index),
                    source,
                })?;
        }
        Ok(())
    }

    /// One of `what` per simulation, or an error saying how many were given.
    fn check_count(&self, what: &'static str, given: usize) -> Result<(), FleetError> {
        let expected = self.sims.len();
        if given == expected {
            return Ok(());
        }
        Err(FleetError {
            index: None,
            source: LiveError::Count {
                what,
                given,
                expected,
            },
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The thesis machine (every key at its default), in memory.
    fn thesis() -> LiveSim {
        LiveSim::new(Scene::default(), None).unwrap()
    }

    /// A fleet steps each member as it would alone, refuses a count of commands that is
    /// not one per member, and refuses a velocity command to a wire-following scene.
    #[test]
    fn a_fleet_steps_each_member_as_alone_and_checks_its_commands() {
        let mut alone = thesis();
        alone.step(Command::Scene, 300).unwrap();
        let mut fleet = LiveFleet::new(vec![thesis(), thesis()]);
        let err = fleet.step(&[Command::Scene], 300).unwrap_err();
        assert!(err.to_string().starts_with("1 commands for 2"), "{err}");
        fleet.step(&[Command::Scene, Command::Scene], 300).unwrap();
        for s in fleet.sims() {
            assert_eq!(s.outputs(), alone.outputs());
        }
        let v = Command::Velocity {
            linear_m_s: 0.3,
            angular_rad_s: 0.0,
        };
        let err = fleet.step(&[Command::Scene, v], 1).unwrap_err();
        assert_eq!(err.index, Some(1));
        assert!(err.to_string().contains("demand_fwd_pct"), "{err}");
    }
}
