//! Torque terms outside the effect vocabulary: physics a diagnosis names when none of its
//! effects explains what the residual still shows (the contract's "Terms outside the
//! vocabulary"). Each family depends on one named quantity and has a form with an order
//! or exponent; [`TermParams`] declares every family's coefficients (all zero: no term),
//! and the laws below are what a model adds when one is switched on.
//!
//! Signs: a torque is positive when it drives the shaft forwards. Wheel-side torques act
//! after the gear (referred to the motor shaft they are divided by the ratio `N`),
//! motor-side torques at the motor shaft.

crate::declare_params! {
    /// The terms outside the vocabulary (section `term`): zero coefficients switch a
    /// family off.
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct TermParams in "term" {
        /// `speed_power`: wheel-side drag `-c sign(w_w) abs(w_w)^n`, coefficient `c` in
        /// N m (s/rad)^n at the wheel, `w_w` the wheel speed in rad/s.
        speed_power_coefficient: f64 = 0.0, "N m (s/rad)^n", NonNegative;
        /// `speed_power`: the exponent `n` of the wheel speed.
        speed_power_exponent: f64 = 2.0, "", closed(0.5, 4.0);
        /// `periodic_motor_angle`: the sine part `a` of `a sin(n theta_m) + b cos(n theta_m)`
        /// at the motor shaft (`A cos phi` of `A sin(n theta_m + phi)`).
        motor_periodic_sin_nm as "motor_periodic_sin_Nm": f64 = 0.0, "N m", Finite;
        /// `periodic_motor_angle`: the cosine part `b` (`A sin phi`).
        motor_periodic_cos_nm as "motor_periodic_cos_Nm": f64 = 0.0, "N m", Finite;
        /// `periodic_motor_angle`: periods per motor turn.
        motor_periodic_order: f64 = 1.0, "", closed(1.0, 12.0);
        /// `periodic_wheel_angle`: the sine part at the wheel (after the gear).
        wheel_periodic_sin_nm as "wheel_periodic_sin_Nm": f64 = 0.0, "N m", Finite;
        /// `periodic_wheel_angle`: the cosine part at the wheel.
        wheel_periodic_cos_nm as "wheel_periodic_cos_Nm": f64 = 0.0, "N m", Finite;
        /// `periodic_wheel_angle`: periods per wheel turn.
        wheel_periodic_order: f64 = 1.0, "", closed(1.0, 6.0);
        /// `load_dependent_friction`: friction at the motor shaft as this share of the
        /// torque the gears carry (a gear efficiency of about 1 - ratio).
        load_friction_ratio: f64 = 0.0, "", closed(0.0, 0.9);
        /// `current_power`: the torque constant falls as `K (1 - k abs(i)^n)`; this is
        /// `k`, in 1/A^n.
        current_power_coefficient: f64 = 0.0, "1/A^n", NonNegative;
        /// `current_power`: the exponent `n` of the current.
        current_power_exponent: f64 = 1.0, "", closed(1.0, 2.0);
        /// `thermal_drift`: the winding resistance rises as `R0 (1 + a q)`, `q` the square
        /// of the current low-passed over the thermal time constant (A^2); this is `a`.
        heating_coefficient_1_a2 as "heating_coefficient_1_A2": f64 = 0.0, "1/A^2", NonNegative;
        /// `thermal_drift`: the windings' thermal time constant.
        thermal_time_constant_s: f64 = 30.0, "s", Positive;
        /// `time_drift`: the winding resistance changes by this share per second.
        resistance_drift_1_s: f64 = 0.0, "1/s", Finite;
        /// `time_drift`: the torque constant changes by this share per second.
        torque_constant_drift_1_s: f64 = 0.0, "1/s", Finite;
        /// `time_drift`: the viscous friction changes by this share per second.
        viscous_drift_1_s: f64 = 0.0, "1/s", Finite;
    }
}

/// A family of terms: what the term depends on and its form (the contract's table).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Family {
    /// Wheel-side torque growing with a power of the wheel speed.
    SpeedPower,
    /// Motor-side torque periodic in the motor angle.
    PeriodicMotorAngle,
    /// Wheel-side torque periodic in the wheel angle.
    PeriodicWheelAngle,
    /// Motor-side friction proportional to the transmitted torque.
    LoadDependentFriction,
    /// Winding resistance rising with the heat of the current.
    ThermalDrift,
    /// Torque constant falling with the current.
    CurrentPower,
    /// A parameter changing steadily over the recording.
    TimeDrift,
}

impl Family {
    /// Every family a model can switch on.
    pub const ALL: [Family; 7] = [
        Family::SpeedPower,
        Family::PeriodicMotorAngle,
        Family::PeriodicWheelAngle,
        Family::LoadDependentFriction,
        Family::ThermalDrift,
        Family::CurrentPower,
        Family::TimeDrift,
    ];

    /// The contract's name.
    pub fn name(self) -> &'static str {
        match self {
            Family::SpeedPower => "speed_power",
            Family::PeriodicMotorAngle => "periodic_motor_angle",
            Family::PeriodicWheelAngle => "periodic_wheel_angle",
            Family::LoadDependentFriction => "load_dependent_friction",
            Family::ThermalDrift => "thermal_drift",
            Family::CurrentPower => "current_power",
            Family::TimeDrift => "time_drift",
        }
    }

    /// The family by its contract name.
    pub fn from_name(s: &str) -> Option<Family> {
        Family::ALL.into_iter().find(|f| f.name() == s)
    }

    /// What the term depends on, in words.
    pub fn quantity(self) -> &'static str {
        match self {
            Family::SpeedPower => "wheel speed",
            Family::PeriodicMotorAngle => "motor angle",
            Family::PeriodicWheelAngle => "wheel angle",
            Family::LoadDependentFriction => "transmitted torque",
            Family::ThermalDrift => "heat from the current",
            Family::CurrentPower => "current",
            Family::TimeDrift => "time",
        }
    }
}

/// Which parameter a [`Family::TimeDrift`] term lets drift.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Drifting {
    /// The winding resistance.
    Resistance,
    /// The torque (back-EMF) constant.
    TorqueConstant,
    /// The viscous friction.
    Viscous,
}

/// `speed_power`'s torque at the wheel, N m: `-c sign(w) |w|^n`.
#[inline]
pub fn speed_power_torque_nm(coefficient: f64, exponent: f64, wheel_speed_rad_s: f64) -> f64 {
    if wheel_speed_rad_s == 0.0 {
        return 0.0;
    }
    -coefficient * wheel_speed_rad_s.signum() * wheel_speed_rad_s.abs().powf(exponent)
}

/// A periodic torque, N m: `a sin(n theta) + b cos(n theta)` (`= A sin(n theta + phi)`
/// with `a = A cos phi`, `b = A sin phi`).
#[inline]
pub fn periodic_torque_nm(sin_nm: f64, cos_nm: f64, order: f64, angle_rad: f64) -> f64 {
    let (s, c) = (order * angle_rad).sin_cos();
    sin_nm * s + cos_nm * c
}

/// A periodic torque's amplitude (N m) and phase (rad, in [0, 2 pi)) from its sine and
/// cosine parts.
pub fn amplitude_phase(sin_nm: f64, cos_nm: f64) -> (f64, f64) {
    (
        sin_nm.hypot(cos_nm),
        cos_nm.atan2(sin_nm).rem_euclid(std::f64::consts::TAU),
    )
}

/// `load_dependent_friction`'s torque at the motor shaft, N m: `-mu |T| sign(w)`, the
/// sign smoothed as the Coulomb law is (`tanh(w / eps)`, eps in rad/s) so a fit can
/// differentiate it.
#[inline]
pub fn load_friction_torque_nm(
    ratio: f64,
    transmitted_nm: f64,
    speed_rad_s: f64,
    smoothing_rad_s: f64,
) -> f64 {
    -ratio * transmitted_nm.abs() * (speed_rad_s / smoothing_rad_s.max(1e-12)).tanh()
}

/// `current_power`'s share of the torque constant left at a current, `1 - k |i|^n`
/// (floored at zero: the flux cannot reverse).
#[inline]
pub fn torque_constant_share(coefficient: f64, exponent: f64, current_a: f64) -> f64 {
    (1.0 - coefficient * current_a.abs().powf(exponent)).max(0.0)
}

/// `thermal_drift`'s heat after a step `h` (s) at a steady current: the exact solution of
/// [`heat_rate_a2_s`] over it, `q' = i^2 + (q - i^2) exp(-h / tau)` (stable for any `h`).
#[inline]
pub fn heat_after_a2(heat_a2: f64, current_a: f64, time_constant_s: f64, h: f64) -> f64 {
    let steady = current_a * current_a;
    steady + (heat_a2 - steady) * (-h / time_constant_s).exp()
}

/// `thermal_drift`'s heat state: the rate of the square of the current low-passed over the
/// thermal time constant, A^2/s: `dq/dt = (i^2 - q) / tau`. With `Cth dT/dt = i^2 R - dT /
/// Rth` and `R` near `R0`, the temperature rise is `Rth R0 q`, so `R = R0 (1 + a q)`.
#[inline]
pub fn heat_rate_a2_s(heat_a2: f64, current_a: f64, time_constant_s: f64) -> f64 {
    (current_a * current_a - heat_a2) / time_constant_s
}

/// The factor a steady drift has brought a parameter to after `t_s` seconds, `1 + r t`.
#[inline]
pub fn drift_factor(rate_1_s: f64, t_s: f64) -> f64 {
    1.0 + rate_1_s * t_s
}

impl TermParams {
    /// Whether any family is switched on.
    pub fn any(&self) -> bool {
        *self
            != TermParams {
                speed_power_exponent: self.speed_power_exponent,
                motor_periodic_order: self.motor_periodic_order,
                wheel_periodic_order: self.wheel_periodic_order,
                current_power_exponent: self.current_power_exponent,
                thermal_time_constant_s: self.thermal_time_constant_s,
                ..TermParams::default()
            }
    }

    /// The families switched on (a coefficient not zero), in the contract's order.
    pub fn families_on(&self) -> Vec<Family> {
        let on = |f: Family| match f {
            Family::SpeedPower => self.speed_power_coefficient != 0.0,
            Family::PeriodicMotorAngle => {
                self.motor_periodic_sin_nm != 0.0 || self.motor_periodic_cos_nm != 0.0
            }
            Family::PeriodicWheelAngle => {
                self.wheel_periodic_sin_nm != 0.0 || self.wheel_periodic_cos_nm != 0.0
            }
            Family::LoadDependentFriction => self.load_friction_ratio != 0.0,
            Family::ThermalDrift => self.heating_coefficient_1_a2 != 0.0,
            Family::CurrentPower => self.current_power_coefficient != 0.0,
            Family::TimeDrift => {
                self.resistance_drift_1_s != 0.0
                    || self.torque_constant_drift_1_s != 0.0
                    || self.viscous_drift_1_s != 0.0
            }
        };
        Family::ALL.into_iter().filter(|&f| on(f)).collect()
    }

    /// Whether every family is off (what a scene leaves out).
    pub fn is_off(&self) -> bool {
        !self.any()
    }

    /// The torque the angle- and speed-dependent terms add at the motor shaft, N m
    /// (wheel-side terms divided by the gear `ratio`).
    #[inline]
    pub fn shaft_torque_nm(
        &self,
        ratio: f64,
        motor_angle_rad: f64,
        wheel_angle_rad: f64,
        wheel_speed_rad_s: f64,
    ) -> f64 {
        self.motor_side_torque_nm(motor_angle_rad)
            + self.wheel_side_torque_nm(wheel_angle_rad, wheel_speed_rad_s) / ratio
    }

    /// The motor-side periodic torque, N m.
    #[inline]
    pub fn motor_side_torque_nm(&self, motor_angle_rad: f64) -> f64 {
        periodic_torque_nm(
            self.motor_periodic_sin_nm,
            self.motor_periodic_cos_nm,
            self.motor_periodic_order,
            motor_angle_rad,
        )
    }

    /// The wheel-side terms' torque at the wheel, N m: drag and the periodic torque.
    #[inline]
    pub fn wheel_side_torque_nm(&self, wheel_angle_rad: f64, wheel_speed_rad_s: f64) -> f64 {
        speed_power_torque_nm(
            self.speed_power_coefficient,
            self.speed_power_exponent,
            wheel_speed_rad_s,
        ) + periodic_torque_nm(
            self.wheel_periodic_sin_nm,
            self.wheel_periodic_cos_nm,
            self.wheel_periodic_order,
            wheel_angle_rad,
        )
    }

    /// The motor's parameters as the terms have changed them at this current, heat
    /// (A^2) and time since the recording's start (s): resistance, torque constant and
    /// viscous friction.
    #[inline]
    pub fn motor_at(
        &self,
        motor: &crate::model::motor::MotorParams,
        current_a: f64,
        heat_a2: f64,
        t_s: f64,
    ) -> crate::model::motor::MotorParams {
        let k_share = torque_constant_share(
            self.current_power_coefficient,
            self.current_power_exponent,
            current_a,
        );
        crate::model::motor::MotorParams {
            resistance_ohm: motor.resistance_ohm
                * (1.0 + self.heating_coefficient_1_a2 * heat_a2)
                * drift_factor(self.resistance_drift_1_s, t_s),
            torque_constant_nm_a: motor.torque_constant_nm_a
                * k_share
                * drift_factor(self.torque_constant_drift_1_s, t_s),
            viscous_nm_s_rad: motor.viscous_nm_s_rad * drift_factor(self.viscous_drift_1_s, t_s),
            ..*motor
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn drag_opposes_the_wheel_with_the_power_of_its_speed() {
        // 0.04 N m (s/rad)^2 at 10 rad/s: 4 N m against the motion, either way.
        assert!((speed_power_torque_nm(0.04, 2.0, 10.0) + 4.0).abs() < 1e-12);
        assert!((speed_power_torque_nm(0.04, 2.0, -10.0) - 4.0).abs() < 1e-12);
        assert_eq!(speed_power_torque_nm(0.04, 0.5, 0.0), 0.0);
    }

    #[test]
    fn a_periodic_torque_is_its_amplitude_and_phase() {
        let (a, phi) = (0.078, 6.1368);
        let (s, c) = (a * f64::cos(phi), a * f64::sin(phi));
        let (amp, ph) = amplitude_phase(s, c);
        assert!(
            (amp - a).abs() < 1e-12 && (ph - phi).abs() < 1e-9,
            "{amp} {ph}"
        );
        for theta in [0.0, 0.3, 2.0] {
            let direct = a * (4.0 * theta + phi).sin();
            assert!((periodic_torque_nm(s, c, 4.0, theta) - direct).abs() < 1e-12);
        }
    }

    #[test]
    fn heat_settles_at_the_square_of_a_steady_current() {
        // Euler over ten time constants of 2 s at 3 A: q -> 9 A^2.
        let (mut q, h) = (0.0, 1e-3);
        for _ in 0..20_000 {
            q += h * heat_rate_a2_s(q, 3.0, 2.0);
        }
        assert!((q - 9.0).abs() < 1e-3, "{q}");
        // The exact step agrees with the integrated rate, and settles however long it is.
        let exact = heat_after_a2(0.0, 3.0, 2.0, 1.0);
        assert!((exact - 9.0 * (1.0 - (-0.5f64).exp())).abs() < 1e-12);
        assert!((heat_after_a2(0.0, 3.0, 1e-9, 1e-3) - 9.0).abs() < 1e-12);
    }

    #[test]
    fn load_friction_is_a_share_of_the_transmitted_torque_against_the_motion() {
        let t = load_friction_torque_nm(0.1, -2.0, 50.0, 0.5);
        assert!((t + 0.2).abs() < 1e-9, "{t}");
        assert!(load_friction_torque_nm(0.1, 2.0, 0.0, 0.5).abs() < 1e-12);
    }

    #[test]
    fn the_terms_change_the_motor_where_they_say() {
        let motor = crate::model::motor::MotorParams::default();
        let t = TermParams {
            current_power_coefficient: 0.01,
            heating_coefficient_1_a2: 0.002,
            resistance_drift_1_s: 0.001,
            ..TermParams::default()
        };
        assert!(t.any() && !TermParams::default().any());
        assert_eq!(
            t.families_on(),
            [
                Family::ThermalDrift,
                Family::CurrentPower,
                Family::TimeDrift
            ]
        );
        let m = t.motor_at(&motor, 10.0, 25.0, 20.0);
        let r = motor.resistance_ohm * 1.05 * 1.02;
        assert!((m.resistance_ohm - r).abs() < 1e-12);
        assert!((m.torque_constant_nm_a - 0.9 * motor.torque_constant_nm_a).abs() < 1e-12);
    }
}
