//! `agvsim identify`: fit a rig's model to one recording (or several tests of one
//! machine), print the identification, and write what was asked for (JSON, SVG plots,
//! Rerun).

use std::path::PathBuf;

use super::{check_targets, write_file, CommandError, Say};
use crate::ident::{identify, report, IdentifyOptions};
use crate::record::Recording;
use crate::rig::Rig;

/// What `agvsim identify` was asked.
#[derive(Debug, Clone, Default)]
pub struct IdentifyRequest {
    /// The rig file.
    pub rig: PathBuf,
    /// One recording, or several tests of one machine fitted together (they share its
    /// parameters; each starts from rest).
    pub recordings: Vec<PathBuf>,
    /// A second recording to check the identified model on.
    pub validate: Option<PathBuf>,
    /// The model, free parameters, starts and iterations.
    pub options: IdentifyOptions,
    /// Where to write the report as JSON.
    pub json: Option<PathBuf>,
    /// Where to write SVG plots.
    pub plot_dir: Option<PathBuf>,
    /// Where to write a Rerun recording.
    pub save_rrd: Option<PathBuf>,
    /// Where to write the self-contained HTML report.
    pub html: Option<PathBuf>,
    /// The command line, for the HTML report.
    pub command: String,
}

/// Identifies, prints the report, and writes the files asked for.
pub fn run(req: &IdentifyRequest, say: Say) -> Result<(), CommandError> {
    let transcript = super::Transcript::new(say);
    let say = |s: &str| transcript.say(s);
    // Output paths are checked before the fit's work, not after it.
    check_targets(&[
        ("--json", req.json.as_deref(), false),
        ("--report", req.plot_dir.as_deref(), true),
        ("--save", req.save_rrd.as_deref(), false),
        ("--html", req.html.as_deref(), false),
    ])?;
    let rig = Rig::load(&req.rig)?;
    let rec = Recording::load_joined(&req.recordings)?;
    let val = req.validate.as_deref().map(Recording::load).transpose()?;
    let mut id = identify(&rig, &req.rig, &rec, val.as_ref(), &req.options)?;
    id.rig = req.rig.display().to_string();
    say(&report::render(&id));
    let mut written = Vec::new();
    if let Some(path) = &req.json {
        let text = serde_json::to_string_pretty(&id).unwrap_or_default();
        write_file(path, text)?;
        written.push(path.clone());
    }
    if let Some(dir) = &req.plot_dir {
        let io = super::io(dir);
        written.extend(
            crate::ident::plots::write_evaluation(dir, "estimation", &id.estimation)
                .map_err(&io)?,
        );
        if let Some(v) = &id.validation {
            written
                .extend(crate::ident::plots::write_evaluation(dir, "validation", v).map_err(&io)?);
        }
    }
    if let Some(path) = &req.save_rrd {
        crate::viz::save_identification(path, &id)?;
        written.push(path.clone());
    }
    for f in &written {
        say(&format!("wrote      {}\n", f.display()));
    }
    if let Some(p) = &req.html {
        let names = super::joined_names(&req.recordings);
        let html = crate::html::reports::identification(
            &id,
            &names,
            &rec,
            &transcript.text(),
            &req.command,
        );
        write_file(p, html)?;
        say(&format!("wrote      {}\n", p.display()));
    }
    Ok(())
}
