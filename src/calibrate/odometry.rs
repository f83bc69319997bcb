//! The wheels' odometry as a fitting model of the wheel geometry: the pose a
//! differential-drive robot's measured wheel rotations give through the rolling law
//! ([`crate::model::chassis::rolling_motion`], the simulator's own no-slip kinematics) with
//! effective rolling radii and a track, against a pose measured apart from the wheels (a
//! motion-capture or map pose). This is what odometry calibration (Borenstein's UMBmark,
//! OptiOdom) fits; it needs no dynamics, so a robot's motors, speed loops and their
//! tracking errors, which a simulation driven by the commands would have to get right
//! first, do not enter it. A calibration searches the geometry on it in milliseconds and
//! confirms the result through the simulator.
//!
//! The wheels' rotations come from the recording's wheel angles (`left_wheel_angle_rad`,
//! `right_wheel_angle_rad`: encoder positions) where it has them, else from the wheel
//! speeds (`left_wheel_speed_m_s`, ..., encoder rates read with the configured radius,
//! each the mean over the interval ending at its row).

use crate::ident::data::Dataset;
use crate::ident::model::{Diverged, ParamSpec, Predictor};
use crate::model::chassis::rolling_motion;
use crate::model::chassis::ChassisParams;
use crate::model::wheel::WheelParams;
use crate::record::channels as chan;
use crate::record::Recording;

/// The keys the model fits, in its parameter order.
pub const KEYS: [&str; 3] = [
    WheelParams::left_rolling_radius_m.key(),
    WheelParams::right_rolling_radius_m.key(),
    ChassisParams::track_width_m.key(),
];

/// The wheels' turns over each interval (left, right), rad, from the recording.
#[derive(Debug, Clone)]
pub struct WheelTurns {
    /// Turn of each wheel between row `k - 1` and row `k` (row 0: zero), rad.
    pub turns_rad: Vec<[f64; 2]>,
    /// What they were read from, in words.
    pub source: String,
}

impl WheelTurns {
    /// The turns from `rec`'s wheel angles, else its wheel speeds read with
    /// `configured_radius_m`; `None` where it has neither pair, or a cell is missing.
    pub fn of(rec: &Recording, configured_radius_m: f64) -> Option<WheelTurns> {
        let pair = |a: &str, b: &str| -> Option<[Vec<f64>; 2]> {
            let col = |n: &str| -> Option<Vec<f64>> {
                rec.column(n)?.iter().copied().collect::<Option<Vec<f64>>>()
            };
            Some([col(a)?, col(b)?])
        };
        let n = rec.t_s.len();
        if let Some([l, r]) = pair(chan::LEFT_WHEEL_ANGLE_RAD, chan::RIGHT_WHEEL_ANGLE_RAD) {
            let turns_rad = (0..n)
                .map(|k| match k {
                    0 => [0.0; 2],
                    k => [l[k] - l[k - 1], r[k] - r[k - 1]],
                })
                .collect();
            return Some(WheelTurns {
                turns_rad,
                source: "the wheels' encoder angles".into(),
            });
        }
        let [l, r] = pair(chan::LEFT_WHEEL_SPEED_M_S, chan::RIGHT_WHEEL_SPEED_M_S)?;
        let turns_rad = (0..n)
            .map(|k| match k {
                0 => [0.0; 2],
                k => {
                    let dt = rec.t_s[k] - rec.t_s[k - 1];
                    [
                        l[k] * dt / configured_radius_m,
                        r[k] * dt / configured_radius_m,
                    ]
                }
            })
            .collect();
        Some(WheelTurns {
            turns_rad,
            source: format!(
                "the wheels' encoder speeds read with the configured radius {configured_radius_m} m"
            ),
        })
    }
}

/// The odometry model: pose from the wheels' turns through the geometry.
pub struct Odometry {
    specs: Vec<ParamSpec>,
    turns: WheelTurns,
}

impl Odometry {
    /// The model starting at `start` (left radius, right radius, track, m), each searched
    /// within 20 % of it (a wheel's effective radius and the track are known to a few
    /// percent).
    pub fn new(turns: WheelTurns, start: [f64; 3]) -> Odometry {
        let specs = KEYS
            .iter()
            .zip(start)
            .map(|(k, v)| {
                ParamSpec {
                    rough: false,
                    ..ParamSpec::new(k, v, 0.8 * v, 1.25 * v)
                }
                .with_fd_step(1e-6)
            })
            .collect();
        Odometry { specs, turns }
    }
}

impl Predictor for Odometry {
    fn param_specs(&self) -> &[ParamSpec] {
        &self.specs
    }

    /// `x_m`, `y_m`, `heading_rad` (as the dataset orders them) from its first measured
    /// pose (the comparison is over windows that each restart from the measured pose, so
    /// the start matters not).
    fn predict(&self, p: &[f64], data: &Dataset) -> Result<Vec<Vec<f64>>, Diverged> {
        let (radii, track) = ([p[0], p[1]], p[2]);
        let start = |n: &str| data.first_measured(n).unwrap_or(0.0);
        let (mut x, mut y, mut h) = (start(chan::X_M), start(chan::Y_M), start(chan::HEADING_RAD));
        let mut pose = vec![[0.0; 3]; data.len()];
        for (k, turn) in self.turns.turns_rad.iter().enumerate().take(data.len()) {
            let rims = [radii[0] * turn[0], radii[1] * turn[1]];
            let (forward, turned) = rolling_motion(rims, track);
            let mid = h + 0.5 * turned;
            x += forward * mid.cos();
            y += forward * mid.sin();
            h += turned;
            pose[k] = [x, y, h];
        }
        data.output_names
            .iter()
            .map(|n| {
                let i = match n.as_str() {
                    chan::X_M => 0,
                    chan::Y_M => 1,
                    chan::HEADING_RAD => 2,
                    _ => return Err(Diverged { t_s: data.t_s[0] }),
                };
                Ok(pose.iter().map(|q| q[i]).collect())
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A robot on a circle: its wheels turn as the rolling law says for radii 0.04 and
    /// 0.0396 m and a track of 0.2 m; the model at those values gives the circle's pose,
    /// and at the configured (equal) radii it does not.
    #[test]
    fn the_wheels_turns_give_the_pose_through_the_geometry() {
        let (rl, rr, b) = (0.04, 0.0396, 0.2);
        let dt = 0.05;
        let (v, w) = (0.2, 0.5);
        let n = 200;
        let turn = [(v - 0.5 * w * b) * dt / rl, (v + 0.5 * w * b) * dt / rr];
        let mut turns_rad = vec![turn; n];
        turns_rad[0] = [0.0; 2];
        let t: Vec<f64> = (0..n).map(|k| k as f64 * dt).collect();
        let pose: Vec<[f64; 3]> = t
            .iter()
            .map(|&t| {
                let h = w * t;
                [v / w * h.sin(), v / w * (1.0 - h.cos()), h]
            })
            .collect();
        let data = Dataset {
            name: "circle".into(),
            t_s: t.clone(),
            input_names: vec![],
            inputs: vec![],
            output_names: vec!["x_m".into(), "y_m".into(), "heading_rad".into()],
            outputs: (0..3)
                .map(|i| pose.iter().map(|p| Some(p[i])).collect())
                .collect(),
            segment_starts: vec![0],
        };
        let m = Odometry::new(
            WheelTurns {
                turns_rad,
                source: "test".into(),
            },
            [0.04, 0.04, 0.2],
        );
        let y = m.predict(&[rl, rr, b], &data).unwrap();
        for k in 0..n {
            for i in 0..3 {
                // The chord along the mid-interval heading against the arc: Δh²/24.
                assert!((y[i][k] - pose[k][i]).abs() < 1e-3, "{k} {i}");
            }
        }
        let off = m.predict(&[0.04, 0.04, 0.2], &data).unwrap();
        assert!((off[2][n - 1] - pose[n - 1][2]).abs() > 0.05);
    }
}
