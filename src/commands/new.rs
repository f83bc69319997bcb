//! `agvsim new`: a new robot's scene from the numbers its builder knows, every derived
//! value commented with how; and `agvsim check`: a scene's plausibility warnings.

use std::path::PathBuf;

use super::flags::{positive_number, yes_no, DriveFlags, Overrides};
use super::{CommandError, Say};
use crate::scene::robot::{new_scene, Guidance, RobotSpec};
use crate::scene::{plausibility::sig, Scene};

/// `--guidance`: one of [`Guidance`]'s words, listed in the help as clap lists possible
/// values.
fn guidance_words() -> impl clap::builder::TypedValueParser<Value = Guidance> {
    use clap::builder::TypedValueParser;
    // The parser admits only the listed words, each of which parses.
    clap::builder::PossibleValuesParser::new(Guidance::ALL.map(Guidance::name))
        .map(|word| word.parse().unwrap_or(Guidance::None))
}

/// `agvsim new`'s command line: the robot's numbers, each in its unit; without --from the
/// first eight are needed.
#[derive(clap::Args, Debug, Clone)]
pub struct NewArgs {
    /// The scene file to write (refused if it exists, unless --force).
    #[arg(value_name = "NAME.toml")]
    pub out: PathBuf,
    /// Start from this scene: its values stand where no number is given, and only values
    /// derived from the numbers given are derived again.
    #[arg(long, value_name = "SCENE.toml")]
    pub from: Option<PathBuf>,
    /// Mass with batteries, kg.
    #[arg(long, value_parser = positive_number)]
    pub mass_kg: Option<f64>,
    /// Distance between the drive wheels' contact patches, m.
    #[arg(long, value_parser = positive_number)]
    pub track_m: Option<f64>,
    /// Drive wheel radius, m.
    #[arg(long, value_parser = positive_number)]
    pub wheel_radius_m: Option<f64>,
    /// The battery, the motor and the gear.
    #[command(flatten)]
    pub drive: DriveFlags,
    /// Tyre compound: hard_polyurethane, soft_rubber or high_grip (`agvsim presets`)
    /// [default: hard_polyurethane].
    #[arg(long)]
    pub tyre: Option<String>,
    /// Castors: yes (four, carrying 40 % of the load) or no (every load on the drive
    /// wheels) [default: yes].
    #[arg(long, value_parser = yes_no)]
    pub castors: Option<bool>,
    /// Guidance: `wire` (the thesis's guide wire and P-D firmware), `none` (a
    /// velocity-commanded base, as a ROS robot: `run` drives its [manoeuvre], a square,
    /// `replay` a recording's cmd_vel) or `open-loop` (constant demands) [default: none].
    #[arg(long, value_parser = guidance_words())]
    pub guidance: Option<Guidance>,
    /// Body length, m [default: twice the track].
    #[arg(long, value_parser = positive_number)]
    pub length_m: Option<f64>,
    /// Body width, m [default: the track plus 0.12 m].
    #[arg(long, value_parser = positive_number)]
    pub width_m: Option<f64>,
    /// The scene's description.
    #[arg(long)]
    pub description: Option<String>,
    /// Replace NAME.toml if it exists.
    #[arg(long)]
    pub force: bool,
}

impl NewArgs {
    /// The request the flags make: the robot's numbers as a [`RobotSpec`]; `command` is
    /// what the scene file's header says made it.
    pub fn request(self, command: String) -> Result<NewRequest, CommandError> {
        let motor = self.drive.motor()?;
        Ok(NewRequest {
            out: self.out,
            from: self.from,
            force: self.force,
            command,
            spec: RobotSpec {
                mass_kg: self.mass_kg,
                track_m: self.track_m,
                wheel_radius_m: self.wheel_radius_m,
                battery_v: self.drive.battery_v,
                motor,
                gear_ratio: self.drive.gear_ratio,
                backlash_rad: self.drive.backlash_rad,
                tyre: self.tyre,
                castors: self.castors,
                guidance: self.guidance,
                length_m: self.length_m,
                width_m: self.width_m,
                description: self.description,
                configured_geometry: false,
                origins: vec![],
                // `--from` is the user's own machine: its drive carries over.
                size_drive: false,
            },
        })
    }
}

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
        report.push_str(&format!(
            "  {:<40} {:>10} {:<10} {}\n",
            d.key.key(),
            // Derived to 4 significant figures; 6 shows them whatever the size.
            crate::numtext::sig(d.value, 6),
            d.key.unit(),
            d.how
        ));
    }
    for n in &new.notes {
        report.push_str(&format!("note: {n}\n"));
    }
    let n = crate::param::plain_number;
    report.push_str(&format!(
        "top speed {} m/s: the motor's no-load speed at the drive limit {} V through the {}:1 gear to a {} m wheel\n",
        sig(new.top_speed_m_s),
        n(new.scene.battery.drive_limit_v),
        n(new.scene.gearbox.ratio),
        n(new.scene.wheel.radius_m)
    ));
    let checked = Scene::checked_from_toml(&new.text, &req.out, &[])?;
    // Each warning names the options that set its key, as the user typed them.
    for (origin, w) in &checked.warnings {
        match req.spec.options_setting(w.key) {
            Some(options) => report.push_str(&format!("warning: {options} ({origin}): {w}\n")),
            None => report.push_str(&format!("warning: {origin}: {w}\n")),
        }
    }
    say(&report);
    crate::output::write_atomically(&req.out, &new.text).map_err(super::io(&req.out))?;
    say(&format!("scene      {}\n", req.out.display()));
    Ok(())
}

/// What `agvsim check` was asked.
#[derive(Debug, Clone, clap::Args)]
pub struct CheckRequest {
    /// Scene file (TOML).
    pub scene: PathBuf,
    /// Scene overrides (`--set`).
    #[command(flatten)]
    pub set: Overrides,
}

/// Loads the scene (every error as `run` gives it) and prints its plausibility warnings.
pub fn check(req: &CheckRequest, say: Say) -> Result<(), CommandError> {
    let checked = Scene::load_checked(&req.scene, &req.set)?;
    let s = &checked.scene;
    let top_speed_m_s = s.top_speed_m_s(s.battery.drive_limit_v);
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
