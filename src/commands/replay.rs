//! `agvsim replay`: drive the simulator with a recording's inputs, compare its outputs
//! with the recording's, and write the simulated recording, a plot per output and
//! optionally a Rerun overlay.

use std::path::PathBuf;

use super::{io, CommandError, Say};
use crate::output::file_stem_or;
use crate::record::Recording;
use crate::replay::{self, report};
use crate::scene::Scene;

/// What `agvsim replay` was asked (its command line).
#[derive(Debug, Clone, clap::Args)]
pub struct ReplayRequest {
    /// Scene file (TOML): the machine to replay on.
    #[arg(long)]
    pub scene: PathBuf,
    /// Recording (exchange format) whose inputs drive the simulator.
    #[arg(long, value_name = "NAME.csv")]
    pub recording: PathBuf,
    /// Output folder [default: runs/replay_RECORDING_NAME].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Scene overrides (`--set`).
    #[command(flatten)]
    pub set: super::flags::Overrides,
    /// Also write the measured and simulated outputs to this Rerun .rrd file.
    #[arg(long, value_name = "FILE.rrd")]
    pub save: Option<PathBuf>,
}

/// Replays, prints the fit per output, and writes the simulated recording and plots.
pub fn run(req: &ReplayRequest, say: Say) -> Result<(), CommandError> {
    let checked = Scene::load_checked(&req.scene, &req.set)?;
    let rec = Recording::load(&req.recording)?;
    // A recording of the motors' voltages drives them past the DCMC: warnings on its
    // gains say nothing of this replay.
    let bypassed = replay::drive_of(&rec).is_ok_and(|d| d.bypasses_dcmc());
    say(&checked.render_warnings_except(|key| bypassed && key.starts_with("dcmc.")));
    let scene = checked.scene;
    let name = file_stem_or(&req.recording, "recording");
    let dir = req
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("runs").join(format!("replay_{name}")));
    let _lock = super::lock_out("--out", &dir)?;
    super::check_targets(&[("--save", req.save.as_deref(), false)])?;
    let r = replay::replay(&scene, &rec)?;
    say(&format!(
        "replay     {} on {} (fidelity {}), inputs {}, {} rows\n",
        req.recording.display(),
        req.scene.display(),
        scene.sim.fidelity.name(),
        r.drive.columns().join(", "),
        r.t_s.len()
    ));
    say(&report::render(&r));
    let csv = dir.join(format!("{name}.replay.csv"));
    let written = (|| -> std::io::Result<()> {
        std::fs::create_dir_all(&dir)?;
        report::write_atomically(&csv, report::simulated_csv(&r, &rec, &req.scene))?;
        report::write_plots(&dir, &r, &name)?;
        Ok(())
    })();
    written.map_err(io(&dir))?;
    say(&format!("simulated  {}\n", csv.display()));
    say(&format!("plots      {}\n", dir.join("plots").display()));
    if let Some(p) = &req.save {
        crate::viz::save_replay(p, &name, &r)?;
        say(&format!("rerun      {}\n", p.display()));
    }
    Ok(())
}
