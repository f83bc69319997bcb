//! Where a bag's independent pose comes from: a pose topic the map names, a chain of
//! `/tf` transforms composed down to the base, or the one pose topic the bag has.

use super::align::Series;
use super::cdr;
use super::converter::{Converter, ODOMETRY, POSE_COV_STAMPED, POSE_STAMPED, TF};
use super::Ros2Error;
use crate::import::bag::Topic;

/// The independent pose, and how it was found (`(what, topic)`):
///
/// - the map's `pose`: a topic (`/mocap/pose`: `geometry_msgs/PoseStamped`,
///   `PoseWithCovarianceStamped`, or a motion-capture bridge's `nav_msgs/Odometry`), or
///   `"PARENT:CHILD"` frames on `/tf` (a chain of transforms composed);
/// - else the one chain of `/tf` (and `/tf_static`) transforms that ends at the base
///   (`base_link`, `base_footprint`) from a root other than the odometry frame (`odom`):
///   a motion-capture frame, or `map -> odom -> base_link` (a localiser's pose: it
///   corrects the odometry's drift from other sensors, but between corrections it is the
///   odometry, which a note says);
/// - else the one `PoseStamped` or `PoseWithCovarianceStamped` topic.
pub(super) fn tracked_pose(
    c: &Converter,
    notes: &mut Vec<String>,
) -> Result<(Series, Option<(String, String)>), Ros2Error> {
    if let Some(p) = c.map.pose.as_deref().filter(|p| p.starts_with('/')) {
        let t = c.bag.topics.iter().find(|t| t.name == p).ok_or_else(|| {
            c.err(format!(
                "--map pose = \"{p}\": no such topic; the bag has {}",
                c.listing()
            ))
        })?;
        return pose_topic(c, t).map(|(s, what)| (s, Some((what, t.name.clone()))));
    }
    let links = tf_links(c)?;
    let chain = match &c.map.pose {
        Some(p) => {
            let (parent, child) = p.split_once(':').ok_or_else(|| Ros2Error::Content {
                bag: c.bag.path.clone(),
                message: format!(
                    "--map pose = \"{p}\": expected \"PARENT:CHILD\" frames or a topic (`/name`)"
                ),
            })?;
            Some(chain_between(&links, parent, child).ok_or_else(|| {
                c.err(format!(
                    "--map pose = \"{p}\": no /tf transform or chain of transforms from `{parent}` to `{child}` in the bag"
                ))
            })?)
        }
        None => {
            let mut chains: Vec<Vec<usize>> = ["base_link", "base_footprint"]
                .iter()
                .flat_map(|base| {
                    roots_of(&links, base)
                        .into_iter()
                        .filter_map(|root| chain_between(&links, &root, base))
                })
                .filter(|ch| links[ch[0]].parent != "odom")
                .collect();
            chains.sort();
            chains.dedup();
            for (i, l) in links.iter().enumerate() {
                if l.parent == "odom"
                    && matches!(l.child.as_str(), "base_link" | "base_footprint")
                    && !chains.iter().any(|ch| ch.contains(&i))
                {
                    notes.push(format!("the /tf transform odom -> {} is the wheel odometry, not an independent pose: not written as x_m, y_m, heading_rad", l.child));
                }
            }
            match chains.len() {
                0 => None,
                1 => chains.pop(),
                _ => {
                    let list: Vec<String> =
                        chains.iter().map(|ch| chain_words(&links, ch)).collect();
                    return Err(c.err(format!(
                        "several /tf chains to the base ({}): choose the independent pose with --map (key `pose`, \"PARENT:CHILD\")",
                        list.join("; ")
                    )));
                }
            }
        }
    };
    let Some(chain) = chain else {
        // No /tf pose: a pose topic, where there is exactly one.
        let topics: Vec<&Topic> = c
            .bag
            .topics
            .iter()
            .filter(|t| matches!(t.msg_type.as_str(), POSE_STAMPED | POSE_COV_STAMPED))
            .collect();
        return match topics.as_slice() {
            [] => Ok((Series::default(), None)),
            [t] => pose_topic(c, t).map(|(s, what)| (s, Some((what, t.name.clone())))),
            several => Err(c.err(format!(
                "several pose topics ({}): choose the independent pose with --map (key `pose`, the topic)",
                several.iter().map(|t| t.name.as_str()).collect::<Vec<_>>().join(", ")
            ))),
        };
    };
    if chain.len() > 1 && chain.iter().any(|&i| links[i].parent == "odom") {
        notes.push(format!(
            "the pose is the chain {}: a localiser's correction of the wheel odometry, independent of the wheels only where the localiser corrected it",
            chain_words(&links, &chain)
        ));
    }
    let topic = links[*chain.last().expect("a chain has a link")]
        .topic
        .clone();
    Ok((
        compose(&links, &chain),
        Some((chain_words(&links, &chain), topic)),
    ))
}

/// One `/tf` (or `/tf_static`) link: parent, child, its topic, and its transforms in time.
struct TfLink {
    parent: String,
    child: String,
    topic: String,
    series: Series,
}

/// Every parent-child link of the bag's transforms.
fn tf_links(c: &Converter) -> Result<Vec<TfLink>, Ros2Error> {
    let mut links: Vec<TfLink> = vec![];
    for t in c.bag.topics.iter().filter(|t| t.msg_type == TF) {
        for (log, tfs) in c.decode(t, cdr::decode_tf)? {
            for tr in tfs {
                let i = match links
                    .iter()
                    .position(|l| l.parent == tr.header.frame_id && l.child == tr.child_frame_id)
                {
                    Some(i) => i,
                    None => {
                        links.push(TfLink {
                            parent: tr.header.frame_id.clone(),
                            child: tr.child_frame_id.clone(),
                            topic: t.name.clone(),
                            series: Series::default(),
                        });
                        links.len() - 1
                    }
                };
                links[i]
                    .series
                    .push(c.at(&t.name, &tr.header, log), tr.pose.to_vec());
            }
        }
    }
    for l in &mut links {
        l.series = std::mem::take(&mut l.series).sorted().with_continuous(2);
    }
    Ok(links)
}

/// The root frames of the tree above `child`: its ancestors that are no frame's child
/// (a chain from one of them is the whole chain, not a tail of a longer one).
fn roots_of(links: &[TfLink], child: &str) -> Vec<String> {
    let mut ancestors: Vec<String> = vec![];
    let mut frontier = vec![child.to_string()];
    while let Some(f) = frontier.pop() {
        for l in links.iter().filter(|l| l.child == f) {
            if !ancestors.contains(&l.parent) && l.parent != child {
                ancestors.push(l.parent.clone());
                frontier.push(l.parent.clone());
            }
        }
    }
    ancestors.retain(|a| !links.iter().any(|l| l.child == *a));
    ancestors
}

/// The links from `parent` down to `child` (indices, root first), if a chain joins them.
/// A frame may have several parents (a localiser's `odom -> base_link` and a motion
/// capture's `mocap -> base_link`), so every parent is tried, depth first.
fn chain_between(links: &[TfLink], parent: &str, child: &str) -> Option<Vec<usize>> {
    fn up(links: &[TfLink], parent: &str, at: &str, chain: &mut Vec<usize>) -> bool {
        if at == parent {
            return !chain.is_empty();
        }
        for (i, l) in links.iter().enumerate().filter(|(_, l)| l.child == at) {
            if chain.contains(&i) {
                continue; // a cycle in a malformed tree
            }
            chain.push(i);
            if up(links, parent, &l.parent, chain) {
                return true;
            }
            chain.pop();
        }
        false
    }
    let mut chain = vec![];
    up(links, parent, child, &mut chain).then(|| {
        chain.reverse();
        chain
    })
}

fn chain_words(links: &[TfLink], chain: &[usize]) -> String {
    let mut w = links[chain[0]].parent.clone();
    for &i in chain {
        w.push_str(" -> ");
        w.push_str(&links[i].child);
    }
    w
}

/// The chain's transforms composed at each time of its last link (the one to the base),
/// each other link at its transform nearest in time (a static one: its only one).
fn compose(links: &[TfLink], chain: &[usize]) -> Series {
    let last = &links[*chain.last().expect("a chain has a link")].series;
    let mut out = Series::default();
    for (k, &t) in last.t_ns.iter().enumerate() {
        let mut pose = [0.0_f64, 0.0, 0.0];
        for &i in chain {
            let s = &links[i].series;
            let v = if std::ptr::eq(s, last) {
                Some(last.values[k].clone())
            } else {
                nearest_value(s, t)
            };
            let Some(v) = v else { continue };
            let (sin, cos) = pose[2].sin_cos();
            pose = [
                pose[0] + cos * v[0] - sin * v[1],
                pose[1] + sin * v[0] + cos * v[1],
                pose[2] + v[2],
            ];
        }
        out.push(t, pose.to_vec());
    }
    out.sorted()
}

/// The value of a series nearest in time to `t` (none for an empty series).
fn nearest_value(s: &Series, t: i64) -> Option<Vec<f64>> {
    let i = s.t_ns.partition_point(|&x| x < t);
    let pick = match (i.checked_sub(1), (i < s.t_ns.len()).then_some(i)) {
        (Some(a), Some(b)) => {
            if t - s.t_ns[a] <= s.t_ns[b] - t {
                a
            } else {
                b
            }
        }
        (Some(a), None) => a,
        (None, Some(b)) => b,
        (None, None) => return None,
    };
    Some(s.values[pick].clone())
}

/// A pose topic's poses in time, and what they are in words.
fn pose_topic(c: &Converter, t: &Topic) -> Result<(Series, String), Ros2Error> {
    let mut s = Series::default();
    let what = match t.msg_type.as_str() {
        POSE_STAMPED => {
            for (log, (h, p)) in c.decode(t, cdr::decode_pose_stamped)? {
                s.push(c.at(&t.name, &h, log), p.to_vec());
            }
            format!("{POSE_STAMPED} pose")
        }
        POSE_COV_STAMPED => {
            for (log, (h, p)) in c.decode(t, cdr::decode_pose_with_covariance_stamped)? {
                s.push(c.at(&t.name, &h, log), p.to_vec());
            }
            format!("{POSE_COV_STAMPED} pose.pose")
        }
        ODOMETRY => {
            for (log, m) in c.decode(t, cdr::decode_odometry)? {
                s.push(c.at(&t.name, &m.header, log), m.pose.to_vec());
            }
            format!("{ODOMETRY} pose.pose (a motion-capture bridge's, as --map pose says)")
        }
        other => {
            return Err(c.err(format!(
                "--map pose: topic `{}` is a {other}; a pose comes from {POSE_STAMPED}, {POSE_COV_STAMPED} or {ODOMETRY}",
                t.name
            )))
        }
    };
    Ok((s.sorted().with_continuous(2), what))
}
