//! `agvsim linearize`: the plant linearised about straight running on the wire, its
//! controllability, observability and closed-loop poles, optionally exported.

use std::path::{Path, PathBuf};

use super::{check_targets, write_file, CommandError, Say};
use crate::scene::Scene;
use crate::sim::linearize::{self, export, Linearisation};

/// What `agvsim linearize` was asked.
#[derive(Debug, Clone)]
pub struct LinearizeRequest {
    /// The scene file.
    pub scene: PathBuf,
    /// Scene overrides, `KEY=VALUE`.
    pub set: Vec<String>,
    /// Where to write A, B, C, D (`.mat` or `.json`).
    pub export: Option<PathBuf>,
}

/// Linearises, writes the export when asked, and prints the analysis.
pub fn run(req: &LinearizeRequest, say: Say) -> Result<(), CommandError> {
    let scene = Scene::load(&req.scene, &req.set)?;
    if let Some(path) = &req.export {
        export_format(path)?;
        check_targets(&[("--export", Some(path), false)])?;
    }
    let l = linearize::linearise(&scene)?;
    if let Some(path) = &req.export {
        write_export(&l, path)?;
        say(&format!("exported         {}\n", path.display()));
    }
    say(&format!("scene            {}\n", req.scene.display()));
    say(&linearize::render(&l, &linearize::analyse(&l)));
    Ok(())
}

/// The export's format from its name's extension.
fn export_format(path: &Path) -> Result<&'static str, CommandError> {
    match path.extension().and_then(|e| e.to_str()) {
        Some("mat") => Ok("mat"),
        Some("json") => Ok("json"),
        _ => Err(CommandError::Option {
            option: "--export".into(),
            value: path.display().to_string(),
            message: "expected a name ending in .mat or .json".into(),
        }),
    }
}

/// `linearize --export FILE.mat|FILE.json`.
fn write_export(l: &Linearisation, path: &Path) -> Result<(), CommandError> {
    let bytes = match export_format(path)? {
        "mat" => export::to_mat(l),
        _ => serde_json::to_vec_pretty(&export::to_json(l)).unwrap_or_default(),
    };
    write_file(path, bytes)
}
