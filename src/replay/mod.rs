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

pub mod report;

use std::path::PathBuf;

use crate::ident::evaluate::fit_pct;
use crate::record::{vehicle_columns, Recording};
use crate::rig::RigKind;
use crate::scene::Scene;
use crate::sim::reduced::{ReducedBase, ReducedError};
use crate::sim::{Actuation, Sim, SimError, Snapshot};

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

/// How the recording drives the simulator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Drive {
    /// Left and right motor voltages, V.
    Voltages,
    /// Forward and turn demand into the DCMC, pct.
    Demands,
    /// A drive axis (the left drive, wheels lifted) on its motor voltage, V.
    AxisVoltage,
    /// A drive axis on its demand into the motor controller, pct (as a forward demand,
    /// so both sides run alike and the left one is compared).
    AxisDemand,
    /// A velocity command into the base controller (a ROS robot's `/cmd_vel`): forward
    /// speed, m/s, and yaw rate, rad/s.
    Velocity,
}

impl Drive {
    /// The recording's input columns this drive reads.
    pub fn columns(self) -> &'static [&'static str] {
        match self {
            Drive::Voltages => &["left_voltage_V", "right_voltage_V"],
            Drive::Demands => &["demand_fwd_pct", "demand_turn_pct"],
            Drive::AxisVoltage => &["voltage_V"],
            Drive::AxisDemand => &["demand_pct"],
            Drive::Velocity => &["cmd_linear_m_s", "cmd_angular_rad_s"],
        }
    }

    /// Whether the motors' voltages come from the recording itself, so the DCMC (its
    /// gains and limits) takes no part in the replay.
    pub fn bypasses_dcmc(self) -> bool {
        matches!(self, Drive::Voltages | Drive::AxisVoltage)
    }

    fn actuation(self, u: &[f64]) -> Actuation {
        match self {
            Drive::Voltages => Actuation::Voltage([u[0], u[1]]),
            Drive::Demands => Actuation::Demand {
                forward_pct: u[0],
                turn_pct: u[1],
            },
            Drive::AxisVoltage => Actuation::Voltage([u[0], 0.0]),
            Drive::AxisDemand => Actuation::Demand {
                forward_pct: u[0],
                turn_pct: 0.0,
            },
            Drive::Velocity => Actuation::Velocity {
                linear_m_s: u[0],
                angular_rad_s: u[1],
            },
        }
    }

    fn lifted(self) -> bool {
        matches!(self, Drive::AxisVoltage | Drive::AxisDemand)
    }
}

/// A simulator output a recording column can be compared with.
struct Channel {
    name: String,
    read: fn(&Snapshot) -> f64,
    /// For an encoder-derived speed, the angle (or rim distance) whose mean rate over
    /// the sample interval ending at the row is the output ([`encoder_source`]).
    rate_of: Option<fn(&Snapshot) -> f64>,
}

/// The quantity an encoder counts, for the outputs the contract derives from encoders:
/// `motor_speed_rad_s` (and each side's) and the wheel rim speeds are count differences
/// over the sample interval, so a row holds the *mean* speed over the interval ending at
/// it (the development set's convention, and what a rig's `sensors.motor_encoder_counts_per_rev`
/// states), not the speed at the instant: at a 25 ms interval the two differ by half an
/// interval's lag, which a fit would otherwise explain with a dead time. A gyro's yaw
/// rate and a current are read at the instant.
fn encoder_source(name: &str) -> Option<fn(&Snapshot) -> f64> {
    match name {
        "motor_speed_rad_s" | "left_motor_speed_rad_s" => Some(|s| s.sides[0].motor_angle_rad),
        "right_motor_speed_rad_s" => Some(|s| s.sides[1].motor_angle_rad),
        "left_wheel_speed_m_s" => Some(|s| s.sides[0].wheel_rim_distance_m),
        "right_wheel_speed_m_s" => Some(|s| s.sides[1].wheel_rim_distance_m),
        _ => None,
    }
}

/// Reads one output from a simulator snapshot.
type Probe = fn(&Snapshot) -> f64;

/// The drive-axis outputs (the left drive of the lifted simulator).
fn axis_channels() -> Vec<(&'static str, Probe)> {
    vec![
        ("motor_speed_rad_s", |s| s.sides[0].motor_speed_rad_s),
        ("motor_angle_rad", |s| s.sides[0].motor_angle_rad),
        ("wheel_angle_rad", |s| s.sides[0].wheel_angle_rad),
        ("current_A", |s| s.sides[0].current_a),
    ]
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

/// The drive the recording's columns give, voltages first (then demands, then velocity
/// commands).
pub fn drive_of(rec: &Recording) -> Result<Drive, ReplayError> {
    choose_drive(rec)
}

/// The drive the recording's columns give, voltages first.
fn choose_drive(rec: &Recording) -> Result<Drive, ReplayError> {
    let candidates: &[Drive] = match rec.rig {
        RigKind::DriveAxis => &[Drive::AxisVoltage, Drive::AxisDemand],
        RigKind::Vehicle | RigKind::Base => &[Drive::Voltages, Drive::Demands, Drive::Velocity],
        RigKind::DrivePair => &[Drive::Voltages, Drive::Demands],
    };
    candidates
        .iter()
        .copied()
        .find(|d| d.columns().iter().all(|c| rec.column(c).is_some()))
        .ok_or_else(|| {
            let wanted: Vec<String> = candidates
                .iter()
                .map(|d| d.columns().join(" and "))
                .collect();
            // Contract inputs the simulator's machine has no way to take: say why.
            let other: Vec<&str> = ["torque_Nm", "force_N", "command_V", "reference_rad", "reference_m"]
                .into_iter()
                .filter(|c| rec.column(c).is_some())
                .collect();
            let why = if other.is_empty() {
                String::new()
            } else {
                format!(
                    " ({} drive a current amplifier or a position loop, which the simulated AGV, DC motors behind the DCMC, does not have; `agvsim identify` and `diagnose` fit such records with their rig)",
                    other.join(", ")
                )
            };
            recording_err(
                rec,
                format!(
                    "no input the simulator can be driven by: expected {}{why}",
                    wanted.join(", or ")
                ),
            )
        })
}

/// Whether `other` can validate what is fitted on `rec`: a recording of the same rig,
/// driven by the same inputs, measuring at least one output `rec` measures; the message
/// says what differs (a recording of another rig or robot would print fits of nothing).
pub fn check_validation(rec: &Recording, other: &Recording) -> Result<(), NotAValidation> {
    if other.rig != rec.rig {
        return Err(NotAValidation::OtherRig {
            other: other.rig,
            fitted: rec.rig,
        });
    }
    let (a, b) = (choose_drive(rec)?, choose_drive(other)?);
    if a != b {
        return Err(NotAValidation::OtherDrive {
            other: b.columns().join(" and "),
            fitted: a.columns().join(" and "),
        });
    }
    let (mine, _) = channels(rec, a);
    let (theirs, _) = channels(other, b);
    let common = mine
        .iter()
        .filter(|c| theirs.iter().any(|t| t.name == c.name))
        .count();
    if common == 0 {
        return Err(NotAValidation::NoCommonOutput(
            mine.iter()
                .map(|c| c.name.as_str())
                .collect::<Vec<_>>()
                .join(", "),
        ));
    }
    Ok(())
}

/// Why a recording cannot validate what was fitted on another.
#[derive(Debug, thiserror::Error)]
pub enum NotAValidation {
    /// A recording of another rig kind.
    #[error("a `{other}` recording, where the recording fitted is `{fitted}`: validate on a recording of the same rig")]
    OtherRig {
        /// The validation recording's kind.
        other: RigKind,
        /// The fitted recording's kind.
        fitted: RigKind,
    },
    /// A recording no replay can drive.
    #[error(transparent)]
    Undriven(#[from] ReplayError),
    /// A recording driven by other inputs.
    #[error("driven by {other}, where the recording fitted is driven by {fitted}: validate on a recording of the same inputs")]
    OtherDrive {
        /// The validation recording's input columns.
        other: String,
        /// The fitted recording's.
        fitted: String,
    },
    /// A recording measuring none of the fitted outputs (named).
    #[error("measures none of the outputs the recording fitted measures ({0})")]
    NoCommonOutput(String),
}

/// A note when the recording also holds velocity commands that a voltage or demand drive
/// leaves unused: two drives in one recording, and the replay follows one.
fn unused_drive_note(rec: &Recording, drive: Drive) -> Option<String> {
    let velocity = Drive::Velocity.columns();
    let present = velocity.iter().all(|c| rec.column(c).is_some());
    (drive != Drive::Velocity && present && rec.rig == RigKind::Vehicle).then(|| {
        format!(
            "driven by {}; the velocity commands {} are in the recording too and were not used (voltages, then demands, then velocity commands: drop the columns of the drive not meant)",
            drive.columns().join(" and "),
            velocity.join(" and ")
        )
    })
}

/// The input columns, each held over missing cells (a cell before the first value is an
/// error: the start must be known).
fn held_inputs(rec: &Recording, drive: Drive) -> Result<Vec<Vec<f64>>, ReplayError> {
    drive
        .columns()
        .iter()
        .map(|name| {
            let col = rec.column(name).unwrap_or_default();
            let mut last = None;
            col.iter()
                .enumerate()
                .map(|(i, v)| {
                    last = v.or(last);
                    last.ok_or_else(|| {
                        recording_err(
                            rec,
                            format!(
                                "input `{name}` has no value at its first row (t = {} s)",
                                rec.t_s[i]
                            ),
                        )
                    })
                })
                .collect()
        })
        .collect()
}

/// The simulator outputs this recording has columns for.
fn channels(rec: &Recording, drive: Drive) -> (Vec<Channel>, Vec<String>) {
    let table: Vec<(&str, Probe)> = if drive.lifted() {
        axis_channels()
    } else {
        vehicle_columns()
            .into_iter()
            .filter(|c| c.name != "t_s")
            .map(|c| (c.name, c.value))
            .collect()
    };
    let mut found = vec![];
    let mut missing = vec![];
    for name in &rec.names {
        if drive.columns().contains(&name.as_str()) {
            continue;
        }
        match table.iter().find(|(n, _)| n == name) {
            Some((_, read))
                if !Drive::Demands.columns().contains(&name.as_str())
                    && !Drive::Velocity.columns().contains(&name.as_str()) =>
            {
                found.push(Channel {
                    name: name.clone(),
                    read: *read,
                    rate_of: encoder_source(name),
                })
            }
            _ => missing.push(name.clone()),
        }
    }
    (found, missing)
}

/// Rows at the start over which the inputs hold their first value (at least one): while
/// the command has not changed, a machine that starts from rest is still at its start.
fn rows_before_first_command_change(inputs: &[Vec<f64>]) -> usize {
    let n = inputs.first().map_or(0, Vec::len);
    (1..n)
        .find(|&k| inputs.iter().any(|col| col[k] != col[0]))
        .unwrap_or(n)
        .max(1)
}

/// Mean of the measured cells, if any.
fn mean_of(cells: &[Option<f64>]) -> Option<f64> {
    let v: Vec<f64> = cells.iter().flatten().copied().collect();
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

/// Mean direction of the measured headings (through their sines and cosines, so that
/// samples either side of +-pi average correctly); a single sample is returned as it is.
fn mean_heading(cells: &[Option<f64>]) -> Option<f64> {
    let v: Vec<f64> = cells.iter().flatten().copied().collect();
    match v.len() {
        0 => None,
        1 => Some(v[0]),
        _ => {
            let (s, c) = v
                .iter()
                .fold((0.0, 0.0), |(s, c), h| (s + h.sin(), c + h.cos()));
            Some(s.atan2(c))
        }
    }
}

/// What a replay runs: the simulator, or the reduced base a fit of a velocity-commanded
/// recording evaluates ([`crate::sim::reduced`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Engine {
    /// The simulator at the scene's fidelity.
    #[default]
    Simulator,
    /// The reduced velocity-commanded base: only for a vehicle on the floor driven by
    /// velocity commands.
    ReducedBase,
}

/// The machine a replay steps.
enum Machine {
    Full(Box<Sim>),
    Reduced(Box<ReducedBase>),
}

impl Machine {
    fn new(
        scene: &Scene,
        rec: &Recording,
        engine: Engine,
        coils: bool,
    ) -> Result<Machine, ReplayError> {
        Ok(match engine {
            Engine::Simulator => {
                let sim = Sim::new(scene)?;
                // A replay's recorded inputs drive the motors: the wire matters only to coil
                // readings compared with the recording's.
                Machine::Full(Box::new(if coils { sim } else { sim.without_coils() }))
            }
            Engine::ReducedBase => {
                Machine::Reduced(Box::new(ReducedBase::new(scene).map_err(|source| {
                    ReplayError::Reduced {
                        file: rec.path.clone(),
                        source,
                    }
                })?))
            }
        })
    }

    fn dt_s(&self) -> f64 {
        match self {
            Machine::Full(s) => s.params().sim.dt_s,
            Machine::Reduced(r) => r.dt_s(),
        }
    }

    fn step(&mut self) -> Result<(), SimError> {
        match self {
            Machine::Full(s) => s.step(),
            Machine::Reduced(r) => r.step(),
        }
    }

    fn snapshot(&self) -> Snapshot {
        match self {
            Machine::Full(s) => s.snapshot(),
            Machine::Reduced(r) => r.snapshot(),
        }
    }

    fn set_actuation(&mut self, a: Actuation) {
        match self {
            Machine::Full(s) => s.set_actuation(a),
            Machine::Reduced(r) => r.set_actuation(a),
        }
    }

    /// A periodic term's phase read at the encoders' angles (the reduced base has no
    /// terms).
    fn read_term_phase_at(&mut self, measured_rad: [f64; 2]) {
        if let Machine::Full(s) = self {
            s.read_term_phase_at(measured_rad);
        }
    }
}

/// The motor angles a periodic term is read at over `rows`, per side (left, right): the
/// recording's encoder angle (`motor_angle_rad`, or each side's `left_`/`right_`), or its
/// speed integrated from zero at the first row (an encoder's speed is its count
/// difference over the interval ending at its row, so the integral is exact to a count).
/// `None` where the scene has no periodic term, the recording neither column, or the
/// column never changes (an encoder that never turned, or a placeholder for the outputs
/// a replay is to simulate: the simulated angle is the phase then).
fn term_phases(
    scene: &Scene,
    rec: &Recording,
    rows: &std::ops::Range<usize>,
) -> Option<[Vec<f64>; 2]> {
    use crate::model::term::Family;
    let periodic = scene
        .term
        .families_on()
        .iter()
        .any(|f| matches!(f, Family::PeriodicMotorAngle | Family::PeriodicWheelAngle));
    if !periodic {
        return None;
    }
    let side = |prefix: &str| -> Option<Vec<f64>> {
        let t = &rec.t_s[rows.clone()];
        let angle: Option<Vec<f64>> = rec
            .column(&format!("{prefix}angle_rad"))
            .and_then(|c| c[rows.clone()].iter().copied().collect());
        let speed = rec
            .column(&format!("{prefix}speed_rad_s"))
            .map(|c| &c[rows.clone()]);
        let theta = crate::ident::data::measured_angle(t, angle.as_deref(), speed)?;
        let turned = theta.iter().any(|x| *x != theta[0]);
        turned.then_some(theta)
    };
    match (side("motor_"), side("left_motor_"), side("right_motor_")) {
        (Some(m), _, _) => Some([m.clone(), m]),
        (None, Some(l), Some(r)) => Some([l, r]),
        _ => None,
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
    if engine == Engine::ReducedBase && drive != Drive::Velocity {
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

/// Voltage inputs beyond what the scene's drive delivers, which the bridges clip.
fn clipped_inputs(scene: &Scene, drive: Drive, inputs: &[Vec<f64>]) -> Vec<String> {
    if !matches!(drive, Drive::Voltages | Drive::AxisVoltage) {
        return vec![];
    }
    let limit = scene
        .battery
        .drive_limit_v
        .min(scene.battery.open_circuit_v);
    let over = inputs
        .iter()
        .flatten()
        .filter(|v| v.abs() > limit * (1.0 + 1e-9))
        .count();
    let peak = inputs.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    if over == 0 {
        return vec![];
    }
    vec![format!(
        "{over} input value(s) up to {} V exceed the scene's drive (battery.drive_limit_V = {} V on a {} V battery) and were clipped to it: is the scene's battery the recording's?",
        crate::param::plain_number(peak),
        scene.battery.drive_limit_v,
        scene.battery.open_circuit_v
    )]
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
    if let (Some(x), Some(y)) = (start("x_m"), start("y_m")) {
        scene.start.x_m = x;
        scene.start.y_m = y;
    }
    if let Some(c) = rec.column("heading_rad") {
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

/// Rows of rest at a segment's start from which its start pose is averaged well enough
/// (a tracker's noise over 20 samples is a fifth of one sample's); with fewer the start
/// pose is fitted over [`START_POSE_WINDOW_S`] instead ([`align_start_pose`]).
const MIN_STILL_ROWS: usize = 20;

/// Span at a segment's start over which its start pose is fitted when the machine moves
/// from the first row, s: long enough to average the tracker's noise, short enough that
/// a model still being fitted stays close to the measurement.
const START_POSE_WINDOW_S: f64 = 0.25;

/// Fits the start pose of a segment that moves from its first row, where one noisy
/// sample would set it (a tracker's 5 mrad on the heading turns the whole replayed path,
/// and a fit bends the machine's keys to follow it). The floor is the same everywhere,
/// so a start pose off by a rotation and a shift moves the whole simulated path rigidly:
/// the heading is corrected by the mean measured-less-simulated heading over the window,
/// the path turned by it about its first point, then shifted by the mean position
/// difference. Outputs other than the pose are unchanged.
fn align_start_pose(
    rec: &Recording,
    rows: std::ops::Range<usize>,
    chans: &[Channel],
    simulated: &mut [Vec<f64>],
) {
    let find = |name: &str| chans.iter().position(|c| c.name == name);
    let (Some(ix), Some(iy), Some(ih)) = (find("x_m"), find("y_m"), find("heading_rad")) else {
        return;
    };
    let (Some(mx), Some(my), Some(mh)) = (
        rec.column("x_m"),
        rec.column("y_m"),
        rec.column("heading_rad"),
    ) else {
        return;
    };
    let t0 = rec.t_s[rows.start];
    let window: Vec<usize> = (0..rows.len())
        .take_while(|&j| rec.t_s[rows.start + j] - t0 <= START_POSE_WINDOW_S)
        .filter(|&j| {
            let k = rows.start + j;
            mx[k].is_some() && my[k].is_some() && mh[k].is_some()
        })
        .collect();
    if window.len() < 2 {
        return;
    }
    let n = window.len() as f64;
    let (s, c) = window.iter().fold((0.0, 0.0), |(s, c), &j| {
        let d = mh[rows.start + j].unwrap() - simulated[ih][j];
        (s + d.sin(), c + d.cos())
    });
    let turn = s.atan2(c);
    let (x0, y0) = (simulated[ix][0], simulated[iy][0]);
    let (sin, cos) = turn.sin_cos();
    for j in 0..rows.len() {
        let (dx, dy) = (simulated[ix][j] - x0, simulated[iy][j] - y0);
        simulated[ix][j] = x0 + cos * dx - sin * dy;
        simulated[iy][j] = y0 + sin * dx + cos * dy;
        simulated[ih][j] += turn;
    }
    let shift = |m: &[Option<f64>], i: usize, sim: &[Vec<f64>]| {
        window
            .iter()
            .map(|&j| m[rows.start + j].unwrap() - sim[i][j])
            .sum::<f64>()
            / n
    };
    let (sx, sy) = (shift(mx, ix, simulated), shift(my, iy, simulated));
    for j in 0..rows.len() {
        simulated[ix][j] += sx;
        simulated[iy][j] += sy;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A path simulated from a start pose 0.02 rad and a few millimetres off (one noisy
    /// sample's) is turned and shifted back onto the measured one: after alignment it
    /// matches the measured path everywhere within a fraction of a millimetre, far
    /// beyond the window it was fitted on.
    #[test]
    fn a_start_pose_off_by_one_samples_noise_is_fitted_out_rigidly() {
        let n = 400;
        let t: Vec<f64> = (0..n).map(|k| k as f64 * 0.005).collect();
        let path = |t: f64| [t + 0.2 * t * t, 0.3 * t * t, 0.4 * t];
        let mut text = String::from("# agvsim-recording: 1\n# rig: vehicle\nt_s,left_voltage_V,right_voltage_V,x_m,y_m,heading_rad\n");
        for &t in &t {
            let p = path(t);
            text.push_str(&format!("{t},1,1,{},{},{}\n", p[0], p[1], p[2]));
        }
        let rec = Recording::parse(&text, std::path::Path::new("moving.csv")).unwrap();
        let chans: Vec<Channel> = ["x_m", "y_m", "heading_rad"]
            .iter()
            .map(|n| Channel {
                name: n.to_string(),
                read: |_| 0.0,
                rate_of: None,
            })
            .collect();
        // The simulated path: the measured one turned 0.02 rad and shifted by (3, -2) mm.
        let (turn, ox, oy) = (0.02_f64, 0.003, -0.002);
        let (s, c) = turn.sin_cos();
        let mut sim: Vec<Vec<f64>> = vec![vec![]; 3];
        for &t in &t {
            let p = path(t);
            sim[0].push(ox + c * p[0] - s * p[1]);
            sim[1].push(oy + s * p[0] + c * p[1]);
            sim[2].push(p[2] + turn);
        }
        align_start_pose(&rec, 0..n, &chans, &mut sim);
        for k in 0..n {
            let p = path(t[k]);
            for i in 0..3 {
                assert!(
                    (sim[i][k] - p[i]).abs() < 1e-9,
                    "row {k}, pose {i}: {} vs {}",
                    sim[i][k],
                    p[i]
                );
            }
        }
    }
}
