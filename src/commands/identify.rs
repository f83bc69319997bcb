//! `agvsim identify`: fit a rig's model to one recording (or several tests of one
//! machine), print the identification, and write what was asked for (JSON, SVG plots,
//! Rerun).

use std::path::PathBuf;

use super::{write_file, CommandError, Say};
use crate::ident::{identify, report, IdentifyOptions, ModelChoice};
use crate::record::Recording;
use crate::rig::Rig;

/// What `agvsim identify` was asked (its command line).
#[derive(Debug, Clone, clap::Args)]
pub struct IdentifyRequest {
    /// Rig file (NAME.rig.toml).
    #[arg(long)]
    pub rig: PathBuf,
    /// Recording (NAME.csv, exchange format). Repeat it to fit several tests of one
    /// machine together (they share its parameters; each starts from rest).
    #[arg(long = "recording", required = true, value_name = "NAME.csv")]
    pub recordings: Vec<PathBuf>,
    /// Model structure: drive-axis, falling-weight, coast-down, gain, p or pi
    /// [default: from the recording's experiment, else the rig kind].
    #[arg(long, value_parser = |s: &str| s.parse::<ModelChoice>())]
    pub model: Option<ModelChoice>,
    /// Comma-separated parameters to fit [default: the structure's identifiable set].
    #[arg(long, value_delimiter = ',')]
    pub free: Option<Vec<String>>,
    /// A second recording to check the identified model on.
    #[arg(long, value_name = "OTHER.csv")]
    pub validate: Option<PathBuf>,
    /// Write the report as JSON here.
    #[arg(long, value_name = "OUT.json")]
    pub json: Option<PathBuf>,
    /// Write a report folder (SVG plots of the fit and the residual checks) here
    /// (`--plot` is an older name for it).
    #[arg(long = "report", value_name = "DIR", alias = "plot")]
    pub plot_dir: Option<PathBuf>,
    /// Save measured and simulated outputs to a Rerun .rrd file.
    #[arg(long = "save", value_name = "FILE.rrd")]
    pub save_rrd: Option<PathBuf>,
    /// Write one self-contained HTML report here (the recording, the estimates with their
    /// standard deviations and verdicts, the fits before and after with the plots, the
    /// command): no network needed to open it.
    #[arg(long, value_name = "FILE.html")]
    pub html: Option<PathBuf>,
    /// Number of solver starts (rig values, then perturbed within a factor 2).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=50))]
    pub starts: u32,
    /// Iteration limit of each start.
    #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u32).range(1..=10000))]
    pub max_iterations: u32,
    /// The command line, for the HTML report.
    #[arg(skip = super::command_line())]
    pub command: String,
}

impl Default for IdentifyRequest {
    /// No files; the command line's defaults (3 starts, 100 iterations).
    fn default() -> Self {
        IdentifyRequest {
            rig: PathBuf::new(),
            recordings: vec![],
            model: None,
            free: None,
            validate: None,
            json: None,
            plot_dir: None,
            save_rrd: None,
            html: None,
            starts: 3,
            max_iterations: 100,
            command: String::new(),
        }
    }
}

impl IdentifyRequest {
    /// The identification's options: the model, free parameters, starts and iterations.
    pub fn options(&self) -> IdentifyOptions {
        IdentifyOptions {
            model: self.model,
            free: self.free.clone(),
            starts: self.starts as usize,
            max_iterations: self.max_iterations as usize,
            ..Default::default()
        }
    }
}

/// Identifies, prints the report, and writes the files asked for.
pub fn run(req: &IdentifyRequest, say: Say) -> Result<(), CommandError> {
    let transcript = super::Transcript::new(say);
    let say = |s: &str| transcript.say(s);
    // Output paths are checked before the fit's work, not after it.
    let _locks = super::lock_targets(&[
        ("--json", req.json.as_deref(), false),
        ("--report", req.plot_dir.as_deref(), true),
        ("--save", req.save_rrd.as_deref(), false),
        ("--html", req.html.as_deref(), false),
    ])?;
    let rig = Rig::load(&req.rig)?;
    let rec = Recording::load_joined(&req.recordings)?;
    let val = req.validate.as_deref().map(Recording::load).transpose()?;
    let mut id = identify(&rig, &req.rig, &rec, val.as_ref(), &req.options())?;
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
