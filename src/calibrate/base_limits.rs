//! The base controller's own limits, read off a velocity-commanded recording before any
//! physics is asked to explain the gap between what was commanded and what the wheels did.
//!
//! A ROS base controller (`diff_drive_controller`) passes a command through its speed
//! limiter (each component within `+-max`, changing at most `max_accel dt` a step) before
//! its kinematics make the wheels' set-points. The wheels' encoders, read with the radius
//! and separation the controller is configured with, give back what it passed:
//! `v = (l + r) / 2`, `w = (r - l) / b` (after the drivers' loops' short lag). A robot
//! logged without its encoders shows the same in its tracked pose: the forward speed and
//! the yaw rate differenced over [`POSE_SPAN_S`] ([`pose_motion`]). So:
//!
//! - **a speed limit** shows as commands the wheels never reach: the command beyond
//!   [`BEYOND_REACH`] times the largest speed measured for at least [`MIN_BEYOND_ROWS`]
//!   rows; its start is that largest speed (the 99.5th percentile, past the encoders'
//!   counting noise);
//! - **an acceleration limit** shows as commanded steps the wheels climb at one rate: a
//!   step the measured speed takes more than [`MIN_RAMP_ROWS`] rows to cross at its
//!   steepest (the 95th percentile of its slope over [`SLOPE_SPAN_S`]), where the drivers'
//!   loops alone follow in one or two; its start is that slope.
//!
//! These are starts: the limits are then fitted through the model (with the drivers'
//! loops and the chassis), and kept only where the evidence rule supports them.

use crate::model::base_controller::BaseParams;
use crate::param::ParamKey;
use crate::record::channels as chan;
use crate::record::Recording;
use crate::scene::Scene;

/// How far beyond the largest measured speed a command must go to show a limit.
pub const BEYOND_REACH: f64 = 1.5;

/// Rows a command must stay beyond reach for a speed limit to show.
pub const MIN_BEYOND_ROWS: usize = 3;

/// Rows the measured speed must take to cross a commanded step at its steepest for an
/// acceleration limit to show (the loops alone follow a step within a row or two).
pub const MIN_RAMP_ROWS: f64 = 4.0;

/// Span over which a measured speed's slope is taken, s.
pub const SLOPE_SPAN_S: f64 = 0.2;

/// Span over which a tracked pose is differenced into the base's speeds where the
/// recording has no wheel speeds, s: long enough that a motion tracker's millimetres of
/// noise stay a few per cent of a slow base's speed, short beside the limiter's ramps
/// (on OptiOdom's square runs, the pose's speeds over 0.1 s find the limits the wheels'
/// encoders find, within 12 %).
pub const POSE_SPAN_S: f64 = 0.1;

/// The limits a recording shows, each with where its fit starts (key's unit).
#[derive(Debug, Clone, PartialEq)]
pub struct Shown {
    /// Each limit key and its start.
    pub starts: Vec<(ParamKey, f64)>,
    /// What the base's motion was read from.
    pub seen_by: SeenBy,
}

/// What a recording's base motion is read from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SeenBy {
    /// The wheels' encoders (their speeds).
    Wheels,
    /// The tracked pose (a recording without the wheels' speeds).
    Pose,
}

impl SeenBy {
    /// What moved, as a report says it ("the wheels never follow").
    pub fn noun(self) -> &'static str {
        match self {
            SeenBy::Wheels => "the wheels",
            SeenBy::Pose => "the tracked pose's speeds",
        }
    }
}

/// The forward speed (m/s) and yaw rate (rad/s) the wheels' encoders give at each row,
/// read as the base controller's configuration reads them; `None` without both wheels'
/// speeds. Rows where either is not measured are `None`.
fn measured_motion(rec: &Recording, scene: &Scene) -> Option<[Vec<Option<f64>>; 2]> {
    let l = rec.column(chan::LEFT_WHEEL_SPEED_M_S)?;
    let r = rec.column(chan::RIGHT_WHEEL_SPEED_M_S)?;
    let b = scene
        .base
        .wheel_separation_m
        .unwrap_or(scene.chassis.track_width_m);
    let v = l
        .iter()
        .zip(r)
        .map(|(l, r)| Some(0.5 * (l.as_ref()? + r.as_ref()?)))
        .collect();
    let w = l
        .iter()
        .zip(r)
        .map(|(l, r)| Some((r.as_ref()? - l.as_ref()?) / b))
        .collect();
    Some([v, w])
}

/// The forward speed (m/s, along the heading) and yaw rate (rad/s) of the tracked pose at
/// each row, each a central difference over [`POSE_SPAN_S`] (a row either side at least);
/// `None` without the pose's three columns, and at rows where the pose is not measured or
/// the span reaches past the recording.
fn pose_motion(rec: &Recording) -> Option<[Vec<Option<f64>>; 2]> {
    let (x, y, heading) = (
        rec.column(chan::X_M)?,
        rec.column(chan::Y_M)?,
        rec.column(chan::HEADING_RAD)?,
    );
    let dt = crate::record::median_interval_s(&rec.t_s)?;
    let half = ((0.5 * POSE_SPAN_S / dt).round() as usize).max(1);
    let n = rec.t_s.len();
    let at = |k: usize| -> Option<[f64; 2]> {
        let (a, b) = (k.checked_sub(half)?, k + half);
        if b >= n {
            return None;
        }
        let d = rec.t_s[b] - rec.t_s[a];
        let (ha, hb) = (heading[a]?, heading[b]?);
        let (s, c) = (0.5 * (ha + hb)).sin_cos();
        let along = (x[b]? - x[a]?) * c + (y[b]? - y[a]?) * s;
        (d > 0.0).then(|| [along / d, (hb - ha) / d])
    };
    let motion: Vec<Option<[f64; 2]>> = (0..n).map(at).collect();
    Some([0, 1].map(|i| motion.iter().map(|m| m.map(|m| m[i])).collect()))
}

/// The `q`-quantile of the absolute values (0 for none).
fn abs_quantile(values: impl Iterator<Item = f64>, q: f64) -> f64 {
    let mut v: Vec<f64> = values.map(f64::abs).filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    let i = ((q * (v.len() - 1) as f64).round() as usize).min(v.len() - 1);
    v[i]
}

/// A speed limit one component shows: its start, or `None`.
fn speed_limit(command: &[Option<f64>], measured: &[Option<f64>]) -> Option<f64> {
    let reach = abs_quantile(measured.iter().flatten().copied(), 0.995);
    if !(reach > 0.0) {
        return None;
    }
    let beyond = command
        .iter()
        .flatten()
        .filter(|u| u.abs() > BEYOND_REACH * reach)
        .count();
    (beyond >= MIN_BEYOND_ROWS).then_some(reach)
}

/// An acceleration limit one component shows: its start, or `None`.
fn accel_limit(t_s: &[f64], command: &[Option<f64>], measured: &[Option<f64>]) -> Option<f64> {
    let dt = crate::record::median_interval_s(t_s)?;
    // The measured speed's slope over [`SLOPE_SPAN_S`] (and two rows at least): the
    // encoders' counting noise over one row would swamp a gentle ramp.
    let span = ((SLOPE_SPAN_S / dt).round() as usize).max(2);
    let slopes = (span..measured.len()).filter_map(|k| {
        let (a, b) = (measured[k - span]?, measured[k]?);
        Some((b - a) / (t_s[k] - t_s[k - span]))
    });
    let slope = abs_quantile(slopes, 0.95);
    // The commanded steps (their 99th percentile: the rare largest step of a recording
    // is no pattern; a motor's torque limit also makes one look like a ramp).
    let step = abs_quantile(
        (1..command.len()).filter_map(|k| Some(command[k]? - command[k - 1]?)),
        0.99,
    );
    // A step followed at once shows a slope of the step over the span: the climb must take
    // longer than that by the rows the loops take.
    let span_s = span as f64 * dt;
    (slope > 0.0 && step / slope > span_s + MIN_RAMP_ROWS * dt).then_some(slope)
}

/// The limits `rec` shows of the base controller of `scene` (see the module's doc).
pub fn shown(rec: &Recording, scene: &Scene) -> Shown {
    let mut starts = vec![];
    let none = Shown {
        starts: vec![],
        seen_by: SeenBy::Wheels,
    };
    let (Some(cv), Some(cw)) = (
        rec.column(chan::CMD_LINEAR_M_S),
        rec.column(chan::CMD_ANGULAR_RAD_S),
    ) else {
        return none;
    };
    let seen = measured_motion(rec, scene)
        .map(|m| (SeenBy::Wheels, m))
        .or_else(|| pose_motion(rec).map(|m| (SeenBy::Pose, m)));
    let Some((seen_by, [v, w])) = seen else {
        return none;
    };
    let components = [
        (
            cv,
            &v,
            BaseParams::max_linear_m_s,
            BaseParams::max_linear_accel_m_s2,
        ),
        (
            cw,
            &w,
            BaseParams::max_angular_rad_s,
            BaseParams::max_angular_accel_rad_s2,
        ),
    ];
    for (command, measured, max, max_accel) in components {
        if let Some(s) = speed_limit(command, measured) {
            starts.push((max, s));
        }
        if let Some(a) = accel_limit(&rec.t_s, command, measured) {
            starts.push((max_accel, a));
        }
    }
    Shown { starts, seen_by }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_command_never_reached_is_a_limit_and_one_reached_is_none() {
        // Commanded 1 then 3 for ten rows each; the wheels follow to 1, then stay at 1.2.
        let command: Vec<Option<f64>> = (0..20)
            .map(|k| Some(if k < 10 { 1.0 } else { 3.0 }))
            .collect();
        let measured: Vec<Option<f64>> = (0..20)
            .map(|k| Some(if k < 10 { 1.0 } else { 1.2 }))
            .collect();
        let s = speed_limit(&command, &measured).unwrap();
        assert!((s - 1.2).abs() < 1e-12, "{s}");
        let reached: Vec<Option<f64>> = command.clone();
        assert_eq!(speed_limit(&command, &reached), None);
    }

    #[test]
    fn a_tracked_pose_gives_the_speeds_of_a_base_without_encoders() {
        // A base on a circle at 0.3 m/s and 0.5 rad/s, tracked at 20 Hz: the pose's
        // central differences over 0.1 s give both within the chord's shortening of the
        // arc, 1 - sinc(0.025) = 1e-4.
        let mut text = String::from(
            "# agvsim-recording: 1\n# rig: vehicle\nt_s,cmd_linear_m_s,cmd_angular_rad_s,x_m,y_m,heading_rad\n",
        );
        for k in 0..40 {
            let t = k as f64 * 0.05;
            let th = 0.5 * t + 0.3;
            let radius = 0.3 / 0.5;
            let (x, y) = (radius * th.sin(), -radius * th.cos());
            text.push_str(&format!("{t},0.3,0.5,{x},{y},{th}\n"));
        }
        let rec = Recording::parse(&text, std::path::Path::new("circle.csv")).unwrap();
        let [v, w] = pose_motion(&rec).unwrap();
        assert_eq!(
            (v[0], v[39]),
            (None, None),
            "the span reaches past the ends"
        );
        for k in 1..39 {
            let (v, w) = (v[k].unwrap(), w[k].unwrap());
            assert!((v - 0.3).abs() < 0.3 * 2e-4, "row {k}: {v}");
            assert!((w - 0.5).abs() < 1e-12, "row {k}: {w}");
        }
    }

    #[test]
    fn a_step_climbed_at_one_rate_is_an_acceleration_limit() {
        // Steps between 0 and 1 m/s every 50 rows of 10 ms, followed through a limiter of
        // 0.5 m/s^2 (each step would take 200 rows to cross).
        let t: Vec<f64> = (0..400).map(|k| k as f64 * 0.01).collect();
        let command: Vec<Option<f64>> = (0..400)
            .map(|k| Some(if (k / 50) % 2 == 1 { 1.0 } else { 0.0 }))
            .collect();
        let mut ramp: Vec<Option<f64>> = vec![Some(0.0)];
        for k in 1..400 {
            let (was, asked) = (ramp[k - 1].unwrap(), command[k].unwrap());
            ramp.push(Some(was + (asked - was).clamp(-0.005, 0.005)));
        }
        let a = accel_limit(&t, &command, &ramp).unwrap();
        assert!((a - 0.5).abs() < 1e-9, "{a}");
        // Followed within a row: no limit.
        let followed: Vec<Option<f64>> = command.clone();
        assert_eq!(accel_limit(&t, &command, &followed), None);
    }
}
