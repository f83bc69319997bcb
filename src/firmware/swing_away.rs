//! The "swing away" reversing strategy the thesis describes (Ch. 1.6, Fig. 1.1) but did not
//! build: reversing on the front coil pair alone, the AGV steers its drive axle (now the
//! leading end) onto the wire, which means first turning the sensor end *away* from the
//! wire. The one pair cannot see the heading, so the strategy keeps its own estimate of
//! where the wire is by dead reckoning, and that estimate assumes the wire is the straight
//! line it started on. On a curve the assumption is wrong and nothing tells the vehicle so
//! ("the minimal sensing AGV has no knowledge of the curve even after the centre of the
//! AGV is well off the guide wire").
//!
//! The thesis notes that dead reckoning needs "additional sensors to measure the distance
//! travelled by the wheels": this strategy is given the drive wheels' rim speeds (wheel
//! encoders, a retrofit; encoders on the motors would count the gear play as motion), so
//! that its failure on a curve is the straight-line assumption's rather than odometry
//! drift's. Tyre slip still misleads it, as it would the real retrofit.

use crate::model::chassis::{wrap_angle, Pose};
use crate::model::Bounded;
use crate::sensing::coil::CoilParams;

/// Where the strategy believes it is, relative to the straight line it assumes the wire is.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LineEstimate {
    /// Drive-axle midpoint's offset from the line, m (left positive).
    pub axle_offset_m: f64,
    /// Body heading relative to the line, rad (counter-clockwise positive).
    pub heading_rad: f64,
}

impl LineEstimate {
    /// The line this estimate places the wire on, as the segment of `half_length_m` either
    /// side of the point nearest the axle, world frame, m, for a vehicle at `pose`: the
    /// line runs at the estimated heading behind the body's, with the axle the estimated
    /// offset to its left.
    pub fn assumed_wire_m(&self, pose: Pose, half_length_m: f64) -> [[f64; 2]; 2] {
        let (sin, cos) = (pose.heading_rad - self.heading_rad).sin_cos();
        let foot = [
            pose.x_m + self.axle_offset_m * sin,
            pose.y_m - self.axle_offset_m * cos,
        ];
        [
            [foot[0] - half_length_m * cos, foot[1] - half_length_m * sin],
            [foot[0] + half_length_m * cos, foot[1] + half_length_m * sin],
        ]
    }
}

/// The strategy's state: no estimate until it has seen the wire and reversed straight.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SwingAwayState {
    /// Where the strategy believes the wire is, once it has an estimate.
    pub estimate: Option<LineEstimate>,
    /// When the strategy first saw the wire and began reversing straight, s.
    pub straight_since_s: Option<f64>,
    /// Time of the last interrupt, s.
    pub last_t_s: Option<f64>,
}

/// What the strategy reads at an interrupt.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SwingAwayInput {
    /// Readings of the steering pair (S0 left, S1 right), counts.
    pub readings_adc: [f64; 2],
    /// The pair sees the wire (not below the lost threshold).
    pub wire_seen: bool,
    /// Drive wheels' rim speeds (left, right), m/s (odometry).
    pub wheel_speed_m_s: [f64; 2],
    /// Time of this interrupt, s.
    pub t_s: f64,
}

crate::declare_params! {
    /// The swing-away reversing strategy's gains (scene section `[controller.swing_away]`).
    /// The defaults are ours (*assumed*): a heading loop several times faster than the
    /// axle loop.
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct SwingAwayDesign in "controller.swing_away" {
        /// Rate at which the axle closes on the assumed line.
        axle_gain_per_s: f64 = 0.5, "1/s", Positive;
        /// Yaw-rate demand per rad of heading error.
        heading_gain_per_s: f64 = 2.5, "1/s", Positive;
        /// Largest heading demand relative to the line.
        max_heading_rad: f64 = 0.35, "rad", open(0.0, std::f64::consts::FRAC_PI_2);
        /// Share of the disagreement between sensed and estimated pair offset the
        /// estimate takes at each interrupt.
        correction: f64 = 0.2, "", closed(0.0, 1.0);
        /// Reverse straight this long after first seeing the wire (the wheels spin up and
        /// would mislead the odometry) before taking the line estimate and steering.
        straight_start_s: f64 = 1.0, "s", NonNegative;
    }
}

/// The strategy's design: what it knows of the vehicle, and its gains.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SwingAwayParams {
    /// The pair's sensing law (to turn a difference back into an offset).
    pub coil: CoilParams,
    /// Half the spacing of the two coils, m.
    pub half_spacing_m: f64,
    /// How far the steering pair is ahead of the drive axle, m (body x).
    pub sensor_ahead_m: f64,
    /// Drive-wheel track, m.
    pub track_width_m: f64,
    /// Steady yaw rate of one count of turn demand, rad/s (from the DCMC and drivetrain).
    pub yaw_rate_per_turn_count: f64,
    /// The strategy's gains.
    pub design: SwingAwayDesign,
}

/// The heading demand divides by the reversing speed; below this it uses this, m/s.
const MIN_REVERSING_M_S: f64 = 0.1;

impl SwingAwayParams {
    /// Readings (S0 left, S1 right) of the pair `offset_m` left of a straight wire, square
    /// to it, counts.
    pub fn pair_readings(&self, offset_m: f64) -> [f64; 2] {
        let a = self.half_spacing_m;
        [
            self.coil.straight_wire_reading(offset_m + a),
            self.coil.straight_wire_reading(offset_m - a),
        ]
    }

    /// The pair's offset that best explains both readings, m (left positive). The
    /// difference alone is ambiguous (it falls again beyond the coils, as the thesis's
    /// calibration table shows); the sum tells the branches apart. Least squares over
    /// offsets within twenty coil heights, on a 1 mm grid refined by golden section.
    pub fn sensed_offset_m(&self, readings_adc: [f64; 2]) -> f64 {
        let misfit = |y: f64| {
            let [l, r] = self.pair_readings(y);
            (l - readings_adc[0]).powi(2) + (r - readings_adc[1]).powi(2)
        };
        let range = 20.0 * self.coil.height_m;
        let n = (2.0 * range / 1e-3).ceil() as usize;
        let grid = |i: usize| -range + 2.0 * range * i as f64 / n as f64;
        let best = (0..=n)
            .min_by(|&i, &j| misfit(grid(i)).total_cmp(&misfit(grid(j))))
            .unwrap_or(n / 2);
        let (mut lo, mut hi) = (grid(best.saturating_sub(1)), grid((best + 1).min(n)));
        let g = 0.5 * (5f64.sqrt() - 1.0);
        for _ in 0..40 {
            let m1 = hi - g * (hi - lo);
            let m2 = lo + g * (hi - lo);
            if misfit(m1) < misfit(m2) {
                hi = m2;
            } else {
                lo = m1;
            }
        }
        0.5 * (lo + hi)
    }

    /// One interrupt: updates the estimate (dead reckoning from the wheels, then the
    /// pair's sensed offset where it sees the wire) and returns the turn demand, counts
    /// (positive turns left).
    pub fn step(&self, s: &mut SwingAwayState, u: &SwingAwayInput) -> f64 {
        let [left, right] = u.wheel_speed_m_s;
        let speed_m_s = 0.5 * (left + right);
        let yaw_rate_rad_s = (right - left) / self.track_width_m;
        let l = self.sensor_ahead_m;
        let dt_s = u.t_s - s.last_t_s.unwrap_or(u.t_s);
        s.last_t_s = Some(u.t_s);
        let e = match s.estimate.as_mut() {
            None => {
                if !u.wire_seen {
                    s.last_t_s = None;
                    return 0.0;
                }
                let since = *s.straight_since_s.get_or_insert(u.t_s);
                if u.t_s - since < self.design.straight_start_s {
                    return 0.0;
                }
                // The strategy starts from where it assumes it is: parallel to the wire,
                // having reversed straight.
                s.estimate.insert(LineEstimate {
                    axle_offset_m: self.sensed_offset_m(u.readings_adc),
                    heading_rad: 0.0,
                })
            }
            Some(e) => {
                e.heading_rad = wrap_angle(e.heading_rad + yaw_rate_rad_s * dt_s);
                e.axle_offset_m += speed_m_s * e.heading_rad.sin() * dt_s;
                if u.wire_seen {
                    let predicted = e.axle_offset_m + l * e.heading_rad.sin();
                    let sensed = self.sensed_offset_m(u.readings_adc);
                    e.axle_offset_m += self.design.correction * (sensed - predicted);
                }
                e
            }
        };
        let reversing_m_s = (-speed_m_s).max(MIN_REVERSING_M_S);
        let heading_demand = self.heading_to_close(e.axle_offset_m, reversing_m_s);
        let yaw_rate_demand =
            self.design.heading_gain_per_s * wrap_angle(heading_demand - e.heading_rad);
        yaw_rate_demand / self.yaw_rate_per_turn_count
    }

    /// The heading, relative to the line, at which a reversing axle `axle_offset_m` off it
    /// closes on it at `axle_gain_per_s`: the axle moves by `-speed sin(heading)`, so the
    /// nose swings away from the side the axle is on. Rad.
    pub fn heading_to_close(&self, axle_offset_m: f64, reversing_m_s: f64) -> f64 {
        let limit = self.design.max_heading_rad.sin();
        (self.design.axle_gain_per_s * axle_offset_m / reversing_m_s)
            .bounded(-limit, limit)
            .asin()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> SwingAwayParams {
        SwingAwayParams {
            coil: CoilParams {
                height_m: 0.038,
                full_scale_adc: 250.0,
                law: crate::sensing::coil::CoilLaw::Physical,
            },
            half_spacing_m: 0.038,
            sensor_ahead_m: 0.45,
            track_width_m: 0.5,
            yaw_rate_per_turn_count: 0.04,
            design: SwingAwayDesign {
                straight_start_s: 0.0,
                ..SwingAwayDesign::default()
            },
        }
    }

    #[test]
    fn the_sensed_offset_inverts_the_sensing_law_on_either_side_of_the_peak() {
        let p = params();
        // Beyond about one coil spacing the difference falls again: 20 and 60 mm give
        // nearly the same difference, yet both readings together tell them apart.
        let diff = |y: f64| {
            let [l, r] = p.pair_readings(y);
            l - r
        };
        assert!(diff(0.06).abs() < diff(0.04).abs());
        for y in [-0.2, -0.12, -0.06, -0.02, 0.0, 0.01, 0.03, 0.06, 0.12, 0.2] {
            let back = p.sensed_offset_m(p.pair_readings(y));
            assert!((back - y).abs() < 1e-5, "offset {y}: sensed {back}");
        }
        // ADC rounding moves it by well under a millimetre near the wire.
        let rounded = p.pair_readings(0.05).map(f64::round);
        assert!((p.sensed_offset_m(rounded) - 0.05).abs() < 1e-3);
    }

    #[test]
    fn reversing_with_the_axle_left_of_the_line_swings_the_nose_further_left() {
        let p = params();
        let mut s = SwingAwayState::default();
        // Parallel, pair (and axle) 50 mm left of the wire, reversing at 1 m/s.
        let u = SwingAwayInput {
            readings_adc: p.pair_readings(0.05),
            wire_seen: true,
            wheel_speed_m_s: [-1.0, -1.0],
            t_s: 0.0,
        };
        let turn = p.step(&mut s, &u);
        let e = s.estimate.unwrap();
        assert!((e.axle_offset_m - 0.05).abs() < 1e-6);
        // Turning left (counter-clockwise) moves the front, the sensor end, away from it.
        assert!(turn > 0.0, "{turn}");
        // Mirror image: right of the wire, turn right.
        let mut s = SwingAwayState::default();
        let u = SwingAwayInput {
            readings_adc: p.pair_readings(-0.05),
            ..u
        };
        assert!(p.step(&mut s, &u) < 0.0);
    }

    #[test]
    fn the_assumed_wire_lies_the_estimated_offset_from_the_axle_at_the_estimated_heading() {
        let e = LineEstimate {
            axle_offset_m: 0.2,
            heading_rad: 0.3,
        };
        let pose = Pose {
            x_m: 1.0,
            y_m: 2.0,
            heading_rad: 0.5,
        };
        let [a, z] = e.assumed_wire_m(pose, 3.0);
        let (dx, dy) = (z[0] - a[0], z[1] - a[1]);
        assert!((dx.hypot(dy) - 6.0).abs() < 1e-12);
        assert!(
            (dy.atan2(dx) - 0.2).abs() < 1e-12,
            "line at heading minus estimate"
        );
        // Signed distance of the axle to the left of the line (cross product).
        let left = (dx * (pose.y_m - a[1]) - dy * (pose.x_m - a[0])) / 6.0;
        assert!((left - 0.2).abs() < 1e-12, "{left}");
    }

    #[test]
    fn dead_reckoning_follows_the_wheels_while_the_wire_is_unseen() {
        let p = params();
        let mut s = SwingAwayState {
            estimate: Some(LineEstimate::default()),
            last_t_s: Some(0.0),
            ..SwingAwayState::default()
        };
        // Reversing at 1 m/s with the right wheel 0.1 m/s faster: yaw rate 0.2 rad/s.
        for k in 1..=100 {
            let u = SwingAwayInput {
                readings_adc: [0.0, 0.0],
                wire_seen: false,
                wheel_speed_m_s: [-1.05, -0.95],
                t_s: 0.01 * k as f64,
            };
            p.step(&mut s, &u);
        }
        let e = s.estimate.unwrap();
        assert!((e.heading_rad - 0.2).abs() < 1e-9, "{}", e.heading_rad);
        // Reversing with the nose turned left carries the axle right: -v t sin(avg heading).
        let expected = -(0.1f64).sin() * 1.0;
        assert!(
            (e.axle_offset_m - expected).abs() < 0.01,
            "{}",
            e.axle_offset_m
        );
    }
}
