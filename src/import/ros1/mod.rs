//! ROS 1: its bag file (`.bag`, format 2.0, [`read`]) and what its messages need to be
//! read as ROS 2's: the marker that tells the message decoders (`import::ros2::cdr`) a
//! message is in ROS 1's serialisation, and ROS 2's names for ROS 1's types. A ROS 1 bag
//! is then converted as a ROS 2 bag is (`agvsim import ros1` is `import ros2`).

mod bag_file;

pub(in crate::import) use bag_file::read;

/// The four bytes agvsim puts before a ROS 1 message so that the message decoders read
/// it as ROS 1's serialisation (not a CDR encapsulation: those start `00`).
pub const ROS1_MARKER: [u8; 4] = *b"ROS1";

/// A ROS 1 type in ROS 2's naming.
pub(crate) fn ros2_type(ros1: &str) -> String {
    match ros1 {
        "tf/tfMessage" => "tf2_msgs/msg/TFMessage".into(),
        t => match t.split_once('/') {
            Some((pkg, name)) if !name.contains('/') => format!("{pkg}/msg/{name}"),
            _ => t.into(),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ros1_types_are_named_as_ros2_names_them() {
        assert_eq!(ros2_type("geometry_msgs/Twist"), "geometry_msgs/msg/Twist");
        assert_eq!(ros2_type("tf/tfMessage"), "tf2_msgs/msg/TFMessage");
        assert_eq!(ros2_type("tf2_msgs/TFMessage"), "tf2_msgs/msg/TFMessage");
    }
}
