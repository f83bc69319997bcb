//! `agvsim experiment`: one of the thesis's lab experiments on a simulated machine, its
//! recording and rig file written.

use std::path::PathBuf;

use super::{CommandError, Say};
use crate::experiment::{run_experiment, ExperimentKind, ExperimentOptions};
use crate::scene::Scene;

/// What `agvsim experiment` was asked.
#[derive(Debug, Clone)]
pub struct ExperimentRequest {
    /// Which experiment.
    pub kind: ExperimentKind,
    /// The scene giving the machine.
    pub scene: PathBuf,
    /// Its settings (output folder, name, seed, interval, demands, noise, rig error).
    pub options: ExperimentOptions,
}

/// Runs the experiment and prints what it wrote.
pub fn run(req: &ExperimentRequest, say: Say) -> Result<(), CommandError> {
    let scene = Scene::load(&req.scene, &[])?;
    let _lock = super::lock_out("--out", &req.options.out_dir)?;
    let o = run_experiment(req.kind, &scene, &req.options)?;
    say(&format!(
        "experiment {} on {}: {} samples\n",
        req.kind.name(),
        req.scene.display(),
        o.samples
    ));
    say(&format!("recording  {}\n", o.recording.display()));
    say(&format!("rig        {}\n", o.rig.display()));
    for f in &o.extra {
        say(&format!("also       {}\n", f.display()));
    }
    Ok(())
}
