//! A `diff_drive_controller` parameter file (the YAML ros2_control loads): the wheel
//! geometry the robot's odometry and base controller are configured with, and the
//! velocity and acceleration limits of its speed limiters.
//!
//! The parameters sit under `CONTROLLER_NAME: ros__parameters:` (ROS 2) or directly under
//! `CONTROLLER_NAME:` beside `type: diff_drive_controller/DiffDriveController` (ROS 1), as
//! dotted keys (`linear.x.max_velocity: 1.0`) or nested maps (`linear: {x: {max_velocity:
//! 1.0}}`); YAML merge keys (`<<: *defaults`) are applied first. The controller is the one
//! whose parameters name `wheel_separation`; a file with two is refused naming both.
//!
//! A limit is `.nan` (no limit: ros2_control's default), a positive number, or switched
//! off by `has_velocity_limits: false` / `has_acceleration_limits: false` (ROS 1 and older
//! ROS 2, where 0 is the default beside it); a negative or zero limit that is switched on
//! would stop the robot and is refused.

use std::path::{Path, PathBuf};

/// What the file configures (each `None` where it says nothing).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DiffDriveParams {
    /// `wheel_separation` times `wheel_separation_multiplier`, m.
    pub wheel_separation_m: Option<f64>,
    /// `wheel_radius` times the mean of `left_`/`right_wheel_radius_multiplier`, m.
    pub wheel_radius_m: Option<f64>,
    /// The left and right radius multipliers where they differ (the scene's controller
    /// has one radius: their mean is taken, and a note says so).
    pub unequal_multipliers: Option<(f64, f64)>,
    /// `linear.x.max_velocity`, m/s.
    pub max_linear_m_s: Option<f64>,
    /// `linear.x.max_acceleration`, m/s^2.
    pub max_linear_accel_m_s2: Option<f64>,
    /// `angular.z.max_velocity`, rad/s.
    pub max_angular_rad_s: Option<f64>,
    /// `angular.z.max_acceleration`, rad/s^2.
    pub max_angular_accel_rad_s2: Option<f64>,
}

/// Why the file cannot be read.
#[derive(Debug, thiserror::Error)]
#[error("{}: {message}", file.display())]
pub struct ControllerFileError {
    /// The file.
    pub file: PathBuf,
    /// What is wrong.
    pub message: String,
}

/// Reads a parameter file.
pub fn load(path: &Path) -> Result<DiffDriveParams, ControllerFileError> {
    let err = |message: String| ControllerFileError {
        file: path.to_owned(),
        message,
    };
    let text = crate::output::read_text_bounded(path, crate::output::MAX_CONFIG_BYTES)
        .map_err(|e| err(format!("cannot read: {e}")))?;
    parse(&text).map_err(|e| err(e.to_string()))
}

/// Why a parameter file's text gives no diff-drive controller.
#[derive(Debug, thiserror::Error)]
pub enum ParamsFault {
    /// Not YAML.
    #[error("not YAML: {0}")]
    NotYaml(#[from] serde_yaml::Error),
    /// No diff_drive_controller's parameters.
    #[error("no diff_drive_controller's parameters: expected a controller's map with `wheel_separation`, under `NAME: ros__parameters:` (ROS 2) or under `NAME:` beside `type: diff_drive_controller/DiffDriveController` (ROS 1)")]
    NoController,
    /// More than one controller names `wheel_separation`.
    #[error("{} controllers give wheel_separation ({}): agvsim reads one; keep the robot's in the file", .0.len(), crate::numtext::backticked(.0))]
    Several(Vec<String>),
    /// A parameter that is no finite number (its key and value as read).
    #[error("`{0}`: expected a number, found {1}")]
    NotNumber(String, String),
    /// A size that is not positive.
    #[error("`{0}` = {1}: expected a positive number")]
    NotPositive(String, f64),
    /// A limit that is neither a positive number nor `.nan`.
    #[error("`{0}`: expected a positive number, or .nan for no limit, found {1}")]
    NotLimit(String, String),
}

/// Parses a parameter file's text.
pub fn parse(text: &str) -> Result<DiffDriveParams, ParamsFault> {
    let mut doc: serde_yaml::Value = serde_yaml::from_str(text)?;
    doc.apply_merge()?;
    let found = controllers(&doc);
    let params = match found.as_slice() {
        [] => return Err(ParamsFault::NoController),
        [(_, one)] => *one,
        several => {
            return Err(ParamsFault::Several(
                several.iter().map(|(name, _)| name.clone()).collect(),
            ))
        }
    };
    let get = |dotted: &str| -> Result<Option<f64>, ParamsFault> {
        let v = lookup(params, dotted);
        match v {
            None => Ok(None),
            Some(v) => match v.as_f64() {
                Some(x) if x.is_finite() => Ok(Some(x)),
                _ => Err(ParamsFault::NotNumber(dotted.into(), format!("{v:?}"))),
            },
        }
    };
    let positive = |dotted: &str| -> Result<Option<f64>, ParamsFault> {
        match get(dotted)? {
            Some(x) if x <= 0.0 => Err(ParamsFault::NotPositive(dotted.into(), x)),
            other => Ok(other),
        }
    };
    let separation = positive("wheel_separation")?;
    let radius = positive("wheel_radius")?;
    let sep_mult = positive("wheel_separation_multiplier")?.unwrap_or(1.0);
    let left = positive("left_wheel_radius_multiplier")?.unwrap_or(1.0);
    let right = positive("right_wheel_radius_multiplier")?.unwrap_or(1.0);
    let limit = |axis: &str, kind: &str| limit_of(params, axis, kind);
    Ok(DiffDriveParams {
        wheel_separation_m: separation.map(|s| s * sep_mult),
        wheel_radius_m: radius.map(|r| r * 0.5 * (left + right)),
        unequal_multipliers: (left != right).then_some((left, right)),
        max_linear_m_s: limit("linear.x", "velocity")?,
        max_linear_accel_m_s2: limit("linear.x", "acceleration")?,
        max_angular_rad_s: limit("angular.z", "velocity")?,
        max_angular_accel_rad_s2: limit("angular.z", "acceleration")?,
    })
}

/// `AXIS.max_KIND` as a limit: `None` where it is absent, `.nan` or switched off by
/// `AXIS.has_KIND_limits: false`; an error where it is switched on and not positive.
fn limit_of(
    params: &serde_yaml::Value,
    axis: &str,
    kind: &str,
) -> Result<Option<f64>, ParamsFault> {
    let dotted = format!("{axis}.max_{kind}");
    let switched_off = lookup(params, &format!("{axis}.has_{kind}_limits"))
        .and_then(serde_yaml::Value::as_bool)
        == Some(false);
    match lookup(params, &dotted).map(|v| (v, v.as_f64())) {
        None => Ok(None),
        Some(_) if switched_off => Ok(None),
        Some((_, Some(x))) if x.is_nan() => Ok(None),
        Some((_, Some(x))) if x.is_finite() && x > 0.0 => Ok(Some(x)),
        Some((v, _)) => Err(ParamsFault::NotLimit(dotted, format!("{v:?}"))),
    }
}

/// Every controller's parameter map that names `wheel_separation`, with its name: the
/// `ros__parameters` maps (ROS 2) if there are any; else the maps beside a
/// `diff_drive_controller` `type` (ROS 1) if there are any; else any map holding it
/// directly. A map of defaults merged into the controller (`<<: *defaults`) holds it too,
/// and is not a second controller where the controller is found by its layout.
fn controllers(doc: &serde_yaml::Value) -> Vec<(String, &serde_yaml::Value)> {
    let mut all = vec![];
    holding_separation(doc, "", &mut all);
    let ros2: Vec<_> = all.iter().filter(|c| c.2 == Layout::Ros2).collect();
    let typed: Vec<_> = all.iter().filter(|c| c.2 == Layout::Ros1Typed).collect();
    let pick = if !ros2.is_empty() {
        ros2
    } else if !typed.is_empty() {
        typed
    } else {
        all.iter().collect()
    };
    pick.into_iter().map(|(n, v, _)| (n.clone(), *v)).collect()
}

/// How a controller's parameters sit in the file.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Layout {
    /// Under `ros__parameters`.
    Ros2,
    /// Beside `type: diff_drive_controller/...`.
    Ros1Typed,
    /// A map that holds `wheel_separation`, nothing more said.
    Plain,
}

fn holding_separation<'a>(
    v: &'a serde_yaml::Value,
    name: &str,
    found: &mut Vec<(String, &'a serde_yaml::Value, Layout)>,
) {
    let Some(map) = v.as_mapping() else { return };
    if let Some(p) = map.get("ros__parameters") {
        if lookup(p, "wheel_separation").is_some() {
            found.push((name.to_string(), p, Layout::Ros2));
            return;
        }
    }
    if map.get("wheel_separation").is_some() {
        let typed = map
            .get("type")
            .and_then(serde_yaml::Value::as_str)
            .is_some_and(|t| t.contains("diff_drive_controller"));
        let layout = if typed {
            Layout::Ros1Typed
        } else {
            Layout::Plain
        };
        found.push((name.to_string(), v, layout));
        return;
    }
    for (k, child) in map {
        let key = k.as_str().map_or_else(|| format!("{k:?}"), str::to_string);
        holding_separation(child, &key, found);
    }
}

/// A dotted parameter, as one key or as nested maps (or a mix).
fn lookup<'a>(v: &'a serde_yaml::Value, dotted: &str) -> Option<&'a serde_yaml::Value> {
    let map = v.as_mapping()?;
    if let Some(x) = map.get(dotted) {
        return Some(x);
    }
    let (head, rest) = dotted.split_once('.')?;
    lookup(map.get(head)?, rest)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dotted_and_nested_parameters_are_read_with_their_multipliers() {
        let nested = "diff_drive_base_controller:\n  ros__parameters:\n    wheel_separation: 0.2\n    wheel_radius: 0.042\n    wheel_separation_multiplier: 1.01\n    left_wheel_radius_multiplier: 1.0\n    right_wheel_radius_multiplier: 0.98\n    linear:\n      x:\n        max_velocity: 0.5\n        max_acceleration: 1.0\n    angular:\n      z:\n        max_velocity: 2.0\n";
        let p = parse(nested).unwrap();
        assert!((p.wheel_separation_m.unwrap() - 0.202).abs() < 1e-12);
        assert!((p.wheel_radius_m.unwrap() - 0.042 * 0.99).abs() < 1e-12);
        assert_eq!(p.unequal_multipliers, Some((1.0, 0.98)));
        assert_eq!(p.max_linear_m_s, Some(0.5));
        assert_eq!(p.max_linear_accel_m_s2, Some(1.0));
        assert_eq!(p.max_angular_rad_s, Some(2.0));
        assert_eq!(p.max_angular_accel_rad_s2, None);
        let dotted = "controller_manager:\n  ros__parameters:\n    update_rate: 50\nbase:\n  ros__parameters:\n    wheel_separation: 0.3\n    linear.x.max_velocity: .nan\n    angular.z.max_acceleration: 3.0\n";
        let p = parse(dotted).unwrap();
        assert_eq!(p.wheel_separation_m, Some(0.3));
        assert_eq!(p.wheel_radius_m, None);
        assert_eq!(p.max_linear_m_s, None, "NaN is no limit");
        assert_eq!(p.max_angular_accel_rad_s2, Some(3.0));
        let e = parse("a: 1").unwrap_err().to_string();
        assert!(e.contains("wheel_separation") && e.contains("ROS 1"), "{e}");
        let e = parse("c:\n  ros__parameters:\n    wheel_separation: -1\n")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("wheel_separation") && e.contains("positive"),
            "{e}"
        );
    }

    /// ROS 1's layout, merge keys, two controllers, and limits switched on at zero or
    /// below, off, or `.nan`.
    #[test]
    fn ros1_layouts_merge_keys_two_controllers_and_limits() {
        let ros1 = "mobile_base_controller:\n  type: diff_drive_controller/DiffDriveController\n  wheel_separation: 0.42\n  wheel_radius: 0.05\n  linear:\n    x:\n      has_velocity_limits: true\n      max_velocity: 1.2\n      has_acceleration_limits: false\n      max_acceleration: 0.0\n";
        let p = parse(ros1).unwrap();
        assert_eq!(p.wheel_separation_m, Some(0.42));
        assert_eq!(p.max_linear_m_s, Some(1.2));
        assert_eq!(p.max_linear_accel_m_s2, None, "switched off");
        let merged = "defaults: &defaults\n  wheel_radius: 0.05\n  wheel_separation: 0.3\nbase:\n  ros__parameters:\n    <<: *defaults\n    wheel_separation: 0.42\n";
        // The defaults' map is no controller; the merged keys are the controller's, its
        // own wheel_separation over the default's.
        let p = parse(merged).unwrap();
        assert_eq!(
            (p.wheel_radius_m, p.wheel_separation_m),
            (Some(0.05), Some(0.42))
        );
        let two = "left_base:\n  ros__parameters:\n    wheel_separation: 0.3\nright_base:\n  ros__parameters:\n    wheel_separation: 16\n";
        let e = parse(two).unwrap_err().to_string();
        assert!(
            e.contains("2 controllers") && e.contains("`left_base`, `right_base`"),
            "{e}"
        );
        for bad in ["-1", "0"] {
            let text = format!("c:\n  ros__parameters:\n    wheel_separation: 0.3\n    linear.x.max_velocity: {bad}\n");
            let e = parse(&text).unwrap_err().to_string();
            assert!(
                e.contains("linear.x.max_velocity") && e.contains(".nan for no limit"),
                "{e}"
            );
        }
    }
}
