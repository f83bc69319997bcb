//! `agvsim import csv|mat|wpilib|ros2`: a recording kept in another format converted into the
//! exchange format, checked to read back as the contract's, and written whole.

use std::path::{Path, PathBuf};

use super::flags::{positive_number, DriveFlags};
use super::{io, stem, write_file, CommandError, Say};
use crate::import::wpilib::{self, wpilog, Assumptions};
use crate::import::{csv_map, mat, ImportError};
use crate::record::Recording;
use crate::rig::Rig;

/// What a map file holds, with an example, as `import csv --help` and `import mat --help`
/// print it (a string, not a doc comment: its indented example is TOML, not a doctest).
macro_rules! map_help {
    () => {
        "The map (TOML) names the rig, the time column and each contract column's source,
with a unit (ms, us, rpm, deg, deg_s, rev, mm, cm, mm_s, mV, mA, mNm) or a `scale`
(and an optional `offset`):

    rig = \"drive_axis\"
    time = { column = \"time_ms\", unit = \"ms\" }
    [columns]
    voltage_V = { column = \"volts\" }
    motor_speed_rad_s = { column = \"vel_rpm\", unit = \"rpm\" }
    current_A = { column = \"amps_x10\", scale = 0.1 }

docs/commands.md (import csv) and docs/matlab.md have more."
    };
}

/// The map file's help ([`map_help`]), for reference.
pub const MAP_HELP: &str = map_help!();

/// `agvsim import`'s formats, each with its command line.
#[derive(clap::Subcommand, Debug, Clone)]
pub enum ImportFormat {
    /// A ROS bag (a ROS 2 .mcap or .db3 file or rosbag2 folder with metadata.yaml, or a ROS 1
    /// .bag file) of a robot driven by velocity commands: BAG.csv, a `vehicle` recording
    /// with cmd_linear_m_s, cmd_angular_rad_s from the Twist topic, wheel speeds from
    /// JointState (else from the Odometry twist and the track), yaw rate from Imu, odom_*
    /// from Odometry (the robot's own odometry, not ground truth), x_m/y_m/heading_rad from
    /// an independent pose (a /tf chain to the base, or a PoseStamped,
    /// PoseWithCovarianceStamped or mocap Odometry topic), and how each was made in its
    /// header; and BAG.scene.toml when the track and wheel radius are known (from
    /// /robot_description, the flags or --controller-yaml).
    #[command(alias = "ros1", alias = "ros")]
    Ros2(Ros2Args),
    /// A MATLAB file (MAT level 5) by a map file ([`MAP_HELP`] is its help's example).
    #[command(
        about = "A MATLAB file (MAT level 5, as `save` writes by default) by a map file like the\nCSV's, each `column` naming a variable (a vector).",
        long_about = concat!(
            "A MATLAB file (MAT level 5, as `save` writes by default) by a map file like the\nCSV's, each `column` naming a variable (a vector).\n\n",
            map_help!()
        )
    )]
    Mat {
        /// The MAT-file.
        file: PathBuf,
        /// The map file (TOML).
        #[arg(long, value_name = "MAP.toml")]
        map: PathBuf,
        /// Output folder [default: runs/import]; the recording is FILE_STEM.csv there.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Any CSV by a map file ([`MAP_HELP`] is its help's example).
    #[command(
        about = "Any CSV whose columns have other names or units, by a map file: the time and each\ncontract column with its source column and unit or scale.",
        long_about = concat!(
            "Any CSV whose columns have other names or units, by a map file: the time and each\ncontract column with its source column and unit or scale.\n\n",
            map_help!()
        )
    )]
    Csv {
        /// The CSV file (a header row, then data).
        file: PathBuf,
        /// The map file (TOML).
        #[arg(long, value_name = "MAP.toml")]
        map: PathBuf,
        /// Output folder [default: runs/import]; the recording is FILE_STEM.csv there.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// A WPILib SysId log (SysId's JSON data file, or a DataLog .wpilog written by
    /// SysIdRoutineLog): one recording per test (FILE_STEM_TEST.csv; rig `vehicle` for a
    /// drivetrain, `drive_axis` for one mechanism), the nominal rig of the linear machine
    /// SysId's kV and kA describe (FILE_STEM.rig.toml), and SysId's kS, kV, kA (kG).
    Wpilib(WpilibArgs),
}

impl ImportFormat {
    /// Converts the file the command line names.
    pub fn run(self, say: Say) -> Result<(), CommandError> {
        match self {
            ImportFormat::Ros2(args) => {
                let command = std::env::args().collect::<Vec<_>>().join(" ");
                ros2(&args.request(command)?, say)
            }
            ImportFormat::Csv { file, map, out } => mapped(
                &MappedImport {
                    file,
                    map,
                    out,
                    mat: false,
                },
                say,
            ),
            ImportFormat::Mat { file, map, out } => mapped(
                &MappedImport {
                    file,
                    map,
                    out,
                    mat: true,
                },
                say,
            ),
            ImportFormat::Wpilib(args) => wpilib(&args.request(), say),
        }
    }
}

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
    let bytes = crate::output::read_bounded(&req.file, crate::output::MAX_INPUT_BYTES).map_err(
        |source| ImportError::Read {
            file: req.file.clone(),
            source,
        },
    )?;
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
fn check_recording(text: &str, path: &Path) -> Result<Recording, CommandError> {
    Recording::parse(text, path).map_err(|e| CommandError::Contract {
        what: "the converted recording".into(),
        message: e.to_string(),
    })
}

/// `agvsim import wpilib`'s command line (and Python's `import_wpilib`'s arguments).
#[derive(clap::Args, Debug, Clone)]
pub struct WpilibArgs {
    /// The log (.json or .wpilog).
    pub file: PathBuf,
    /// Output folder [default: runs/import].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// DataLog only: the routine (the LOG of `sysid-test-state-LOG`) when there are several.
    #[arg(long)]
    pub routine: Option<String>,
    /// DataLog only: the motor of a single mechanism, or LEFT,RIGHT of a drivetrain
    /// [default: the routine's one motor, or its motors named left and right].
    #[arg(long, value_delimiter = ',')]
    pub motors: Vec<String>,
    /// DataLog only: drivetrain, drivetrain-angular, simple, elevator or arm
    /// [default: a drivetrain for two motors (angular when driven in opposition), else simple].
    #[arg(long, value_parser = |s: &str| s.parse::<wpilib::Mechanism>())]
    pub mechanism: Option<wpilib::Mechanism>,
    /// Drive wheel (or a linear mechanism's drum) radius, m: needed for a drivetrain
    /// logged in rotations; the vehicle rig's wheel [default 0.0762].
    #[arg(long, value_parser = positive_number)]
    pub wheel_radius_m: Option<f64>,
    /// Motor resistance per side, ohm [default: from the logged current, else 0.05, said as assumed].
    #[arg(long, value_parser = positive_number)]
    pub resistance_ohm: Option<f64>,
    /// Track width, m [default: from a turning test's gyro, else 0.6, said as assumed]
    /// (`--track-width-m` is an older name for it).
    #[arg(long = "track-m", alias = "track-width-m", value_parser = positive_number)]
    pub track_width_m: Option<f64>,
    /// Battery voltage, V [default: none stated; the logged voltages are the applied ones]
    /// (`--supply-v` is an older name for it).
    #[arg(long = "battery-V", alias = "supply-v", value_parser = positive_number)]
    pub supply_v: Option<f64>,
}

impl WpilibArgs {
    /// The request these values make.
    pub fn request(self) -> WpilibImport {
        WpilibImport {
            file: self.file,
            choice: wpilog::Choice {
                routine: self.routine,
                motors: self.motors,
                mechanism: self.mechanism,
            },
            assumed: Assumptions {
                wheel_radius_m: self.wheel_radius_m,
                resistance_ohm: self.resistance_ohm,
                track_width_m: self.track_width_m,
                supply_v: self.supply_v,
            },
            out: self.out,
        }
    }
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
    say(&crate::import::wpilib::feedforward::render(
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

/// `agvsim import ros2`'s command line (and Python's `import_ros2`'s arguments).
#[derive(clap::Args, Debug, Clone)]
pub struct Ros2Args {
    /// The bag.
    pub bag: PathBuf,
    /// A topic map (TOML) choosing among several topics of a type: keys cmd_vel,
    /// joint_states, imu, odom, battery, pose = "PARENT:CHILD" (frames on /tf) or
    /// "/topic", left_wheel_joint, right_wheel_joint, time = "header" or "log".
    #[arg(long, value_name = "MAP.toml")]
    pub map: Option<PathBuf>,
    /// Output folder [default: runs/import].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Drive wheel radius, m [default: from /robot_description].
    #[arg(long, value_parser = positive_number)]
    pub wheel_radius_m: Option<f64>,
    /// Track width, m [default: from /robot_description].
    #[arg(long, value_parser = positive_number)]
    pub track_m: Option<f64>,
    /// Robot mass for the scene, kg [default: sized from the body's outline as the thesis
    /// machine's 120 kg on 1 x 0.62 m, said as a guess].
    #[arg(long, value_parser = positive_number)]
    pub mass_kg: Option<f64>,
    /// The robot's `diff_drive_controller` parameters (YAML, as ros2_control loads
    /// them): its wheel_separation, wheel_radius and their multipliers become the
    /// scene's configured odometry, its velocity and acceleration limits the base
    /// controller's.
    #[arg(long, value_name = "PARAMS.yaml")]
    pub controller_yaml: Option<PathBuf>,
    /// The battery, the motor and the gear [default: the battery topic's median
    /// voltage; a motor and gear sized for the robot as the thesis machine's are for it (its
    /// top speed at the wheel, its push per weight), said as guesses; no gear play].
    #[command(flatten)]
    pub drive: DriveFlags,
}

impl Ros2Args {
    /// The request these values make; `command` is what the scene's header says made it.
    pub fn request(self, command: String) -> Result<Ros2Import, CommandError> {
        Ok(Ros2Import {
            bag: self.bag,
            map: self.map,
            geometry: crate::import::ros2::Geometry {
                wheel_radius_m: self.wheel_radius_m,
                track_m: self.track_m,
                ..Default::default()
            },
            robot: crate::import::ros2::robot::Given {
                mass_kg: self.mass_kg,
                motor: self.drive.motor()?,
                battery_v: self.drive.battery_v,
                gear_ratio: self.drive.gear_ratio,
                backlash_rad: self.drive.backlash_rad,
                controller_yaml: self.controller_yaml,
                command,
            },
            out: self.out,
        })
    }
}

/// What `agvsim import ros2` was asked.
#[derive(Debug, Clone)]
pub struct Ros2Import {
    /// The bag: an .mcap or .db3 file, or a rosbag2 folder.
    pub bag: PathBuf,
    /// The topic map, if given.
    pub map: Option<PathBuf>,
    /// Track and wheel radius beside the bag's description.
    pub geometry: crate::import::ros2::Geometry,
    /// What the user said of the robot (mass, drive, controller file, the command line).
    pub robot: crate::import::ros2::robot::Given,
    /// Output folder (default `runs/import`).
    pub out: Option<PathBuf>,
}

/// Reads the bag, writes `DIR/BAG.csv` and, where the track and wheel radius are known,
/// `DIR/BAG.scene.toml` (every file or none), and says how each column was made.
pub fn ros2(req: &Ros2Import, say: Say) -> Result<(), CommandError> {
    use crate::import::ros2;
    let map = match &req.map {
        Some(p) => ros2::TopicMap::load(p)?,
        None => ros2::TopicMap::default(),
    };
    // The controller's file is read first: where the bag has no description of the
    // wheels, its configured radius and separation convert the wheel speeds.
    let params = match &req.robot.controller_yaml {
        Some(p) => Some(
            ros2::controller::load(p).map_err(|e| CommandError::Contract {
                what: "--controller-yaml".into(),
                message: e.to_string(),
            })?,
        ),
        None => None,
    };
    let mut geometry = req.geometry.clone();
    if let (Some(p), Some(file)) = (&params, &req.robot.controller_yaml) {
        let from = |what: &str| format!("{what} in {} (--controller-yaml)", file.display());
        geometry.configured_radius_m = p.wheel_radius_m.map(|r| (r, from("wheel_radius")));
        geometry.configured_track_m = p.wheel_separation_m.map(|b| (b, from("wheel_separation")));
    }
    let rec = ros2::import(&req.bag, &map, &geometry)?;
    let dir = out_dir(&req.out);
    let _lock = super::lock_out("--out", &dir)?;
    let stem = crate::output::safe_file_stem(&stem(&req.bag, "bag"));
    let csv_path = dir.join(format!("{stem}.csv"));
    let text = rec.to_csv();
    let parsed = check_recording(&text, &csv_path)?;
    let mut files = vec![(csv_path.clone(), text)];
    let scene_path = dir.join(format!("{stem}.scene.toml"));
    // The geometry comes from the flags, the bag's description or, where neither gives
    // it, the controller's file (each given to the import above, which names its source).
    let mut warnings: Vec<String> = vec![];
    if let Some(g) = &rec.geometry {
        let (text, said) =
            ros2::robot::scene(&req.robot, &rec, g, params.as_ref(), &stem, &scene_path)?;
        warnings = said;
        warnings.extend(limits_shown(&parsed, &text, &scene_path));
        files.push((scene_path.clone(), text));
    }
    std::fs::create_dir_all(&dir).map_err(io(&dir))?;
    for (path, text) in &files {
        write_file(path, text)?;
    }
    say(&ros2_report(
        req,
        &rec,
        &warnings,
        &csv_path,
        (files.len() > 1).then_some(&scene_path),
    ));
    Ok(())
}

/// What the recording shows of the base controller's own limits
/// ([`crate::calibrate::base_limits`]): commands the wheels never follow, said with the
/// numbers, so that nobody asks other physics to explain the gap.
fn limits_shown(rec: &Recording, scene_text: &str, scene_path: &Path) -> Vec<String> {
    use crate::model::base_controller::BaseParams;
    let Ok(scene) = crate::scene::Scene::from_toml(scene_text, scene_path, &[]) else {
        return vec![];
    };
    let sig = crate::scene::plausibility::sig;
    let peak = |column: &str| {
        rec.column(column).map_or(0.0, |c| {
            c.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()))
        })
    };
    let shown = crate::calibrate::base_limits::shown(rec, &scene);
    shown
        .starts
        .iter()
        .map(|(key, start)| {
            let unit = key.unit();
            let (what, command) = if *key == BaseParams::max_linear_m_s
                || *key == BaseParams::max_linear_accel_m_s2
            {
                ("linear", "cmd_linear_m_s")
            } else {
                ("angular", "cmd_angular_rad_s")
            };
            let moved = shown.seen_by.noun();
            let seen = if key.key().contains("accel") {
                format!("{moved} climb its steps at about {} {unit} at most", sig(*start))
            } else {
                format!(
                    "it asks up to {} {unit}, {moved} reach about {} {unit}",
                    sig(peak(command)),
                    sig(*start)
                )
            };
            format!(
                "limits     /cmd_vel's {what} speed: {seen}: the base controller's (or its drivers') limit {} (`agvsim calibrate` fits it first, effect base_limits)\n",
                key.key()
            )
        })
        .collect()
}

/// What `import ros2` prints: the bag, how each column was made, notes and warnings,
/// the files written (`scene`: the scene's, if one was).
fn ros2_report(
    req: &Ros2Import,
    rec: &crate::import::ros2::Ros2Recording,
    warnings: &[String],
    csv_path: &Path,
    scene: Option<&PathBuf>,
) -> String {
    let mut report = format!(
        "bag        {} ({} storage), {} rows over {} s\n",
        req.bag.display(),
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
    report.push_str(&format!("recording  {}\n", csv_path.display()));
    if let Some(scene_path) = scene {
        report.push_str(&format!("scene      {}\n", scene_path.display()));
    } else {
        report.push_str("scene      not written: the bag has no /robot_description with the drive wheels; give --track-m and --wheel-radius-m\n");
    }
    report
}
