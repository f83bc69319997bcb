//! The shape of the `agvsim` command line: its commands, their options and the value
//! checks clap runs on them. `main` dispatches what is parsed here.

use std::path::PathBuf;

use clap::{Parser, Subcommand};

use agvsim::experiment::{DemandPattern, ExperimentKind};
use agvsim::ident::ModelChoice;

#[derive(Parser)]
#[command(
    name = "agvsim",
    version,
    about = "Simulate, identify and diagnose wire-guided AGVs"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand)]
pub enum ImportFormat {
    /// A ROS bag (a ROS 2 .mcap or .db3 file or rosbag2 folder with metadata.yaml, or a ROS 1
    /// .bag file) of a robot driven by velocity commands: BAG.csv, a `vehicle` recording
    /// with cmd_linear_m_s, cmd_angular_rad_s from the Twist topic, wheel speeds from
    /// JointState (else from the Odometry twist and the track), yaw rate from Imu, odom_*
    /// from Odometry (the robot's own odometry, not ground truth), x_m/y_m/heading_rad from
    /// an independent pose (a /tf chain to the base, or a PoseStamped,
    /// PoseWithCovarianceStamped or mocap Odometry topic), and how each was made in its
    /// header; and BAG.scene.toml when the track and wheel radius are known (from
    /// /robot_description, the flags or --controller-yaml).
    #[command(alias = "ros1", alias = "ros")]
    Ros2 {
        /// The bag.
        bag: PathBuf,
        /// A topic map (TOML) choosing among several topics of a type: keys cmd_vel,
        /// joint_states, imu, odom, battery, pose = "PARENT:CHILD" (frames on /tf) or
        /// "/topic", left_wheel_joint, right_wheel_joint, time = "header" or "log".
        #[arg(long, value_name = "MAP.toml")]
        map: Option<PathBuf>,
        /// Output folder [default: runs/import].
        #[arg(long)]
        out: Option<PathBuf>,
        /// Drive wheel radius, m [default: from /robot_description].
        #[arg(long, value_parser = positive_number)]
        wheel_radius_m: Option<f64>,
        /// Track width, m [default: from /robot_description].
        #[arg(long, value_parser = positive_number)]
        track_m: Option<f64>,
        /// Robot mass for the scene, kg [default: the thesis machine's 120, said as such].
        #[arg(long, value_parser = positive_number)]
        mass_kg: Option<f64>,
        /// The robot's `diff_drive_controller` parameters (YAML, as ros2_control loads
        /// them): its wheel_separation, wheel_radius and their multipliers become the
        /// scene's configured odometry, its velocity and acceleration limits the base
        /// controller's.
        #[arg(long, value_name = "PARAMS.yaml")]
        controller_yaml: Option<PathBuf>,
        /// The battery, the motor and the gear [default: the battery topic's median
        /// voltage; the thesis machine's motor and gear, said as assumed; no gear play].
        #[command(flatten)]
        drive: DriveArgs,
    },
    /// A MATLAB file (MAT level 5, as `save` writes by default) by a map file like the
    /// CSV's, each `column` naming a variable (a vector).
    ///
    /// The map (TOML) names the rig, the time column and each contract column's source,
    /// with a unit (ms, us, rpm, deg, deg_s, rev, mm, cm, mm_s, mV, mA, mNm) or a `scale`
    /// (and an optional `offset`):
    ///
    ///     rig = "drive_axis"
    ///     time = { column = "time_ms", unit = "ms" }
    ///     [columns]
    ///     voltage_V = { column = "volts" }
    ///     motor_speed_rad_s = { column = "vel_rpm", unit = "rpm" }
    ///     current_A = { column = "amps_x10", scale = 0.1 }
    ///
    /// docs/commands.md (import csv) and docs/matlab.md have more.
    #[command(verbatim_doc_comment)]
    Mat {
        /// The MAT-file.
        file: PathBuf,
        /// The map file (TOML).
        #[arg(long, value_name = "MAP.toml")]
        map: PathBuf,
        /// Output folder [default: runs/import]; the recording is FILE_STEM.csv there.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Any CSV whose columns have other names or units, by a map file: the time and each
    /// contract column with its source column and unit or scale.
    ///
    /// The map (TOML) names the rig, the time column and each contract column's source,
    /// with a unit (ms, us, rpm, deg, deg_s, rev, mm, cm, mm_s, mV, mA, mNm) or a `scale`
    /// (and an optional `offset`):
    ///
    ///     rig = "drive_axis"
    ///     time = { column = "time_ms", unit = "ms" }
    ///     [columns]
    ///     voltage_V = { column = "volts" }
    ///     motor_speed_rad_s = { column = "vel_rpm", unit = "rpm" }
    ///     current_A = { column = "amps_x10", scale = 0.1 }
    ///
    /// docs/commands.md (import csv) and docs/matlab.md have more.
    #[command(verbatim_doc_comment)]
    Csv {
        /// The CSV file (a header row, then data).
        file: PathBuf,
        /// The map file (TOML).
        #[arg(long, value_name = "MAP.toml")]
        map: PathBuf,
        /// Output folder [default: runs/import]; the recording is FILE_STEM.csv there.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// A WPILib SysId log (SysId's JSON data file, or a DataLog .wpilog written by
    /// SysIdRoutineLog): one recording per test (FILE_STEM_TEST.csv; rig `vehicle` for a
    /// drivetrain, `drive_axis` for one mechanism), the nominal rig of the linear machine
    /// SysId's kV and kA describe (FILE_STEM.rig.toml), and SysId's kS, kV, kA (kG).
    Wpilib {
        /// The log (.json or .wpilog).
        file: PathBuf,
        /// Output folder [default: runs/import].
        #[arg(long)]
        out: Option<PathBuf>,
        /// DataLog only: the routine (the LOG of `sysid-test-state-LOG`) when there are several.
        #[arg(long)]
        routine: Option<String>,
        /// DataLog only: the motor of a single mechanism, or LEFT,RIGHT of a drivetrain
        /// [default: the routine's one motor, or its motors named left and right].
        #[arg(long, value_delimiter = ',')]
        motors: Vec<String>,
        /// DataLog only: drivetrain, drivetrain-angular, simple, elevator or arm
        /// [default: a drivetrain for two motors (angular when driven in opposition), else simple].
        #[arg(long, value_parser = parse_mechanism)]
        mechanism: Option<agvsim::import::wpilib::Mechanism>,
        /// Drive wheel (or a linear mechanism's drum) radius, m: needed for a drivetrain
        /// logged in rotations; the vehicle rig's wheel [default 0.0762].
        #[arg(long, value_parser = positive_number)]
        wheel_radius_m: Option<f64>,
        /// Motor resistance per side, ohm [default: from the logged current, else 0.05, said as assumed].
        #[arg(long, value_parser = positive_number)]
        resistance_ohm: Option<f64>,
        /// Track width, m [default: from a turning test's gyro, else 0.6, said as assumed]
        /// (`--track-width-m` is an older name for it).
        #[arg(long = "track-m", alias = "track-width-m", value_parser = positive_number)]
        track_width_m: Option<f64>,
        /// Battery voltage, V [default: none stated; the logged voltages are the applied ones]
        /// (`--supply-v` is an older name for it).
        #[arg(long = "battery-V", alias = "supply-v", value_parser = positive_number)]
        supply_v: Option<f64>,
    },
}

fn parse_mechanism(s: &str) -> Result<agvsim::import::wpilib::Mechanism, String> {
    s.parse()
}

pub fn positive_number(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("`{s}`: expected a positive number")),
    }
}

#[derive(Subcommand)]
pub enum Command {
    /// Simulate a scene and write its recording (CSV, exchange format) and summary.
    Run {
        /// Scene file (TOML), e.g. scenes/lab_offset_120mm.toml.
        scene: PathBuf,
        /// Output folder [default: runs/SCENE_NAME].
        #[arg(long)]
        out: Option<PathBuf>,
        /// Override a scene value, e.g. --set controller.kp_num=-2 (repeatable).
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
        /// Simulated time, s (overrides sim.duration_s).
        #[arg(long, value_parser = positive_seconds)]
        duration: Option<f64>,
        /// Seed of the sensor noise (overrides sim.seed).
        #[arg(long)]
        seed: Option<u64>,
        /// Write a Rerun recording to this .rrd file.
        #[arg(long, value_name = "FILE.rrd")]
        save: Option<PathBuf>,
        /// Open the Rerun viewer and stream to it.
        #[arg(long, conflicts_with_all = ["save", "connect"])]
        spawn: bool,
        /// Stream to a running Rerun viewer.
        #[arg(long, conflicts_with_all = ["save"])]
        connect: bool,
        /// Interval between Rerun frames, s.
        #[arg(long, default_value_t = 0.02, value_parser = positive_seconds)]
        rerun_interval: f64,
    },
    /// Drive the simulator (the scene, at its fidelity) with a recording's inputs instead of
    /// its firmware and compare its outputs with the recording's: fit per output, the
    /// simulated recording beside the measured one, a plot per output.
    Replay {
        /// Scene file (TOML): the machine to replay on.
        #[arg(long)]
        scene: PathBuf,
        /// Recording (exchange format) whose inputs drive the simulator.
        #[arg(long, value_name = "NAME.csv")]
        recording: PathBuf,
        /// Output folder [default: runs/replay_RECORDING_NAME].
        #[arg(long)]
        out: Option<PathBuf>,
        /// Override a scene value, e.g. --set chassis.mass_kg=300 (repeatable).
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
        /// Also write the measured and simulated outputs to this Rerun .rrd file.
        #[arg(long, value_name = "FILE.rrd")]
        save: Option<PathBuf>,
    },
    /// Fit the scene's uncertain keys to a recording through the simulator itself, print
    /// each key before and after and the replay fit on the original and calibrated scene,
    /// and write the calibrated scene.
    Calibrate {
        /// Scene file (TOML): its values are the beliefs.
        #[arg(long)]
        scene: PathBuf,
        /// Recording (exchange format) to fit. Repeat it to fit several tests of one
        /// machine together: each is replayed from rest, and all share the scene's keys.
        #[arg(long, required = true, value_name = "NAME.csv")]
        recording: Vec<PathBuf>,
        /// Comma-separated scene keys to fit [default: the recording kind's set: motor
        /// resistance, torque constant, rotor inertia, viscous friction for a lifted drive;
        /// torque constant, resistance, chassis mass and yaw inertia for a vehicle; chassis mass, yaw inertia and the base's speed-loop gains for a vehicle driven by velocity commands].
        /// `none`: fit only the effects' keys.
        #[arg(long, value_delimiter = ',')]
        free: Vec<String>,
        /// Comma-separated effects of the contract's vocabulary to try (backlash,
        /// coulomb_friction, friction_asymmetry, offset, voltage_saturation, battery_sag,
        /// transport_delay, speed_feedback, wheel_slip, castor_drag, wheel_geometry): each is switched on
        /// through its scene key and fitted with the free keys, and kept only where the
        /// recording gives evidence for it. `all`: every effect this recording can show;
        /// `none`: the free keys only.
        #[arg(
            long,
            value_delimiter = ',',
            value_name = "NAME,...",
            default_value = "all"
        )]
        effects: Vec<String>,
        /// Write the calibrated scene here (the original text with the fitted keys
        /// replaced and commented).
        #[arg(long, value_name = "CALIBRATED.toml")]
        write: Option<PathBuf>,
        /// Another recording to compare the original and calibrated scenes on (repeat it
        /// for several tests: compared together, each from rest).
        #[arg(long, value_name = "OTHER.csv")]
        validate: Vec<PathBuf>,
        /// Override a scene value before fitting (repeatable).
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
        /// Write the result (keys, fits) as JSON here.
        #[arg(long, value_name = "OUT.json")]
        json: Option<PathBuf>,
        /// Write a plot per fitted output (measured, original and calibrated replays) here.
        #[arg(long, value_name = "DIR")]
        report: Option<PathBuf>,
        /// Also write the measured outputs with the original and calibrated scenes' replays,
        /// overlaid per output on one timeline, to this Rerun .rrd file.
        #[arg(long, value_name = "FILE.rrd")]
        save: Option<PathBuf>,
        /// Write one self-contained HTML report here (the recording, the keys with their
        /// standard deviations and verdicts, each effect tried with its evidence, the fits
        /// before and after with the plots, the scene's changes, the command).
        #[arg(long, value_name = "FILE.html")]
        html: Option<PathBuf>,
        /// Worker threads [default: one per core]; the result is the same for any count.
        #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
        jobs: Option<u32>,
    },
    /// Convert a recording kept in another format into the exchange format.
    Import {
        #[command(subcommand)]
        format: ImportFormat,
    },
    /// Run a scene over a grid of values in parallel and tabulate the metrics of every run
    /// (results.csv, plots); `sweep merge` joins shard folders.
    Sweep(SweepArgs),
    /// Run a shipped study (sweeps plus an analysis). Writes summary.md, plots and the
    /// sweeps' results.
    #[command(after_help = agvsim::study::StudyKind::listing())]
    Study {
        /// The study: one of the names listed below.
        #[arg(value_parser = |s: &str| s.parse::<agvsim::study::StudyKind>())]
        name: agvsim::study::StudyKind,
        /// Output folder [default: runs/study_NAME].
        #[arg(long)]
        out: Option<PathBuf>,
        /// Parallel runs [default: one per core].
        #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
        jobs: Option<u32>,
        /// A coarser grid: the same analysis on fewer runs.
        #[arg(long)]
        quick: bool,
    },
    /// Linearise the scene's plant (drivetrains and chassis) about straight running on the
    /// wire and report controllability from the motor voltages and observability from the
    /// coil pair (ranks, and which states the coils cannot see), then close the P-D loop
    /// around it and report its poles and stability. The full level is linearised as its
    /// no-slip counterpart.
    Linearize {
        /// Scene file (TOML), e.g. scenes/lab_offset_120mm.toml.
        scene: PathBuf,
        /// Override a scene value, e.g. --set controller.reverse=true (repeatable).
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
        /// Also write A, B, C, D (discrete-time, with Ts and the named states, inputs and
        /// outputs and their units) to FILE.mat (MATLAB `load`, SciPy `loadmat`) or FILE.json.
        #[arg(long, value_name = "FILE.mat|FILE.json")]
        export: Option<PathBuf>,
    },
    /// List the tyre compounds and floor surfaces and the tyre values they combine into.
    Presets,
    /// Print the scene reference: every key, the values it allows and its default (the
    /// table the scene is validated against, in Markdown).
    Keys,
    /// Write a new robot's scene from the numbers its builder knows: mass, track, wheel
    /// radius, battery, the motor's datasheet point and gear ratio. Every other value is
    /// derived (yaw inertia from mass and footprint, motor resistance and torque constant
    /// from the datasheet, DCMC gains from the motor and battery, limits from the battery)
    /// and commented with how. Example: agvsim new my_robot.toml --mass-kg 60 --track-m 0.4
    /// --wheel-radius-m 0.05 --battery-V 12 --motor-rated-V 12 --motor-no-load-rpm 3000
    /// --motor-stall-current-A 20 --gear-ratio 20 --tyre soft_rubber
    New(NewArgs),
    /// Diagnose or calibrate every recording of a fleet (a folder of NAME.csv, each with
    /// NAME.rig.toml beside it, or a list file), in parallel and shardable across a
    /// cluster's array tasks (--shard I/N or auto); each result is written whole as it
    /// finishes, a rerun keeps finished ones, and `batch merge` joins shards into one
    /// summary.csv and fleet.md.
    Batch {
        #[command(subcommand)]
        action: BatchAction,
    },
    /// Load a scene and report values that do not fit the machine's own size and supply
    /// (yaw inertia against mass and footprint, drive limit against the battery, fault
    /// threshold against the sag, DCMC gains against the motor, tyre friction), each with
    /// the key, its value, what was expected and why. `run`, `replay` and `calibrate` print
    /// the same warnings.
    Check {
        /// Scene file (TOML).
        scene: PathBuf,
        /// Override a scene value, e.g. --set chassis.mass_kg=60 (repeatable).
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
    },
    /// Run one of the thesis's lab experiments on a simulated AGV; write the recording and
    /// its rig file (exchange format).
    Experiment {
        /// lifted-random-demand, falling-weight, coast-down or floor-run.
        #[arg(value_parser = |s: &str| s.parse::<ExperimentKind>())]
        kind: ExperimentKind,
        /// Scene file (TOML) giving the machine, e.g. scenes/lab_offset_120mm.toml.
        scene: PathBuf,
        /// Output folder.
        #[arg(long, default_value = "runs/experiments")]
        out: PathBuf,
        /// File stem of the outputs [default: the experiment's name].
        #[arg(long)]
        name: Option<String>,
        /// Seed of noise and random demands (overrides sim.seed).
        #[arg(long)]
        seed: Option<u64>,
        /// Sample interval, s (floor-run: dash interval) [default: 0.025 lifted, 0.002
        /// falling weight, 0.005 coast-down, 0.25 floor-run].
        #[arg(long, value_parser = positive_seconds)]
        interval: Option<f64>,
        /// Length of a lifted-wheel run, s.
        #[arg(long, default_value_t = 15.0, value_parser = positive_seconds)]
        duration: f64,
        /// Lifted-wheel demand: pulses (microcontroller pattern) or walk (joystick-like).
        #[arg(long, default_value = "pulses", value_parser = |s: &str| s.parse::<DemandPattern>())]
        pattern: DemandPattern,
        /// Peak forward demand, pct (turn peaks at half).
        #[arg(long, default_value_t = 40.0, value_parser = demand_pct)]
        peak_demand: f64,
        /// Pulses: each demand level is held a random whole number of samples in MIN..MAX
        /// (both included); 20..60 is joystick-like at 25 ms.
        #[arg(long, default_value = "4..16", value_parser = hold_range)]
        hold: (usize, usize),
        /// RMS white noise on encoder speeds, rad/s.
        #[arg(long, default_value_t = 0.5, value_parser = non_negative)]
        speed_noise: f64,
        /// Largest relative error of the rig file's beliefs, e.g. 0.2 for up to 20 %.
        #[arg(long, default_value_t = 0.0, value_parser = non_negative)]
        rig_error: f64,
    },
    /// Find what physics the rig's model leaves out: fit the nominal model, locate the
    /// residual by regime, fit each candidate effect, keep what is significant (with
    /// --scene: through the simulator).
    #[command(group(clap::ArgGroup::new("machine").required(true).multiple(false)))]
    Diagnose {
        /// Rig file (NAME.rig.toml): the fitting models' nominal machine.
        #[arg(long, group = "machine")]
        rig: Option<PathBuf>,
        /// Scene file instead of a rig: diagnose through the simulator itself (the scene's
        /// free keys fitted, then each effect switched on through its scene key, as
        /// calibrate does), for recordings the fitting models cannot take, such as a robot
        /// driven by velocity commands (cmd_linear_m_s, cmd_angular_rad_s).
        #[arg(long, group = "machine")]
        scene: Option<PathBuf>,
        /// Recording (NAME.csv, exchange format). Repeat it to diagnose several tests of
        /// one machine together (SysId's quasistatic and dynamic tests, forward and
        /// backward): they share the machine's parameters and each starts from rest.
        #[arg(long, required = true, value_name = "NAME.csv")]
        recording: Vec<PathBuf>,
        /// A second recording to check the diagnosed model on.
        #[arg(long, value_name = "OTHER.csv")]
        validate: Option<PathBuf>,
        /// Write the diagnosis JSON (contract format) here.
        #[arg(long, value_name = "OUT.json")]
        json: Option<PathBuf>,
        /// Write a report folder (text, SVG plots of baseline and diagnosed fits).
        #[arg(long, value_name = "DIR")]
        report: Option<PathBuf>,
        /// Save measured, baseline and diagnosed outputs to a Rerun .rrd file.
        #[arg(long, value_name = "FILE.rrd")]
        save: Option<PathBuf>,
        /// Write one self-contained HTML report here (the recording, the estimates with their
        /// standard deviations and verdicts, the fits before and after with the plots, the
        /// command): no network needed to open it.
        #[arg(long, value_name = "FILE.html")]
        html: Option<PathBuf>,
        /// Comma-separated effects of the contract's vocabulary to try (backlash,
        /// coulomb_friction, friction_asymmetry, offset, voltage_saturation, battery_sag,
        /// transport_delay, speed_feedback, wheel_slip, castor_drag, wheel_geometry). `all`: every effect
        /// that applies to the rig's model; `none`: the nominal model only.
        #[arg(
            long,
            value_delimiter = ',',
            value_name = "NAME,...",
            default_value = "all"
        )]
        effects: Vec<String>,
        /// Worker threads [default: one per core]; the result is the same for any count.
        #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
        jobs: Option<u32>,
    },
    /// Prove the diagnosis on agvsim's own recordings with concealed effects (and a clean
    /// one): each effect must be found within 15 % and nothing on the clean case.
    Prove {
        /// Output folder for the recordings, rigs and diagnoses.
        #[arg(long, default_value = "runs/prove")]
        out: PathBuf,
        /// The small version (clean, Coulomb friction, voltage saturation; 8 s records).
        #[arg(long)]
        quick: bool,
        /// Seed of inputs, noise and rig errors.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Run only these cases (comma-separated names, e.g. `backlash,vehicle_clean`; with
        /// `--calibrate`, any part of a case's name, e.g. `sysid,base_velocity/cmd_vel_steps/clean`).
        #[arg(long = "case", value_delimiter = ',', value_name = "NAME,...")]
        cases: Vec<String>,
        /// Prove `calibrate` instead: round trips through the simulator, each effect a
        /// recording kind can show concealed in a machine recorded on the excitations
        /// people use, calibrated from a scene 5-20 % off with every effect offered; the
        /// concealed effect must be accepted first within 10 %, and nothing on a clean
        /// recording. Prints each case and the 1-sigma coverage of the fitted keys.
        #[arg(long)]
        calibrate: bool,
    },
    /// Fit a rig's model to a recording: parameters with standard deviations, loss, FPE,
    /// AIC, fit per output and residual checks.
    Identify {
        /// Rig file (NAME.rig.toml).
        #[arg(long)]
        rig: PathBuf,
        /// Recording (NAME.csv, exchange format). Repeat it to fit several tests of one
        /// machine together (they share its parameters; each starts from rest).
        #[arg(long, required = true, value_name = "NAME.csv")]
        recording: Vec<PathBuf>,
        /// Model structure: drive-axis, falling-weight, coast-down, gain, p or pi
        /// [default: from the recording's experiment, else the rig kind].
        #[arg(long, value_parser = |s: &str| s.parse::<ModelChoice>())]
        model: Option<ModelChoice>,
        /// Comma-separated parameters to fit [default: the structure's identifiable set].
        #[arg(long, value_delimiter = ',')]
        free: Option<Vec<String>>,
        /// A second recording to check the identified model on.
        #[arg(long, value_name = "OTHER.csv")]
        validate: Option<PathBuf>,
        /// Write the report as JSON here.
        #[arg(long, value_name = "OUT.json")]
        json: Option<PathBuf>,
        /// Write a report folder (SVG plots of the fit and the residual checks) here
        /// (`--plot` is an older name for it).
        #[arg(long, value_name = "DIR", alias = "plot")]
        report: Option<PathBuf>,
        /// Save measured and simulated outputs to a Rerun .rrd file.
        #[arg(long, value_name = "FILE.rrd")]
        save: Option<PathBuf>,
        /// Write one self-contained HTML report here (the recording, the estimates with their
        /// standard deviations and verdicts, the fits before and after with the plots, the
        /// command): no network needed to open it.
        #[arg(long, value_name = "FILE.html")]
        html: Option<PathBuf>,
        /// Number of solver starts (rig values, then perturbed within a factor 2).
        #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=50))]
        starts: u32,
        /// Iteration limit of each start.
        #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u32).range(1..=10000))]
        max_iterations: u32,
    },
}

pub fn positive_seconds(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .parse()
        .map_err(|_| format!("`{s}` is not a number of seconds"))?;
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(format!("`{s}`: expected a positive number of seconds"))
    }
}

fn non_negative(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err(format!("`{s}`: expected a number >= 0")),
    }
}

/// `MIN..MAX` whole samples, 1 <= MIN <= MAX.
fn hold_range(s: &str) -> Result<(usize, usize), String> {
    let bad =
        || format!("`{s}`: expected MIN..MAX whole samples with 1 <= MIN <= MAX, e.g. 20..60");
    let (a, b) = s.split_once("..").ok_or_else(bad)?;
    let (a, b): (usize, usize) = (
        a.trim().parse().map_err(|_| bad())?,
        b.trim().parse().map_err(|_| bad())?,
    );
    if a >= 1 && a <= b {
        Ok((a, b))
    } else {
        Err(bad())
    }
}

fn demand_pct(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v > 0.0 && v <= 100.0 => Ok(v),
        _ => Err(format!("`{s}`: expected a demand in percent, 0 < d <= 100")),
    }
}

#[derive(clap::Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct SweepArgs {
    #[command(subcommand)]
    pub action: Option<SweepAction>,
    /// Scene file (TOML), e.g. scenes/high_gain_slip.toml.
    #[arg(required = true)]
    pub scene: Option<PathBuf>,
    /// A scene key and its values: a list (tyre.compound=hard_polyurethane,soft_rubber), a
    /// linear range LO..HI:N (controller.gain_scale=0.1..6:25) or a log range
    /// log:LO..HI:N. Repeat for a full grid; the first is the slowest in run order.
    #[arg(long = "vary", value_name = "KEY=VALUES", required = true)]
    pub vary: Vec<String>,
    /// Runs per grid point, with noise seeds sim.seed, sim.seed+1, ...
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=10000))]
    pub repeat: u32,
    /// Parallel runs [default: one per core]. Results do not depend on it.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub jobs: Option<u32>,
    /// Run only the I-th of N contiguous slices of the runs (e.g. a cluster job array);
    /// join the slices' folders with `agvsim sweep merge`.
    /// `auto`: from the scheduler's array variables (see `agvsim batch diagnose --help`).
    #[arg(long, value_name = "I/N|auto")]
    pub shard: Option<String>,
    /// Output folder [default: runs/sweep_SCENE_NAME, with _shard_I_of_N when sharded].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Override a scene value for every run, e.g. --set sim.duration_s=10 (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Simulated time of each run, s (overrides sim.duration_s).
    #[arg(long, value_parser = positive_seconds)]
    pub duration: Option<f64>,
    /// Also write every run's path and lateral error (traces/run_NNNNN.csv).
    #[arg(long)]
    pub traces: bool,
    /// Refuse grids of more runs than this (a guard against a typo that asks for a
    /// million runs).
    #[arg(long, default_value_t = agvsim::sweep::DEFAULT_MAX_RUNS)]
    pub max_runs: usize,
    /// Continue an interrupted sweep in its --out folder (same arguments): its finished
    /// runs are kept and only the rest are run.
    #[arg(long)]
    pub resume: bool,
}

#[derive(Subcommand)]
pub enum SweepAction {
    /// Join the folders of `--shard` runs of one sweep into the unsharded result.
    Merge {
        /// The shard folders, in any order.
        #[arg(required = true)]
        shards: Vec<PathBuf>,
        /// Folder for the merged results.csv, sweep.toml and plots.
        #[arg(long)]
        out: PathBuf,
    },
}

/// `agvsim new`'s numbers: each in its unit; without --from the first eight are needed.
#[derive(clap::Args)]
pub struct NewArgs {
    /// The scene file to write (refused if it exists, unless --force).
    #[arg(value_name = "NAME.toml")]
    pub out: PathBuf,
    /// Start from this scene: its values stand where no number is given, and only values
    /// derived from the numbers given are derived again.
    #[arg(long, value_name = "SCENE.toml")]
    pub from: Option<PathBuf>,
    /// Mass with batteries, kg.
    #[arg(long, value_parser = positive_number)]
    pub mass_kg: Option<f64>,
    /// Distance between the drive wheels' contact patches, m.
    #[arg(long, value_parser = positive_number)]
    pub track_m: Option<f64>,
    /// Drive wheel radius, m.
    #[arg(long, value_parser = positive_number)]
    pub wheel_radius_m: Option<f64>,
    /// The battery, the motor and the gear.
    #[command(flatten)]
    pub drive: DriveArgs,
    /// Tyre compound: hard_polyurethane, soft_rubber or high_grip (`agvsim presets`)
    /// [default: hard_polyurethane].
    #[arg(long)]
    pub tyre: Option<String>,
    /// Castors: yes (four, carrying 40 % of the load) or no (every load on the drive
    /// wheels) [default: yes].
    #[arg(long, value_parser = yes_no)]
    pub castors: Option<bool>,
    /// Guidance: `wire` (the thesis's guide wire and P-D firmware), `none` (a
    /// velocity-commanded base, as a ROS robot: `run` drives its [manoeuvre], a square,
    /// `replay` a recording's cmd_vel) or `open-loop` (constant demands) [default: none].
    #[arg(long, value_parser = ["wire", "none", "open-loop"])]
    pub guidance: Option<String>,
    /// Body length, m [default: twice the track].
    #[arg(long, value_parser = positive_number)]
    pub length_m: Option<f64>,
    /// Body width, m [default: the track plus 0.12 m].
    #[arg(long, value_parser = positive_number)]
    pub width_m: Option<f64>,
    /// The scene's description.
    #[arg(long)]
    pub description: Option<String>,
    /// Replace NAME.toml if it exists.
    #[arg(long)]
    pub force: bool,
}

/// A robot's battery, drive motor (one datasheet point) and gear, as `new` and `import
/// ros2` take them; each in its unit.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct DriveArgs {
    /// Battery (open-circuit) voltage, V.
    #[arg(long = "battery-V", value_parser = positive_number)]
    pub battery_v: Option<f64>,
    /// The motor datasheet's rated voltage, V [default: --battery-V].
    #[arg(long = "motor-rated-V", value_parser = positive_number)]
    pub motor_rated_v: Option<f64>,
    /// The motor's no-load speed at its rated voltage, rpm (at the motor shaft, before the
    /// gear).
    #[arg(long, value_parser = positive_number)]
    pub motor_no_load_rpm: Option<f64>,
    /// The motor's stall current at its rated voltage, A.
    #[arg(long = "motor-stall-current-A", value_parser = positive_number)]
    pub motor_stall_current_a: Option<f64>,
    /// The motor's stall torque at its rated voltage, N m (at the motor shaft); used for
    /// the resistance when the stall current is not given.
    #[arg(long = "motor-stall-torque-Nm", value_parser = positive_number)]
    pub motor_stall_torque_nm: Option<f64>,
    /// Motor turns per wheel turn.
    #[arg(long, value_parser = positive_number)]
    pub gear_ratio: Option<f64>,
    /// Gear play at the wheel, rad [default: 0, none].
    #[arg(long)]
    pub backlash_rad: Option<f64>,
}

fn yes_no(s: &str) -> Result<bool, String> {
    match s {
        "yes" | "true" => Ok(true),
        "no" | "false" => Ok(false),
        _ => Err(format!("`{s}`: expected yes or no")),
    }
}

#[derive(Subcommand)]
pub enum BatchAction {
    /// Diagnose each recording against its rig.
    Diagnose {
        #[command(flatten)]
        common: BatchCommon,
        /// One rig for every recording [default: each recording's NAME.rig.toml, or the
        /// list's second column].
        #[arg(long, value_name = "NAME.rig.toml")]
        rig: Option<PathBuf>,
    },
    /// Calibrate one scene to each recording (each robot's own calibrated keys).
    Calibrate {
        #[command(flatten)]
        common: BatchCommon,
        /// The scene fitted to each recording.
        #[arg(long, value_name = "SCENE.toml")]
        scene: PathBuf,
    },
    /// Join the folders of `--shard` runs of one batch: their results and one summary.
    Merge {
        /// The shard folders, in any order.
        #[arg(required = true)]
        shards: Vec<PathBuf>,
        /// Output folder.
        #[arg(long)]
        out: PathBuf,
    },
}

#[derive(clap::Args)]
pub struct BatchCommon {
    /// A folder of recordings (every *.csv), or a list file (one `recording.csv
    /// [rig.toml]` per line, relative to the list; # comments).
    #[arg(value_name = "FOLDER|LIST")]
    pub recordings: PathBuf,
    /// Comma-separated effects to try, `all` or `none` (as diagnose and calibrate take).
    #[arg(
        long,
        value_delimiter = ',',
        value_name = "NAME,...",
        default_value = "all"
    )]
    pub effects: Vec<String>,
    /// Only the I-th of N contiguous slices of the recordings (1-based), or `auto`: from
    /// the scheduler's array variables (Slurm SLURM_ARRAY_TASK_ID/_MIN/_MAX/_COUNT,
    /// Kubernetes JOB_COMPLETION_INDEX, AWS Batch AWS_BATCH_JOB_ARRAY_INDEX/_SIZE, or
    /// AGVSIM_SHARD_INDEX from 0; the count from AGVSIM_SHARD_COUNT where the scheduler
    /// does not give it).
    #[arg(long, value_name = "I/N|auto")]
    pub shard: Option<String>,
    /// Output folder [default: runs/batch_NAME, with _shard_I_of_N when sharded].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Worker threads [default: one per core]; the results do not depend on it.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub jobs: Option<u32>,
}
