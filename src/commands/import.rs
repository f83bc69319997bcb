//! `agvsim import csv|mat|wpilib|ros2`: a recording kept in another format converted into the
//! exchange format, checked to read back as the contract's, and written whole.

use std::path::{Path, PathBuf};

use super::flags::{positive_number, DriveFlags};
use super::{io, write_file, CommandError, Say};
pub use crate::import::ros2::Ros2Import;
pub use crate::import::wpilib::WpilibImport;
use crate::import::wpilib::{self, wpilog, Assumptions};
pub use crate::import::MappedImport;
use crate::import::{FileKind, Importer, Made};
use crate::record::channels as chan;
use crate::record::Recording;

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

/// Converts what `req` asks, then, holding the output folder's lock, writes every file or
/// none and says the report; `extra` adds what only a later floor can say of the files
/// (it is said after what the import says before its files).
fn write_import(
    req: &dyn Importer,
    extra: &dyn Fn(&Made) -> String,
    say: Say,
) -> Result<(), CommandError> {
    let dir = req.out_dir();
    let mut made = req.import(&dir)?;
    made.said_before.push_str(&extra(&made));
    let _lock = super::lock_out("--out", &dir)?;
    std::fs::create_dir_all(&dir).map_err(io(&dir))?;
    for f in &made.files {
        write_file(&f.path, &f.text)?;
    }
    say(&made.report());
    Ok(())
}

/// `agvsim import csv` or `import mat`: the recording `DIR/FILE_STEM.csv`.
pub fn mapped(req: &MappedImport, say: Say) -> Result<(), CommandError> {
    write_import(req, &|_| String::new(), say)
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

/// `agvsim import wpilib`: one recording per test, the nominal rig and, for a vehicle,
/// its scene (every file or none); SysId's gains said.
pub fn wpilib(req: &WpilibImport, say: Say) -> Result<(), CommandError> {
    write_import(req, &|_| String::new(), say)
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

/// `agvsim import ros2`: `DIR/BAG.csv` and, where the track and wheel radius are known,
/// `DIR/BAG.scene.toml` (every file or none), saying how each column was made and what the
/// recording shows of the base controller's own limits.
pub fn ros2(req: &Ros2Import, say: Say) -> Result<(), CommandError> {
    write_import(req, &limits_of_made, say)
}

/// [`limits_shown`] of an import's recording and scene (nothing without a scene).
fn limits_of_made(made: &Made) -> String {
    let (Some(rec), Some(scene)) = (made.first(FileKind::Recording), made.first(FileKind::Scene))
    else {
        return String::new();
    };
    let Ok(parsed) = Recording::parse(&rec.text, &rec.path) else {
        return String::new();
    };
    limits_shown(&parsed, &scene.text, &scene.path).concat()
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
                ("linear", chan::CMD_LINEAR_M_S)
            } else {
                ("angular", chan::CMD_ANGULAR_RAD_S)
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
