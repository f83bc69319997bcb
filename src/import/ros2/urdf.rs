//! The two numbers a drive needs from a URDF robot description: the track (the lateral
//! distance between the drive wheels' joints) and the wheel radius (the wheel link's
//! cylinder). Read by plain text search: a URDF from `xacro` is flat XML, and only these
//! attributes matter.

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

/// The value of attribute `name` in an element's text.
fn attr<'a>(element: &'a str, name: &str) -> Option<&'a str> {
    let key = format!("{name}=\"");
    let start = element.find(&key)? + key.len();
    let len = element[start..].find('"')?;
    Some(&element[start..start + len])
}

/// The `<tag ...>...</tag>` (or self-closed) elements of `xml`.
fn elements<'a>(xml: &'a str, tag: &str) -> Vec<&'a str> {
    let open = format!("<{tag} ");
    let close = format!("</{tag}>");
    let mut out = vec![];
    let mut rest = xml;
    while let Some(i) = rest.find(&open) {
        let from = &rest[i..];
        let head_end = from.find('>').unwrap_or(from.len());
        let end = if from[..head_end].ends_with('/') {
            head_end + 1
        } else {
            from.find(&close).map_or(from.len(), |j| j + close.len())
        };
        out.push(&from[..end]);
        rest = &from[end..];
    }
    out
}

/// A wheel joint: continuous, its name chosen or naming the side and "wheel".
fn wheel_joint<'a>(joints: &[&'a str], side: &str, chosen: Option<&str>) -> Option<&'a str> {
    joints.iter().copied().find(|j| {
        let name = attr(j, "name").unwrap_or("");
        match chosen {
            Some(c) => name == c,
            None => {
                attr(j, "type") == Some("continuous")
                    && name.contains("wheel")
                    && name.contains(side)
            }
        }
    })
}

/// The drive's geometry, if the description has both wheels' joints and the left
/// wheel's cylinder.
pub fn drive_geometry(xml: &str, left: Option<&str>, right: Option<&str>) -> Option<DriveGeometry> {
    let joints = elements(xml, "joint");
    let (l, r) = (
        wheel_joint(&joints, "left", left)?,
        wheel_joint(&joints, "right", right)?,
    );
    let y = |j: &str| -> Option<f64> {
        let origin = elements(j, "origin").into_iter().next()?;
        attr(origin, "xyz")?.split_whitespace().nth(1)?.parse().ok()
    };
    let child = elements(l, "child").into_iter().next()?;
    let link_name = attr(child, "link")?;
    let link = elements(xml, "link")
        .into_iter()
        .find(|k| attr(k, "name") == Some(link_name))?;
    let radius: f64 = elements(link, "cylinder")
        .into_iter()
        .find_map(|c| attr(c, "radius")?.parse().ok())?;
    let track = (y(l)? - y(r)?).abs();
    (track > 0.0 && radius > 0.0).then(|| DriveGeometry {
        track_m: track,
        wheel_radius_m: radius,
        joints: [l, r].map(|j| attr(j, "name").unwrap_or("").to_string()),
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
        assert!(drive_geometry(xml, Some("nope"), None).is_none());
    }
}
