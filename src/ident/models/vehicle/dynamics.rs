//! The vehicle's equations as the fitting code integrates them: its blocks at a parameter
//! vector, its state at rest, the derivatives and the outputs.

use super::{Vehicle, VehicleBlocks, BODY, SIDE, SLIP_SPEED_FLOOR_M_S};
use crate::ident::data::Dataset;
use crate::ident::model::{Dynamics, OutputKind};
use crate::record::channels as chan;

impl Dynamics for Vehicle {
    type Blocks = VehicleBlocks;
    type Output = VehicleOutput;

    #[inline]
    fn blocks(&self, p: &[f64]) -> VehicleBlocks {
        self.blocks_of(&self.declared(p))
    }

    fn n_states(&self) -> usize {
        BODY + 6
    }

    fn initial_state(&self, _b: &VehicleBlocks, data: &Dataset) -> Vec<f64> {
        // At rest; the pose where the tracker first saw the vehicle.
        let mut x = vec![0.0; self.n_states()];
        x[BODY + 3] = data.first_measured(chan::X_M).unwrap_or(0.0);
        x[BODY + 4] = data.first_measured(chan::Y_M).unwrap_or(0.0);
        x[BODY + 5] = data.first_measured(chan::HEADING_RAD).unwrap_or(0.0);
        x
    }

    fn max_step_s(&self, b: &VehicleBlocks) -> f64 {
        self.step_bound(b, SLIP_SPEED_FLOOR_M_S)
    }

    /// With a gear play: the first of the two sides' teeth to meet or part.
    fn event_fraction(
        &self,
        b: &VehicleBlocks,
        before: &[f64],
        after: &[f64],
        h: f64,
    ) -> Option<f64> {
        if !b.play {
            return None;
        }
        (0..2)
            .filter_map(|side| {
                let (twist_before, twist_rate) = Self::twist(b, before, side);
                let twist_after = Self::twist(b, after, side).0;
                b.drivetrain
                    .gearbox
                    .flank_crossing(twist_before, twist_after, twist_rate * h)
            })
            .reduce(f64::min)
    }

    /// The tyre's stiffness falls as the contact speed rises (slip is measured against
    /// it), so a moving vehicle allows longer steps than one at rest. The slowest contact
    /// at the interval's start is taken at half its speed: no record's sample interval is
    /// long enough for a vehicle to lose half its speed within it.
    fn max_step_at(&self, b: &VehicleBlocks, x: &[f64]) -> Option<f64> {
        let (fwd, yaw_rate) = (x[BODY], x[BODY + 2]);
        let sweep = (yaw_rate * 0.5 * b.body.track_width_m).abs();
        let slowest = (fwd.abs() - sweep).abs();
        Some(self.step_bound(
            b,
            (0.25 * slowest * slowest + SLIP_SPEED_FLOOR_M_S * SLIP_SPEED_FLOOR_M_S).sqrt(),
        ))
    }

    fn input_delay_s(&self, b: &VehicleBlocks) -> f64 {
        b.supply.delay_s
    }

    /// The order of one evaluation: terminal voltages (saturation, sag), each side's
    /// armature and the torque driving its rotor, then the motors' friction, the gears and
    /// the wheels with the chassis, rolling without slip (the simulator's no-slip body)
    /// unless the tyres' slip forces join them (a tracked pose, or the wheel-slip block),
    /// then the pose.
    fn derivatives(&self, b: &VehicleBlocks, x: &[f64], u: &[f64], _held: &[f64], dx: &mut [f64]) {
        let motor = &b.drivetrain.motor;
        let v = self.terminal_voltages(b, [u[0], u[1]], [x[0], x[SIDE]]);
        let mut driving = [0.0; 2];
        for (side, driving) in driving.iter_mut().enumerate() {
            let s = side * SIDE;
            let (i, wm) = (x[s], x[s + 1]);
            dx[s] = motor.current_rate_a_s(v[side], i, wm);
            *driving = motor.driving_torque_nm(motor.electromagnetic_torque_nm(i), 0.0);
            dx[s + 2] = wm;
        }
        if b.peak_mu.is_some() || self.creeping_tyres {
            self.slipping(b, x, driving, dx);
        } else {
            self.rolling(b, x, driving, dx);
        }
        let (fwd, lat, heading) = (x[BODY], x[BODY + 1], x[BODY + 5]);
        let (sin, cos) = heading.sin_cos();
        dx[BODY + 3] = fwd * cos - lat * sin;
        dx[BODY + 4] = fwd * sin + lat * cos;
        dx[BODY + 5] = x[BODY + 2];
    }

    /// The vehicle starts where the tracker first saw it, but that reading is as noisy as
    /// any other: a start heading 5 mrad off swings the whole path by 5 mrad, 10 mm at 2 m.
    /// The start pose is therefore fitted, in closed form, to each simulation: the small
    /// rigid motion (rotation about the start point, then shift) that best aligns the
    /// simulated pose with the tracked one, positions and heading weighted by the tracker's
    /// noise. This is the least-squares optimum over three nuisance parameters, at no cost
    /// in simulations.
    fn align_outputs(&self, data: &Dataset, y: &mut [Vec<f64>]) {
        let (Some(jx), Some(jy)) = (data.output_index(chan::X_M), data.output_index(chan::Y_M))
        else {
            return;
        };
        let jh = data.output_index(chan::HEADING_RAD);
        let (wp, wh) = (
            1.0 / (self.tracker_position_noise_m * self.tracker_position_noise_m),
            1.0 / (self.tracker_heading_noise_rad * self.tracker_heading_noise_rad),
        );
        let (xs, ys) = (y[jx][0], y[jy][0]);
        // Linearised in the rotation a: x' = x - a (y - ys) + dx, y' = y + a (x - xs) + dy,
        // heading' = heading + a. Normal equations for (a, dx, dy).
        let mut n = nalgebra::Matrix3::<f64>::zeros();
        let mut b = nalgebra::Vector3::<f64>::zeros();
        for k in 0..data.len() {
            if let (Some(mx), Some(my)) = (data.outputs[jx][k], data.outputs[jy][k]) {
                let (rx, ry) = (-(y[jy][k] - ys), y[jx][k] - xs);
                for (row, resid) in [
                    (nalgebra::Vector3::new(rx, 1.0, 0.0), mx - y[jx][k]),
                    (nalgebra::Vector3::new(ry, 0.0, 1.0), my - y[jy][k]),
                ] {
                    n += wp * row * row.transpose();
                    b += wp * row * resid;
                }
            }
            if let Some(jh) = jh {
                if let Some(mh) = data.outputs[jh][k] {
                    let row = nalgebra::Vector3::new(1.0, 0.0, 0.0);
                    n += wh * row * row.transpose();
                    b += wh * row * (mh - y[jh][k]);
                }
            }
        }
        let Some(sol) = n.lu().solve(&b) else {
            return;
        };
        let (a, dx, dy) = (sol[0], sol[1], sol[2]);
        if !(a.is_finite() && dx.is_finite() && dy.is_finite()) {
            return;
        }
        let (sin, cos) = a.sin_cos();
        for k in 0..data.len() {
            let (px, py) = (y[jx][k] - xs, y[jy][k] - ys);
            y[jx][k] = xs + cos * px - sin * py + dx;
            y[jy][k] = ys + sin * px + cos * py + dy;
            if let Some(jh) = jh {
                y[jh][k] += a;
            }
        }
    }

    fn output_of(&self, name: &str) -> VehicleOutput {
        use VehicleOutput as O;
        match name {
            chan::X_M => O::X,
            chan::Y_M => O::Y,
            chan::HEADING_RAD => O::Heading,
            chan::LEFT_MOTOR_SPEED_RAD_S => O::LeftMotorSpeed,
            chan::RIGHT_MOTOR_SPEED_RAD_S => O::RightMotorSpeed,
            chan::LEFT_WHEEL_SPEED_M_S => O::LeftWheelSpeed,
            chan::RIGHT_WHEEL_SPEED_M_S => O::RightWheelSpeed,
            chan::YAW_RATE_RAD_S => O::YawRate,
            chan::LEFT_CURRENT_A => O::LeftCurrent,
            chan::RIGHT_CURRENT_A => O::RightCurrent,
            _ => O::Other,
        }
    }

    fn output_kind(&self, o: VehicleOutput) -> OutputKind {
        match o {
            VehicleOutput::LeftMotorSpeed if self.encoder => OutputKind::IntervalRate(2),
            VehicleOutput::RightMotorSpeed if self.encoder => OutputKind::IntervalRate(SIDE + 2),
            _ => OutputKind::Instant,
        }
    }

    fn output(
        &self,
        b: &VehicleBlocks,
        o: VehicleOutput,
        x: &[f64],
        _u: &[f64],
        _held: &[f64],
    ) -> f64 {
        use VehicleOutput as O;
        let wheel = |s: usize| self.wheel_speed_rad_s(x, s);
        match o {
            O::X => x[BODY + 3],
            O::Y => x[BODY + 4],
            O::Heading => x[BODY + 5],
            O::LeftMotorSpeed => x[1],
            O::RightMotorSpeed => x[SIDE + 1],
            O::LeftWheelSpeed => wheel(0) * b.drivetrain.wheel.radius_m,
            O::RightWheelSpeed => wheel(SIDE) * b.drivetrain.wheel.radius_m,
            O::YawRate => x[BODY + 2],
            O::LeftCurrent => x[0],
            O::RightCurrent => x[SIDE],
            O::Other => f64::NAN,
        }
    }
}

/// What a vehicle's output column is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VehicleOutput {
    /// `x_m`, at the drive-axle midpoint.
    X,
    /// `y_m`.
    Y,
    /// `heading_rad`.
    Heading,
    /// `left_motor_speed_rad_s`.
    LeftMotorSpeed,
    /// `right_motor_speed_rad_s`.
    RightMotorSpeed,
    /// `left_wheel_speed_m_s`.
    LeftWheelSpeed,
    /// `right_wheel_speed_m_s`.
    RightWheelSpeed,
    /// `yaw_rate_rad_s`.
    YawRate,
    /// `left_current_A`.
    LeftCurrent,
    /// `right_current_A`.
    RightCurrent,
    /// A column the model does not produce.
    Other,
}
