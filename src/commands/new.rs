//! `agvsim new`: a new robot's scene from the numbers its builder knows, every derived
//! value commented with how; and `agvsim check`: a scene's plausibility warnings.

use std::path::PathBuf;

use super::{CommandError, Say};
use crate::scene::robot::{new_scene, RobotSpec};
use crate::scene::{keys, plausibility::sig, Scene};

/// What `agvsim new` was asked.
#[derive(Debug, Clone)]
pub struct NewRequest {
    /// The scene file to write.
    pub out: PathBuf,
    /// The robot's numbers.
    pub spec: RobotSpec,
    /// A scene to start from (its values where no number is given).
    pub from: Option<PathBuf>,
    /// Replace an existing file.
    pub force: bool,
    /// The command line, for the file's header.
    pub command: String,
}

/// Writes the scene and prints what was derived, the implied top speed and any warning.
pub fn run(req: &NewRequest, say: Say) -> Result<(), CommandError> {
    if req.out.exists() && !req.force {
        return Err(CommandError::Option {
            option: "NAME.toml".into(),
            value: req.out.display().to_string(),
            message: "exists; choose another name or pass --force to replace it".into(),
        });
    }
    super::check_targets(&[("NAME.toml", Some(&req.out), false)])?;
    let base = match &req.from {
        Some(p) => Some(Scene::load(p, &[])?),
        None => None,
    };
    let new = new_scene(
        &req.spec,
        req.from.as_deref().zip(base.as_ref()),
        &req.command,
    )?;
    let mut report = String::from("derived:\n");
    for d in &new.derived {
        let unit = keys::table().find(d.key).map_or("", |k| k.unit);
        report.push_str(&format!(
            "  {:<40} {:>10} {:<10} {}\n",
            d.key,
            // Derived to 4 significant figures; 6 shows them whatever the size.
            crate::numtext::sig(d.value, 6),
            unit,
            d.how
        ));
    }
    for n in &new.notes {
        report.push_str(&format!("note: {n}\n"));
    }
    report.push_str(&format!(
        "top speed {} m/s: the motor's no-load speed at the drive limit {} V through the {}:1 gear to a {} m wheel\n",
        sig(new.top_speed_m_s),
        new.scene.battery.drive_limit_v,
        new.scene.gearbox.ratio,
        new.scene.wheel.radius_m
    ));
    let checked = Scene::checked_from_toml(&new.text, &req.out, &[])?;
    report.push_str(&checked.render_warnings());
    say(&report);
    crate::output::write_atomically(&req.out, &new.text).map_err(super::io(&req.out))?;
    say(&format!("scene      {}\n", req.out.display()));
    Ok(())
}

/// What `agvsim check` was asked.
#[derive(Debug, Clone)]
pub struct CheckRequest {
    /// The scene file.
    pub scene: PathBuf,
    /// Scene overrides, `KEY=VALUE`.
    pub set: Vec<String>,
}

/// Loads the scene (every error as `run` gives it) and prints its plausibility warnings.
pub fn check(req: &CheckRequest, say: Say) -> Result<(), CommandError> {
    let checked = Scene::load_checked(&req.scene, &req.set)?;
    let s = &checked.scene;
    let top_speed_m_s =
        s.battery.drive_limit_v / s.motor.torque_constant_nm_a / s.gearbox.ratio * s.wheel.radius_m;
    let mut report = format!(
        "{}: loads; {} kg, track {} m, {} m wheels, {} V; top speed {} m/s at the drive limit\n",
        req.scene.display(),
        sig(s.chassis.mass_kg + s.payload.mass_kg),
        s.chassis.track_width_m,
        s.wheel.radius_m,
        s.battery.open_circuit_v,
        sig(top_speed_m_s)
    );
    report.push_str(&checked.render_warnings());
    report.push_str(&match checked.warnings.len() {
        0 => "no plausibility warnings\n".to_string(),
        1 => "1 plausibility warning\n".to_string(),
        n => format!("{n} plausibility warnings\n"),
    });
    say(&report);
    Ok(())
}
