//! The wheels in a `sensor_msgs/JointState` stream: is each chosen joint there, and does
//! it carry a speed? A joint named differently from the URDF's, a velocity array shorter
//! than `name`, a driver that publishes positions only or NaN: each would leave the wheel
//! columns empty without a word.

use super::cdr::JointState;

/// How many of a stream's messages give one joint a finite speed, and why the others do not.
#[derive(Debug, Default, PartialEq)]
pub struct JointSpeeds {
    /// Messages naming the joint.
    pub named: usize,
    /// Of those, messages whose velocity array reaches the joint's entry.
    pub with_velocity: usize,
    /// Of those, finite speeds.
    pub finite: usize,
}

/// Counts `joint`'s speeds in `msgs`.
pub fn speeds_of(msgs: &[&JointState], joint: &str) -> JointSpeeds {
    let mut s = JointSpeeds::default();
    for m in msgs {
        let Some(i) = m.name.iter().position(|n| n == joint) else {
            continue;
        };
        s.named += 1;
        if let Some(v) = m.velocity.get(i) {
            s.with_velocity += 1;
            if v.is_finite() {
                s.finite += 1;
            }
        }
    }
    s
}

/// Every joint name the stream carries, in order of first appearance.
pub fn names_in(msgs: &[&JointState]) -> Vec<String> {
    let mut names: Vec<String> = vec![];
    for m in msgs {
        for n in &m.name {
            if !names.contains(n) {
                names.push(n.clone());
            }
        }
    }
    names
}

/// Why a wheel's joint gives no speed in a joint-state stream.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum JointFault {
    /// No message names the joint.
    #[error("topic `{topic}`: no joint named `{joint}` (the {side} wheel, {named_by}); its joints are {}; name the wheels with --map left_wheel_joint = \"...\", right_wheel_joint = \"...\"", crate::numtext::backticked(.joints))]
    NotNamed {
        /// The stream's topic.
        topic: String,
        /// The joint looked for.
        joint: String,
        /// Which wheel (`left`, `right`).
        side: String,
        /// Who named the joint (the URDF, `--map`, the default).
        named_by: String,
        /// The joints the stream does name.
        joints: Vec<String>,
    },
    /// The joint is named but no message gives it a finite speed.
    #[error("topic `{topic}`: joint `{joint}` (the {side} wheel) gives no speed: {why}; agvsim reads the wheels' speeds from `velocity`")]
    NoSpeed {
        /// The stream's topic.
        topic: String,
        /// The joint.
        joint: String,
        /// Which wheel.
        side: String,
        /// Why: no velocity array long enough, or only non-finite values.
        why: &'static str,
    },
}

/// Why `joint` (the `side` wheel, named by `named_by`) gives no speed in `topic`'s
/// `msgs`, or `Ok(note)`: `None` when every message gives one, else how many do not.
pub fn check(
    topic: &str,
    msgs: &[&JointState],
    side: &str,
    joint: &str,
    named_by: &str,
) -> Result<Option<String>, JointFault> {
    let s = speeds_of(msgs, joint);
    let total = msgs.len();
    if s.named == 0 {
        return Err(JointFault::NotNamed {
            topic: topic.into(),
            joint: joint.into(),
            side: side.into(),
            named_by: named_by.into(),
            joints: names_in(msgs),
        });
    }
    if s.finite == 0 {
        let why = if s.with_velocity == 0 {
            "its velocity array is empty or shorter than `name` in every message (a driver that publishes positions only?)"
        } else {
            "every velocity it carries is NaN or infinite"
        };
        return Err(JointFault::NoSpeed {
            topic: topic.into(),
            joint: joint.into(),
            side: side.into(),
            why,
        });
    }
    Ok((s.finite < total).then(|| {
        format!(
            "{} of the {total} messages of {topic} give no finite speed for joint `{joint}` (the {side} wheel: {} do not name it, {} have a velocity array too short, {} a NaN or infinite one): those cells are empty",
            total - s.finite,
            total - s.named,
            s.named - s.with_velocity,
            s.with_velocity - s.finite
        )
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn js(names: &[&str], velocity: &[f64]) -> JointState {
        JointState {
            header: Default::default(),
            name: names.iter().map(|s| s.to_string()).collect(),
            position: vec![],
            velocity: velocity.to_vec(),
            effort: vec![],
        }
    }

    #[test]
    fn a_joint_not_in_the_stream_is_named_with_the_joints_it_has() {
        let a = js(&["wl", "wr"], &[1.0, 2.0]);
        let e = check("/js", &[&a], "left", "left_wheel_joint", "the URDF")
            .unwrap_err()
            .to_string();
        assert!(e.contains("no joint named `left_wheel_joint`"), "{e}");
        assert!(e.contains("`wl`, `wr`"), "{e}");
    }

    #[test]
    fn a_short_velocity_array_or_nan_speeds_give_no_speed() {
        let short = js(&["l", "r"], &[1.0]);
        assert_eq!(check("/js", &[&short], "left", "l", "x"), Ok(None));
        let e = check("/js", &[&short], "right", "r", "x")
            .unwrap_err()
            .to_string();
        assert!(e.contains("shorter than `name`"), "{e}");
        let nan = js(&["l", "r"], &[f64::NAN, f64::NAN]);
        let e = check("/js", &[&nan, &nan], "left", "l", "x")
            .unwrap_err()
            .to_string();
        assert!(e.contains("NaN"), "{e}");
    }

    #[test]
    fn some_messages_without_a_speed_are_counted_in_a_note() {
        let good = js(&["l", "r"], &[1.0, 2.0]);
        let nan = js(&["l", "r"], &[f64::NAN, 2.0]);
        let other = js(&["arm"], &[0.0]);
        let note = check("/js", &[&good, &nan, &other], "left", "l", "x")
            .unwrap()
            .unwrap();
        assert!(note.starts_with("2 of the 3 messages"), "{note}");
        assert!(
            note.contains("1 do not name it, 0 have a velocity array too short, 1 a NaN"),
            "{note}"
        );
    }
}
