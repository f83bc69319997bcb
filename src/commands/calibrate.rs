//! `agvsim calibrate`: fit the scene's keys (and the effects the recording shows) to a
//! recording through the simulator, print each key before and after and the replay fits,
//! and write the calibrated scene, JSON, plots and a Rerun overlay when asked.

use std::path::PathBuf;

use super::flags::{no_progress, Effects, Jobs, Overrides};
use super::{io, on_workers, write_file, CommandError, Say};
use crate::calibrate::{self, write as cw, Request};
use crate::record::Recording;
use crate::scene::Scene;

/// What `agvsim calibrate` was asked (its command line).
#[derive(Debug, Clone, clap::Args)]
pub struct CalibrateRequest {
    /// Scene file (TOML): its values are the beliefs.
    #[arg(long)]
    pub scene: PathBuf,
    /// Recording (exchange format) to fit. Repeat it to fit several tests of one
    /// machine together: each is replayed from rest, and all share the scene's keys.
    #[arg(long, required = true, value_name = "NAME.csv")]
    pub recording: Vec<PathBuf>,
    /// Comma-separated scene keys to fit [default: the recording kind's set: motor
    /// resistance, torque constant, rotor inertia, viscous friction for a lifted drive;
    /// torque constant, resistance, chassis mass and yaw inertia for a vehicle; chassis mass, yaw inertia and the base's speed-loop gains for a vehicle driven by velocity commands].
    /// `none`: fit only the effects' keys.
    #[arg(long, value_delimiter = ',')]
    pub free: Vec<String>,
    /// Effects to try, each switched on through its scene key.
    #[command(flatten)]
    pub effects: Effects,
    /// Write the calibrated scene here (the original text with the fitted keys
    /// replaced and commented).
    #[arg(long, value_name = "CALIBRATED.toml")]
    pub write: Option<PathBuf>,
    /// Another recording to compare the original and calibrated scenes on (repeat it
    /// for several tests: compared together, each from rest).
    #[arg(long, value_name = "OTHER.csv")]
    pub validate: Vec<PathBuf>,
    /// Scene overrides, applied before fitting.
    #[command(flatten)]
    pub set: Overrides,
    /// Write the result (keys, fits) as JSON here.
    #[arg(long, value_name = "OUT.json")]
    pub json: Option<PathBuf>,
    /// Write a plot per fitted output (measured, original and calibrated replays) here.
    #[arg(long, value_name = "DIR")]
    pub report: Option<PathBuf>,
    /// Also write the measured outputs with the original and calibrated scenes' replays,
    /// overlaid per output on one timeline, to this Rerun .rrd file.
    #[arg(long, value_name = "FILE.rrd")]
    pub save: Option<PathBuf>,
    /// Write one self-contained HTML report here (the recording, the keys with their
    /// standard deviations and verdicts, each effect tried with its evidence, the fits
    /// before and after with the plots, the scene's changes, the command).
    #[arg(long, value_name = "FILE.html")]
    pub html: Option<PathBuf>,
    /// Worker threads (`--jobs`).
    #[command(flatten)]
    pub jobs: Jobs,
    /// The command line, for the HTML report.
    #[arg(skip = super::command_line())]
    pub command: String,
    /// Told each stage as it starts.
    #[arg(skip = no_progress as fn(&str))]
    pub progress: fn(&str),
}

/// Calibrates, prints the keys, effects and fits, and writes the outputs asked for.
pub fn run(req: &CalibrateRequest, say: Say) -> Result<(), CommandError> {
    let transcript = super::Transcript::new(say);
    let say = |s: &str| transcript.say(s);
    let mut request = Request {
        free: req.free.clone(),
        effects: req.effects.choice()?,
        validate: None,
    };
    let text = crate::scene::read_scene_text(&req.scene)?;
    let checked = Scene::checked_from_toml(&text, &req.scene, &req.set)?;
    say(&checked.render_warnings());
    let scene = checked.scene;
    // A key to fit that is none of the scene's is named before any replay.
    if let Some(k) = req
        .free
        .iter()
        .find(|k| *k != "none" && crate::scene::keys::table().find(k).is_none())
    {
        return Err(CommandError::Option {
            option: "--free".into(),
            value: k.clone(),
            message: "no such scene key (`agvsim keys` lists them)".into(),
        });
    }
    let rec = Recording::load_joined(&req.recording)?;
    let other = (!req.validate.is_empty())
        .then(|| Recording::load_joined(&req.validate))
        .transpose()?;
    // A validation recording that cannot validate this fit is refused before the fit.
    if let Some(o) = &other {
        crate::replay::check_validation(&rec, o).map_err(|message| CommandError::Option {
            option: "--validate".into(),
            value: super::joined_names(&req.validate),
            message: message.to_string(),
        })?;
    }
    request.validate = other.clone();
    let recordings = super::joined_names(&req.recording);
    // The output paths are checked before the fit's work.
    let _locks = super::lock_targets(&[
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
    let c = on_workers(req.jobs.count(), || {
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
        let (b, a) = on_workers(req.jobs.count(), || {
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
    write_outputs(req, &c, &text, &rec, &transcript)
}

/// Writes what the request asks for beside the report (JSON, plots, the calibrated scene,
/// a Rerun overlay, the HTML report), saying each file as it is written.
fn write_outputs(
    req: &CalibrateRequest,
    c: &calibrate::Calibration,
    text: &str,
    rec: &Recording,
    transcript: &super::Transcript,
) -> Result<(), CommandError> {
    let say = |s: &str| transcript.say(s);
    let recordings = super::joined_names(&req.recording);
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
        let v = cw::json(c, &req.scene.display().to_string(), &recordings);
        write_file(p, serde_json::to_string_pretty(&v).unwrap_or_default())?;
        say(&format!("json       {}\n", p.display()));
    }
    if let Some(dir) = &req.report {
        cw::write_plots(dir, c, &source_name).map_err(io(dir))?;
        say(&format!("plots      {}\n", dir.display()));
    }
    if let Some(w) = &req.write {
        let out = cw::calibrated_text(text, c, &source_name, &req.set)?;
        // The written scene must load on its own: it carries the --set values too.
        Scene::from_toml(&out, w, &[]).map_err(|e| CommandError::WrittenScene(e.to_string()))?;
        write_file(w, &out)?;
        say(&format!("scene      {}\n", w.display()));
    }
    if let Some(p) = &req.save {
        crate::viz::save_calibration(p, &source_name, c)?;
        say(&format!("rerun      {}\n", p.display()));
    }
    if let Some(p) = &req.html {
        let html = crate::html::reports::calibration(
            "Calibration",
            c,
            &req.scene.display().to_string(),
            &recordings,
            rec,
            &transcript.text(),
            &req.command,
        );
        write_file(p, html)?;
        say(&format!("html       {}\n", p.display()));
    }
    Ok(())
}
