//! From a bag's topics to the recording's columns: which topic plays which part, each
//! message decoded and placed in time, the streams met on one time base.

use std::path::PathBuf;

use super::align::{held, median_interval_ns, nearest, seconds_of_ns, Series};
use super::bag::{Bag, Storage, Topic};
use super::cdr::{self, CdrError, Header};
use super::{clock, joints, urdf};
use super::{Geometry, Ros2Error, TimeSource, TopicMap};

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

const COMMAND_TYPES: &[&str] = &["geometry_msgs/msg/Twist", "geometry_msgs/msg/TwistStamped"];
const JOINT_STATE: &str = "sensor_msgs/msg/JointState";
const IMU: &str = "sensor_msgs/msg/Imu";
pub(super) const ODOMETRY: &str = "nav_msgs/msg/Odometry";
const BATTERY: &str = "sensor_msgs/msg/BatteryState";
pub(super) const TF: &str = "tf2_msgs/msg/TFMessage";
const STRING: &str = "std_msgs/msg/String";
pub(super) const POSE_STAMPED: &str = "geometry_msgs/msg/PoseStamped";
pub(super) const POSE_COV_STAMPED: &str = "geometry_msgs/msg/PoseWithCovarianceStamped";

/// A bag being converted: the bag, the user's topic map and the time source.
pub(super) struct Converter<'a> {
    pub(super) bag: &'a Bag,
    pub(super) map: &'a TopicMap,
    time: TimeSource,
    /// Each stream's (log time, time placed at), for the clocks' check.
    placed: std::cell::RefCell<clock::StreamTimes>,
}

fn s_of(ns: i64) -> f64 {
    ns as f64 * 1e-9
}

impl<'a> Converter<'a> {
    pub(super) fn err(&self, message: String) -> Ros2Error {
        Ros2Error::Content {
            bag: self.bag.path.clone(),
            message,
        }
    }

    pub(super) fn listing(&self) -> String {
        self.bag
            .topics
            .iter()
            .map(|t| format!("{} ({}, {} messages)", t.name, t.msg_type, t.messages.len()))
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// The topic playing `role`: the map's choice, else the one topic of its types.
    fn pick(
        &self,
        role: &str,
        key: &str,
        types: &[&str],
        chosen: Option<&String>,
        required: bool,
    ) -> Result<Option<&'a Topic>, Ros2Error> {
        let bag: &'a Bag = self.bag;
        let topic = match chosen {
            Some(name) => {
                let t = bag.topics.iter().find(|t| &t.name == name).ok_or_else(|| {
                    self.err(format!(
                        "--map {key} = \"{name}\": no such topic; the bag has {}",
                        self.listing()
                    ))
                })?;
                if !types.contains(&t.msg_type.as_str()) {
                    return Err(self.err(format!(
                        "topic `{name}` is `{}`, not a {role} type agvsim decodes ({})",
                        t.msg_type,
                        types.join(", ")
                    )));
                }
                t
            }
            None => {
                let found: Vec<&'a Topic> = bag
                    .topics
                    .iter()
                    .filter(|t| types.contains(&t.msg_type.as_str()))
                    .collect();
                match found.as_slice() {
                    [] if required => {
                        return Err(self.err(format!(
                            "no {role} topic: expected one of type {}; the bag has {}",
                            types.join(" or "),
                            self.listing()
                        )))
                    }
                    [] => return Ok(None),
                    [one] => *one,
                    several => {
                        let names: Vec<&str> = several.iter().map(|t| t.name.as_str()).collect();
                        return Err(self.err(format!(
                            "several {role} topics ({}): choose one with --map (key `{key}`)",
                            names.join(", ")
                        )));
                    }
                }
            }
        };
        if topic.messages.is_empty() {
            return Err(self.err(format!(
                "topic `{}` ({}) has no messages",
                topic.name, topic.msg_type
            )));
        }
        Ok(Some(topic))
    }

    /// Decodes every message of a topic, naming the message that fails.
    pub(super) fn decode<T>(
        &self,
        topic: &Topic,
        f: impl Fn(&[u8]) -> Result<T, CdrError>,
    ) -> Result<Vec<(i64, T)>, Ros2Error> {
        topic
            .messages
            .iter()
            .enumerate()
            .map(|(k, m)| {
                f(&m.data).map(|v| (m.log_time_ns, v)).map_err(|e| {
                    self.err(format!(
                        "topic `{}` ({}), message {} (log time {:.6} s): {e}",
                        topic.name,
                        topic.msg_type,
                        k + 1,
                        s_of(m.log_time_ns)
                    ))
                })
            })
            .collect()
    }

    /// Where a message of `topic` is placed in time: its header stamp or its log time.
    pub(super) fn at(&self, topic: &str, h: &Header, log_ns: i64) -> i64 {
        let at = if self.time == TimeSource::Header && h.stamp_ns > 0 {
            h.stamp_ns
        } else {
            log_ns
        };
        let mut placed = self.placed.borrow_mut();
        match placed.get_mut(topic) {
            Some(times) => times.push((log_ns, at)),
            None => {
                placed.insert(topic.to_string(), vec![(log_ns, at)]);
            }
        }
        at
    }

    fn time_words(&self) -> &'static str {
        match self.time {
            TimeSource::Header => "header stamp (log time where unstamped)",
            TimeSource::Log => "log time",
        }
    }
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
    let mut conversions = vec![];
    let mut notes = vec![];

    // Geometry: flags first, then the robot description.
    let description = bag
        .topics
        .iter()
        .find(|t| t.msg_type == STRING && t.name.ends_with("robot_description"));
    let described = match description.and_then(|t| t.messages.last()) {
        Some(m) => {
            let xml = cdr::decode_string(&m.data).map_err(|e| {
                c.err(format!(
                    "topic `{}`: {e}",
                    description.map_or("", |t| &t.name)
                ))
            })?;
            match urdf::drive_geometry(
                &xml,
                map.left_wheel_joint.as_deref(),
                map.right_wheel_joint.as_deref(),
            ) {
                Ok(g) => Some(g),
                Err(why) => {
                    notes.push(format!(
                        "topic `{}` not used for the drive's geometry: {why}",
                        description.map_or("", |t| &t.name)
                    ));
                    None
                }
            }
        }
        None => None,
    };
    let radius = geometry
        .wheel_radius_m
        .map(|r| (r, "--wheel-radius-m".to_string()))
        .or_else(|| {
            described.as_ref().map(|d| {
                (
                    d.wheel_radius_m,
                    format!(
                        "/robot_description: joint `{}`'s wheel cylinder",
                        d.joints[0]
                    ),
                )
            })
        });
    let track = geometry
        .track_m
        .map(|t| (t, "--track-m".to_string()))
        .or_else(|| {
            described.as_ref().map(|d| {
                (
                    d.track_m,
                    format!(
                        "/robot_description: lateral distance of joints `{}` and `{}`",
                        d.joints[0], d.joints[1]
                    ),
                )
            })
        });

    // A radius or track that is not a length (an infinite cylinder in the URDF) is named
    // with where it came from before any column is made of it.
    for (what, v) in [("wheel radius", &radius), ("track", &track)] {
        if let Some((v, from)) = v {
            if !(v.is_finite() && *v > 0.0) {
                return Err(c.err(format!(
                    "{what} {} from {from}: expected a finite length greater than zero, m",
                    crate::param::plain_number(*v)
                )));
            }
        }
    }

    // Commands.
    let cmd_topic = c
        .pick(
            "velocity command",
            "cmd_vel",
            COMMAND_TYPES,
            map.cmd_vel.as_ref(),
            true,
        )?
        .ok_or_else(|| c.err("no velocity command topic".into()))?;
    let mut commands = Series::default();
    if cmd_topic.msg_type.ends_with("TwistStamped") {
        for (log, (h, tw)) in c.decode(cmd_topic, cdr::decode_twist_stamped)? {
            commands.push(
                c.at(&cmd_topic.name, &h, log),
                vec![tw.linear_x_m_s, tw.angular_z_rad_s],
            );
        }
    } else {
        let unstamped = Header::default();
        for (log, tw) in c.decode(cmd_topic, cdr::decode_twist)? {
            commands.push(
                c.at(&cmd_topic.name, &unstamped, log),
                vec![tw.linear_x_m_s, tw.angular_z_rad_s],
            );
        }
    }
    let commands = commands.sorted();
    let cmd_time = if cmd_topic.msg_type.ends_with("TwistStamped") {
        c.time_words()
    } else {
        "log time (a Twist has no stamp)"
    };
    let cmd_how = |field: &str| {
        format!(
            "{} ({}) {field}, base frame, at its {cmd_time}, held until the next (zero-order hold, as a base controller acts on it)",
            cmd_topic.name, cmd_topic.msg_type
        )
    };

    // Outputs, each stream decoded.
    let joints = c.pick(
        "wheel joint state",
        "joint_states",
        &[JOINT_STATE],
        map.joint_states.as_ref(),
        false,
    )?;
    let imu = c.pick("IMU", "imu", &[IMU], map.imu.as_ref(), false)?;
    let odom = c.pick("odometry", "odom", &[ODOMETRY], map.odom.as_ref(), false)?;
    let battery = c.pick(
        "battery",
        "battery",
        &[BATTERY],
        map.battery.as_ref(),
        false,
    )?;

    let mut wheel = Series::default();
    let mut wheel_names: Option<[String; 2]> = None;
    if let Some(t) = joints {
        let msgs = c.decode(t, cdr::decode_joint_state)?;
        let chosen = |side: &str, explicit: &Option<String>| -> Option<String> {
            explicit
                .clone()
                .or_else(|| {
                    described
                        .as_ref()
                        .map(|d| d.joints[usize::from(side == "right")].clone())
                })
                .or_else(|| {
                    msgs.iter()
                        .flat_map(|(_, m)| m.name.iter())
                        .find(|n| n.contains(side) && n.contains("wheel"))
                        .cloned()
                })
        };
        let (Some(l), Some(r)) = (
            chosen("left", &map.left_wheel_joint),
            chosen("right", &map.right_wheel_joint),
        ) else {
            return Err(c.err(format!(
                "topic `{}`: no joints named as the left and right wheels (names with `left`/`right` and `wheel`); name them with --map left_wheel_joint, right_wheel_joint",
                t.name
            )));
        };
        let named_by = |side: &str, explicit: &Option<String>| match (explicit, &described) {
            (Some(_), _) => format!("--map {side}_wheel_joint"),
            (None, Some(_)) => "/robot_description's wheel joint".to_string(),
            (None, None) => format!("the joint whose name holds `{side}` and `wheel`"),
        };
        let all: Vec<&cdr::JointState> = msgs.iter().map(|(_, m)| m).collect();
        for (side, joint, explicit) in [
            ("left", &l, &map.left_wheel_joint),
            ("right", &r, &map.right_wheel_joint),
        ] {
            let note = joints::check(&t.name, &all, side, joint, &named_by(side, explicit))
                .map_err(|m| c.err(m))?;
            notes.extend(note);
        }
        for (log, m) in &msgs {
            let pick = |v: &[f64], name: &str| {
                m.name
                    .iter()
                    .position(|n| n == name)
                    .and_then(|i| v.get(i).copied())
                    .unwrap_or(f64::NAN)
            };
            wheel.push(
                c.at(&t.name, &m.header, *log),
                vec![
                    pick(&m.velocity, &l),
                    pick(&m.velocity, &r),
                    pick(&m.position, &l),
                    pick(&m.position, &r),
                    pick(&m.effort, &l),
                    pick(&m.effort, &r),
                ],
            );
        }
        wheel_names = Some([l, r]);
    }
    let wheel = wheel.sorted();

    let mut gyro = Series::default();
    if let Some(t) = imu {
        for (log, m) in c.decode(t, cdr::decode_imu)? {
            gyro.push(c.at(&t.name, &m.header, log), vec![m.yaw_rate_rad_s]);
        }
    }
    let gyro = gyro.sorted();
    let mut odometry = Series::default();
    let mut odom_frames = None;
    if let Some(t) = odom {
        for (log, m) in c.decode(t, cdr::decode_odometry)? {
            odom_frames.get_or_insert((m.header.frame_id.clone(), m.child_frame_id.clone()));
            odometry.push(
                c.at(&t.name, &m.header, log),
                vec![
                    m.pose[0],
                    m.pose[1],
                    m.pose[2],
                    m.twist.linear_x_m_s,
                    m.twist.angular_z_rad_s,
                ],
            );
        }
    }
    let odometry = odometry.sorted().with_continuous(2);
    let mut volts = Series::default();
    if let Some(t) = battery {
        for (log, m) in c.decode(t, cdr::decode_battery_state)? {
            volts.push(c.at(&t.name, &m.header, log), vec![m.voltage_v]);
        }
    }
    let volts = volts.sorted();
    let (pose, pose_frames) = super::pose::tracked_pose(&c, &mut notes)?;
    if time == TimeSource::Header {
        if let Some(why) = clock::disagreement(&c.placed.borrow()) {
            return Ok(Timed::ClocksDisagree(why));
        }
    }

    // The time base: the wheels' stamps, else the gyro's, else the odometry's, else the
    // pose's.
    let pose_source = pose_frames.as_ref().map(|(_, topic)| topic.clone());
    let (base, base_name) = [(&wheel, joints), (&gyro, imu), (&odometry, odom)]
        .into_iter()
        .find_map(|(s, t)| t.map(|t| (s, t.name.clone())))
        .or_else(|| pose_source.map(|name| (&pose, name)))
        .ok_or_else(|| {
            c.err(format!(
                "no output to compare: expected a {JOINT_STATE}, {IMU} or {ODOMETRY} topic, or a pose (/tf to the base, {POSE_STAMPED}, {POSE_COV_STAMPED}); the bag has {}",
                c.listing()
            ))
        })?;
    let first_cmd = commands.t_ns[0];
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
            cmd_topic.name,
            s_of(first_cmd)
        )));
    }
    let half = median_interval_ns(&rows).unwrap_or(1) / 2;
    let mut names = vec![];
    let mut columns = vec![];
    let mut add =
        |name: &str, col: Vec<Option<f64>>, how: String, conversions: &mut Vec<Conversion>| {
            if col.iter().any(Option::is_some) {
                names.push(name.to_string());
                columns.push(col);
                conversions.push(Conversion {
                    column: name.into(),
                    how,
                });
            }
        };
    let align = |s: &Series, j: usize, is_base: bool| {
        if is_base {
            nearest(&rows, s, j, 0)
        } else {
            nearest(&rows, s, j, half)
        }
    };
    let placing = |is_base: bool| {
        if is_base {
            "one row per message (the time base)".to_string()
        } else {
            "each row takes the nearest message within half a row interval, else the cell is empty"
                .to_string()
        }
    };
    add(
        "cmd_linear_m_s",
        held(&rows, &commands, 0),
        cmd_how("linear.x"),
        &mut conversions,
    );
    add(
        "cmd_angular_rad_s",
        held(&rows, &commands, 1),
        cmd_how("angular.z"),
        &mut conversions,
    );
    if let (Some(t), Some([l, r])) = (joints, &wheel_names) {
        let is_base = base_name == t.name;
        let Some((radius_m, radius_from)) = &radius else {
            return Err(c.err(format!(
                "topic `{}` gives wheel speeds in rad/s and the contract's are rim speeds in m/s: give --wheel-radius-m (the bag has no /robot_description with the wheels)",
                t.name
            )));
        };
        for (j, side, joint) in [(0, "left", l), (1, "right", r)] {
            let rad_s = align(&wheel, j, is_base);
            add(
                &format!("{side}_wheel_speed_m_s"),
                rad_s.iter().map(|v| v.map(|w| w * radius_m)).collect(),
                format!("{} ({JOINT_STATE}) velocity of joint `{joint}`, rad/s, times the wheel radius {radius_m} m ({radius_from}); {}", t.name, placing(is_base)),
                &mut conversions,
            );
            add(
                &format!("{side}_wheel_angle_rad"),
                align(&wheel, j + 2, is_base),
                format!(
                    "{} position of joint `{joint}`, rad; {}",
                    t.name,
                    placing(is_base)
                ),
                &mut conversions,
            );
            add(
                &format!("{side}_wheel_effort_Nm"),
                align(&wheel, j + 4, is_base),
                format!("{} effort of joint `{joint}`, as the driver reports it (N m for a revolute joint, by the message's convention); {}", t.name, placing(is_base)),
                &mut conversions,
            );
        }
    }
    if let Some(t) = imu {
        let is_base = base_name == t.name;
        add(
            "yaw_rate_rad_s",
            align(&gyro, 0, is_base),
            format!("{} ({IMU}) angular_velocity.z, in the IMU's frame taken as level and aligned with the base; {}", t.name, placing(is_base)),
            &mut conversions,
        );
    }
    // Without joint states, the odometry's twist is what the wheels measured: each wheel's
    // rim speed from the body's through the configured track.
    if let (None, Some(t), Some((track_m, track_from))) = (joints, odom, &track) {
        let is_base = base_name == t.name;
        let (v, w) = (align(&odometry, 3, is_base), align(&odometry, 4, is_base));
        for (side, sign) in [("left", -1.0), ("right", 1.0)] {
            add(
                &format!("{side}_wheel_speed_m_s"),
                v.iter()
                    .zip(&w)
                    .map(|(v, w)| Some(v.as_ref()? + sign * 0.5 * track_m * w.as_ref()?))
                    .collect(),
                format!("{} ({ODOMETRY}) twist.linear.x {} half the track {track_m} m ({track_from}) times twist.angular.z: the wheels' rim speeds as the odometry measured them (the bag has no {JOINT_STATE}); {}", t.name, if sign < 0.0 { "less" } else { "plus" }, placing(is_base)),
                &mut conversions,
            );
        }
    }
    if let Some(t) = odom {
        let is_base = base_name == t.name;
        let (frame, child) = odom_frames.clone().unwrap_or_default();
        for (j, col, field) in [
            (0, "odom_x_m", "pose.position.x"),
            (1, "odom_y_m", "pose.position.y"),
            (2, "odom_heading_rad", "yaw of pose.orientation, unwrapped"),
            (3, "odom_linear_m_s", "twist.linear.x"),
            (4, "odom_angular_rad_s", "twist.angular.z"),
        ] {
            add(
                col,
                align(&odometry, j, is_base),
                format!("{} ({ODOMETRY}) {field}, frame `{frame}` (twist in `{child}`): the robot's own odometry, not ground truth, so not the contract's pose; {}", t.name, placing(is_base)),
                &mut conversions,
            );
        }
    }
    if let Some((frames, topic)) = &pose_frames {
        let is_base = base_name == *topic;
        for (j, col, field) in [
            (0, "x_m", "x"),
            (1, "y_m", "y"),
            (2, "heading_rad", "heading (yaw), unwrapped"),
        ] {
            let where_ = if frames.contains(" -> ") {
                format!("{topic} transform {frames}")
            } else {
                format!("{topic} ({frames})")
            };
            add(
                col,
                if is_base { nearest(&rows, &pose, j, 0) } else { nearest(&rows, &pose, j, half) },
                format!("{where_}, {field}: an independent pose (the base frame taken at the drive-axle midpoint); {}", placing(is_base)),
                &mut conversions,
            );
        }
    }
    if let Some(t) = battery {
        add(
            "battery_voltage_V",
            held(&rows, &volts, 0),
            format!(
                "{} ({BATTERY}) voltage, held from each message to the next",
                t.name
            ),
            &mut conversions,
        );
    }
    let battery_v = {
        let mut v: Vec<f64> = volts
            .values
            .iter()
            .map(|v| v[0])
            .filter(|v| v.is_finite() && *v > 0.0)
            .collect();
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied()
    };
    for t in &bag.topics {
        let used = [Some(cmd_topic), joints, imu, odom, battery]
            .iter()
            .flatten()
            .any(|u| u.name == t.name)
            || t.msg_type == TF
            || pose_frames
                .as_ref()
                .is_some_and(|(_, topic)| *topic == t.name)
            || (t.msg_type == STRING && t.name.ends_with("robot_description"));
        if !used {
            notes.push(format!("topic `{}` ({}) not used", t.name, t.msg_type));
        }
    }
    let t0 = rows[0];
    let timing = vec![
        (
            "time".to_string(),
            format!("each message at its {}", c.time_words()),
        ),
        (
            "rows".to_string(),
            format!(
                "one per {base_name} message from the first command on ({} at {:.6} s)",
                cmd_topic.name,
                s_of(first_cmd)
            ),
        ),
        ("time_zero_ns".to_string(), t0.to_string()),
    ];
    Ok(Timed::Done(Box::new(Ros2Recording {
        bag: bag.path.clone(),
        storage: bag.storage,
        time_zero_ns: t0,
        t_s: rows.iter().map(|t| s_of(t - t0)).collect(),
        t_ns: rows.iter().map(|t| t - t0).collect(),
        names,
        columns,
        conversions,
        timing,
        geometry: match (track, radius) {
            (Some((t, tf)), Some((r, rf))) => {
                Some((t, r, format!("track from {tf}; wheel radius from {rf}")))
            }
            _ => None,
        },
        battery_v,
        notes,
    })))
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
        s.push_str("t_s");
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
