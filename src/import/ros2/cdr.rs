//! CDR, the wire format of ROS 2 messages (OMG XCDR1 as rosbag2 stores it), and the
//! standard messages agvsim reads from a bag.
//!
//! A message is a 4-byte encapsulation header (`00 01`: little-endian, `00 00`:
//! big-endian, then two option bytes) followed by its fields in declaration order, each
//! primitive aligned to its own size counted from the end of the header. A string is a
//! `u32` length (with its terminating NUL) and its bytes; a sequence a `u32` count and its
//! elements; a fixed array its elements alone.
//!
//! The same decoders read ROS 1's serialisation (a ROS 1 bag's messages, behind
//! [`ROS1_MARKER`]): little-endian, nothing aligned, strings without their NUL, and a
//! `Header` that starts with a `uint32 seq`.

pub use crate::import::ros1::ROS1_MARKER;

/// Why a message cannot be decoded.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CdrError {
    /// The message ends before a field.
    #[error("the message ends at byte {at} of {len}, inside `{field}`")]
    Truncated {
        /// Where the read would have ended.
        at: usize,
        /// The message's length.
        len: usize,
        /// The field being read.
        field: &'static str,
    },
    /// Not a CDR encapsulation this reader knows.
    #[error("unknown CDR encapsulation {0:#06x} (expected 0x0000 or 0x0001, plain CDR)")]
    Encapsulation(u16),
    /// A string that is not UTF-8 or lacks its NUL.
    #[error("string `{0}` is not a UTF-8 string (NUL-terminated, in CDR)")]
    BadString(&'static str),
}

/// Reads CDR fields in order.
pub struct Cdr<'a> {
    buf: &'a [u8],
    pos: usize,
    little: bool,
    /// ROS 1's layout: nothing aligned, strings without NUL, `Header.seq`.
    ros1: bool,
}

/// Longest sequence accepted, elements: a count beyond the message's own size is a
/// corrupt message, not a reason to allocate gigabytes.
fn plausible_count(count: usize, elem: usize, remaining: usize) -> bool {
    count.saturating_mul(elem.max(1)) <= remaining
}

impl<'a> Cdr<'a> {
    /// A reader after the encapsulation header.
    pub fn new(buf: &'a [u8]) -> Result<Cdr<'a>, CdrError> {
        if buf.len() < 4 {
            return Err(CdrError::Truncated {
                at: 4,
                len: buf.len(),
                field: "encapsulation header",
            });
        }
        if buf[..4] == ROS1_MARKER {
            return Ok(Cdr {
                buf: &buf[4..],
                pos: 0,
                little: true,
                ros1: true,
            });
        }
        let kind = u16::from_be_bytes([buf[0], buf[1]]);
        let little = match kind {
            0x0001 => true,
            0x0000 => false,
            other => return Err(CdrError::Encapsulation(other)),
        };
        Ok(Cdr {
            buf: &buf[4..],
            pos: 0,
            little,
            ros1: false,
        })
    }

    fn take(&mut self, n: usize, field: &'static str) -> Result<&'a [u8], CdrError> {
        let align = if self.ros1 { 1 } else { n.min(8) };
        let pad = (align - self.pos % align) % align;
        let start = self.pos + pad;
        let end = start + n;
        if end > self.buf.len() {
            return Err(CdrError::Truncated {
                at: end + 4,
                len: self.buf.len() + 4,
                field,
            });
        }
        self.pos = end;
        Ok(&self.buf[start..end])
    }

    /// A `float64`.
    pub fn f64(&mut self, field: &'static str) -> Result<f64, CdrError> {
        let b: [u8; 8] = self.take(8, field)?.try_into().expect("8 bytes");
        Ok(if self.little {
            f64::from_le_bytes(b)
        } else {
            f64::from_be_bytes(b)
        })
    }

    /// A `float32`.
    pub fn f32(&mut self, field: &'static str) -> Result<f32, CdrError> {
        let b: [u8; 4] = self.take(4, field)?.try_into().expect("4 bytes");
        Ok(if self.little {
            f32::from_le_bytes(b)
        } else {
            f32::from_be_bytes(b)
        })
    }

    /// A `uint32`.
    pub fn u32(&mut self, field: &'static str) -> Result<u32, CdrError> {
        let b: [u8; 4] = self.take(4, field)?.try_into().expect("4 bytes");
        Ok(if self.little {
            u32::from_le_bytes(b)
        } else {
            u32::from_be_bytes(b)
        })
    }

    /// An `int32`.
    pub fn i32(&mut self, field: &'static str) -> Result<i32, CdrError> {
        Ok(self.u32(field)? as i32)
    }

    /// A `uint8` or `bool`.
    pub fn u8(&mut self, field: &'static str) -> Result<u8, CdrError> {
        Ok(self.take(1, field)?[0])
    }

    /// A `string`.
    pub fn string(&mut self, field: &'static str) -> Result<String, CdrError> {
        let n = self.u32(field)? as usize;
        if n == 0 {
            return Ok(String::new());
        }
        let remaining = self.buf.len() - self.pos;
        if n > remaining {
            return Err(CdrError::Truncated {
                at: self.pos + n + 4,
                len: self.buf.len() + 4,
                field,
            });
        }
        let bytes = &self.buf[self.pos..self.pos + n];
        self.pos += n;
        if self.ros1 {
            return std::str::from_utf8(bytes)
                .map(str::to_owned)
                .map_err(|_| CdrError::BadString(field));
        }
        match bytes.split_last() {
            Some((0, text)) => std::str::from_utf8(text)
                .map(str::to_owned)
                .map_err(|_| CdrError::BadString(field)),
            _ => Err(CdrError::BadString(field)),
        }
    }

    fn count(&mut self, elem: usize, field: &'static str) -> Result<usize, CdrError> {
        let n = self.u32(field)? as usize;
        if !plausible_count(n, elem, self.buf.len() - self.pos) {
            return Err(CdrError::Truncated {
                at: self.pos + n.saturating_mul(elem) + 4,
                len: self.buf.len() + 4,
                field,
            });
        }
        Ok(n)
    }

    /// A `float64[]`.
    pub fn f64_seq(&mut self, field: &'static str) -> Result<Vec<f64>, CdrError> {
        let n = self.count(8, field)?;
        (0..n).map(|_| self.f64(field)).collect()
    }

    /// A `float32[]`.
    pub fn f32_seq(&mut self, field: &'static str) -> Result<Vec<f32>, CdrError> {
        let n = self.count(4, field)?;
        (0..n).map(|_| self.f32(field)).collect()
    }

    /// A `string[]`.
    pub fn string_seq(&mut self, field: &'static str) -> Result<Vec<String>, CdrError> {
        let n = self.count(4, field)?;
        (0..n).map(|_| self.string(field)).collect()
    }

    /// `n` `float64`s of a fixed array.
    pub fn skip_f64s(&mut self, n: usize, field: &'static str) -> Result<(), CdrError> {
        for _ in 0..n {
            self.f64(field)?;
        }
        Ok(())
    }
}

/// `std_msgs/Header`: the stamp, s since the epoch, and the frame.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Header {
    /// The stamp, ns since the epoch (0: not stamped).
    pub stamp_ns: i64,
    /// The frame the data is in.
    pub frame_id: String,
}

fn header(c: &mut Cdr) -> Result<Header, CdrError> {
    if c.ros1 {
        c.u32("header.seq")?;
    }
    let sec = c.i32("header.stamp.sec")? as i64;
    let nanosec = c.u32("header.stamp.nanosec")? as i64;
    Ok(Header {
        stamp_ns: sec * 1_000_000_000 + nanosec,
        frame_id: c.string("header.frame_id")?,
    })
}

fn vector3(c: &mut Cdr, field: &'static str) -> Result<[f64; 3], CdrError> {
    Ok([c.f64(field)?, c.f64(field)?, c.f64(field)?])
}

/// Heading (yaw about z), rad, of a quaternion `(x, y, z, w)`.
pub fn yaw_of_quaternion([x, y, z, w]: [f64; 4]) -> f64 {
    (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z))
}

fn quaternion_yaw(c: &mut Cdr, field: &'static str) -> Result<f64, CdrError> {
    let q = [c.f64(field)?, c.f64(field)?, c.f64(field)?, c.f64(field)?];
    Ok(yaw_of_quaternion(q))
}

/// `geometry_msgs/Twist` (or the twist of a `TwistStamped`): planar velocity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Twist {
    /// `linear.x`, m/s.
    pub linear_x_m_s: f64,
    /// `angular.z`, rad/s.
    pub angular_z_rad_s: f64,
}

fn twist(c: &mut Cdr) -> Result<Twist, CdrError> {
    let l = vector3(c, "twist.linear")?;
    let a = vector3(c, "twist.angular")?;
    Ok(Twist {
        linear_x_m_s: l[0],
        angular_z_rad_s: a[2],
    })
}

/// `geometry_msgs/Twist`.
pub fn decode_twist(buf: &[u8]) -> Result<Twist, CdrError> {
    twist(&mut Cdr::new(buf)?)
}

/// `geometry_msgs/TwistStamped`.
pub fn decode_twist_stamped(buf: &[u8]) -> Result<(Header, Twist), CdrError> {
    let mut c = Cdr::new(buf)?;
    Ok((header(&mut c)?, twist(&mut c)?))
}

/// `nav_msgs/Odometry`, planar: pose in the header's frame, twist in the child's.
#[derive(Debug, Clone, PartialEq)]
pub struct Odometry {
    /// Stamp and frame of the pose.
    pub header: Header,
    /// The frame of the twist (the robot's base).
    pub child_frame_id: String,
    /// Position x, y, m, and heading, rad.
    pub pose: [f64; 3],
    /// Forward speed, m/s, and yaw rate, rad/s.
    pub twist: Twist,
}

/// `nav_msgs/Odometry`.
pub fn decode_odometry(buf: &[u8]) -> Result<Odometry, CdrError> {
    let mut c = Cdr::new(buf)?;
    let header = header(&mut c)?;
    let child_frame_id = c.string("child_frame_id")?;
    let p = vector3(&mut c, "pose.pose.position")?;
    let yaw = quaternion_yaw(&mut c, "pose.pose.orientation")?;
    c.skip_f64s(36, "pose.covariance")?;
    let tw = twist(&mut c)?;
    c.skip_f64s(36, "twist.covariance")?;
    Ok(Odometry {
        header,
        child_frame_id,
        pose: [p[0], p[1], yaw],
        twist: tw,
    })
}

/// A planar pose: x, y, m, and heading, rad, of `geometry_msgs/Pose`.
fn pose(c: &mut Cdr, field: &'static str) -> Result<[f64; 3], CdrError> {
    let p = vector3(c, field)?;
    let yaw = quaternion_yaw(c, field)?;
    Ok([p[0], p[1], yaw])
}

/// `geometry_msgs/PoseStamped`: the stamp and frame, and the planar pose.
pub fn decode_pose_stamped(buf: &[u8]) -> Result<(Header, [f64; 3]), CdrError> {
    let mut c = Cdr::new(buf)?;
    Ok((header(&mut c)?, pose(&mut c, "pose")?))
}

/// `geometry_msgs/PoseWithCovarianceStamped` (a localiser's output): the stamp and frame,
/// and the planar pose (the covariance read past).
pub fn decode_pose_with_covariance_stamped(buf: &[u8]) -> Result<(Header, [f64; 3]), CdrError> {
    let mut c = Cdr::new(buf)?;
    let h = header(&mut c)?;
    let p = pose(&mut c, "pose.pose")?;
    c.skip_f64s(36, "pose.covariance")?;
    Ok((h, p))
}

/// `sensor_msgs/JointState`.
#[derive(Debug, Clone, PartialEq)]
pub struct JointState {
    /// Stamp and frame.
    pub header: Header,
    /// Joint names.
    pub name: Vec<String>,
    /// Positions, rad for a revolute joint (may be empty).
    pub position: Vec<f64>,
    /// Speeds, rad/s (may be empty).
    pub velocity: Vec<f64>,
    /// Efforts, N m for a revolute joint (may be empty).
    pub effort: Vec<f64>,
}

/// `sensor_msgs/JointState`.
pub fn decode_joint_state(buf: &[u8]) -> Result<JointState, CdrError> {
    let mut c = Cdr::new(buf)?;
    Ok(JointState {
        header: header(&mut c)?,
        name: c.string_seq("name")?,
        position: c.f64_seq("position")?,
        velocity: c.f64_seq("velocity")?,
        effort: c.f64_seq("effort")?,
    })
}

/// `sensor_msgs/Imu`, what a planar robot uses of it.
#[derive(Debug, Clone, PartialEq)]
pub struct Imu {
    /// Stamp and frame.
    pub header: Header,
    /// `angular_velocity.z`, rad/s.
    pub yaw_rate_rad_s: f64,
    /// `linear_acceleration.x`, m/s^2.
    pub accel_x_m_s2: f64,
}

/// `sensor_msgs/Imu`.
pub fn decode_imu(buf: &[u8]) -> Result<Imu, CdrError> {
    let mut c = Cdr::new(buf)?;
    let header = header(&mut c)?;
    c.skip_f64s(4, "orientation")?;
    c.skip_f64s(9, "orientation_covariance")?;
    let w = vector3(&mut c, "angular_velocity")?;
    c.skip_f64s(9, "angular_velocity_covariance")?;
    let a = vector3(&mut c, "linear_acceleration")?;
    c.skip_f64s(9, "linear_acceleration_covariance")?;
    Ok(Imu {
        header,
        yaw_rate_rad_s: w[2],
        accel_x_m_s2: a[0],
    })
}

/// `sensor_msgs/BatteryState`, what a drive uses of it.
#[derive(Debug, Clone, PartialEq)]
pub struct BatteryState {
    /// Stamp and frame.
    pub header: Header,
    /// Terminal voltage, V.
    pub voltage_v: f64,
    /// Current, A (negative while discharging, by the message's convention; NaN if not
    /// measured).
    pub current_a: f64,
}

/// A `float32` as the decimal it was written as (24.4, not 24.399999618530273).
fn widened(x: f32) -> f64 {
    x.to_string().parse().unwrap_or(x as f64)
}

/// `sensor_msgs/BatteryState`.
pub fn decode_battery_state(buf: &[u8]) -> Result<BatteryState, CdrError> {
    let mut c = Cdr::new(buf)?;
    let header = header(&mut c)?;
    let voltage_v = widened(c.f32("voltage")?);
    let _temperature = c.f32("temperature")?;
    let current_a = widened(c.f32("current")?);
    // charge, capacity, design_capacity, percentage, three status bytes, present, then the
    // cell sequences and two strings: read so that a short message is caught.
    for f in ["charge", "capacity", "design_capacity", "percentage"] {
        c.f32(f)?;
    }
    for f in [
        "power_supply_status",
        "power_supply_health",
        "power_supply_technology",
        "present",
    ] {
        c.u8(f)?;
    }
    c.f32_seq("cell_voltage")?;
    c.f32_seq("cell_temperature")?;
    c.string("location")?;
    c.string("serial_number")?;
    Ok(BatteryState {
        header,
        voltage_v,
        current_a,
    })
}

/// One `geometry_msgs/TransformStamped` of a `tf2_msgs/TFMessage`, planar.
#[derive(Debug, Clone, PartialEq)]
pub struct Transform {
    /// Stamp and parent frame.
    pub header: Header,
    /// The child frame.
    pub child_frame_id: String,
    /// Translation x, y, m, and heading, rad, of the child in the parent.
    pub pose: [f64; 3],
}

/// `tf2_msgs/TFMessage`.
pub fn decode_tf(buf: &[u8]) -> Result<Vec<Transform>, CdrError> {
    let mut c = Cdr::new(buf)?;
    let n = c.count(4, "transforms")?;
    (0..n)
        .map(|_| {
            let header = header(&mut c)?;
            let child_frame_id = c.string("child_frame_id")?;
            let t = vector3(&mut c, "transform.translation")?;
            let yaw = quaternion_yaw(&mut c, "transform.rotation")?;
            Ok(Transform {
                header,
                child_frame_id,
                pose: [t[0], t[1], yaw],
            })
        })
        .collect()
}

/// `std_msgs/String`.
pub fn decode_string(buf: &[u8]) -> Result<String, CdrError> {
    Cdr::new(buf)?.string("data")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A Twist as a ROS 2 publisher encodes it: header `00 01 00 00`, six doubles.
    fn twist_bytes(v: f64, w: f64) -> Vec<u8> {
        let mut b = vec![0, 1, 0, 0];
        for x in [v, 0.0, 0.0, 0.0, 0.0, w] {
            b.extend(x.to_le_bytes());
        }
        b
    }

    #[test]
    fn a_twist_decodes_and_a_short_one_names_its_field() {
        let t = decode_twist(&twist_bytes(0.5, -0.25)).unwrap();
        assert_eq!((t.linear_x_m_s, t.angular_z_rad_s), (0.5, -0.25));
        let b = twist_bytes(0.5, -0.25);
        let e = decode_twist(&b[..30]).unwrap_err().to_string();
        assert!(e.contains("twist.angular"), "{e}");
    }

    #[test]
    fn strings_align_the_doubles_after_them() {
        // Header stamp (8 bytes), frame "ab" (4 + 3 bytes), padding to 8, then a double.
        let mut b = vec![0, 1, 0, 0];
        b.extend(7i32.to_le_bytes());
        b.extend(9u32.to_le_bytes());
        b.extend(3u32.to_le_bytes());
        b.extend(b"ab\0");
        b.push(0); // pad 15 -> 16
        b.extend(1.5f64.to_le_bytes());
        let mut c = Cdr::new(&b).unwrap();
        let h = header(&mut c).unwrap();
        assert_eq!(h.stamp_ns, 7_000_000_009);
        assert_eq!(h.frame_id, "ab");
        assert_eq!(c.f64("x").unwrap(), 1.5);
    }

    #[test]
    fn a_corrupt_count_is_refused_not_allocated() {
        let mut b = vec![0, 1, 0, 0];
        b.extend(u32::MAX.to_le_bytes());
        let e = Cdr::new(&b).unwrap().f64_seq("position").unwrap_err();
        assert!(matches!(
            e,
            CdrError::Truncated {
                field: "position",
                ..
            }
        ));
    }

    #[test]
    fn yaw_of_a_quarter_turn() {
        let h = std::f64::consts::FRAC_PI_4;
        let q = [0.0, 0.0, h.sin(), h.cos()];
        assert!((yaw_of_quaternion(q) - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    }
}
