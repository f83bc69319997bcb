//! The two numbers a drive needs from a URDF robot description: the track (the lateral
//! distance between the drive wheels' joints) and the wheel radius (the wheel link's
//! cylinder). Read with an XML parser (`roxmltree`), so that attributes on lines of their
//! own, single quotes, comments and padded numbers read as any URDF tool reads them.

/// Track and wheel radius from a URDF, with the joint names used.
#[derive(Debug, Clone, PartialEq)]
pub struct DriveGeometry {
    /// Lateral distance between the wheel joints' origins, m.
    pub track_m: f64,
    /// The left wheel link's cylinder radius, m.
    pub wheel_radius_m: f64,
    /// The joints read (left, right).
    pub joints: [String; 2],
}

type Node<'a, 'i> = roxmltree::Node<'a, 'i>;

/// The element's children named `tag`.
fn children<'a, 'i>(node: Node<'a, 'i>, tag: &'a str) -> impl Iterator<Item = Node<'a, 'i>> {
    node.children()
        .filter(move |c| c.is_element() && c.tag_name().name() == tag)
}

/// A number attribute, white space around it allowed.
fn number(node: Node, attr: &str) -> Option<f64> {
    node.attribute(attr)?.trim().parse().ok()
}

/// A wheel joint: the one named `chosen`, else a continuous (or revolute) joint whose
/// name holds the side and "wheel".
fn wheel_joint<'a, 'i>(
    robot: Node<'a, 'i>,
    side: &str,
    chosen: Option<&str>,
) -> Option<Node<'a, 'i>> {
    children(robot, "joint").find(|j| {
        let name = j.attribute("name").unwrap_or("");
        match chosen {
            Some(c) => name == c,
            None => {
                matches!(j.attribute("type"), Some("continuous" | "revolute"))
                    && name.contains("wheel")
                    && name.contains(side)
            }
        }
    })
}

/// A joint's lateral offset: the y of its origin's `xyz` (0 without an origin).
fn lateral_m(joint: Node) -> Option<f64> {
    match children(joint, "origin").next() {
        None => Some(0.0),
        Some(o) => match o.attribute("xyz") {
            None => Some(0.0),
            Some(xyz) => xyz.split_whitespace().nth(1)?.parse().ok(),
        },
    }
}

/// The radius of the first cylinder of the link's visual or collision geometry.
fn cylinder_radius_m(link: Node) -> Option<f64> {
    link.descendants()
        .filter(|n| n.is_element() && n.tag_name().name() == "cylinder")
        .find_map(|c| number(c, "radius"))
}

/// Why a robot description gives no drive geometry.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum UrdfFault {
    /// The text is not XML.
    #[error("not XML: {0}")]
    NotXml(String),
    /// The root element is not `<robot>`.
    #[error("its root element is <{0}>, not <robot>")]
    NotRobot(String),
    /// The joint the user named is not there.
    #[error("no joint named `{0}`")]
    NoJointNamed(String),
    /// No joint looks like a side's wheel.
    #[error("no continuous or revolute joint whose name holds `{0}` and `wheel` (name them with --map left_wheel_joint, right_wheel_joint)")]
    NoWheelJoint(&'static str),
    /// A wheel joint without a child link.
    #[error("joint `{0}` has no <child link=...>")]
    NoChildLink(String),
    /// A wheel joint's child link is not described.
    #[error("no link `{link}` (the child of joint `{joint}`)")]
    NoLink {
        /// The link's name.
        link: String,
        /// The joint naming it.
        joint: String,
    },
    /// A wheel link without a cylinder to take the radius from.
    #[error("link `{0}` has no <cylinder radius=...>")]
    NoCylinder(String),
    /// A wheel joint's origin is not a point.
    #[error("joint `{0}`: its origin's xyz is not three numbers")]
    BadOrigin(String),
    /// Both wheels at the same lateral offset.
    #[error("joints `{0}` and `{1}` are at the same lateral offset: no track")]
    NoTrack(String, String),
}

/// The drive's geometry, or why the description gives none (not XML, no wheel joints,
/// no cylinder on the left wheel's link).
pub fn drive_geometry(
    xml: &str,
    left: Option<&str>,
    right: Option<&str>,
) -> Result<DriveGeometry, UrdfFault> {
    let doc = roxmltree::Document::parse(xml).map_err(|e| match e {
        roxmltree::Error::DtdDetected => UrdfFault::NotXml(
            "it declares a DTD (<!DOCTYPE ...>), which is refused: its entities can expand without bound; a URDF needs none (xacro's output has none)".into(),
        ),
        e => UrdfFault::NotXml(e.to_string()),
    })?;
    let robot = doc.root_element();
    if robot.tag_name().name() != "robot" {
        return Err(UrdfFault::NotRobot(robot.tag_name().name().to_string()));
    }
    let joint = |side: &'static str, chosen: Option<&str>| {
        wheel_joint(robot, side, chosen).ok_or_else(|| match chosen {
            Some(c) => UrdfFault::NoJointNamed(c.to_string()),
            None => UrdfFault::NoWheelJoint(side),
        })
    };
    let (l, r) = (joint("left", left)?, joint("right", right)?);
    let name = |j: Node| j.attribute("name").unwrap_or("").to_string();
    let link_name = children(l, "child")
        .next()
        .and_then(|c| c.attribute("link"))
        .ok_or_else(|| UrdfFault::NoChildLink(name(l)))?;
    let link = children(robot, "link")
        .find(|k| k.attribute("name") == Some(link_name))
        .ok_or_else(|| UrdfFault::NoLink {
            link: link_name.to_string(),
            joint: name(l),
        })?;
    let radius =
        cylinder_radius_m(link).ok_or_else(|| UrdfFault::NoCylinder(link_name.to_string()))?;
    let y = |j: Node| lateral_m(j).ok_or_else(|| UrdfFault::BadOrigin(name(j)));
    let track = (y(l)? - y(r)?).abs();
    if track <= 0.0 {
        return Err(UrdfFault::NoTrack(name(l), name(r)));
    }
    Ok(DriveGeometry {
        track_m: track,
        wheel_radius_m: radius,
        joints: [name(l), name(r)],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn track_and_radius_from_a_two_wheel_description() {
        let xml = r#"<robot name="r"><link name="base_link"/>
          <link name="lw"><visual><geometry><cylinder radius="0.08" length="0.03"/></geometry></visual></link>
          <joint name="left_wheel_joint" type="continuous"><parent link="base_link"/><child link="lw"/>
            <origin xyz="0 0.21 0.08" rpy="0 0 0"/></joint>
          <joint name="right_wheel_joint" type="continuous"><parent link="base_link"/><child link="rw"/>
            <origin xyz="0 -0.19 0.08"/></joint></robot>"#;
        let g = drive_geometry(xml, None, None).unwrap();
        assert!((g.track_m - 0.40).abs() < 1e-12);
        assert_eq!(g.wheel_radius_m, 0.08);
        assert_eq!(
            drive_geometry(xml, Some("nope"), None).unwrap_err(),
            UrdfFault::NoJointNamed("nope".into())
        );
        assert!(drive_geometry(xml, Some("nope"), None)
            .unwrap_err()
            .to_string()
            .contains("no joint named `nope`"));
    }

    #[test]
    fn attributes_on_their_own_lines_single_quotes_revolute_joints_and_padding_read() {
        let xml = "<?xml version='1.0'?>\n<!-- from xacro -->\n<robot\n  name='r'>\n\
          <link name='lw'>\n  <collision>\n    <geometry>\n      <cylinder\n        length='0.03'\n        radius=' 0.0825 '/>\n    </geometry>\n  </collision>\n</link>\n\
          <joint\n    name='wheel_left_joint'\n    type='revolute'>\n  <child link='lw'/>\n  <origin\n    xyz='0 0.1 0'/>\n</joint>\n\
          <joint type='revolute' name='wheel_right_joint'><child link='rw'/><origin xyz='0 -0.1 0'/></joint>\n</robot>\n";
        let g = drive_geometry(xml, None, None).unwrap();
        assert!((g.track_m - 0.2).abs() < 1e-12);
        assert_eq!(g.wheel_radius_m, 0.0825);
        assert_eq!(g.joints, ["wheel_left_joint", "wheel_right_joint"]);
    }

    #[test]
    fn a_description_that_is_not_urdf_says_why() {
        assert!(drive_geometry("<robot", None, None)
            .unwrap_err()
            .to_string()
            .starts_with("not XML"));
        assert_eq!(
            drive_geometry("<sdf/>", None, None).unwrap_err(),
            UrdfFault::NotRobot("sdf".into())
        );
        assert!(drive_geometry("<sdf/>", None, None)
            .unwrap_err()
            .to_string()
            .contains("<sdf>"));
    }
}
