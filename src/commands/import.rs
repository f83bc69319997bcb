//! `agvsim import csv|mat|wpilib`: a recording kept in another format converted into the
//! exchange format, checked to read back as the contract's, and written whole.

use std::path::{Path, PathBuf};

use super::{io, stem, write_file, CommandError, Say};
use crate::import::wpilib::{self, wpilog, Assumptions};
use crate::import::{csv_map, mat, ImportError};
use crate::record::Recording;
use crate::rig::Rig;

/// What `agvsim import csv` or `import mat` was asked.
#[derive(Debug, Clone)]
pub struct MappedImport {
    /// The CSV or MAT file.
    pub file: PathBuf,
    /// The map file.
    pub map: PathBuf,
    /// Output folder (default `runs/import`).
    pub out: Option<PathBuf>,
    /// A MAT file (else a CSV).
    pub mat: bool,
}

/// The output folder an import writes into.
fn out_dir(out: &Option<PathBuf>) -> PathBuf {
    out.clone()
        .unwrap_or_else(|| PathBuf::from("runs").join("import"))
}

/// Loads the map, reads the file, converts it, checks the result reads as a contract
/// recording, and writes it as `DIR/FILE_STEM.csv`.
pub fn mapped(req: &MappedImport, say: Say) -> Result<(), CommandError> {
    let map = csv_map::load_map(&req.map)?;
    let bytes = std::fs::read(&req.file).map_err(|source| ImportError::Read {
        file: req.file.clone(),
        source,
    })?;
    let text = if req.mat {
        mat::convert(&bytes, &req.file, &map, &req.map)?
    } else {
        let text = String::from_utf8(bytes).map_err(|_| ImportError::Data {
            file: req.file.clone(),
            line: 0,
            message: "not UTF-8 text".into(),
        })?;
        csv_map::convert(&text, &req.file, &map, &req.map)?
    };
    let _lock = super::lock_out("--out", &out_dir(&req.out))?;
    let path = out_dir(&req.out).join(format!("{}.csv", stem(&req.file, "imported")));
    check_recording(&text, &path)?;
    write_file(&path, &text)?;
    say(&format!("recording  {}\n", path.display()));
    Ok(())
}

/// A converted recording must read back as the contract's.
fn check_recording(text: &str, path: &Path) -> Result<(), CommandError> {
    Recording::parse(text, path).map_err(|e| CommandError::Contract {
        what: "the converted recording".into(),
        message: e.to_string(),
    })?;
    Ok(())
}

/// What `agvsim import wpilib` was asked.
#[derive(Debug, Clone)]
pub struct WpilibImport {
    /// The SysId JSON or DataLog.
    pub file: PathBuf,
    /// Which routine and motors (DataLog only).
    pub choice: wpilog::Choice,
    /// Values the log cannot give.
    pub assumed: Assumptions,
    /// Output folder (default `runs/import`).
    pub out: Option<PathBuf>,
}

/// Reads, converts, writes every file or none, prints SysId's gains.
pub fn wpilib(req: &WpilibImport, say: Say) -> Result<(), CommandError> {
    let imported = wpilib::import(&req.file, &req.choice, &req.assumed)?;
    let dir = out_dir(&req.out);
    let _lock = super::lock_out("--out", &dir)?;
    let stem = stem(&req.file, "sysid");
    let mut files = Vec::new();
    for r in &imported.recordings {
        // A test's name comes from inside the log: made safe, it names a file in `dir`.
        let path = dir.join(format!(
            "{stem}_{}.csv",
            crate::output::safe_file_stem(&r.test)
        ));
        check_recording(&r.text, &path)?;
        files.push((path, r.text.clone()));
    }
    let rig_path = dir.join(format!("{stem}.rig.toml"));
    let rig = Rig::parse(&imported.rig, &rig_path).map_err(|e| CommandError::Contract {
        what: "the nominal rig".into(),
        message: e.to_string(),
    })?;
    files.push((rig_path.clone(), imported.rig.clone()));
    let scene_path = dir.join(format!("{stem}.scene.toml"));
    let scene = scene_of(&rig, &imported.rig, &rig_path);
    if let Some(text) = &scene {
        crate::scene::Scene::from_toml(text, &scene_path, &[]).map_err(|e| {
            CommandError::Contract {
                what: "the machine's scene".into(),
                message: e.to_string(),
            }
        })?;
        files.push((scene_path.clone(), text.clone()));
    }
    std::fs::create_dir_all(&dir).map_err(io(&dir))?;
    for (path, text) in &files {
        write_file(path, text)?;
    }
    say(&format!(
        "log        {} ({})\n",
        req.file.display(),
        imported.log.source
    ));
    for (path, _) in &files[..imported.recordings.len()] {
        say(&format!("recording  {}\n", path.display()));
    }
    say(&format!("rig        {}\n", rig_path.display()));
    if scene.is_some() {
        say(&format!("scene      {}\n", scene_path.display()));
    }
    say(&format!(
        "SysId feedforward ({}, per {} of {}):\n",
        imported.log.mechanism.name(),
        imported.speed_unit,
        if imported.log.mechanism.is_drivetrain() {
            "wheel rim"
        } else {
            "shaft"
        }
    ));
    say(&crate::ident::feedforward::render(
        &imported.feedforward,
        imported.speed_unit,
    ));
    Ok(())
}

/// The imported vehicle as a scene for the simulator ([`Rig::scene_toml`]), headed by the
/// rig's own notes on what was measured and what assumed; `None` for a lifted axis.
fn scene_of(rig: &Rig, rig_text: &str, rig_path: &std::path::Path) -> Option<String> {
    let rig_name = rig_path
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    let body = rig.scene_toml(&format!("The machine of {rig_name}, for the simulator"))?;
    let mut text = format!(
        "# The machine of {rig_name} as a scene (agvsim import): its values, and how far each is believed ([uncertainty_pct]), are the rig's:\n"
    );
    for line in rig_text.lines().filter(|l| l.starts_with('#')) {
        text.push_str(line);
        text.push('\n');
    }
    text.push_str(
        "# Not in the rig, so the scene's defaults (the thesis's vehicle): castors, tyres (hard polyurethane), battery (24 V: above every logged voltage, which is what the controllers applied), guide wire, sensors and firmware. `calibrate --recording` replays the logged voltages; `run` would follow the thesis's wire.\n",
    );
    text.push_str(&body);
    Some(text)
}
