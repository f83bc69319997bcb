//! `agvsim identify` as a library call: load the rig and recordings, identify, and write
//! what was asked for (JSON, SVG plots, Rerun).

use std::path::{Path, PathBuf};

use super::{identify, IdentError, Identification, IdentifyOptions};
use crate::plot;
use crate::record::Recording;
use crate::rig::Rig;

/// Files and choices of one `identify` call.
#[derive(Debug, Clone, Default)]
pub struct IdentifyJob {
    pub rig: PathBuf,
    /// One recording, or several tests of one machine fitted together (they share its
    /// parameters; each starts from rest).
    pub recordings: Vec<PathBuf>,
    pub validate: Option<PathBuf>,
    pub options: IdentifyOptions,
    pub json: Option<PathBuf>,
    pub plot_dir: Option<PathBuf>,
    pub save_rrd: Option<PathBuf>,
}

/// What was identified and written.
#[derive(Debug, Clone)]
pub struct IdentifyOutcome {
    pub identification: Identification,
    pub written: Vec<PathBuf>,
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> IdentError + '_ {
    move |e| IdentError::Setup(format!("{}: {e}", path.display()))
}

pub fn run(job: &IdentifyJob) -> Result<IdentifyOutcome, IdentError> {
    // Output paths are checked before the fit's work, not after it.
    let targets = [
        ("--json", &job.json, false),
        ("--plot", &job.plot_dir, true),
        ("--save", &job.save_rrd, false),
    ];
    for (option, path, folder) in targets {
        if let Some(p) = path {
            crate::output::check_target(option, p, folder).map_err(IdentError::Setup)?;
        }
    }
    let rig = Rig::load(&job.rig)?;
    let rec = Recording::load_joined(&job.recordings)?;
    let val = job.validate.as_deref().map(Recording::load).transpose()?;
    let mut id = identify(&rig, &job.rig, &rec, val.as_ref(), &job.options)?;
    id.rig = job.rig.display().to_string();
    let mut written = Vec::new();
    if let Some(path) = &job.json {
        let text = serde_json::to_string_pretty(&id).expect("reports serialise");
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(io(dir))?;
        }
        std::fs::write(path, text).map_err(io(path))?;
        written.push(path.clone());
    }
    if let Some(dir) = &job.plot_dir {
        written.extend(plot::write_evaluation(dir, "estimation", &id.estimation).map_err(io(dir))?);
        if let Some(v) = &id.validation {
            written.extend(plot::write_evaluation(dir, "validation", v).map_err(io(dir))?);
        }
    }
    if let Some(path) = &job.save_rrd {
        crate::viz::save_identification(path, &id)
            .map_err(|e| IdentError::Setup(format!("{}: {}", path.display(), e.0)))?;
        written.push(path.clone());
    }
    Ok(IdentifyOutcome {
        identification: id,
        written,
    })
}
