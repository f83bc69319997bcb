//! `agvsim import wpilib` as an [`Importer`]: one recording per test
//! (`DIR/FILE_STEM_TEST.csv`), the nominal rig (`DIR/FILE_STEM.rig.toml`), the machine's
//! scene where the rig is a vehicle's (`DIR/FILE_STEM.scene.toml`), and SysId's gains said.

use std::path::{Path, PathBuf};

use super::{import, wpilog, Assumptions};
use crate::import::{checked_recording, FileKind, ImportFailure, Importer, Made, MadeFile};
use crate::rig::Rig;

/// What `agvsim import wpilib` was asked.
#[derive(Debug, Clone)]
pub struct WpilibImport {
    /// The SysId JSON or DataLog.
    pub file: PathBuf,
    /// Which routine and motors (DataLog only).
    pub choice: wpilog::Choice,
    /// Values the log cannot give.
    pub assumed: Assumptions,
    /// Output folder (default [`crate::import::DEFAULT_OUT`]).
    pub out: Option<PathBuf>,
}

impl Importer for WpilibImport {
    fn out(&self) -> Option<&Path> {
        self.out.as_deref()
    }

    /// Reads and converts the log; every file checked to read back as the contract's.
    fn import(&self, dir: &Path) -> Result<Made, ImportFailure> {
        let imported = import(&self.file, &self.choice, &self.assumed)?;
        let stem = crate::output::file_stem_or(&self.file, "sysid");
        let mut files = Vec::new();
        for r in &imported.recordings {
            // A test's name comes from inside the log: made safe, it names a file in `dir`.
            let path = dir.join(format!(
                "{stem}_{}.csv",
                crate::output::safe_file_stem(&r.test)
            ));
            files.push(checked_recording(r.text.clone(), path)?);
        }
        let rig_path = dir.join(format!("{stem}.rig.toml"));
        let rig = Rig::parse(&imported.rig, &rig_path).map_err(|e| ImportFailure::Contract {
            what: "the nominal rig".into(),
            message: e.to_string(),
        })?;
        let scene = scene_of(&rig, &imported.rig, &rig_path);
        files.push(MadeFile {
            kind: FileKind::Rig,
            path: rig_path,
            text: imported.rig.clone(),
        });
        if let Some(text) = scene {
            let path = dir.join(format!("{stem}.scene.toml"));
            crate::scene::Scene::from_toml(&text, &path, &[]).map_err(|e| {
                ImportFailure::Contract {
                    what: "the machine's scene".into(),
                    message: e.to_string(),
                }
            })?;
            files.push(MadeFile {
                kind: FileKind::Scene,
                path,
                text,
            });
        }
        Ok(Made {
            said_before: format!(
                "log        {} ({})\n",
                self.file.display(),
                imported.log.source
            ),
            files,
            said_after: gains_said(&imported),
        })
    }
}

/// SysId's gains as the import prints them.
fn gains_said(imported: &super::Imported) -> String {
    let mut s = format!(
        "SysId feedforward ({}, per {} of {}):\n",
        imported.log.mechanism.name(),
        imported.speed_unit,
        if imported.log.mechanism.is_drivetrain() {
            "wheel rim"
        } else {
            "shaft"
        }
    );
    s.push_str(&crate::sysid::render(
        &imported.feedforward,
        imported.speed_unit,
    ));
    s
}

/// The imported vehicle as a scene for the simulator ([`Rig::scene_toml`]), headed by the
/// rig's own notes on what was measured and what assumed; `None` for a lifted axis.
fn scene_of(rig: &Rig, rig_text: &str, rig_path: &Path) -> Option<String> {
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
