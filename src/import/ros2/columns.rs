//! From a bag's topics to the recording's columns: which topic plays which part, each
//! message decoded and placed in time, the streams met on one time base.

use std::path::PathBuf;

use super::align::{held, median_interval_ns, nearest, seconds_of_ns, Series};
use super::converter::{
    s_of, Converter, BATTERY, IMU, JOINT_STATE, ODOMETRY, POSE_COV_STAMPED, POSE_STAMPED, STRING,
    TF,
};
use super::{clock, streams};
use super::{Geometry, Ros2Error, TimeSource, TopicMap};
use crate::import::bag::{Bag, Storage, Topic};
use crate::record::channels as chan;

/// How one column was made, for the recording's header.
#[derive(Debug, Clone, PartialEq)]
pub struct Conversion {
    /// The column.
    pub column: String,
    /// Topic, type, field, frame and alignment, in words.
    pub how: String,
}

/// A bag converted: the recording's columns and how each was made.
#[derive(Debug, Clone)]
pub struct Ros2Recording {
    /// The bag.
    pub bag: PathBuf,
    /// Its storage.
    pub storage: Storage,
    /// Time of the first row, ns since the epoch.
    pub time_zero_ns: i64,
    /// Row times, s from the first.
    pub t_s: Vec<f64>,
    /// Row times, ns from the first (written exactly).
    pub t_ns: Vec<i64>,
    /// Column names, `t_s` excluded.
    pub names: Vec<String>,
    /// Columns (`None`: not measured at that row), in `names`' order.
    pub columns: Vec<Vec<Option<f64>>>,
    /// How each column was made.
    pub conversions: Vec<Conversion>,
    /// How times and rows were chosen.
    pub timing: Vec<(String, String)>,
    /// Track and wheel radius, m, with where they came from.
    pub geometry: Option<(f64, f64, String)>,
    /// Median battery voltage, V, where the bag has a battery topic.
    pub battery_v: Option<f64>,
    /// What a reader should know (topics left unused, rows dropped).
    pub notes: Vec<String>,
}

/// Converts a bag's topics to a velocity-commanded vehicle recording.
///
/// Messages are placed at their header stamps unless the map says `time = "log"`; where
/// the stamps are not one clock with the log times ([`clock::disagreement`]) every
/// message is placed at its log time instead, and a note says why; a map that asks for
/// header stamps then has the bag refused.
pub fn convert(bag: &Bag, map: &TopicMap, geometry: &Geometry) -> Result<Ros2Recording, Ros2Error> {
    let time = map.time.unwrap_or_default();
    match convert_timed(bag, map, geometry, time)? {
        Timed::Done(r) => Ok(*r),
        Timed::ClocksDisagree(why) if map.time.is_none() => {
            match convert_timed(bag, map, geometry, TimeSource::Log)? {
                Timed::Done(mut r) => {
                    r.notes.insert(
                        0,
                        format!("header stamps not used: {why}; every message is placed at its log time (say time = \"log\" in a --map file to choose it)"),
                    );
                    Ok(*r)
                }
                // Not reached (log times are one clock and are not checked), but an
                // error, not a panic, if it were.
                Timed::ClocksDisagree(why) => Err(Ros2Error::Content {
                    bag: bag.path.clone(),
                    message: why,
                }),
            }
        }
        Timed::ClocksDisagree(why) => Err(Ros2Error::Content {
            bag: bag.path.clone(),
            message: format!("the --map file asks for header stamps (time = \"header\"), but {why}; say time = \"log\" to place each message at its log time"),
        }),
    }
}

/// A conversion done, or stopped because the header stamps are not one clock.
enum Timed {
    Done(Box<Ros2Recording>),
    ClocksDisagree(String),
}

fn convert_timed(
    bag: &Bag,
    map: &TopicMap,
    geometry: &Geometry,
    time: TimeSource,
) -> Result<Timed, Ros2Error> {
    let c = Converter {
        bag,
        map,
        time,
        placed: Default::default(),
    };
    let mut notes = vec![];
    let size = streams::drive_size(&c, geometry, &mut notes)?;
    let cmd = streams::commands(&c)?;
    let topics = Outputs::picked(&c)?;
    let (wheel, wheel_names) =
        streams::wheels(&c, topics.joints, size.described.as_ref(), &mut notes)?;
    let gyro = streams::gyro(&c, topics.imu)?;
    let (odometry, odom_frames) = streams::odometry(&c, topics.odom)?;
    let volts = streams::battery(&c, topics.battery)?;
    let (pose, pose_frames) = super::pose::tracked_pose(&c, &mut notes)?;
    if time == TimeSource::Header {
        if let Some(why) = clock::disagreement(&c.placed.borrow()) {
            return Ok(Timed::ClocksDisagree(why));
        }
    }

    // The time base: the wheels' stamps, else the gyro's, else the odometry's, else the
    // pose's.
    let (base, base_name) = [
        (&wheel, topics.joints.map(|t| t.name.clone())),
        (&gyro, topics.imu.map(|t| t.name.clone())),
        (&odometry, topics.odom.map(|t| t.name.clone())),
        (&pose, pose_frames.as_ref().map(|(_, topic)| topic.clone())),
    ]
    .into_iter()
    .find_map(|(s, name)| name.map(|n| (s, n)))
    .ok_or_else(|| {
        c.err(format!(
            "no output to compare: expected a {JOINT_STATE}, {IMU} or {ODOMETRY} topic, or a pose (/tf to the base, {POSE_STAMPED}, {POSE_COV_STAMPED}); the bag has {}",
            c.listing()
        ))
    })?;
    let rows = rows_from_first_command(&c, base, &base_name, &cmd, &mut notes)?;
    let mut table = Table::new(&rows, &base_name);
    table.add_commands(&cmd);
    if let (Some(t), Some(names)) = (topics.joints, &wheel_names) {
        table.add_wheels(&c, t, &wheel, names, &size)?;
    }
    if let Some(t) = topics.imu {
        let placing = table.placing(&t.name);
        table.add(
            chan::YAW_RATE_RAD_S,
            table.align(&gyro, 0, &t.name),
            format!("{} ({IMU}) angular_velocity.z, in the IMU's frame taken as level and aligned with the base; {placing}", t.name),
        );
    }
    // Without joint states, the odometry's twist is what the wheels measured.
    if let (None, Some(t), Some(track)) = (topics.joints, topics.odom, &size.track) {
        table.add_odometry_wheels(t, &odometry, track);
    }
    if let Some(t) = topics.odom {
        table.add_odometry(t, &odometry, odom_frames.clone().unwrap_or_default());
    }
    if let Some((frames, topic)) = &pose_frames {
        table.add_pose(&pose, frames, topic);
    }
    if let Some(t) = topics.battery {
        table.add(
            "battery_voltage_V",
            held(&rows, &volts, 0),
            format!(
                "{} ({BATTERY}) voltage, held from each message to the next",
                t.name
            ),
        );
    }
    notes.extend(unused_topics(bag, &topics, cmd.topic, &pose_frames));
    let timing = timing(&c, &rows, &base_name, &cmd);
    Ok(Timed::Done(Box::new(Ros2Recording {
        bag: bag.path.clone(),
        storage: bag.storage,
        time_zero_ns: rows[0],
        t_s: rows.iter().map(|t| s_of(t - rows[0])).collect(),
        t_ns: rows.iter().map(|t| t - rows[0]).collect(),
        names: table.names,
        columns: table.columns,
        conversions: table.conversions,
        timing,
        geometry: match (size.track, size.radius) {
            (Some((t, tf)), Some((r, rf))) => {
                Some((t, r, format!("track from {tf}; wheel radius from {rf}")))
            }
            _ => None,
        },
        battery_v: streams::median_voltage(&volts),
        notes,
    })))
}

/// How the rows were timed: the clock, the time base from the first command, the zero.
fn timing(
    c: &Converter,
    rows: &[i64],
    base_name: &str,
    cmd: &streams::Commands,
) -> Vec<(String, String)> {
    vec![
        (
            "time".to_string(),
            format!("each message at its {}", c.time_words()),
        ),
        (
            "rows".to_string(),
            format!(
                "one per {base_name} message from the first command on ({} at {:.6} s)",
                cmd.topic.name,
                s_of(cmd.series.t_ns[0])
            ),
        ),
        ("time_zero_ns".to_string(), rows[0].to_string()),
    ]
}

/// The output topics a bag's conversion reads, each if the bag has one.
struct Outputs<'a> {
    joints: Option<&'a Topic>,
    imu: Option<&'a Topic>,
    odom: Option<&'a Topic>,
    battery: Option<&'a Topic>,
}

impl<'a> Outputs<'a> {
    /// The output topics: each the map's choice, else the bag's one topic of its type.
    fn picked(c: &Converter<'a>) -> Result<Self, Ros2Error> {
        Ok(Outputs {
            joints: c.pick(
                "wheel joint state",
                "joint_states",
                &[JOINT_STATE],
                c.map.joint_states.as_ref(),
                false,
            )?,
            imu: c.pick("IMU", "imu", &[IMU], c.map.imu.as_ref(), false)?,
            odom: c.pick("odometry", "odom", &[ODOMETRY], c.map.odom.as_ref(), false)?,
            battery: c.pick(
                "battery",
                "battery",
                &[BATTERY],
                c.map.battery.as_ref(),
                false,
            )?,
        })
    }
}

/// The rows' times: the time base's messages from the first command on, strictly
/// increasing (what is left out is counted in a note); fewer than two is refused.
fn rows_from_first_command(
    c: &Converter,
    base: &Series,
    base_name: &str,
    cmd: &streams::Commands,
    notes: &mut Vec<String>,
) -> Result<Vec<i64>, Ros2Error> {
    let first_cmd = cmd.series.t_ns[0];
    let mut rows: Vec<i64> = Vec::with_capacity(base.t_ns.len());
    for &t in &base.t_ns {
        if t >= first_cmd && rows.last().is_none_or(|&p| t > p) {
            rows.push(t);
        }
    }
    let before = base.t_ns.iter().filter(|&&t| t < first_cmd).count();
    if before > 0 {
        notes.push(format!("{before} message(s) of {base_name} before the first command were left out (rows start at the first command)"));
    }
    let dropped = base.t_ns.len() - before - rows.len();
    if dropped > 0 {
        notes.push(format!("{dropped} message(s) of {base_name} repeat an earlier stamp and were dropped (rows must be strictly increasing)"));
    }
    if rows.len() < 2 {
        return Err(c.err(format!(
            "fewer than two {base_name} messages after the first command on {} (at {:.6} s): nothing to compare",
            cmd.topic.name,
            s_of(first_cmd)
        )));
    }
    Ok(rows)
}

/// The recording's columns as they are made, each with how it was made, on the rows'
/// times: the time base's own stream one row per message, every other stream by the
/// nearest message within half a row interval.
struct Table<'r> {
    rows: &'r [i64],
    base_name: &'r str,
    half: i64,
    names: Vec<String>,
    columns: Vec<Vec<Option<f64>>>,
    conversions: Vec<Conversion>,
}

impl<'r> Table<'r> {
    fn new(rows: &'r [i64], base_name: &'r str) -> Self {
        Table {
            rows,
            base_name,
            half: median_interval_ns(rows).unwrap_or(1) / 2,
            names: vec![],
            columns: vec![],
            conversions: vec![],
        }
    }

    /// Adds a column that holds at least one value.
    fn add(&mut self, name: &str, col: Vec<Option<f64>>, how: String) {
        if col.iter().any(Option::is_some) {
            self.names.push(name.to_string());
            self.columns.push(col);
            self.conversions.push(Conversion {
                column: name.into(),
                how,
            });
        }
    }

    /// Value `j` of `s` on the rows (`topic` the stream's).
    fn align(&self, s: &Series, j: usize, topic: &str) -> Vec<Option<f64>> {
        if topic == self.base_name {
            nearest(self.rows, s, j, 0)
        } else {
            nearest(self.rows, s, j, self.half)
        }
    }

    /// How `topic`'s messages are placed on the rows, for the column's conversion note.
    fn placing(&self, topic: &str) -> String {
        if topic == self.base_name {
            "one row per message (the time base)".to_string()
        } else {
            "each row takes the nearest message within half a row interval, else the cell is empty"
                .to_string()
        }
    }

    /// The commands, each held until the next (zero-order hold, as a base controller acts
    /// on it).
    fn add_commands(&mut self, cmd: &streams::Commands) {
        let how = |field: &str| {
            format!(
                "{} ({}) {field}, base frame, at its {}, held until the next (zero-order hold, as a base controller acts on it)",
                cmd.topic.name, cmd.topic.msg_type, cmd.time_words
            )
        };
        let rows = self.rows;
        self.add(
            chan::CMD_LINEAR_M_S,
            held(rows, &cmd.series, 0),
            how("linear.x"),
        );
        self.add(
            chan::CMD_ANGULAR_RAD_S,
            held(rows, &cmd.series, 1),
            how("angular.z"),
        );
    }

    /// Each wheel's rim speed (its joint's speed times the wheel radius, which must then
    /// be known), angle and effort.
    fn add_wheels(
        &mut self,
        c: &Converter,
        t: &Topic,
        wheel: &Series,
        [l, r]: &[String; 2],
        size: &streams::DriveSize,
    ) -> Result<(), Ros2Error> {
        let Some((radius_m, radius_from)) = &size.radius else {
            let described = match &size.not_described {
                Some(why) => why.clone(),
                None => "the bag has no /robot_description with the wheels".into(),
            };
            return Err(c.err(format!(
                "topic `{}` gives wheel speeds in rad/s and the contract's are rim speeds in m/s: give --wheel-radius-m ({described}; no --controller-yaml with wheel_radius)",
                t.name
            )));
        };
        let placing = self.placing(&t.name);
        for (j, side, joint) in [(0, "left", l), (1, "right", r)] {
            let rad_s = self.align(wheel, j, &t.name);
            self.add(
                &format!("{side}_wheel_speed_m_s"),
                rad_s.iter().map(|v| v.map(|w| w * radius_m)).collect(),
                format!("{} ({JOINT_STATE}) velocity of joint `{joint}`, rad/s, times the wheel radius {radius_m} m ({radius_from}); {placing}", t.name),
            );
            self.add(
                &format!("{side}_wheel_angle_rad"),
                self.align(wheel, j + 2, &t.name),
                format!("{} position of joint `{joint}`, rad; {placing}", t.name),
            );
            self.add(
                &format!("{side}_wheel_effort_Nm"),
                self.align(wheel, j + 4, &t.name),
                format!("{} effort of joint `{joint}`, as the driver reports it (N m for a revolute joint, by the message's convention); {placing}", t.name),
            );
        }
        Ok(())
    }

    /// Each wheel's rim speed from the body's twist through the configured track (a bag
    /// without joint states).
    fn add_odometry_wheels(
        &mut self,
        t: &Topic,
        odometry: &Series,
        (track_m, track_from): &(f64, String),
    ) {
        let placing = self.placing(&t.name);
        let (v, w) = (
            self.align(odometry, 3, &t.name),
            self.align(odometry, 4, &t.name),
        );
        for (side, sign) in [("left", -1.0), ("right", 1.0)] {
            self.add(
                &format!("{side}_wheel_speed_m_s"),
                v.iter()
                    .zip(&w)
                    .map(|(v, w)| Some(v.as_ref()? + sign * 0.5 * track_m * w.as_ref()?))
                    .collect(),
                format!("{} ({ODOMETRY}) twist.linear.x {} half the track {track_m} m ({track_from}) times twist.angular.z: the wheels' rim speeds as the odometry measured them (the bag has no {JOINT_STATE}); {placing}", t.name, if sign < 0.0 { "less" } else { "plus" }),
            );
        }
    }

    /// The robot's own odometry (pose and twist), not the contract's pose.
    fn add_odometry(&mut self, t: &Topic, odometry: &Series, (frame, child): (String, String)) {
        let placing = self.placing(&t.name);
        for (j, col, field) in [
            (0, chan::ODOM_X_M, "pose.position.x"),
            (1, chan::ODOM_Y_M, "pose.position.y"),
            (
                2,
                chan::ODOM_HEADING_RAD,
                "yaw of pose.orientation, unwrapped",
            ),
            (3, chan::ODOM_LINEAR_M_S, "twist.linear.x"),
            (4, chan::ODOM_ANGULAR_RAD_S, "twist.angular.z"),
        ] {
            self.add(
                col,
                self.align(odometry, j, &t.name),
                format!("{} ({ODOMETRY}) {field}, frame `{frame}` (twist in `{child}`): the robot's own odometry, not ground truth, so not the contract's pose; {placing}", t.name),
            );
        }
    }

    /// The independent pose (the contract's x, y and heading).
    fn add_pose(&mut self, pose: &Series, frames: &str, topic: &str) {
        let placing = self.placing(topic);
        for (j, col, field) in [
            (0, chan::X_M, "x"),
            (1, chan::Y_M, "y"),
            (2, chan::HEADING_RAD, "heading (yaw), unwrapped"),
        ] {
            let where_ = if frames.contains(" -> ") {
                format!("{topic} transform {frames}")
            } else {
                format!("{topic} ({frames})")
            };
            self.add(
                col,
                self.align(pose, j, topic),
                format!("{where_}, {field}: an independent pose (the base frame taken at the drive-axle midpoint); {placing}"),
            );
        }
    }
}

/// A note per topic the conversion did not read (the transforms and the robot
/// description count as read).
fn unused_topics(
    bag: &Bag,
    topics: &Outputs,
    cmd_topic: &Topic,
    pose_frames: &Option<(String, String)>,
) -> Vec<String> {
    let read = [
        Some(cmd_topic),
        topics.joints,
        topics.imu,
        topics.odom,
        topics.battery,
    ];
    bag.topics
        .iter()
        .filter(|t| {
            let used = read.iter().flatten().any(|u| u.name == t.name)
                || t.msg_type == TF
                || pose_frames
                    .as_ref()
                    .is_some_and(|(_, topic)| *topic == t.name)
                || (t.msg_type == STRING && t.name.ends_with("robot_description"));
            !used
        })
        .map(|t| format!("topic `{}` ({}) not used", t.name, t.msg_type))
        .collect()
}

impl Ros2Recording {
    /// The recording in the exchange format.
    pub fn to_csv(&self) -> String {
        let stem = self
            .bag
            .file_name()
            .map_or("bag".into(), |n| n.to_string_lossy().into_owned());
        let mut s = format!(
            "# agvsim-recording: 1\n# rig: vehicle\n# description: ROS 2 bag {stem} ({} storage), driven by velocity commands, imported by agvsim import ros2\n# source: ROS 2 bag {stem}\n",
            self.storage.name()
        );
        for (k, v) in &self.timing {
            s.push_str(&format!("# ros2.{k}: {v}\n"));
        }
        for c in &self.conversions {
            s.push_str(&format!("# ros2.{}: {}\n", c.column, c.how));
        }
        s.push_str(chan::T_S);
        for n in &self.names {
            s.push(',');
            s.push_str(n);
        }
        s.push('\n');
        for (k, t) in self.t_ns.iter().enumerate() {
            s.push_str(&seconds_of_ns(*t));
            for col in &self.columns {
                s.push(',');
                if let Some(v) = col[k] {
                    s.push_str(&format!("{v}"));
                }
            }
            s.push('\n');
        }
        s
    }
}
