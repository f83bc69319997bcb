//! `agvsim import ros2` (and `ros1`) as an [`Importer`]: the bag's recording
//! (`DIR/BAG.csv`) and, where the track and wheel radius are known, the robot's scene
//! (`DIR/BAG.scene.toml`, [`super::robot::scene`]), with how each column was made said.

use std::path::{Path, PathBuf};

use super::{controller, robot, Geometry, Ros2Recording, TopicMap};
use crate::import::{checked_recording, FileKind, ImportFailure, Importer, Made, MadeFile};

/// What `agvsim import ros2` was asked.
#[derive(Debug, Clone)]
pub struct Ros2Import {
    /// The bag: an .mcap or .db3 file, or a rosbag2 folder.
    pub bag: PathBuf,
    /// The topic map, if given.
    pub map: Option<PathBuf>,
    /// Track and wheel radius beside the bag's description.
    pub geometry: Geometry,
    /// What the user said of the robot (mass, drive, controller file, the command line).
    pub robot: robot::Given,
    /// Output folder (default [`crate::import::DEFAULT_OUT`]).
    pub out: Option<PathBuf>,
}

impl Importer for Ros2Import {
    fn out(&self) -> Option<&Path> {
        self.out.as_deref()
    }

    /// Reads the bag, converts it and, where the track and wheel radius are known, makes
    /// the robot's scene.
    fn import(&self, dir: &Path) -> Result<Made, ImportFailure> {
        let map = match &self.map {
            Some(p) => TopicMap::load(p)?,
            None => TopicMap::default(),
        };
        // The controller's file is read first: where the bag has no description of the
        // wheels, its configured radius and separation convert the wheel speeds.
        let params = match &self.robot.controller_yaml {
            Some(p) => Some(controller::load(p).map_err(|e| ImportFailure::Contract {
                what: "--controller-yaml".into(),
                message: e.to_string(),
            })?),
            None => None,
        };
        let mut geometry = self.geometry.clone();
        if let (Some(p), Some(file)) = (&params, &self.robot.controller_yaml) {
            let from = |what: &str| format!("{what} in {} (--controller-yaml)", file.display());
            geometry.configured_radius_m = p.wheel_radius_m.map(|r| (r, from("wheel_radius")));
            geometry.configured_track_m =
                p.wheel_separation_m.map(|b| (b, from("wheel_separation")));
        }
        let rec = super::import(&self.bag, &map, &geometry)?;
        let stem = crate::output::safe_file_stem(&crate::output::file_stem_or(&self.bag, "bag"));
        let mut files = vec![checked_recording(
            rec.to_csv(),
            dir.join(format!("{stem}.csv")),
        )?];
        // The geometry comes from the flags, the bag's description or, where neither gives
        // it, the controller's file (each given to the import above, which names its source).
        let mut warnings: Vec<String> = vec![];
        if let Some(g) = &rec.geometry {
            let path = dir.join(format!("{stem}.scene.toml"));
            let (text, said) = robot::scene(&self.robot, &rec, g, params.as_ref(), &stem, &path)?;
            warnings = said;
            files.push(MadeFile {
                kind: FileKind::Scene,
                path,
                text,
            });
        }
        let said_after = if files.len() > 1 {
            String::new()
        } else {
            "scene      not written: the bag has no /robot_description with the drive wheels; give --track-m and --wheel-radius-m\n".into()
        };
        Ok(Made {
            said_before: said_before(&self.bag, &rec, &warnings),
            files,
            said_after,
        })
    }
}

/// What `import ros2` says before its files: the bag, how each column was made, notes and
/// warnings.
fn said_before(bag: &Path, rec: &Ros2Recording, warnings: &[String]) -> String {
    let mut report = format!(
        "bag        {} ({} storage), {} rows over {} s\n",
        bag.display(),
        rec.storage.name(),
        rec.t_s.len(),
        crate::scene::plausibility::sig(*rec.t_s.last().unwrap_or(&0.0))
    );
    for (k, v) in &rec.timing {
        report.push_str(&format!("{k:<10} {v}\n"));
    }
    for c in &rec.conversions {
        report.push_str(&format!("  {:<22} {}\n", c.column, c.how));
    }
    for n in &rec.notes {
        report.push_str(&format!("note: {n}\n"));
    }
    for w in warnings {
        report.push_str(w);
    }
    report
}
