//! A velocity-commanded base: the base controller a ROS robot runs (`ros2_controllers`'
//! `diff_drive_controller`) and the speed loops of its motor drivers.
//!
//! The command `(v, w)` (forward speed m/s, yaw rate rad/s, a `/cmd_vel` Twist) is first
//! limited as the controller's speed limiter does it, each component alone: its value to
//! `+-max`, then its change per step to `+-max_accel dt`. The diff-drive kinematics then
//! give each wheel's speed, and through the gear each motor's set-point, rad/s:
//!
//! `w_left = n (v - w b / 2) / r`, `w_right = n (v + w b / 2) / r`
//!
//! with `b` the track width, m, `r` the wheel radius, m, and `n` the gear ratio. Each motor
//! driver closes a PI loop on its motor's speed,
//! `V = kp (w_set - w) + ki integral(w_set - w) dt`, V, clipped to what the bridge can
//! give, the integral held while the output is clipped (anti-windup, as drivers do).
//! A limit or acceleration of 0 means none, ROS's default.

use super::speed_loop::SpeedLoopGains;
use crate::model::Bounded;

crate::declare_params! {
    /// A velocity-commanded base (scene section `[base]`): the limits of its base
    /// controller and its motor drivers' speed loops. Used when a run is driven by
    /// `cmd_linear_m_s` and `cmd_angular_rad_s` (a ROS robot's `/cmd_vel`).
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct BaseParams in "base" {
        /// Largest forward speed the base controller passes, either way (0: no limit;
        /// diff_drive_controller's `linear.x.max_velocity`).
        max_linear_m_s: f64 = 0.0, "m/s", NonNegative;
        /// Largest forward acceleration it passes (0: no limit; `linear.x.max_acceleration`).
        max_linear_accel_m_s2: f64 = 0.0, "m/s^2", NonNegative;
        /// Largest yaw rate it passes, either way (0: no limit; `angular.z.max_velocity`).
        max_angular_rad_s: f64 = 0.0, "rad/s", NonNegative;
        /// Largest yaw acceleration it passes (0: no limit; `angular.z.max_acceleration`).
        max_angular_accel_rad_s2: f64 = 0.0, "rad/s^2", NonNegative;
        /// The motor drivers' proportional gain on the motor speed error. *Assumed*: the
        /// thesis unit's speed loop (`dcmc.kp_V_s_rad`).
        speed_kp_v_s_rad as "speed_kp_V_s_rad": f64 = 0.5, "V s/rad", NonNegative;
        /// The motor drivers' integral gain on the motor speed error. *Assumed*: the
        /// thesis unit's (`dcmc.ki_V_rad`).
        speed_ki_v_rad as "speed_ki_V_rad": f64 = 4.0, "V/rad", NonNegative;
        /// The wheel radius the base controller and its odometry are configured with
        /// (`diff_drive_controller`'s `wheel_radius` times its multiplier): what turns a
        /// command into wheel speeds and encoder counts into distance. The wheels roll on
        /// their effective radii (`wheel.left_rolling_radius_m`, ...) whatever it says.
        wheel_radius_m: Option<f64> = None, "m", Positive, unset "wheel.radius_m";
        /// The wheel separation the base controller and its odometry are configured with
        /// (`wheel_separation` times its multiplier). The wheels meet the floor
        /// `chassis.track_width_m` apart whatever it says.
        wheel_separation_m: Option<f64> = None, "m", Positive, unset "chassis.track_width_m";
    }
}

/// The drive's geometry the base controller's kinematics use: the configured wheel
/// separation and radius (what the controller believes), not the floor's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BaseGeometry {
    /// Distance between the drive wheels, m.
    pub track_width_m: f64,
    /// Drive wheel radius, m.
    pub wheel_radius_m: f64,
    /// Motor turns per wheel turn.
    pub gear_ratio: f64,
}

/// What the base remembers: the command as limited so far and the drivers' integrators.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct BaseState {
    /// The limited command: forward speed, m/s, and yaw rate, rad/s.
    pub command: [f64; 2],
    /// The drivers' speed-error integrals (left, right), rad.
    pub integral_rad: [f64; 2],
}

/// What the base reads at a step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BaseInput {
    /// Commanded forward speed, m/s.
    pub linear_m_s: f64,
    /// Commanded yaw rate, rad/s (positive: turning left).
    pub angular_rad_s: f64,
    /// Motor speeds (left, right), rad/s.
    pub motor_speed_rad_s: [f64; 2],
    /// Highest voltage the bridges can give now, V.
    pub available_v: f64,
}

/// What the base gives the motors.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct BaseOutput {
    /// Motor speed set-points (left, right), rad/s.
    pub setpoint_rad_s: [f64; 2],
    /// Motor terminal voltages (left, right), V.
    pub voltage_v: [f64; 2],
}

/// One component's limited value after `dt`: the command within `+-max`, reached from
/// `previous` at no more than `max_accel` (each 0: no limit).
pub fn speed_limited(previous: f64, command: f64, max: f64, max_accel: f64, dt: f64) -> f64 {
    let target = if max > 0.0 {
        command.bounded(-max, max)
    } else {
        command
    };
    if max_accel > 0.0 {
        let step = max_accel * dt;
        previous + (target - previous).bounded(-step, step)
    } else {
        target
    }
}

/// Motor speed set-points (left, right), rad/s, of a forward speed `v` (m/s) and yaw rate
/// `w` (rad/s): the diff-drive kinematics through the gear.
pub fn motor_setpoints_rad_s(g: &BaseGeometry, v: f64, w: f64) -> [f64; 2] {
    let half = 0.5 * w * g.track_width_m;
    [v - half, v + half].map(|rim| g.gear_ratio * rim / g.wheel_radius_m)
}

impl BaseParams {
    /// The drivers' speed loop.
    pub fn speed_loop(&self) -> SpeedLoopGains {
        SpeedLoopGains {
            feedforward_v_s_rad: 0.0,
            kp_v_s_rad: self.speed_kp_v_s_rad,
            ki_v_rad: self.speed_ki_v_rad,
        }
    }

    /// One control step of length `dt`: limit the command, make the set-points, run
    /// both drivers' loops.
    pub fn step(&self, g: &BaseGeometry, s: &mut BaseState, u: &BaseInput, dt: f64) -> BaseOutput {
        s.command = [
            speed_limited(
                s.command[0],
                u.linear_m_s,
                self.max_linear_m_s,
                self.max_linear_accel_m_s2,
                dt,
            ),
            speed_limited(
                s.command[1],
                u.angular_rad_s,
                self.max_angular_rad_s,
                self.max_angular_accel_rad_s2,
                dt,
            ),
        ];
        let setpoint = motor_setpoints_rad_s(g, s.command[0], s.command[1]);
        let gains = self.speed_loop();
        let a = u.available_v.max(0.0);
        let mut voltage = [0.0; 2];
        for i in 0..2 {
            let error = setpoint[i] - u.motor_speed_rad_s[i];
            let integral = s.integral_rad[i] + error * dt;
            let request = gains.voltage_v(setpoint[i], u.motor_speed_rad_s[i], integral);
            voltage[i] = request.bounded(-a, a);
            // Anti-windup: the integral moves only while the output is not clipped, or
            // when it moves back from the limit.
            if voltage[i] == request || (integral.abs() < s.integral_rad[i].abs()) {
                s.integral_rad[i] = integral;
            }
        }
        BaseOutput {
            setpoint_rad_s: setpoint,
            voltage_v: voltage,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const G: BaseGeometry = BaseGeometry {
        track_width_m: 0.5,
        wheel_radius_m: 0.1,
        gear_ratio: 20.0,
    };

    #[test]
    fn kinematics_turn_in_place_and_drive_straight() {
        // 1 m/s straight: each rim at 1 m/s, wheel 10 rad/s, motor 200 rad/s.
        assert_eq!(motor_setpoints_rad_s(&G, 1.0, 0.0), [200.0, 200.0]);
        // 1 rad/s in place on a 0.5 m track: rims at -+0.25 m/s, motors -+50 rad/s.
        let [l, r] = motor_setpoints_rad_s(&G, 0.0, 1.0);
        assert!((l + 50.0).abs() < 1e-12 && (r - 50.0).abs() < 1e-12);
    }

    #[test]
    fn the_limiter_clips_the_value_then_its_rate() {
        // Max 1 m/s and 2 m/s^2 at 10 ms steps: a step to 3 m/s rises 0.02 per step and
        // stops at 1.
        let mut v = 0.0;
        for _ in 0..10 {
            v = speed_limited(v, 3.0, 1.0, 2.0, 0.01);
        }
        assert!((v - 0.2).abs() < 1e-12, "{v}");
        for _ in 0..100 {
            v = speed_limited(v, 3.0, 1.0, 2.0, 0.01);
        }
        assert_eq!(v, 1.0);
        // Zero: no limit.
        assert_eq!(speed_limited(0.0, 3.0, 0.0, 0.0, 0.01), 3.0);
    }

    #[test]
    fn the_integral_holds_while_the_drive_is_clipped() {
        let p = BaseParams::default();
        let mut s = BaseState::default();
        let u = BaseInput {
            linear_m_s: 1.0,
            angular_rad_s: 0.0,
            motor_speed_rad_s: [0.0; 2],
            available_v: 1.0,
        };
        // 200 rad/s of error asks 100 V through kp alone: clipped to 1 V, no wind-up.
        let out = p.step(&G, &mut s, &u, 0.001);
        assert_eq!(out.voltage_v, [1.0, 1.0]);
        assert_eq!(s.integral_rad, [0.0, 0.0]);
        // Unclipped, the integral grows by the error times dt.
        let u = BaseInput {
            available_v: 1e3,
            ..u
        };
        let out = p.step(&G, &mut s, &u, 0.001);
        assert!((s.integral_rad[0] - 0.2).abs() < 1e-12);
        assert!((out.voltage_v[0] - (0.5 * 200.0 + 4.0 * 0.2)).abs() < 1e-9);
    }
}
