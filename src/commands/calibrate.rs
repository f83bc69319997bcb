//! `agvsim calibrate`: fit the scene's keys (and the effects the recording shows) to a
//! recording through the simulator, print each key before and after and the replay fits,
//! and write the calibrated scene, JSON, plots and a Rerun overlay when asked.

use std::path::PathBuf;

use super::{check_targets, io, on_workers, write_file, CommandError, Say};
use crate::calibrate::{self, write as cw, Request};
use crate::ident::effects::Choice;
use crate::record::Recording;
use crate::scene::Scene;

/// What `agvsim calibrate` was asked.
#[derive(Debug, Clone)]
pub struct CalibrateRequest {
    /// The scene: its values are the beliefs.
    pub scene: PathBuf,
    /// The recordings to fit (several: tests of one machine, each replayed from rest).
    pub recording: Vec<PathBuf>,
    /// Scene keys to fit (empty: the recording kind's set).
    pub free: Vec<String>,
    /// Effects to try: `all`, `none` or vocabulary names.
    pub effects: Vec<String>,
    /// Where to write the calibrated scene.
    pub write: Option<PathBuf>,
    /// Recordings to compare the scenes on (none: no validation).
    pub validate: Vec<PathBuf>,
    /// Scene overrides before fitting, `KEY=VALUE`.
    pub set: Vec<String>,
    /// Where to write the result as JSON.
    pub json: Option<PathBuf>,
    /// Where to write a plot per fitted output.
    pub report: Option<PathBuf>,
    /// Where to write the Rerun overlay.
    pub save: Option<PathBuf>,
    /// Where to write the self-contained HTML report.
    pub html: Option<PathBuf>,
    /// The command line, for the HTML report.
    pub command: String,
    /// Worker threads (0: one per core).
    pub jobs: usize,
    /// Told each stage as it starts.
    pub progress: fn(&str),
}

/// Calibrates, prints the keys, effects and fits, and writes the outputs asked for.
pub fn run(req: &CalibrateRequest, say: Say) -> Result<(), CommandError> {
    let transcript = super::Transcript::new(say);
    let say = |s: &str| transcript.say(s);
    let request = Request {
        free: req.free.clone(),
        effects: Choice::parse(&req.effects)?,
    };
    let text = crate::scene::read_scene_text(&req.scene)?;
    let checked = Scene::checked_from_toml(&text, &req.scene, &req.set)?;
    say(&checked.render_warnings());
    let scene = checked.scene;
    let rec = Recording::load_joined(&req.recording)?;
    let other = (!req.validate.is_empty())
        .then(|| Recording::load_joined(&req.validate))
        .transpose()?;
    // A validation recording that cannot validate this fit is refused before the fit.
    if let Some(o) = &other {
        crate::replay::check_validation(&rec, o).map_err(|message| CommandError::Option {
            option: "--validate".into(),
            value: super::joined_names(&req.validate),
            message,
        })?;
    }
    let recordings = super::joined_names(&req.recording);
    // The output paths are checked before the fit's work.
    check_targets(&[
        ("--write", req.write.as_deref(), false),
        ("--json", req.json.as_deref(), false),
        ("--report", req.report.as_deref(), true),
        ("--save", req.save.as_deref(), false),
        ("--html", req.html.as_deref(), false),
    ])?;
    say(&format!(
        "calibrate  {} against {} (fidelity {}), through the simulator\n",
        req.scene.display(),
        recordings,
        scene.sim.fidelity.name()
    ));
    let c = on_workers(req.jobs, || {
        Ok(calibrate::calibrate_telling(
            &scene,
            &rec,
            &request,
            &req.progress,
        )?)
    })?;
    say(&cw::render(&c));
    say(&format!(
        "mean       {:.1} % -> {:.1} % over the fitted outputs ({} iterations in all stages)\n",
        cw::mean_fit(&c.before, &c.outputs),
        cw::mean_fit(&c.after, &c.outputs),
        c.iterations
    ));
    if let Some(o) = &other {
        let (b, a) = on_workers(req.jobs, || {
            Ok((
                crate::replay::replay(&scene, o)?,
                crate::replay::replay(&c.scene, o)?,
            ))
        })?;
        say(&format!(
            "validate   {}: {:.1} % -> {:.1} %\n",
            super::joined_names(&req.validate),
            cw::mean_fit(&b, &c.outputs),
            cw::mean_fit(&a, &c.outputs)
        ));
    }
    let source_name = req
        .recording
        .iter()
        .map(|p| {
            p.file_name().map_or_else(
                || "the recording".into(),
                |n| n.to_string_lossy().into_owned(),
            )
        })
        .collect::<Vec<String>>()
        .join(" + ");
    if let Some(p) = &req.json {
        let v = cw::json(&c, &req.scene.display().to_string(), &recordings);
        write_file(p, serde_json::to_string_pretty(&v).unwrap_or_default())?;
        say(&format!("json       {}\n", p.display()));
    }
    if let Some(dir) = &req.report {
        cw::write_plots(dir, &c, &source_name).map_err(io(dir))?;
        say(&format!("plots      {}\n", dir.display()));
    }
    if let Some(w) = &req.write {
        let out = cw::calibrated_text(&text, &c, &source_name, &req.set)?;
        // The written scene must load on its own: it carries the --set values too.
        Scene::from_toml(&out, w, &[]).map_err(|e| CommandError::WrittenScene(e.to_string()))?;
        write_file(w, &out)?;
        say(&format!("scene      {}\n", w.display()));
    }
    if let Some(p) = &req.save {
        crate::viz::save_calibration(p, &source_name, &c)?;
        say(&format!("rerun      {}\n", p.display()));
    }
    if let Some(p) = &req.html {
        let html = crate::html::reports::calibration(
            &c,
            &req.scene.display().to_string(),
            &recordings,
            &rec,
            &transcript.text(),
            &req.command,
        );
        write_file(p, html)?;
        say(&format!("html       {}\n", p.display()));
    }
    Ok(())
}
