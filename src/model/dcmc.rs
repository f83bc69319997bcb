//! The wheelchair motor controller (DCMC): forward and turn demand to left and right motor
//! voltage, in the three structures the thesis identified, with the unit's quirks:
//! enable-delay fault, combined-demand fault, turn priority, low-battery fault and active
//! braking when disabled or faulted.

pub use crate::scene::DcmcKind;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DcmcParams {
    pub kind: DcmcKind,
    pub forward_gain_v_pct: f64,
    pub turn_gain_v_pct: f64,
    pub speed_per_pct_rad_s: f64,
    pub kp_v_s_rad: f64,
    pub ki_v_rad: f64,
    pub enable_delay_s: f64,
    pub combined_fault_pct: f64,
    pub turn_priority: bool,
    pub brake_gain_v_s_rad: f64,
    /// Armature current limit per motor, A (the unit limits current from the back-EMF it
    /// measures and the armature resistance it is set up for).
    pub current_limit_a: f64,
    pub armature_resistance_ohm: f64,
    /// Whether the unit's faults are modelled at all.
    pub faults: bool,
}

/// Why the DCMC stopped driving (latched until it is disabled and enabled again).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DcmcFault {
    /// A non-zero demand arrived within the enable delay.
    EnableDelay,
    /// Forward plus turn demand too high together.
    CombinedDemand,
    /// Battery below the low-voltage threshold.
    LowVoltage,
}

impl DcmcFault {
    pub fn name(self) -> &'static str {
        match self {
            DcmcFault::EnableDelay => "enable_delay",
            DcmcFault::CombinedDemand => "combined_demand",
            DcmcFault::LowVoltage => "low_voltage",
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DcmcState {
    /// When the enable line last went active, s.
    pub enabled_since_s: Option<f64>,
    pub fault: Option<DcmcFault>,
    /// PI integrators (left, right), rad.
    pub integral_rad: [f64; 2],
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DcmcInput {
    pub t_s: f64,
    pub enabled: bool,
    pub forward_pct: f64,
    pub turn_pct: f64,
    /// Motor speeds (left, right), rad/s.
    pub motor_speed_rad_s: [f64; 2],
    /// Back-EMF (left, right), V: what the DCMC measures.
    pub back_emf_v: [f64; 2],
    /// Battery terminal voltage below the low-voltage threshold.
    pub low_battery: bool,
    /// Highest voltage the bridges can give now, V.
    pub available_v: f64,
}

#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DcmcOutput {
    /// Motor terminal voltages (left, right), V.
    pub voltage_v: [f64; 2],
    /// Braking actively (disabled or faulted).
    pub braking: bool,
}

/// Demand below this counts as zero for the enable-delay check, pct.
const ZERO_DEMAND_PCT: f64 = 0.5;

impl DcmcParams {
    /// Unlimited (left, right) voltage request of the gain structure (case 1).
    pub fn gain_voltages(&self, forward_pct: f64, turn_pct: f64) -> [f64; 2] {
        let f = self.forward_gain_v_pct * forward_pct;
        let t = self.turn_gain_v_pct * turn_pct;
        [f - t, f + t]
    }

    /// Motor speed set-points (left, right) of the speed-loop structures, rad/s: the same
    /// mix of forward and turn as the gain structure.
    pub fn speed_setpoints(&self, forward_pct: f64, turn_pct: f64) -> [f64; 2] {
        let mix = self.turn_gain_v_pct / self.forward_gain_v_pct;
        let f = self.speed_per_pct_rad_s * forward_pct;
        let t = self.speed_per_pct_rad_s * mix * turn_pct;
        [f - t, f + t]
    }

    /// Steady motor-speed difference (right minus left) per pct of turn demand on unloaded
    /// motors, rad/s: what a designer of the firmware would read off the identified unit.
    /// `back_emf_v_s_rad` is the motors' back-EMF constant.
    pub fn motor_speed_difference_per_turn_pct(&self, back_emf_v_s_rad: f64) -> f64 {
        match self.kind {
            DcmcKind::Gain => 2.0 * self.turn_gain_v_pct / back_emf_v_s_rad,
            DcmcKind::P | DcmcKind::Pi => {
                let [l, r] = self.speed_setpoints(0.0, 1.0);
                r - l
            }
        }
    }

    /// One control step of length `dt`.
    pub fn step(&self, s: &mut DcmcState, u: &DcmcInput, dt: f64) -> DcmcOutput {
        if !u.enabled {
            s.enabled_since_s = None;
            s.fault = None;
            s.integral_rad = [0.0; 2];
            return self.brake(u);
        }
        let since = *s.enabled_since_s.get_or_insert(u.t_s);
        if s.fault.is_none() && self.faults {
            let demanding =
                u.forward_pct.abs() > ZERO_DEMAND_PCT || u.turn_pct.abs() > ZERO_DEMAND_PCT;
            if demanding && u.t_s - since < self.enable_delay_s {
                s.fault = Some(DcmcFault::EnableDelay);
            } else if u.forward_pct.abs() + u.turn_pct.abs() > self.combined_fault_pct {
                s.fault = Some(DcmcFault::CombinedDemand);
            } else if u.low_battery {
                s.fault = Some(DcmcFault::LowVoltage);
            }
        }
        if s.fault.is_some() {
            s.integral_rad = [0.0; 2];
            return self.brake(u);
        }
        let request = match self.kind {
            DcmcKind::Gain => self.gain_voltages(u.forward_pct, u.turn_pct),
            DcmcKind::P | DcmcKind::Pi => {
                let set = self.speed_setpoints(u.forward_pct, u.turn_pct);
                let mut v = [0.0; 2];
                for i in 0..2 {
                    let e = set[i] - u.motor_speed_rad_s[i];
                    if self.kind == DcmcKind::Pi {
                        s.integral_rad[i] += e * dt;
                    }
                    v[i] = self.kp_v_s_rad * e + self.ki_v_rad * s.integral_rad[i];
                }
                v
            }
        };
        let limited = self.limit_current(self.limit(request, u.available_v), u.back_emf_v);
        if self.kind == DcmcKind::Pi {
            // Anti-windup: do not integrate while the output is clipped.
            for i in 0..2 {
                if (limited[i] - request[i]).abs() > 1e-9 {
                    let set = self.speed_setpoints(u.forward_pct, u.turn_pct);
                    s.integral_rad[i] -= (set[i] - u.motor_speed_rad_s[i]) * dt;
                }
            }
        }
        DcmcOutput {
            voltage_v: limited,
            braking: false,
        }
    }

    /// Clips a voltage request to the bridges; with turn priority the difference between
    /// the sides is kept and the common (forward) part gives way.
    pub fn limit(&self, v: [f64; 2], available_v: f64) -> [f64; 2] {
        let a = available_v.max(0.0);
        if v[0].abs() <= a && v[1].abs() <= a {
            return v;
        }
        if self.turn_priority {
            let common = 0.5 * (v[0] + v[1]);
            let half_diff = (0.5 * (v[1] - v[0])).clamp(-a, a);
            let room = a - half_diff.abs();
            let common = common.clamp(-room, room);
            [common - half_diff, common + half_diff]
        } else {
            [v[0].clamp(-a, a), v[1].clamp(-a, a)]
        }
    }

    /// Keeps each armature current within the limit: `|V - emf| <= R I_max`.
    pub fn limit_current(&self, v: [f64; 2], back_emf_v: [f64; 2]) -> [f64; 2] {
        let band = self.armature_resistance_ohm * self.current_limit_a;
        [
            v[0].clamp(back_emf_v[0] - band, back_emf_v[0] + band),
            v[1].clamp(back_emf_v[1] - band, back_emf_v[1] + band),
        ]
    }

    /// Active braking: drive each motor towards zero speed.
    fn brake(&self, u: &DcmcInput) -> DcmcOutput {
        let a = u.available_v.max(0.0);
        let v = [
            (-self.brake_gain_v_s_rad * u.motor_speed_rad_s[0]).clamp(-a, a),
            (-self.brake_gain_v_s_rad * u.motor_speed_rad_s[1]).clamp(-a, a),
        ];
        DcmcOutput {
            voltage_v: self.limit_current(v, u.back_emf_v),
            braking: true,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dcmc() -> DcmcParams {
        DcmcParams {
            kind: DcmcKind::Gain,
            forward_gain_v_pct: 0.235,
            turn_gain_v_pct: 0.12,
            speed_per_pct_rad_s: 3.5,
            kp_v_s_rad: 0.5,
            ki_v_rad: 4.0,
            enable_delay_s: 0.5,
            combined_fault_pct: 185.0,
            turn_priority: true,
            brake_gain_v_s_rad: 0.3,
            current_limit_a: 1000.0,
            armature_resistance_ohm: 0.35,
            faults: true,
        }
    }

    fn input(t: f64, f: f64, turn: f64) -> DcmcInput {
        DcmcInput {
            t_s: t,
            enabled: true,
            forward_pct: f,
            turn_pct: turn,
            motor_speed_rad_s: [100.0, 100.0],
            back_emf_v: [6.3, 6.3],
            low_battery: false,
            available_v: 23.5,
        }
    }

    #[test]
    fn demand_too_soon_after_enable_faults_and_brakes() {
        let d = dcmc();
        let mut s = DcmcState::default();
        d.step(&mut s, &input(0.0, 0.0, 0.0), 0.001);
        let out = d.step(&mut s, &input(0.2, 50.0, 0.0), 0.001);
        assert_eq!(s.fault, Some(DcmcFault::EnableDelay));
        assert!(out.braking && out.voltage_v[0] < 0.0);
        let mut s = DcmcState::default();
        d.step(&mut s, &input(0.0, 0.0, 0.0), 0.001);
        let out = d.step(&mut s, &input(0.6, 50.0, 0.0), 0.001);
        assert_eq!(s.fault, None);
        assert!((out.voltage_v[0] - 11.75).abs() < 1e-9);
    }

    #[test]
    fn turn_priority_slows_the_inner_wheel_and_keeps_the_turn() {
        let d = dcmc();
        let v = d.limit([100.0 * 0.235 - 6.0, 100.0 * 0.235 + 6.0], 23.5);
        assert!((v[1] - v[0] - 12.0).abs() < 1e-9, "turn kept: {v:?}");
        assert!(v[1] <= 23.5 + 1e-12);
        assert!(v[0] < 23.5 - 6.0 - 1e-9, "inner wheel slowed: {v:?}");
    }

    #[test]
    fn high_forward_plus_high_turn_faults() {
        let d = dcmc();
        let mut s = DcmcState::default();
        d.step(&mut s, &input(0.0, 0.0, 0.0), 0.001);
        d.step(&mut s, &input(1.0, 100.0, 90.0), 0.001);
        assert_eq!(s.fault, Some(DcmcFault::CombinedDemand));
    }
}
