//! Permanent-magnet DC motor: armature circuit and rotor, with viscous and Coulomb friction.
//!
//! `L di/dt = V - R i - Kv w`, `J dw/dt = Kt i + T_bias - b(w) w - Tc sign(w) - T_load`,
//! Kt = Kv, with the viscous coefficient `b(w)` allowed to differ by direction.

crate::declare_params! {
    /// Permanent-magnet DC motor, one per side, at the motor shaft (scene section
    /// `[motor]`).
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct MotorParams in "motor" {
        /// Armature resistance (*assumed* 0.35 ohm for the thesis machine).
        resistance_ohm: f64 = 0.35, "ohm", Positive;
        /// Armature inductance (*assumed* 0.8 mH).
        inductance_h as "inductance_H": f64 = 0.0008, "H", Positive;
        /// Torque constant; equals the back-EMF constant in V s/rad (measured 0.063).
        torque_constant_nm_a as "torque_constant_Nm_A": f64 = 0.063, "N m/A", Positive;
        /// Rotor inertia including the worm (*assumed*).
        rotor_inertia_kg_m2: f64 = 2.0e-4, "kg m^2", Positive;
        /// Viscous friction at the motor shaft, the mean of the two directions'
        /// coefficients (*assumed*).
        viscous_nm_s_rad as "viscous_Nm_s_rad": f64 = 1.0e-4, "N m s/rad", NonNegative;
        /// Coulomb friction at the motor shaft: brushes, bearings (*assumed*).
        coulomb_nm as "coulomb_Nm": f64 = 0.02, "N m", NonNegative;
        /// Forward over reverse viscous friction (1: the same both ways; the viscous
        /// coefficient is their mean). The contract's `friction_asymmetry`.
        viscous_ratio: f64 = 1.0, "", Positive;
        /// Constant torque on the motor shaft, driving forward rotation when positive: a
        /// slope's gravity, a cable's pull, a bias. The contract's `offset`.
        offset_nm as "offset_Nm": f64 = 0.0, "N m", Finite;
    }
}

/// What is integrated.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MotorState {
    /// Armature current, A.
    pub current_a: f64,
    /// Shaft speed, rad/s.
    pub speed_rad_s: f64,
    /// Shaft angle, rad.
    pub angle_rad: f64,
}

/// What drives the armature terminals.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Terminal {
    /// Terminal voltage, V.
    Voltage(f64),
    /// Open circuit (power cut): no armature current.
    Open,
}

impl MotorParams {
    /// Back-EMF at a shaft speed, V.
    pub fn back_emf_v(&self, speed_rad_s: f64) -> f64 {
        self.torque_constant_nm_a * speed_rad_s
    }

    /// Electrical damping K^2/R, N m s/rad: the braking torque per unit speed of the
    /// back-EMF through the armature resistance (a shorted or voltage-driven motor).
    pub fn electrical_damping_nm_s_rad(&self) -> f64 {
        electrical_damping_nm_s_rad(self.torque_constant_nm_a, self.resistance_ohm)
    }

    /// No-load speed at a supply voltage, rad/s: `V / K`, where the back-EMF meets the
    /// supply (the no-load current and the motor's own friction neglected).
    pub fn no_load_speed_rad_s(&self, supply_v: f64) -> f64 {
        supply_v / self.torque_constant_nm_a
    }

    /// Stall torque at a supply voltage, N m: `K V / R`, the torque of the current the
    /// resistance alone limits.
    pub fn stall_torque_nm(&self, supply_v: f64) -> f64 {
        self.torque_constant_nm_a * supply_v / self.resistance_ohm
    }

    /// Mechanical time constant `J R / K^2` of the motor driving an inertia (kg m^2 at the
    /// shaft) against its back-EMF and viscous friction, s.
    pub fn mechanical_time_constant_s(&self, inertia_kg_m2: f64) -> f64 {
        inertia_kg_m2 / (self.viscous_nm_s_rad + self.electrical_damping_nm_s_rad())
    }

    /// Electrical time constant L/R, s.
    #[inline]
    pub fn electrical_time_constant_s(&self) -> f64 {
        self.inductance_h / self.resistance_ohm
    }

    /// Armature current after `h` seconds with the terminal voltage and back-EMF held.
    /// The exact solution of the first-order circuit, so stable for any `h`.
    pub fn current_after(
        &self,
        current_a: f64,
        terminal: Terminal,
        speed_rad_s: f64,
        h: f64,
    ) -> f64 {
        match terminal {
            Terminal::Open => 0.0,
            Terminal::Voltage(v) => {
                let steady = (v - self.back_emf_v(speed_rad_s)) / self.resistance_ohm;
                let decay = (-h / self.electrical_time_constant_s()).exp();
                steady + (current_a - steady) * decay
            }
        }
    }

    /// Steady speed of an unloaded motor at a terminal voltage (w > 0 branch), rad/s:
    /// `Kt (V - Kv w)/R = b w + Tc`.
    pub fn steady_speed_rad_s(&self, voltage_v: f64, load_nm: f64) -> f64 {
        let k = self.torque_constant_nm_a;
        let drive = k * voltage_v / self.resistance_ohm - load_nm + self.offset_nm;
        let stall = self.coulomb_nm;
        if drive.abs() <= stall {
            return 0.0;
        }
        let b = viscous_coefficient(self.viscous_nm_s_rad, self.viscous_ratio, drive);
        (drive - stall * drive.signum()) / (self.electrical_damping_nm_s_rad() + b)
    }

    /// Rate of change of the armature current at a terminal voltage, A/s
    /// ([`armature_current_rate`]).
    #[inline]
    pub fn current_rate_a_s(&self, voltage_v: f64, current_a: f64, speed_rad_s: f64) -> f64 {
        armature_current_rate(
            self.resistance_ohm,
            self.inductance_h,
            self.torque_constant_nm_a,
            voltage_v,
            current_a,
            speed_rad_s,
        )
    }

    /// Torque the armature current makes, N m.
    #[inline]
    pub fn electromagnetic_torque_nm(&self, current_a: f64) -> f64 {
        self.torque_constant_nm_a * current_a
    }

    /// Torque driving the rotor before its friction, N m: the motor's own (N m, from the
    /// current, or commanded by a torque amplifier) plus the bias, less the load
    /// (N m at the shaft, opposing positive rotation when positive).
    #[inline]
    pub fn driving_torque_nm(&self, motor_torque_nm: f64, load_nm: f64) -> f64 {
        motor_torque_nm - load_nm + self.offset_nm
    }

    /// Friction torque opposing a shaft speed, N m: the viscous part, which may differ by
    /// direction, and the Coulomb part with a smoothing speed (rad/s; 0: the set-valued
    /// law, see [`coulomb_torque_nm`]).
    #[inline]
    pub fn friction_torque_nm(&self, speed_rad_s: f64, coulomb_smoothing_rad_s: f64) -> f64 {
        viscous_coefficient(self.viscous_nm_s_rad, self.viscous_ratio, speed_rad_s) * speed_rad_s
            + coulomb_torque_nm(self.coulomb_nm, speed_rad_s, coulomb_smoothing_rad_s)
    }

    /// Rotor acceleration, rad/s^2, for the continuous-time models (a fit's RK4):
    /// `J dw/dt = T_drive - b(w) w - Tc(w)`, with the Coulomb law smoothed over
    /// `coulomb_smoothing_rad_s` and `inertia_kg_m2` everything turning with the rotor.
    #[inline]
    pub fn rotor_acceleration_rad_s2(
        &self,
        driving_nm: f64,
        speed_rad_s: f64,
        coulomb_smoothing_rad_s: f64,
        inertia_kg_m2: f64,
    ) -> f64 {
        (driving_nm - self.friction_torque_nm(speed_rad_s, coulomb_smoothing_rad_s)) / inertia_kg_m2
    }

    /// One sub-step of the rotor: electrical, then mechanical with the load torque
    /// (N m at the motor shaft, opposing positive rotation when positive).
    pub fn step(&self, s: &mut MotorState, terminal: Terminal, load_nm: f64, h: f64) {
        s.current_a = self.current_after(s.current_a, terminal, s.speed_rad_s, h);
        let driving = self.driving_torque_nm(self.electromagnetic_torque_nm(s.current_a), load_nm);
        s.speed_rad_s = coulomb_viscous_update(
            s.speed_rad_s,
            driving,
            viscous_coefficient(self.viscous_nm_s_rad, self.viscous_ratio, s.speed_rad_s),
            self.coulomb_nm,
            self.rotor_inertia_kg_m2,
            h,
        );
        s.angle_rad += s.speed_rad_s * h;
    }
}

/// Electrical damping `K^2 / R` of a motor with torque constant `k` (N m/A) and
/// armature resistance `r` (ohm), N m s/rad.
pub fn electrical_damping_nm_s_rad(k: f64, r: f64) -> f64 {
    k * k / r
}

/// Rate of change of the armature current, A/s: `L di/dt = V - R i - K w` (terminal
/// voltage V, back-EMF constant K in V s/rad, shaft speed w in rad/s).
#[inline]
pub fn armature_current_rate(
    resistance_ohm: f64,
    inductance_h: f64,
    torque_constant_nm_a: f64,
    voltage_v: f64,
    current_a: f64,
    speed_rad_s: f64,
) -> f64 {
    (voltage_v - resistance_ohm * current_a - torque_constant_nm_a * speed_rad_s) / inductance_h
}

/// Coulomb friction torque opposing a shaft speed, N m: `Tc sign(w)`, or with a smoothing
/// speed `eps` > 0 (rad/s), `Tc tanh(w / eps)`. The simulator integrates the set-valued law
/// (`eps` 0, with sticking: [`coulomb_viscous_update`]); a fit needs a law it can
/// differentiate, so it sets a small `eps`.
#[inline]
pub fn coulomb_torque_nm(level_nm: f64, speed_rad_s: f64, smoothing_rad_s: f64) -> f64 {
    if level_nm == 0.0 {
        // No friction of this kind: the common case, and the fit's hot loop.
        0.0
    } else if smoothing_rad_s > 0.0 {
        level_nm * (speed_rad_s / smoothing_rad_s).tanh()
    } else if speed_rad_s == 0.0 {
        0.0
    } else {
        level_nm * speed_rad_s.signum()
    }
}

/// Viscous coefficient in the direction of `speed`, N m s/rad, when the forward and
/// reverse coefficients stand in `ratio` (forward over reverse) around the mean `b`:
/// `2 b r / (1 + r)` forward, `2 b / (1 + r)` in reverse, so that the ratio does not also
/// rescale the mean.
#[inline]
pub fn viscous_coefficient(b: f64, ratio: f64, speed: f64) -> f64 {
    if ratio == 1.0 {
        // The same both ways: the common case, and the fit's hot loop (no division).
        b
    } else if speed >= 0.0 {
        2.0 * b * ratio / (1.0 + ratio)
    } else {
        2.0 * b / (1.0 + ratio)
    }
}

/// Speed after a step of `J dw/dt = T - b w - Tc sign(w)`: viscous implicit, Coulomb as a
/// set-valued law (the rotor sticks when the friction impulse could stop it), so that
/// friction never reverses the motion and standstill is exact.
pub fn coulomb_viscous_update(
    speed: f64,
    torque: f64,
    viscous: f64,
    coulomb: f64,
    inertia: f64,
    h: f64,
) -> f64 {
    let trial = speed + h * torque / inertia;
    let friction_dv = h * coulomb / inertia;
    let slid = if trial.abs() <= friction_dv {
        0.0
    } else {
        trial - friction_dv * trial.signum()
    };
    slid / (1.0 + h * viscous / inertia)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn motor() -> MotorParams {
        MotorParams {
            resistance_ohm: 0.35,
            inductance_h: 0.0008,
            torque_constant_nm_a: 0.063,
            rotor_inertia_kg_m2: 2e-4,
            viscous_nm_s_rad: 1e-4,
            viscous_ratio: 1.0,
            coulomb_nm: 0.02,
            offset_nm: 0.0,
        }
    }

    #[test]
    fn derived_quantities_meet_at_the_ends_of_the_torque_speed_line() {
        // Without friction the steady speed at V is the no-load speed, and the stall torque
        // over the damping is the same speed: the torque-speed line's two ends.
        let m = MotorParams {
            viscous_nm_s_rad: 0.0,
            coulomb_nm: 0.0,
            ..motor()
        };
        let v = 24.0;
        let w0 = m.no_load_speed_rad_s(v);
        assert!((w0 - 24.0 / 0.063).abs() < 1e-9);
        assert!((m.steady_speed_rad_s(v, 0.0) - w0).abs() < 1e-9 * w0);
        assert!((m.stall_torque_nm(v) / m.electrical_damping_nm_s_rad() - w0).abs() < 1e-9 * w0);
        // The thesis motor: 4.32 N m stall at 24 V, K^2/R = 0.01134 N m s/rad.
        assert!((m.stall_torque_nm(v) - 4.32).abs() < 1e-12);
        assert!((m.electrical_damping_nm_s_rad() - 0.01134).abs() < 1e-15);
        // J R / K^2 with J = 2e-4 kg m^2: 17.6 ms.
        assert!((m.mechanical_time_constant_s(2e-4) - 2e-4 / 0.01134).abs() < 1e-15);
    }

    #[test]
    fn a_forward_bias_or_a_stiffer_reverse_shows_in_the_steady_speeds() {
        let m = motor();
        let (fwd, rev) = (
            m.steady_speed_rad_s(12.0, 0.0),
            m.steady_speed_rad_s(-12.0, 0.0),
        );
        assert!((fwd + rev).abs() < 1e-12);
        // A bias of one Coulomb level: forward it cancels the friction's loss, in reverse
        // it doubles it.
        let biased = MotorParams {
            offset_nm: 0.02,
            ..m
        };
        let k2r = m.torque_constant_nm_a.powi(2) / m.resistance_ohm + m.viscous_nm_s_rad;
        assert!((biased.steady_speed_rad_s(12.0, 0.0) - fwd - 0.02 / k2r).abs() < 1e-9);
        assert!((biased.steady_speed_rad_s(-12.0, 0.0) - rev - 0.02 / k2r).abs() < 1e-9);
        // Viscous friction three times as strong forward as in reverse, same mean.
        let skewed = MotorParams {
            viscous_ratio: 3.0,
            ..m
        };
        assert!(skewed.steady_speed_rad_s(12.0, 0.0) < fwd);
        assert!(-skewed.steady_speed_rad_s(-12.0, 0.0) > fwd);
        let b = m.viscous_nm_s_rad;
        let mean = 0.5 * (viscous_coefficient(b, 3.0, 1.0) + viscous_coefficient(b, 3.0, -1.0));
        assert!((mean - b).abs() < 1e-18);
        assert!(
            (viscous_coefficient(b, 3.0, 1.0) / viscous_coefficient(b, 3.0, -1.0) - 3.0).abs()
                < 1e-12
        );
    }

    #[test]
    fn coulomb_friction_holds_a_rotor_below_breakaway() {
        // A torque below the Coulomb level must not move a stationary rotor.
        let w = coulomb_viscous_update(0.0, 0.019, 0.0, 0.02, 2e-4, 1e-3);
        assert_eq!(w, 0.0);
        let w = coulomb_viscous_update(0.0, 0.03, 0.0, 0.02, 2e-4, 1e-3);
        assert!((w - 0.01 * 1e-3 / 2e-4).abs() < 1e-12);
    }

    #[test]
    fn free_spin_reaches_the_steady_speed_of_the_motor_equations() {
        let m = motor();
        let mut s = MotorState::default();
        for _ in 0..20000 {
            m.step(&mut s, Terminal::Voltage(12.0), 0.0, 1e-4);
        }
        let expect = m.steady_speed_rad_s(12.0, 0.0);
        assert!(
            (s.speed_rad_s - expect).abs() / expect < 1e-6,
            "{} vs {}",
            s.speed_rad_s,
            expect
        );
    }
}
