//! The shape of the `agvsim` command line: each command's request (declared beside the
//! command in `agvsim::commands`, flags shared by several declared once in
//! `agvsim::commands::flags`) and the subcommands that only group others. `main`
//! dispatches what is parsed here.

use std::path::PathBuf;

use clap::{Parser, Subcommand};

use agvsim::commands::{
    batch::BatchRequest, calibrate::CalibrateRequest, diagnose::DiagnoseRequest,
    diagnose::ProveRequest, experiment::ExperimentRequest, identify::IdentifyRequest,
    import::ImportFormat, linearize::LinearizeRequest, new::CheckRequest, new::NewArgs,
    replay::ReplayRequest, run::RunRequest, study::StudyRequest, sweep::SweepFlags,
};

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
pub enum Command {
    /// Simulate a scene and write its recording (CSV, exchange format) and summary.
    Run(RunRequest),
    /// Drive the simulator (the scene, at its fidelity) with a recording's inputs instead of
    /// its firmware and compare its outputs with the recording's: fit per output, the
    /// simulated recording beside the measured one, a plot per output.
    Replay(ReplayRequest),
    /// Fit the scene's uncertain keys to a recording through the simulator itself, print
    /// each key before and after and the replay fit on the original and calibrated scene,
    /// and write the calibrated scene.
    Calibrate(CalibrateRequest),
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
    Study(StudyRequest),
    /// Linearise the scene's plant (drivetrains and chassis) about straight running on the
    /// wire and report controllability from the motor voltages and observability from the
    /// coil pair (ranks, and which states the coils cannot see), then close the P-D loop
    /// around it and report its poles and stability. The full level is linearised as its
    /// no-slip counterpart.
    Linearize(LinearizeRequest),
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
    Check(CheckRequest),
    /// Run one of the thesis's lab experiments on a simulated AGV; write the recording and
    /// its rig file (exchange format).
    Experiment(ExperimentRequest),
    /// Find what physics the rig's model leaves out: fit the nominal model, locate the
    /// residual by regime, fit each candidate effect, keep what is significant (with
    /// --scene: through the simulator).
    Diagnose(DiagnoseRequest),
    /// Prove the diagnosis on agvsim's own recordings with concealed effects (and a clean
    /// one): each effect must be found within 15 % and nothing on the clean case.
    Prove(ProveRequest),
    /// Fit a rig's model to a recording: parameters with standard deviations, loss, FPE,
    /// AIC, fit per output and residual checks.
    Identify(IdentifyRequest),
}

/// `agvsim sweep`: a sweep, or `sweep merge`.
#[derive(clap::Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct SweepArgs {
    #[command(subcommand)]
    pub action: Option<SweepAction>,
    #[command(flatten)]
    pub flags: SweepFlags,
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

#[derive(Subcommand)]
pub enum BatchAction {
    /// Diagnose each recording against its rig.
    Diagnose {
        #[command(flatten)]
        request: BatchRequest,
        /// One rig for every recording [default: each recording's NAME.rig.toml, or the
        /// list's second column].
        #[arg(long, value_name = "NAME.rig.toml")]
        rig: Option<PathBuf>,
    },
    /// Calibrate one scene to each recording (each robot's own calibrated keys).
    Calibrate {
        #[command(flatten)]
        request: BatchRequest,
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
