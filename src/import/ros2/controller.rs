//! A `diff_drive_controller` parameter file (the YAML ros2_control loads): the wheel
//! geometry the robot's odometry and base controller are configured with, and the
//! velocity and acceleration limits of its speed limiters.
//!
//! The parameters sit under `CONTROLLER_NAME: ros__parameters:`, as dotted keys
//! (`linear.x.max_velocity: 1.0`) or nested maps (`linear: {x: {max_velocity: 1.0}}`);
//! both are read. The controller is the one whose parameters name `wheel_separation`.

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
    #[error("no controller's ros__parameters with wheel_separation (a diff_drive_controller's)")]
    NoController,
    /// A parameter that is no finite number (its key and value as read).
    #[error("`{0}`: expected a number, found {1}")]
    NotNumber(String, String),
    /// A size that is not positive.
    #[error("`{0}` = {1}: expected a positive number")]
    NotPositive(String, f64),
    /// A limit that is neither a number nor `.nan`.
    #[error("`{0}`: expected a number or .nan, found {1}")]
    NotLimit(String, String),
}

/// Parses a parameter file's text.
pub fn parse(text: &str) -> Result<DiffDriveParams, ParamsFault> {
    let doc: serde_yaml::Value = serde_yaml::from_str(text)?;
    let params = find_params(&doc).ok_or(ParamsFault::NoController)?;
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
    // A limit ROS leaves at 0 or NaN is none (the scene's 0).
    let limit = |dotted: &str| -> Result<Option<f64>, ParamsFault> {
        match lookup(params, dotted).map(|v| (v, v.as_f64())) {
            None => Ok(None),
            Some((_, Some(x))) if x.is_nan() || x <= 0.0 => Ok(None),
            Some((_, Some(x))) if x.is_finite() => Ok(Some(x)),
            Some((v, _)) => Err(ParamsFault::NotLimit(dotted.into(), format!("{v:?}"))),
        }
    };
    Ok(DiffDriveParams {
        wheel_separation_m: separation.map(|s| s * sep_mult),
        wheel_radius_m: radius.map(|r| r * 0.5 * (left + right)),
        unequal_multipliers: (left != right).then_some((left, right)),
        max_linear_m_s: limit("linear.x.max_velocity")?,
        max_linear_accel_m_s2: limit("linear.x.max_acceleration")?,
        max_angular_rad_s: limit("angular.z.max_velocity")?,
        max_angular_accel_rad_s2: limit("angular.z.max_acceleration")?,
    })
}

/// The `ros__parameters` map that has `wheel_separation`, anywhere in the document.
fn find_params(v: &serde_yaml::Value) -> Option<&serde_yaml::Value> {
    let map = v.as_mapping()?;
    if let Some(p) = map.get("ros__parameters") {
        if lookup(p, "wheel_separation").is_some() {
            return Some(p);
        }
    }
    map.values().find_map(find_params)
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
        assert!(e.contains("wheel_separation"), "{e}");
        let e = parse("c:\n  ros__parameters:\n    wheel_separation: -1\n")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("wheel_separation") && e.contains("positive"),
            "{e}"
        );
    }
}
