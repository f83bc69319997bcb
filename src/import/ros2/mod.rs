//! `agvsim import ros2`: a ROS 2 bag (MCAP, or a rosbag2 folder with MCAP or SQLite3
//! storage) to a `vehicle` recording driven by velocity commands, and, where the bag (its
//! `/robot_description`) or the user gives the track and wheel radius, a scene to
//! calibrate from.
//!
//! Topics are found by message type; a `--map` file chooses among several. Every
//! conversion (topic, field, frame, time source, how streams of different rates meet on
//! one time base) is stated in the recording's header. Odometry integrated from the
//! wheels is not ground truth: it is written as `odom_*` columns, which nothing compares,
//! and only a pose from another source (a motion-capture or localisation transform on
//! `/tf`) becomes the contract's `x_m`, `y_m`, `heading_rad`. [`Ros2Import`] is the
//! command's request, which makes the files.

mod align;
pub mod cdr;
mod clock;
mod columns;
mod controller;
mod converter;
mod importer;
mod joints;
mod mcap;
mod open;
mod pose;
pub mod robot;
mod sqlite;
mod streams;
mod urdf;

use std::path::{Path, PathBuf};

pub use crate::import::bag::{Bag, BagError, Storage, Topic};
pub use columns::{Conversion, Ros2Recording};
pub use importer::Ros2Import;

/// Why a bag cannot be imported.
#[derive(Debug, thiserror::Error)]
pub enum Ros2Error {
    /// The bag cannot be read.
    #[error(transparent)]
    Bag(#[from] BagError),
    /// The bag's content does not give a recording (the message names the topic).
    #[error("{}: {message}", bag.display())]
    Content {
        /// The bag.
        bag: PathBuf,
        /// What is missing or wrong, naming the topic or message.
        message: String,
    },
    /// The map file is wrong.
    #[error("{}: {message}", file.display())]
    Map {
        /// The map file.
        file: PathBuf,
        /// What is wrong.
        message: String,
    },
}

/// Which time a message is placed at.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum TimeSource {
    /// The message's header stamp where it has one (and it is set), else its log time.
    #[default]
    Header,
    /// The time the recorder received it, for every message.
    Log,
}

/// `--map FILE.toml`: which topic plays which part, where the bag has several of a type
/// (every key optional).
#[derive(Debug, Clone, Default, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TopicMap {
    /// The velocity command topic (`geometry_msgs/Twist` or `TwistStamped`).
    pub cmd_vel: Option<String>,
    /// The wheels' `sensor_msgs/JointState` topic.
    pub joint_states: Option<String>,
    /// The `sensor_msgs/Imu` topic whose yaw rate is the gyro.
    pub imu: Option<String>,
    /// The wheel odometry's `nav_msgs/Odometry` topic.
    pub odom: Option<String>,
    /// The `sensor_msgs/BatteryState` topic.
    pub battery: Option<String>,
    /// The independent pose: `PARENT:CHILD` frames on `/tf` (`mocap:base_link`, a chain
    /// of transforms is composed), or a topic (`/mocap/pose`: `geometry_msgs/PoseStamped`,
    /// `PoseWithCovarianceStamped` or a motion-capture bridge's `nav_msgs/Odometry`).
    pub pose: Option<String>,
    /// The left drive wheel's joint name.
    pub left_wheel_joint: Option<String>,
    /// The right drive wheel's joint name.
    pub right_wheel_joint: Option<String>,
    /// `header` (default) or `log`.
    pub time: Option<TimeSource>,
}

impl TopicMap {
    /// Reads a map file.
    pub fn load(path: &Path) -> Result<TopicMap, Ros2Error> {
        let text = crate::output::read_text_bounded(path, crate::output::MAX_CONFIG_BYTES)
            .map_err(|e| Ros2Error::Map {
                file: path.to_owned(),
                message: format!("cannot read: {e}"),
            })?;
        toml::from_str(&text).map_err(|e| Ros2Error::Map {
            file: path.to_owned(),
            message: format!(
                "{} (keys: cmd_vel, joint_states, imu, odom, battery, pose = \"PARENT:CHILD\" or \"/topic\", left_wheel_joint, right_wheel_joint, time = \"header\" or \"log\")",
                e.message()
            ),
        })
    }
}

/// What the user says of the robot beside the bag.
#[derive(Debug, Clone, Default)]
pub struct Geometry {
    /// Drive wheel radius, m (else from `/robot_description`).
    pub wheel_radius_m: Option<f64>,
    /// Track width, m (else from `/robot_description`).
    pub track_m: Option<f64>,
    /// What the base controller is configured with (`--controller-yaml`): its wheel
    /// radius and separation, m, each with where it came from; used where neither an
    /// option nor the bag's description gives the size.
    pub configured_radius_m: Option<(f64, String)>,
    /// As `configured_radius_m`, the wheel separation, m.
    pub configured_track_m: Option<(f64, String)>,
}

/// Reads a bag and converts it.
pub fn import(
    path: &Path,
    map: &TopicMap,
    geometry: &Geometry,
) -> Result<Ros2Recording, Ros2Error> {
    let bag = open::open(path)?;
    columns::convert(&bag, map, geometry)
}
