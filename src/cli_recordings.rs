//! The commands that take a user's own recording to the simulator: `import csv`,
//! `replay` and `calibrate`. Each loads, calls the library, prints (the work is the
//! library's `import`, `replay` and `calibrate` modules).

use std::path::PathBuf;
use std::process::ExitCode;

use agvsim::scene::Scene;

use crate::{bad_input, fail};

/// `agvsim import csv` and `agvsim import mat`: load the map, read the file, convert it
/// by the map, check the result reads as a contract recording, write it whole.
pub fn import_mapped_command(
    file: &std::path::Path,
    map_path: &std::path::Path,
    out: Option<PathBuf>,
    mat: bool,
) -> ExitCode {
    use agvsim::import::{csv_map, mat};
    let map = match csv_map::load_map(map_path) {
        Ok(m) => m,
        Err(e) => return bad_input(e),
    };
    let bytes = match std::fs::read(file) {
        Ok(b) => b,
        Err(e) => return bad_input(format!("{}: cannot read: {e}", file.display())),
    };
    let converted = if mat {
        mat::convert(&bytes, file, &map, map_path)
    } else {
        match String::from_utf8(bytes) {
            Ok(text) => csv_map::convert(&text, file, &map, map_path),
            Err(_) => return bad_input(format!("{}: not UTF-8 text", file.display())),
        }
    };
    match converted {
        Ok(text) => write_import(file, &text, out),
        Err(e) => bad_input(e),
    }
}

/// Writes a converted recording as `DIR/FILE_STEM.csv` after checking it against the
/// contract.
fn write_import(file: &std::path::Path, text: &str, out: Option<PathBuf>) -> ExitCode {
    let dir = out.unwrap_or_else(|| PathBuf::from("runs").join("import"));
    let stem = file
        .file_stem()
        .map_or_else(|| "imported".into(), |s| s.to_string_lossy().into_owned());
    let path = dir.join(format!("{stem}.csv"));
    if let Err(e) = agvsim::record::Recording::parse(text, &path) {
        return bad_input(format!("the converted recording breaks the contract: {e}"));
    }
    let written =
        std::fs::create_dir_all(&dir).and_then(|_| agvsim::output::write_atomically(&path, text));
    if let Err(e) = written {
        return fail(format!("{}: {e}", path.display()));
    }
    println!("recording  {}", path.display());
    ExitCode::SUCCESS
}

/// `linearize --export FILE.mat|FILE.json`.
pub fn export_linearisation(
    l: &agvsim::sim::linearize::Linearisation,
    path: &std::path::Path,
) -> Result<(), String> {
    use agvsim::sim::linearize::export;
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    let bytes = match ext {
        "mat" => export::to_mat(l),
        "json" => serde_json::to_vec_pretty(&export::to_json(l)).map_err(|e| e.to_string())?,
        _ => {
            return Err(format!(
                "--export {}: expected a name ending in .mat or .json",
                path.display()
            ))
        }
    };
    agvsim::output::check_target("--export", path, false)?;
    agvsim::output::write_atomically(path, bytes)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    println!("exported         {}", path.display());
    Ok(())
}

/// `agvsim import wpilib`: read, convert, write every file or none, print the gains.
pub fn import_wpilib_command(
    file: &std::path::Path,
    choice: &agvsim::import::wpilib::wpilog::Choice,
    assumed: &agvsim::import::wpilib::Assumptions,
    out: Option<PathBuf>,
) -> ExitCode {
    use agvsim::import::wpilib;
    let imported = match wpilib::import(file, choice, assumed) {
        Ok(i) => i,
        Err(e) => return bad_input(e),
    };
    let dir = out.unwrap_or_else(|| PathBuf::from("runs").join("import"));
    let stem = file
        .file_stem()
        .map_or_else(|| "sysid".into(), |s| s.to_string_lossy().into_owned());
    let mut files = Vec::new();
    for r in &imported.recordings {
        let path = dir.join(format!("{stem}_{}.csv", r.test));
        if let Err(e) = agvsim::record::Recording::parse(&r.text, &path) {
            return fail(format!("the converted recording breaks the contract: {e}"));
        }
        files.push((path, r.text.clone()));
    }
    let rig_path = dir.join(format!("{stem}.rig.toml"));
    if let Err(e) = agvsim::rig::Rig::parse(&imported.rig, &rig_path) {
        return fail(format!("the nominal rig does not load: {e}"));
    }
    files.push((rig_path, imported.rig.clone()));
    if let Err(e) = std::fs::create_dir_all(&dir) {
        return fail(format!("{}: {e}", dir.display()));
    }
    for (path, text) in &files {
        if let Err(e) = agvsim::output::write_atomically(path, text) {
            return fail(format!("{}: {e}", path.display()));
        }
    }
    println!("log        {} ({})", file.display(), imported.log.source);
    for (path, _) in &files[..files.len() - 1] {
        println!("recording  {}", path.display());
    }
    println!("rig        {}", files[files.len() - 1].0.display());
    println!(
        "SysId feedforward ({}, per {} of {}):",
        imported.log.mechanism.name(),
        imported.speed_unit,
        if imported.log.mechanism.is_drivetrain() {
            "wheel rim"
        } else {
            "shaft"
        }
    );
    print!(
        "{}",
        agvsim::ident::feedforward::render(&imported.feedforward, imported.speed_unit)
    );
    ExitCode::SUCCESS
}

/// `agvsim replay`: load, replay, write, print.
pub fn replay_command(
    scene_path: &std::path::Path,
    rec_path: &std::path::Path,
    out: Option<PathBuf>,
    set: &[String],
    save: Option<PathBuf>,
) -> ExitCode {
    use agvsim::replay::{self, report};
    let scene = match Scene::load(scene_path, set) {
        Ok(s) => s,
        Err(e) => return bad_input(e),
    };
    let rec = match agvsim::record::Recording::load(rec_path) {
        Ok(r) => r,
        Err(e) => return bad_input(e),
    };
    let name = rec_path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "recording".into());
    let dir = out.unwrap_or_else(|| PathBuf::from("runs").join(format!("replay_{name}")));
    let r = match replay::replay(&scene, &rec) {
        Ok(r) => r,
        Err(e @ replay::ReplayError::Recording { .. }) => return bad_input(e),
        Err(e) => return fail(e),
    };
    println!(
        "replay     {} on {} (fidelity {}), inputs {}, {} rows",
        rec_path.display(),
        scene_path.display(),
        scene.sim.fidelity.name(),
        r.drive.columns().join(", "),
        r.t_s.len()
    );
    print!("{}", report::render(&r));
    let written = (|| -> std::io::Result<Vec<PathBuf>> {
        std::fs::create_dir_all(&dir)?;
        let csv = dir.join(format!("{name}.replay.csv"));
        report::write_atomically(&csv, &report::simulated_csv(&r, &rec, scene_path))?;
        let mut files = vec![csv];
        files.extend(report::write_plots(&dir, &r, &name)?);
        Ok(files)
    })();
    match written {
        Ok(files) => {
            println!("simulated  {}", files[0].display());
            println!("plots      {}", dir.join("plots").display());
        }
        Err(e) => return fail(format!("{}: {e}", dir.display())),
    }
    if let Some(p) = save {
        if let Err(e) = agvsim::viz::save_replay(&p, &name, &r) {
            return fail(e);
        }
        println!("rerun      {}", p.display());
    }
    ExitCode::SUCCESS
}

/// Where `agvsim calibrate` writes.
pub struct CalibrateOutputs {
    pub write: Option<PathBuf>,
    pub json: Option<PathBuf>,
    pub report: Option<PathBuf>,
    pub save: Option<PathBuf>,
}

/// `agvsim calibrate`: load, fit through the simulator, print, write the scene.
pub fn calibrate_command(
    scene_path: &std::path::Path,
    rec_path: &std::path::Path,
    free: &[String],
    effects: &[String],
    outputs: CalibrateOutputs,
    validate: Option<PathBuf>,
    set: &[String],
) -> ExitCode {
    let CalibrateOutputs {
        write,
        json,
        report,
        save,
    } = outputs;
    use agvsim::calibrate::{self, write as cw};
    let request = match calibrate::effects::parse(effects) {
        Ok(effects) => calibrate::Request {
            free: free.to_vec(),
            effects,
        },
        Err(e) => return bad_input(e),
    };
    let text = match std::fs::read_to_string(scene_path) {
        Ok(t) => t,
        Err(e) => return bad_input(format!("{}: cannot read: {e}", scene_path.display())),
    };
    let scene = match Scene::from_toml(&text, scene_path, set) {
        Ok(s) => s,
        Err(e) => return bad_input(e),
    };
    let rec = match agvsim::record::Recording::load(rec_path) {
        Ok(r) => r,
        Err(e) => return bad_input(e),
    };
    let other = match validate.as_deref().map(agvsim::record::Recording::load) {
        Some(Ok(r)) => Some(r),
        Some(Err(e)) => return bad_input(e),
        None => None,
    };
    // The output paths are checked before the fit's work.
    let targets = [
        ("--write", &write, false),
        ("--json", &json, false),
        ("--report", &report, true),
        ("--save", &save, false),
    ];
    for (option, path, folder) in targets {
        if let Some(p) = path {
            if let Err(e) = agvsim::output::check_target(option, p, folder) {
                return bad_input(e);
            }
        }
    }
    println!(
        "calibrate  {} against {} (fidelity {}), through the simulator",
        scene_path.display(),
        rec_path.display(),
        scene.sim.fidelity.name()
    );
    crate::cli_progress::start("calibrate");
    let result = calibrate::calibrate_telling(&scene, &rec, &request, &crate::cli_progress::stage);
    crate::cli_progress::finish();
    let c = match result {
        Ok(c) => c,
        Err(e) => return fail(e),
    };
    print!("{}", cw::render(&c));
    println!(
        "mean       {:.1} % -> {:.1} % over the fitted outputs ({} iterations)",
        cw::mean_fit(&c.before, &c.outputs),
        cw::mean_fit(&c.after, &c.outputs),
        c.iterations
    );
    if let Some(o) = &other {
        let runs = (
            agvsim::replay::replay(&scene, o),
            agvsim::replay::replay(&c.scene, o),
        );
        match runs {
            (Ok(b), Ok(a)) => println!(
                "validate   {}: {:.1} % -> {:.1} %",
                o.path.display(),
                cw::mean_fit(&b, &c.outputs),
                cw::mean_fit(&a, &c.outputs)
            ),
            (Err(e), _) | (_, Err(e)) => return fail(e),
        }
    }
    let source_name = rec_path.file_name().map_or_else(
        || "the recording".into(),
        |n| n.to_string_lossy().into_owned(),
    );
    if let Some(p) = &json {
        let v = cw::json(
            &c,
            &scene_path.display().to_string(),
            &rec_path.display().to_string(),
        );
        let text = serde_json::to_string_pretty(&v).unwrap_or_default();
        if let Err(e) = agvsim::output::write_atomically(p, text) {
            return fail(format!("{}: {e}", p.display()));
        }
        println!("json       {}", p.display());
    }
    if let Some(dir) = &report {
        match cw::write_plots(dir, &c, &source_name) {
            Ok(_) => println!("plots      {}", dir.display()),
            Err(e) => return fail(format!("{}: {e}", dir.display())),
        }
    }
    if let Some(w) = write {
        let source = rec_path.file_name().map_or_else(
            || "the recording".into(),
            |n| n.to_string_lossy().into_owned(),
        );
        let out = match cw::calibrated_text(&text, &c, &source, set) {
            Ok(t) => t,
            Err(e) => return fail(e),
        };
        // The written scene must load on its own: it carries the --set values too.
        if let Err(e) = Scene::from_toml(&out, &w, &[]) {
            return fail(format!("the calibrated scene does not load: {e}"));
        }
        if let Err(e) = agvsim::replay::report::write_atomically(&w, &out) {
            return fail(format!("{}: {e}", w.display()));
        }
        println!("scene      {}", w.display());
    }
    if let Some(p) = &save {
        if let Err(e) = agvsim::viz::save_calibration(p, &source_name, &c) {
            return fail(e);
        }
        println!("rerun      {}", p.display());
    }
    ExitCode::SUCCESS
}
