//! `agvsim diagnose`: find what physics the rig's model leaves out, print the diagnosis,
//! and write the contract JSON, a report folder (text and SVG plots) and a Rerun file when
//! asked.

use std::path::{Path, PathBuf};

use super::{check_targets, on_workers, write_file, CommandError, Say};
use crate::diagnose::{diagnose, report::render, DiagnoseOptions};
use crate::record::Recording;
use crate::rig::Rig;

/// What `agvsim diagnose` was asked.
#[derive(Debug, Clone, Default)]
pub struct DiagnoseRequest {
    /// The rig file (one of this and `scene`).
    pub rig: Option<PathBuf>,
    /// A scene file: diagnose through the simulator.
    pub scene: Option<PathBuf>,
    /// One recording, or several tests of one machine diagnosed together (they share its
    /// parameters; each starts from rest).
    pub recordings: Vec<PathBuf>,
    /// A second recording to check the diagnosed model on.
    pub validate: Option<PathBuf>,
    /// Where to write the contract's diagnosis JSON.
    pub json: Option<PathBuf>,
    /// Where to write a report folder.
    pub report_dir: Option<PathBuf>,
    /// Where to write a Rerun recording.
    pub save_rrd: Option<PathBuf>,
    /// Where to write the self-contained HTML report.
    pub html: Option<PathBuf>,
    /// The command line, for the HTML report.
    pub command: String,
    /// Effects to try, progress reporting.
    pub options: DiagnoseOptions,
    /// Worker threads (0: one per core).
    pub jobs: usize,
}

/// Diagnoses, prints the diagnosis, and writes the files asked for.
pub fn run(req: &DiagnoseRequest, say: Say) -> Result<(), CommandError> {
    let transcript = super::Transcript::new(say);
    let say = |s: &str| transcript.say(s);
    // Output paths are checked before the diagnosis's work, not after it.
    check_targets(&[
        ("--json", req.json.as_deref(), false),
        ("--report", req.report_dir.as_deref(), true),
        ("--save", req.save_rrd.as_deref(), false),
        ("--html", req.html.as_deref(), false),
    ])?;
    let rig_path = match (&req.rig, &req.scene) {
        (_, Some(scene)) => return through_simulator(req, scene, &transcript),
        (Some(r), None) => r,
        (None, None) => {
            return Err(CommandError::Option {
                option: "--rig".into(),
                value: String::new(),
                message: "diagnose needs a rig (--rig) or a scene (--scene)".into(),
            })
        }
    };
    let rig = Rig::load(rig_path)?;
    let rec = Recording::load_joined(&req.recordings)?;
    let val = req.validate.as_deref().map(Recording::load).transpose()?;
    let d = on_workers(req.jobs, || {
        Ok(diagnose(&rig, rig_path, &rec, val.as_ref(), &req.options)?)
    })?;
    say(&render(&d));
    let mut written = Vec::new();
    if let Some(p) = &req.json {
        write_file(
            p,
            serde_json::to_string_pretty(&d.contract_json()).unwrap_or_default(),
        )?;
        written.push(p.clone());
    }
    if let Some(dir) = &req.report_dir {
        let io = super::io(dir);
        let txt = dir.join("diagnosis.txt");
        write_file(&txt, render(&d))?;
        written.push(txt);
        written.extend(crate::diagnose::plots::write(dir, &d).map_err(&io)?);
        written.extend(
            crate::ident::plots::write_evaluation(dir, "baseline", &d.baseline).map_err(&io)?,
        );
        written.extend(
            crate::ident::plots::write_evaluation(dir, "diagnosed", &d.diagnosed).map_err(&io)?,
        );
    }
    if let Some(path) = &req.save_rrd {
        crate::viz::save_diagnosis(path, &d)?;
        written.push(path.clone());
    }
    for f in &written {
        say(&format!("wrote      {}\n", f.display()));
    }
    if let Some(p) = &req.html {
        let names = super::joined_names(&req.recordings);
        let html =
            crate::html::reports::diagnosis(&d, &names, &rec, &transcript.text(), &req.command);
        write_file(p, html)?;
        say(&format!("wrote      {}\n", p.display()));
    }
    Ok(())
}

/// What `agvsim prove` was asked.
#[derive(Debug, Clone)]
pub struct ProveRequest {
    /// Folder for the recordings, rigs and diagnoses.
    pub out: PathBuf,
    /// The small version.
    pub quick: bool,
    /// Seed of inputs, noise and rig errors.
    pub seed: u64,
    /// Only these cases (empty: all).
    pub cases: Vec<String>,
    /// Prove the calibration instead ([`crate::calibrate::prove`]).
    pub calibrate: bool,
}

/// Proves the diagnosis (or with `calibrate`, the calibration) on agvsim's own recordings
/// and prints the table; a case that fails makes the command fail after the table.
pub fn prove(req: &ProveRequest, say: Say) -> Result<(), CommandError> {
    if req.calibrate {
        return prove_calibration(req, say);
    }
    let cases = crate::diagnose::prove::prove(&req.out, req.quick, req.seed, &req.cases)?;
    say(&crate::diagnose::prove::render(&cases));
    let failed = cases.iter().filter(|c| !c.passed).count();
    if failed > 0 {
        return Err(CommandError::ProofFailed {
            failed,
            total: cases.len(),
        });
    }
    Ok(())
}

/// The calibration's round trips ([`crate::calibrate::prove`]), each printed as it ends,
/// then the table with the coverage.
fn prove_calibration(req: &ProveRequest, say: Say) -> Result<(), CommandError> {
    use crate::calibrate::prove::{cases, render, run, Kind};
    let all = cases(&Kind::ALL)?;
    let chosen: Vec<_> = all
        .into_iter()
        .filter(|c| req.cases.is_empty() || req.cases.iter().any(|n| c.name.contains(n.as_str())))
        .collect();
    if chosen.is_empty() {
        return Err(CommandError::Option {
            option: "--case".into(),
            value: req.cases.join(","),
            message: "names no calibration proof case (they are KIND/EXCITATION/EFFECT, e.g. axis_voltage/sysid/backlash)".into(),
        });
    }
    let mut outcomes = vec![];
    for case in &chosen {
        let (o, _) = run(case, req.seed)?;
        say(&format!(
            "{:<44} {}\n",
            case.name,
            if o.passed { "pass" } else { "FAIL" }
        ));
        outcomes.push(o);
    }
    say(&render(&outcomes));
    let failed = outcomes.iter().filter(|o| !o.passed).count();
    if failed > 0 {
        return Err(CommandError::ProofFailed {
            failed,
            total: outcomes.len(),
        });
    }
    Ok(())
}

/// `diagnose --scene`: the calibration's effect rounds through the simulator, printed as
/// calibrate prints them, the contract's JSON on request.
fn through_simulator(
    req: &DiagnoseRequest,
    scene_path: &Path,
    transcript: &super::Transcript,
) -> Result<(), CommandError> {
    let say = |s: &str| transcript.say(s);
    for (option, given) in [
        ("--validate", req.validate.is_some()),
        ("--report", req.report_dir.is_some()),
        ("--save", req.save_rrd.is_some()),
    ] {
        if given {
            return Err(CommandError::Option {
                option: option.into(),
                value: String::new(),
                message: "is not available with --scene yet; `agvsim calibrate --validate/--report/--save` gives them through the simulator".into(),
            });
        }
    }
    let scene = crate::scene::Scene::load(scene_path, &[])?;
    let rec = Recording::load_joined(&req.recordings)?;
    let request = crate::calibrate::Request {
        free: vec![],
        effects: req.options.effects.clone(),
    };
    let progress = req.options.progress.unwrap_or(|_| {});
    let c = on_workers(req.jobs, || {
        Ok(crate::calibrate::calibrate_telling(
            &scene, &rec, &request, &progress,
        )?)
    })?;
    say(&crate::calibrate::write::render(&c));
    // The baseline as `diagnose --rig` has it: the model without effects, its keys fitted.
    let baseline = crate::replay::replay(&c.baseline, &rec)?;
    say(&crate::diagnose::through_simulator::findings_text(
        &c, &baseline,
    ));
    if let Some(p) = &req.json {
        let name = rec
            .path
            .file_name()
            .map_or(String::new(), |n| n.to_string_lossy().into_owned());
        let v = crate::diagnose::through_simulator::contract_json(
            &name,
            &scene_path.display().to_string(),
            &c,
            &baseline,
        );
        write_file(p, serde_json::to_string_pretty(&v).unwrap_or_default())?;
        say(&format!("wrote      {}\n", p.display()));
    }
    if let Some(p) = &req.html {
        let names = super::joined_names(&req.recordings);
        let html = crate::html::reports::calibration(
            &c,
            &scene_path.display().to_string(),
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
