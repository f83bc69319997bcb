//! The message types an import reads, and the converter that holds a bag being converted:
//! it picks the topic that plays each part and places each message in time (its header
//! stamp or its log time), keeping what the clocks' check needs.

use super::cdr::{CdrError, Header};
use super::clock;
use super::{Ros2Error, TimeSource, TopicMap};
use crate::import::bag::{Bag, Topic};

pub(super) const COMMAND_TYPES: &[&str] =
    &["geometry_msgs/msg/Twist", "geometry_msgs/msg/TwistStamped"];
pub(super) const JOINT_STATE: &str = "sensor_msgs/msg/JointState";
pub(super) const IMU: &str = "sensor_msgs/msg/Imu";
pub(super) const ODOMETRY: &str = "nav_msgs/msg/Odometry";
pub(super) const BATTERY: &str = "sensor_msgs/msg/BatteryState";
pub(super) const TF: &str = "tf2_msgs/msg/TFMessage";
pub(super) const STRING: &str = "std_msgs/msg/String";
pub(super) const POSE_STAMPED: &str = "geometry_msgs/msg/PoseStamped";
pub(super) const POSE_COV_STAMPED: &str = "geometry_msgs/msg/PoseWithCovarianceStamped";

/// A bag being converted: the bag, the user's topic map and the time source.
pub(super) struct Converter<'a> {
    pub(super) bag: &'a Bag,
    pub(super) map: &'a TopicMap,
    pub(super) time: TimeSource,
    /// Each stream's (log time, time placed at), for the clocks' check.
    pub(super) placed: std::cell::RefCell<clock::StreamTimes>,
}

/// Nanoseconds as seconds.
pub(super) fn s_of(ns: i64) -> f64 {
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
        if self.bag.topics.is_empty() {
            return "no topic: it holds no records (an empty or cut-short bag)".into();
        }
        self.bag
            .topics
            .iter()
            .map(|t| match t.mixed_types() {
                Some(types) => format!("{} ({types})", t.name),
                None => format!("{} ({}, {} messages)", t.name, t.msg_type, t.messages.len()),
            })
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// The topic playing `role`: the map's choice, else the one topic of its types.
    pub(super) fn pick(
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
        if let Some(types) = topic.mixed_types() {
            // Decoding one type's bytes as another's gives numbers, not an error.
            return Err(self.err(format!(
                "topic `{}` is published under more than one type: {types}; agvsim reads one type per topic: keep one publisher's messages (`rosbag filter` / `ros2 bag convert`), or record the other under its own topic name",
                topic.name
            )));
        }
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

    pub(super) fn time_words(&self) -> &'static str {
        match self.time {
            TimeSource::Header => "header stamp (log time where unstamped)",
            TimeSource::Log => "log time",
        }
    }
}
