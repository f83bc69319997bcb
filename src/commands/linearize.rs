//! `agvsim linearize`: the plant linearised about straight running on the wire, its
//! controllability, observability and closed-loop poles, optionally exported.

use std::path::{Path, PathBuf};

use super::{check_targets, write_file, CommandError, Say};
use crate::scene::Scene;
use crate::sim::linearize::{self, export, Linearisation};

/// What `agvsim linearize` was asked (its command line).
#[derive(Debug, Clone, clap::Args)]
pub struct LinearizeRequest {
    /// Scene file (TOML), e.g. scenes/lab_offset_120mm.toml.
    pub scene: PathBuf,
    /// Scene overrides (`--set`).
    #[command(flatten)]
    pub set: super::flags::Overrides,
    /// Also write A, B, C, D (discrete-time, with Ts and the named states, inputs and
    /// outputs and their units) to FILE.mat (MATLAB `load`, SciPy `loadmat`) or FILE.json.
    #[arg(long, value_name = "FILE.mat|FILE.json")]
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
    say(&report(&req.scene, &l, &linearize::analyse(&l)));
    Ok(())
}

/// What `agvsim linearize` prints of the scene at `scene`: its name, then the analysis.
pub fn report(scene: &Path, l: &Linearisation, reach: &linearize::Reach) -> String {
    format!(
        "scene            {}\n{}",
        scene.display(),
        linearize::render(l, reach)
    )
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
