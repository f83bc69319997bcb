//! Each stream of a bag decoded into a time series: the drive's size (flags, else the
//! robot description), the velocity commands, the wheels' joint states, the gyro, the
//! odometry and the battery. Every message is placed by [`Converter::at`] (its header
//! stamp or its log time), in the order the streams are read here.

use super::align::Series;
use super::cdr::{self, Header};
use super::converter::{Converter, COMMAND_TYPES, STRING};
use super::urdf::DriveGeometry;
use super::{joints, urdf, Geometry, Ros2Error};
use crate::import::bag::Topic;

/// A length in metres and where it came from (a flag, or the robot description).
pub(super) type Sourced = Option<(f64, String)>;

/// The drive's size: the robot description's geometry (if the bag has one that gives it),
/// the wheel radius and the track, each from its flag, else from the description.
pub(super) struct DriveSize {
    /// What /robot_description gives.
    pub described: Option<DriveGeometry>,
    /// Why /robot_description gives nothing, where the bag has one.
    pub not_described: Option<String>,
    /// Wheel radius, m.
    pub radius: Sourced,
    /// Track, m.
    pub track: Sourced,
}

/// The drive's size from the flags, then the robot description; a description that gives
/// none is said in a note, a size that is no length (an infinite cylinder) is refused
/// naming where it came from.
pub(super) fn drive_size(
    c: &Converter,
    geometry: &Geometry,
    notes: &mut Vec<String>,
) -> Result<DriveSize, Ros2Error> {
    let description = c
        .bag
        .topics
        .iter()
        .find(|t| t.msg_type == STRING && t.name.ends_with("robot_description"));
    let mut not_described = None;
    let described = match description.and_then(|t| t.messages.last()) {
        Some(m) => {
            let name = description.map_or("", |t| &t.name);
            let xml =
                cdr::decode_string(&m.data).map_err(|e| c.err(format!("topic `{name}`: {e}")))?;
            match urdf::drive_geometry(
                &xml,
                c.map.left_wheel_joint.as_deref(),
                c.map.right_wheel_joint.as_deref(),
            ) {
                Ok(g) => Some(g),
                Err(why) => {
                    let why = format!("topic `{name}` not used for the drive's geometry: {why}");
                    notes.push(why.clone());
                    not_described = Some(why);
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
        })
        .or_else(|| geometry.configured_radius_m.clone());
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
        })
        .or_else(|| geometry.configured_track_m.clone());
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
    Ok(DriveSize {
        described,
        not_described,
        radius,
        track,
    })
}

/// The velocity commands: their topic, (linear m/s, angular rad/s) by time, and what
/// their time is.
pub(super) struct Commands<'a> {
    /// The Twist or TwistStamped topic.
    pub topic: &'a Topic,
    /// Linear and angular speed commanded, sorted by time.
    pub series: Series,
    /// How each is placed in time.
    pub time_words: &'static str,
}

/// The velocity command stream (a bag without one is refused).
pub(super) fn commands<'a>(c: &Converter<'a>) -> Result<Commands<'a>, Ros2Error> {
    let topic = c
        .pick(
            "velocity command",
            "cmd_vel",
            COMMAND_TYPES,
            c.map.cmd_vel.as_ref(),
            true,
        )?
        .ok_or_else(|| c.err("no velocity command topic".into()))?;
    let stamped = topic.msg_type.ends_with("TwistStamped");
    let mut series = Series::default();
    if stamped {
        for (log, (h, tw)) in c.decode(topic, cdr::decode_twist_stamped)? {
            series.push(
                c.at(&topic.name, &h, log),
                vec![tw.linear_x_m_s, tw.angular_z_rad_s],
            );
        }
    } else {
        let unstamped = Header::default();
        for (log, tw) in c.decode(topic, cdr::decode_twist)? {
            series.push(
                c.at(&topic.name, &unstamped, log),
                vec![tw.linear_x_m_s, tw.angular_z_rad_s],
            );
        }
    }
    Ok(Commands {
        topic,
        series: series.sorted(),
        time_words: if stamped {
            c.time_words()
        } else {
            "log time (a Twist has no stamp)"
        },
    })
}

/// The wheels' joint states: per message the left and right speed (rad/s), position
/// (rad) and effort, and the joints read (left, right); empty without a topic.
pub(super) fn wheels(
    c: &Converter,
    topic: Option<&Topic>,
    described: Option<&DriveGeometry>,
    notes: &mut Vec<String>,
) -> Result<(Series, Option<[String; 2]>), Ros2Error> {
    let mut wheel = Series::default();
    let Some(t) = topic else {
        return Ok((wheel.sorted(), None));
    };
    let map = c.map;
    let msgs = c.decode(t, cdr::decode_joint_state)?;
    let chosen = |side: &str, explicit: &Option<String>| -> Option<String> {
        explicit
            .clone()
            .or_else(|| described.map(|d| d.joints[usize::from(side == "right")].clone()))
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
    let named_by = |side: &str, explicit: &Option<String>| match (explicit, described) {
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
            .map_err(|m| c.err(m.to_string()))?;
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
    Ok((wheel.sorted(), Some([l, r])))
}

/// The gyro's yaw rate, rad/s (empty without a topic).
pub(super) fn gyro(c: &Converter, topic: Option<&Topic>) -> Result<Series, Ros2Error> {
    let mut gyro = Series::default();
    if let Some(t) = topic {
        for (log, m) in c.decode(t, cdr::decode_imu)? {
            gyro.push(c.at(&t.name, &m.header, log), vec![m.yaw_rate_rad_s]);
        }
    }
    Ok(gyro.sorted())
}

/// The odometry's pose (x, y, unwrapped heading) and twist (linear, angular), and its
/// frames (parent, child) as its first message names them.
pub(super) fn odometry(
    c: &Converter,
    topic: Option<&Topic>,
) -> Result<(Series, Option<(String, String)>), Ros2Error> {
    let mut odometry = Series::default();
    let mut frames = None;
    if let Some(t) = topic {
        for (log, m) in c.decode(t, cdr::decode_odometry)? {
            frames.get_or_insert((m.header.frame_id.clone(), m.child_frame_id.clone()));
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
    Ok((odometry.sorted().with_continuous(2), frames))
}

/// The battery's voltage, V (empty without a topic).
pub(super) fn battery(c: &Converter, topic: Option<&Topic>) -> Result<Series, Ros2Error> {
    let mut volts = Series::default();
    if let Some(t) = topic {
        for (log, m) in c.decode(t, cdr::decode_battery_state)? {
            volts.push(c.at(&t.name, &m.header, log), vec![m.voltage_v]);
        }
    }
    Ok(volts.sorted())
}

/// The median of the battery's positive, finite voltages, V.
pub(super) fn median_voltage(volts: &Series) -> Option<f64> {
    let mut v: Vec<f64> = volts
        .values
        .iter()
        .map(|v| v[0])
        .filter(|v| v.is_finite() && *v > 0.0)
        .collect();
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied()
}
