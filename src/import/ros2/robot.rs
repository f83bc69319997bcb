//! The scene `import ros2` writes for the robot of a bag: `agvsim new`'s derivations from
//! the bag's wheel geometry and what the user gave (mass, motor, gear, battery; each not
//! given sized from the robot or taken from the thesis machine, and said), the
//! `diff_drive_controller` file's configured geometry and limits written in, and the
//! plausibility warnings, each naming where its number came from.

use std::path::{Path, PathBuf};

use crate::model::battery::BatteryParams;
use crate::model::chassis::ChassisParams;
use crate::model::wheel::WheelParams;
use crate::scene::robot::{MotorDatasheet, RobotError};

/// What the user said of the robot beside the bag (options, or Python's arguments); each
/// `None` is guessed and said so.
#[derive(Debug, Clone, Default)]
pub struct Given {
    /// Robot mass, kg.
    pub mass_kg: Option<f64>,
    /// The drive motor's datasheet point.
    pub motor: Option<MotorDatasheet>,
    /// Battery voltage, V (else the battery topic's median).
    pub battery_v: Option<f64>,
    /// Motor turns per wheel turn.
    pub gear_ratio: Option<f64>,
    /// Gear play at the wheel, rad (default 0).
    pub backlash_rad: Option<f64>,
    /// A `diff_drive_controller` parameter file, for the warnings' words.
    pub controller_yaml: Option<PathBuf>,
    /// The command line, for the scene's header.
    pub command: String,
}

/// Why the robot's scene cannot be made.
#[derive(Debug, thiserror::Error)]
pub enum RobotSceneError {
    /// Numbers that cannot make a scene.
    #[error(transparent)]
    Robot(#[from] RobotError),
    /// A scene (or the controller's values written in) that does not read back.
    #[error("{what} breaks the contract: {message}")]
    Contract {
        /// What was made.
        what: String,
        /// The reader's complaint.
        message: String,
    },
}

/// The robot's scene text from the bag's geometry (track, wheel radius, and where they
/// came from: `geometry`), what the user gave, and the controller's parameters where a
/// file gave them; with what the import says of it, one line each: every number guessed,
/// and every plausibility warning naming where its number came from.
pub fn scene(
    req: &Given,
    rec: &super::Ros2Recording,
    geometry: &(f64, f64, String),
    params: Option<&super::controller::DiffDriveParams>,
    stem: &str,
    scene_path: &Path,
) -> Result<(String, Vec<String>), RobotSceneError> {
    let (track_m, radius_m, from) = geometry;
    let mut warnings = vec![];
    let battery_v = req.battery_v.or(rec.battery_v);
    let spec = crate::scene::robot::RobotSpec {
        mass_kg: req.mass_kg,
        track_m: Some(*track_m),
        wheel_radius_m: Some(*radius_m),
        battery_v,
        motor: req.motor,
        gear_ratio: req.gear_ratio,
        // No play unless the user says: a robot is not the thesis machine.
        backlash_rad: Some(req.backlash_rad.unwrap_or(0.0)),
        guidance: Some(crate::scene::robot::Guidance::None),
        configured_geometry: true,
        origins: geometry_origins(rec, geometry, req.battery_v.is_none()),
        description: Some(format!(
            "The robot of ROS 2 bag {stem}: {from}{}; {} until calibrated",
            battery_v.map_or(String::new(), |v| format!(
                "; battery {} V{}",
                crate::scene::plausibility::sig(v),
                if req.battery_v.is_some() {
                    ""
                } else {
                    ", the median of its battery topic"
                }
            )),
            if req.motor.is_some() {
                "the rest derived from the numbers given"
            } else {
                "the motor and gear sized for it as the thesis machine's are for that (assumed: give --motor-* and --gear-ratio)"
            }
        )),
        // The thesis machine only stands in for the robot: a motor and gear not given
        // are sized for the robot, not carried over.
        size_drive: true,
        ..Default::default()
    };
    let base = crate::scene::Scene::default();
    let new = crate::scene::robot::new_scene(
        &spec,
        Some((Path::new("the thesis machine (agvsim's defaults)"), &base)),
        &req.command,
    )?;
    warnings.extend(guesses(req, battery_v, &new.scene));
    let mut text = new.text;
    if let Some(p) = &params {
        text = with_controller_params(&text, p, req.controller_yaml.as_deref())?;
    }
    if let Ok(checked) = crate::scene::Scene::checked_from_toml(&text, scene_path, &[]) {
        // Each warning names where its number came from: an option, the bag's
        // description, its battery topic.
        for (origin, w) in &checked.warnings {
            let from = spec.options_setting(w.key).or_else(|| {
                let file = req.controller_yaml.as_ref()?;
                w.key
                    .starts_with("base.")
                    .then(|| format!("--controller-yaml {}", file.display()))
            });
            warnings.push(match from {
                Some(from) => format!("warning: {from} ({origin}): {w}\n"),
                None => format!("warning: {origin}: {w}\n"),
            });
        }
    }
    crate::scene::Scene::from_toml(&text, scene_path, &[]).map_err(|e| {
        RobotSceneError::Contract {
            what: match &req.controller_yaml {
                Some(f) => format!(
                    "the robot's scene (with the values of --controller-yaml {})",
                    f.display()
                ),
                None => "the robot's scene".into(),
            },
            message: e.to_string(),
        }
    })?;
    Ok((text, warnings))
}

/// The numbers the user did not give, said on the console (the scene's comments say them
/// too): each sized from the robot or taken from the thesis machine, with the option that
/// gives it.
fn guesses(req: &Given, battery_v: Option<f64>, scene: &crate::scene::Scene) -> Vec<String> {
    let sig = crate::scene::plausibility::sig;
    let mut said = vec![];
    let thesis = crate::scene::Scene::default();
    if req.mass_kg.is_none() {
        let (c, thesis) = (&scene.chassis, &thesis.chassis);
        said.push(format!(
            "guessed    chassis mass {} kg, sized from its {} x {} m outline as the thesis machine's {} kg on {} x {} m: give --mass-kg\n",
            sig(c.mass_kg),
            sig(c.front_m + c.rear_m),
            sig(c.width_m),
            sig(thesis.mass_kg),
            sig(thesis.front_m + thesis.rear_m),
            sig(thesis.width_m)
        ));
    }
    let proportions = crate::scene::robot::DriveProportions::of(&thesis);
    if req.motor.is_none() {
        let v = battery_v.unwrap_or(scene.battery.open_circuit_v);
        said.push(format!(
            "guessed    motor: {} rad/s no-load, {} N m stall at {} V ({} N m/A, {} ohm), sized as the thesis machine's for it: a top speed of {} m/s at the wheel, both motors at stall pushing {} times its weight: give --motor-no-load-rpm and --motor-stall-current-A\n",
            sig(scene.motor.no_load_speed_rad_s(v)),
            sig(scene.motor.stall_torque_nm(v)),
            sig(v),
            sig(scene.motor.torque_constant_nm_a),
            sig(scene.motor.resistance_ohm),
            sig(proportions.top_speed_m_s),
            sig(proportions.stall_push_per_weight)
        ));
    }
    if req.gear_ratio.is_none() {
        said.push(format!(
            "guessed    gear ratio {}, sized for the thesis machine's top speed of {} m/s on the {} m wheel: give --gear-ratio\n",
            sig(scene.gearbox.ratio),
            sig(proportions.top_speed_m_s),
            sig(scene.wheel.radius_m)
        ));
    }
    if battery_v.is_none() {
        said.push(format!(
            "guessed    battery {} V, the thesis machine's: give --battery-V\n",
            sig(scene.battery.open_circuit_v)
        ));
    }
    said
}

/// Where an imported robot's track, wheel radius and battery voltage came from, when not
/// from an option: the bag's description (or the controller's file) and battery topic.
fn geometry_origins(
    rec: &super::Ros2Recording,
    (_, _, from): &(f64, f64, String),
    battery_from_topic: bool,
) -> Vec<(&'static str, String)> {
    let mut origins = vec![];
    for (key, part) in [
        (ChassisParams::track_width_m.key(), "track"),
        (WheelParams::radius_m.key(), "wheel radius"),
    ] {
        // `from` reads "track from X; wheel radius from Y" (or one source for both).
        let said = from
            .split("; ")
            .find_map(|p| p.strip_prefix(&format!("{part} from ")))
            .unwrap_or(from);
        if !said.starts_with("--") {
            origins.push((key, said.to_string()));
        }
    }
    if battery_from_topic {
        if let Some(c) = rec
            .conversions
            .iter()
            .find(|c| c.column == "battery_voltage_V")
        {
            let topic = c.how.split(' ').next().unwrap_or("the battery topic");
            origins.push((
                BatteryParams::open_circuit_v.key(),
                format!("the median voltage of {topic}"),
            ));
        }
    }
    origins
}

/// The scene's text with a `diff_drive_controller` file's configured geometry and limits
/// written into its `[base]` section, each commented with where it came from.
fn with_controller_params(
    text: &str,
    p: &super::controller::DiffDriveParams,
    file: Option<&Path>,
) -> Result<String, RobotSceneError> {
    let from = file.map_or("the controller file".to_string(), |f| {
        f.display().to_string()
    });
    let mut doc: toml_edit::DocumentMut = text.parse().map_err(|e| RobotSceneError::Contract {
        what: "the robot's scene".into(),
        message: format!("{e}"),
    })?;
    let base = doc["base"].or_insert(toml_edit::table());
    let mut set = |key: &str, value: Option<f64>, what: &str| {
        if let Some(v) = value {
            let mut item = toml_edit::Value::from(v);
            item.decor_mut()
                .set_suffix(format!("  # {what} from {from}"));
            base[key] = toml_edit::Item::Value(item);
        }
    };
    set(
        "wheel_separation_m",
        p.wheel_separation_m,
        "wheel_separation x wheel_separation_multiplier",
    );
    set(
        "wheel_radius_m",
        p.wheel_radius_m,
        &match p.unequal_multipliers {
            Some((l, r)) => format!("wheel_radius x the mean of its left ({l}) and right ({r}) multipliers: the scene's controller has one radius"),
            None => "wheel_radius x its multiplier".to_string(),
        },
    );
    set("max_linear_m_s", p.max_linear_m_s, "linear.x.max_velocity");
    set(
        "max_linear_accel_m_s2",
        p.max_linear_accel_m_s2,
        "linear.x.max_acceleration",
    );
    set(
        "max_angular_rad_s",
        p.max_angular_rad_s,
        "angular.z.max_velocity",
    );
    set(
        "max_angular_accel_rad_s2",
        p.max_angular_accel_rad_s2,
        "angular.z.max_acceleration",
    );
    Ok(doc.to_string())
}
