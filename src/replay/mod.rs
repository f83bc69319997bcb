//! Replay: the simulator itself, at the scene's fidelity (rapier chassis, tyres and castors
//! at `full`), driven by a recording's inputs instead of its firmware, and compared with
//! the recording's outputs. This is how a user sees how well the simulation they run
//! matches their machine, output by output, with the same normalised fit as `identify`.
//!
//! Inputs, by the contract's columns: motor voltages (`left_/right_voltage_V`; a drive
//! axis's `voltage_V`) bypass the DCMC; demands (`demand_fwd_pct`, `demand_turn_pct`; a
//! drive axis's `demand_pct`) go through it; velocity commands (`cmd_linear_m_s`,
//! `cmd_angular_rad_s`, a ROS robot's `/cmd_vel`) go through the scene's `[base]`
//! controller and its drivers' speed loops. Each input is held from its row to the next
//! (zero-order hold, as a controller's output is). A drive axis is the scene's left drive
//! with the wheels lifted; a `drive_pair` recording, both drives lifted. The simulator starts from rest, at the recording's start
//! pose when it has one: the mean of the pose samples taken before the command first
//! changes (the machine is still then), so that one sample's tracker noise does not
//! offset the whole replay.
//!
//! This file is the face and the run: the errors, the result, and the replay's steps in
//! order ([`replay_with`]). What drives it is `inputs.rs`, what it compares `outputs.rs`
//! (with a validation recording's check), what it runs on `engine.rs`, its start pose
//! `start_pose.rs`, its report `report.rs`.

mod engine;
mod inputs;
mod outputs;
pub mod report;
mod start_pose;

use std::path::PathBuf;

use crate::ident::evaluate::fit_pct;
use crate::record::channels as chan;
use crate::record::Recording;
use crate::rig::RigKind;
use crate::scene::Scene;
use crate::sim::reduced::ReducedError;
use crate::sim::SimError;

pub use engine::Engine;
pub use inputs::{drive_of, Drive};
pub use outputs::{check_validation, NotAValidation};

use engine::{term_phases, Machine};
use inputs::{
    choose_drive, clipped_inputs, held_inputs, rows_before_first_command_change, unused_drive_note,
};
use outputs::{channels, Channel};
use start_pose::{align_start_pose, mean_heading, mean_of, MIN_STILL_ROWS};

/// Most simulator steps a replay runs: 1e8 steps is a day of a recording at the 1 ms
/// step, far beyond any rig run, and still minutes of work; beyond it a time column is
/// more likely wrong (in ms, or corrupt) than meant.
pub const MAX_REPLAY_STEPS: f64 = 1e8;

/// Why a replay cannot run.
#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    /// The recording lacks what a replay needs.
    #[error("{file}: {message}")]
    Recording {
        /// The recording.
        file: PathBuf,
        /// What it lacks.
        message: String,
    },
    /// The scene cannot be simulated.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// The reduced base cannot stand in for the scene or the recording.
    #[error("{file}: {source}")]
    Reduced {
        /// The recording.
        file: PathBuf,
        /// Why.
        source: ReducedError,
    },
    /// The simulation diverged during the replay.
    #[error("{file}: the simulation diverged at t = {t_s} s of the recording: {source}")]
    Diverged {
        /// The recording.
        file: PathBuf,
        /// When, s of the recording.
        t_s: f64,
        /// The simulator's error.
        source: SimError,
    },
}

/// One output, measured and simulated at the recording's rows.
#[derive(Debug, Clone)]
pub struct ReplayedOutput {
    /// The output's column name.
    pub name: String,
    /// The recording's values (`None` where not measured).
    pub measured: Vec<Option<f64>>,
    /// The simulator's values at the recording's rows.
    pub simulated: Vec<f64>,
    /// Normalised fit, % (as `identify` reports it); NaN where the column has fewer than
    /// two measured cells (simulated only).
    pub fit_pct: f64,
    /// RMS of measured minus simulated over the measured cells, in the column's unit.
    pub rms_error: f64,
}

/// A replay's result.
#[derive(Debug, Clone)]
pub struct Replay {
    /// Which inputs drove the simulator.
    pub drive: Drive,
    /// The recording's time base, s.
    pub t_s: Vec<f64>,
    /// The inputs as held, `[input][row]`.
    pub inputs: Vec<Vec<f64>>,
    /// Each output compared.
    pub outputs: Vec<ReplayedOutput>,
    /// Recording columns neither used as an input nor produced by the simulator.
    pub not_compared: Vec<String>,
    /// What the replay did to the recording's inputs that a reader must know: inputs
    /// beyond the scene's drive clipped, a DCMC fault that braked the drive.
    pub notes: Vec<String>,
    /// The largest terminal voltage the simulator applied to a motor at the recording's
    /// rows, V: what a DCMC or a base's speed loops asked of the bridges.
    pub peak_terminal_v: f64,
}

impl Replay {
    /// Mean fit over the compared outputs, % (NaN when none has measurements).
    pub fn mean_fit_pct(&self) -> f64 {
        let fits: Vec<f64> = self
            .outputs
            .iter()
            .map(|o| o.fit_pct)
            .filter(|f| f.is_finite())
            .collect();
        if fits.is_empty() {
            return f64::NAN;
        }
        fits.iter().sum::<f64>() / fits.len() as f64
    }

    /// One output by name.
    pub fn output(&self, name: &str) -> Option<&ReplayedOutput> {
        self.outputs.iter().find(|o| o.name == name)
    }
}

fn recording_err(rec: &Recording, message: String) -> ReplayError {
    ReplayError::Recording {
        file: rec.path.clone(),
        message,
    }
}

/// Runs the scene's simulator on the recording's inputs and compares its outputs.
pub fn replay(scene: &Scene, rec: &Recording) -> Result<Replay, ReplayError> {
    replay_with(scene, rec, Engine::Simulator)
}

/// [`replay`] on `engine`: the reduced base takes only a vehicle's velocity commands.
pub fn replay_with(scene: &Scene, rec: &Recording, engine: Engine) -> Result<Replay, ReplayError> {
    if rec.t_s.len() < 2 {
        return Err(recording_err(
            rec,
            format!("too few samples to replay: {} row(s)", rec.t_s.len()),
        ));
    }
    let drive = choose_drive(rec)?;
    if engine.is_reduced() && drive != Drive::Velocity {
        return Err(ReplayError::Reduced {
            file: rec.path.clone(),
            source: ReducedError::NotABase("the recording is not driven by velocity commands"),
        });
    }
    let inputs = held_inputs(rec, drive)?;
    let (chans, not_compared) = channels(rec, drive);
    if chans.is_empty() {
        return Err(recording_err(
            rec,
            "no output column the simulator produces: nothing to compare".into(),
        ));
    }
    let mut scene = scene.clone();
    // A drive axis, and this project's lifted pair, are recorded with the wheels off
    // the floor.
    scene.sim.wheels_lifted = drive.lifted() || rec.rig == RigKind::DrivePair;
    let mut simulated = vec![Vec::with_capacity(rec.t_s.len()); chans.len()];
    let mut notes = clipped_inputs(&scene, drive, &inputs);
    notes.extend(unused_drive_note(rec, drive));
    let mut peak_terminal_v = 0.0_f64;
    // Joined tests each start from their own state of rest.
    for rows in rec.segments() {
        let (part, fault, peak) = simulate_rows(&scene, rec, rows, drive, &inputs, &chans, engine)?;
        peak_terminal_v = peak_terminal_v.max(peak);
        for (all, seg) in simulated.iter_mut().zip(part) {
            all.extend(seg);
        }
        if let Some((t, name)) = fault {
            notes.push(fault_note(&scene, rec, t, name));
        }
    }
    let outputs = chans
        .iter()
        .zip(simulated)
        .map(|(c, sim_y)| {
            let measured: Vec<Option<f64>> = rec.column(&c.name).unwrap_or_default().to_vec();
            let pairs: Vec<f64> = measured
                .iter()
                .zip(&sim_y)
                .filter_map(|(m, s)| m.map(|m| (m - s).powi(2)))
                .collect();
            // A column with fewer than two values is simulated only: no fit.
            let compared = pairs.len() >= 2;
            let rms_error = if compared {
                (pairs.iter().sum::<f64>() / pairs.len() as f64).sqrt()
            } else {
                f64::NAN
            };
            ReplayedOutput {
                name: c.name.clone(),
                fit_pct: if compared {
                    fit_pct(&measured, &sim_y)
                } else {
                    f64::NAN
                },
                measured,
                simulated: sim_y,
                rms_error,
            }
        })
        .collect();
    Ok(Replay {
        drive,
        t_s: rec.t_s.clone(),
        inputs,
        outputs,
        not_compared,
        notes,
        peak_terminal_v,
    })
}

/// A DCMC fault during a replay, said with what the recording did to cause it.
fn fault_note(scene: &Scene, rec: &Recording, t_s: f64, name: &str) -> String {
    let why = match name {
        "enable_delay" => format!(
            ": the recording's demand is non-zero within dcmc.enable_delay_s = {} s of its start, which the unit takes for a stuck stick; set dcmc.enable_delay_s=0 if the unit was enabled before the recording began",
            scene.dcmc.enable_delay_s
        ),
        "low_voltage" => format!(
            ": the battery fell below battery.low_voltage_fault_V = {} V",
            scene.battery.low_voltage_fault_v
        ),
        _ => String::new(),
    };
    format!(
        "the DCMC faulted ({name}) at t = {:.3} s of {} and braked the drive from then on{why}",
        t_s,
        rec.path.display()
    )
}

/// What a segment's replay gives: each output at its rows, the first DCMC fault (when
/// and which), and the largest terminal voltage at its rows, V.
type Segment = (Vec<Vec<f64>>, Option<(f64, &'static str)>, f64);

/// The simulator's outputs at rows `rows` of the recording, from rest at the pose the
/// recording measures while the segment's first command holds (the scene's start where it
/// measures none), driven by the held inputs.
fn simulate_rows(
    scene: &Scene,
    rec: &Recording,
    rows: std::ops::Range<usize>,
    drive: Drive,
    inputs: &[Vec<f64>],
    chans: &[Channel],
    engine: Engine,
) -> Result<Segment, ReplayError> {
    let mut scene = scene.clone();
    let seg_inputs: Vec<Vec<f64>> = inputs.iter().map(|c| c[rows.clone()].to_vec()).collect();
    let still = rows.start + rows_before_first_command_change(&seg_inputs);
    let start = |name: &str| {
        rec.column(name)
            .and_then(|c| mean_of(&c[rows.start..still]))
    };
    if let (Some(x), Some(y)) = (start(chan::X_M), start(chan::Y_M)) {
        scene.start.x_m = x;
        scene.start.y_m = y;
    }
    if let Some(c) = rec.column(chan::HEADING_RAD) {
        if let Some(h) = mean_heading(&c[rows.start..still]) {
            scene.start.heading_rad = h;
        }
    }
    let coils = chans.iter().any(|c| c.name.starts_with("sensor_"));
    let mut sim = Machine::new(&scene, rec, engine, coils)?;
    let dt = sim.dt_s();
    let t0 = rec.t_s[rows.start];
    let span_s = rec.t_s[rows.end - 1] - t0;
    if !(span_s / dt <= MAX_REPLAY_STEPS) {
        return Err(recording_err(
            rec,
            format!(
                "the recording spans {span_s:e} s, {:e} simulator steps of {dt} s (at most {MAX_REPLAY_STEPS:e} are run); check its time column",
                span_s / dt
            ),
        ));
    }
    let mut simulated = vec![Vec::with_capacity(rows.len()); chans.len()];
    let mut fault = None;
    let mut t_sim = 0.0;
    // The encoders' counts at the last row, for the mean rates over each interval.
    let mut counted: Vec<Option<f64>> = vec![None; chans.len()];
    let mut peak_v = 0.0_f64;
    let mut t_last = 0.0;
    let phases = term_phases(&scene, rec, &rows);
    for k in rows.clone() {
        if k > rows.start {
            // Step until the simulator reaches this row's time, holding the last input.
            let target = rec.t_s[k] - t0;
            while t_sim + 0.5 * dt < target {
                sim.step().map_err(|source| ReplayError::Diverged {
                    file: rec.path.clone(),
                    t_s: rec.t_s[k],
                    source: source.naming_suspects(&scene),
                })?;
                t_sim += dt;
            }
        }
        let s = sim.snapshot();
        for ((c, out), last) in chans.iter().zip(simulated.iter_mut()).zip(&mut counted) {
            let value = match (c.rate_of, *last) {
                (Some(count), Some(before)) if t_sim > t_last => {
                    (count(&s) - before) / (t_sim - t_last)
                }
                _ => (c.read)(&s),
            };
            if let Some(count) = c.rate_of {
                *last = Some(count(&s));
            }
            out.push(value);
        }
        t_last = t_sim;
        if fault.is_none() {
            fault = s.dcmc_fault.map(|f| (rec.t_s[k], f));
        }
        peak_v = peak_v.max(s.sides[0].voltage_v.abs().max(s.sides[1].voltage_v.abs()));
        let u: Vec<f64> = inputs.iter().map(|col| col[k]).collect();
        sim.set_actuation(drive.actuation(&u));
        if let Some([l, r]) = &phases {
            sim.read_term_phase_at([l[k - rows.start], r[k - rows.start]]);
        }
    }
    // Coil readings depend on where the wire is: a path moved rigidly would not match them.
    if still - rows.start < MIN_STILL_ROWS && !chans.iter().any(|c| c.name.starts_with("sensor_")) {
        align_start_pose(rec, rows, chans, &mut simulated);
    }
    Ok((simulated, fault, peak_v))
}
