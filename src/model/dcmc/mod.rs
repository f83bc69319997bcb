//! The wheelchair motor controller (DCMC): forward and turn demand to left and right motor
//! voltage, in the three structures the thesis identified, with the unit's quirks:
//! enable-delay fault, combined-demand fault, turn priority, low-battery fault and active
//! braking when disabled or faulted.
//!
//! The unit is slow: the thesis's lifted-wheel identification (section 5.2.1, case 1)
//! found time constants of 0.65 s (left) and 0.58 s (right) from demand to motor speed,
//! twenty times the motor's own mechanical time constant. A wheelchair controller shapes
//! the pilot's demand in its microprocessor; the thesis's first-order fit (1.2-1.7 %
//! standard deviations, and "no compelling evidence for a more complex control
//! strategy") supports first-order lags ([`DcmcResponse`]): each side's forward part has
//! one, the turn part one of its own (the case-1 structure cannot tell them apart; the
//! floor runs bound the turn lag, see `study::thesis_dcmc`). Rate limits ([`DcmcRamp`],
//! the units' acceleration settings) are there for other machines. The shaped request
//! (voltage for `gain`, speed set-point for `p`/`pi`) then goes through the bridges'
//! limits.

mod shaping;

use super::speed_loop::SpeedLoopGains;
use crate::model::Bounded;
pub use shaping::{DcmcRamp, DcmcResponse};

/// How the DCMC turns demand into motor voltage (the thesis's identification cases).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize, serde::Serialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum DcmcKind {
    /// Case 1: a gain matrix from (forward, turn) to (left, right) voltage.
    #[default]
    Gain,
    /// Case 2-I: proportional speed loop.
    P,
    /// Case 2-II: proportional-integral speed loop.
    Pi,
    /// The gain structure's voltage plus integral action on the speed error, the set-point
    /// being the speed that voltage gives the unloaded motor (a unit calibrated to its
    /// motor: forward gain over the back-EMF constant per percent); no proportional term.
    /// The contract's `speed_feedback`, its integral gain `ki_V_rad`.
    #[serde(rename = "gain_pi")]
    GainPi,
}

impl crate::param::Value for DcmcKind {}

impl DcmcKind {
    /// The name a scene uses (`dcmc.kind = "gain_pi"`).
    pub fn name(self) -> &'static str {
        match self {
            DcmcKind::Gain => "gain",
            DcmcKind::P => "p",
            DcmcKind::Pi => "pi",
            DcmcKind::GainPi => "gain_pi",
        }
    }
}

/// What `dcmc.kind` takes.
fn dcmc_kinds() -> String {
    "`gain`, `p`, `pi`, `gain_pi`".into()
}

crate::declare_params! {
    /// The wheelchair motor controller (Dynamic Controls DCMC; scene section `[dcmc]`).
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct DcmcParams in "dcmc" {
        /// How demand becomes motor voltage: a gain matrix (`gain`), a proportional
        /// (`p`) or proportional-integral (`pi`) speed loop, or the gain's voltage with
        /// integral action on the speed error (`gain_pi`).
        kind: DcmcKind = DcmcKind::Gain, "", other(dcmc_kinds);
        /// `gain`: volts per percent of forward demand. Default matched to the thesis's
        /// case-1 identification (see `response_time_left_s`).
        forward_gain_v_pct as "forward_gain_V_pct": f64 = 0.1623, "V/pct", Finite;
        /// `gain`: volts per percent of turn demand (added right, subtracted left). Default
        /// matched likewise: the identified turn/forward column ratio is the thesis's 0.72.
        turn_gain_v_pct as "turn_gain_V_pct": f64 = 0.1020, "V/pct", Finite;
        /// `p`/`pi`: motor speed set-point per percent of demand.
        speed_per_pct_rad_s: f64 = 3.5, "rad/s per pct", Positive;
        /// `p`/`pi`: proportional gain of the speed loop.
        kp_v_s_rad as "kp_V_s_rad": f64 = 0.5, "V s/rad", NonNegative;
        /// `pi`, `gain_pi`: integral gain of the speed loop.
        ki_v_rad as "ki_V_rad": f64 = 4.0, "V/rad", NonNegative;
        /// A non-zero demand within this time of enabling faults the DCMC.
        enable_delay_s: f64 = 0.5, "s", NonNegative;
        /// |forward| + |turn| demand above this faults the DCMC.
        combined_fault_pct: f64 = 185.0, "pct", Positive;
        /// When a side would saturate, keep the turn and slow the common speed.
        turn_priority: bool = true, "", other(crate::param::true_or_false);
        /// Active braking gain when disabled or faulted (drives the speed to zero).
        brake_gain_v_s_rad as "brake_gain_V_s_rad": f64 = 0.3, "V s/rad", NonNegative;
        /// Armature current limit per motor (*assumed*: wheelchair controllers limit at
        /// 40-70 A).
        current_limit_a as "current_limit_A": f64 = 40.0, "A", Positive;
        /// The unit's acceleration setting: the left side's demand may change by at most
        /// this, percent of full demand per second (0: no limit). See `agvsim study
        /// thesis-dcmc`.
        ramp_left_pct_s: f64 = 0.0, "pct/s", NonNegative;
        /// The same for the right side (0: no limit).
        ramp_right_pct_s: f64 = 0.0, "pct/s", NonNegative;
        /// The unit's turn acceleration setting: the turn demand may change by at most
        /// this, percent of full turn demand per second (0: no limit).
        turn_ramp_pct_s: f64 = 0.0, "pct/s", NonNegative;
        /// Time constant of the unit's first-order lag on the left side's forward demand
        /// (0: none). Default matched, with the two gains, so that the machine's
        /// lifted-wheel runs identified with the thesis's case-1 structure give the
        /// thesis's A and B (section 5.2.1; `agvsim study thesis-dcmc`). Equal on both
        /// sides: a 12 % side difference would yaw the vehicle 0.1 rad at every start.
        response_time_left_s: f64 = 0.699, "s", NonNegative;
        /// The same for the right side (0: none).
        response_time_right_s: f64 = 0.699, "s", NonNegative;
        /// Time constant of the lag on the turn demand (0: none). *Assumed* 0: the
        /// thesis's case-1 structure cannot tell a turn lag from a forward one, and with
        /// the forward lags on the turn demand too the firmware's P-D loop at the thesis's
        /// gains loses the wire, which the thesis's vehicle did not.
        turn_response_time_s: f64 = 0.0, "s", NonNegative;
        /// Dead time between an external command (a recording's voltages or demands, as
        /// `replay` applies them) and the drive acting on it (default 0). The contract's
        /// `transport_delay`. The firmware's own delay is `controller.compute_delay_s`.
        command_delay_s: f64 = 0.0, "s", NonNegative;
    }
}

/// The DCMC as wired to its machine: its settings, the motors it drives and whether its
/// faults are modelled at all.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dcmc {
    /// The unit's settings.
    pub params: DcmcParams,
    /// The armature resistance the unit is set up for, ohm (its current limit works from
    /// the back-EMF it measures and this).
    pub armature_resistance_ohm: f64,
    /// The motors' back-EMF constant the unit is calibrated to, V s/rad (`gain_pi`: its
    /// set-point is the speed its voltage gives the unloaded motor).
    pub back_emf_v_s_rad: f64,
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
    /// The fault's name, for summaries.
    pub fn name(self) -> &'static str {
        match self {
            DcmcFault::EnableDelay => "enable_delay",
            DcmcFault::CombinedDemand => "combined_demand",
            DcmcFault::LowVoltage => "low_voltage",
        }
    }
}

/// What the DCMC remembers: its enable time, a latched fault, its integrators and the stages of its demand shaping.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DcmcState {
    /// When the enable line last went active, s.
    pub enabled_since_s: Option<f64>,
    /// The latched fault, if any.
    pub fault: Option<DcmcFault>,
    /// PI integrators (left, right), rad.
    pub integral_rad: [f64; 2],
    /// Forward part of each side's request after its lag (left, right): volts for `gain`,
    /// speed set-point in rad/s for `p`/`pi`.
    pub forward_request: [f64; 2],
    /// Turn part of each side's request after its lag, same units.
    pub turn_request: [f64; 2],
    /// Each side's request after the lags and the ramp: what the unit acts on.
    pub shaped_request: [f64; 2],
}

/// What the DCMC reads at a step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DcmcInput {
    /// Time, s.
    pub t_s: f64,
    /// The enable line is active.
    pub enabled: bool,
    /// Forward demand, pct.
    pub forward_pct: f64,
    /// Turn demand, pct.
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

/// What the DCMC gives the motors.
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
            DcmcKind::Gain | DcmcKind::GainPi => 2.0 * self.turn_gain_v_pct / back_emf_v_s_rad,
            DcmcKind::P | DcmcKind::Pi => {
                let [l, r] = self.speed_setpoints(0.0, 1.0);
                r - l
            }
        }
    }

    /// A side's turn part per percent of turn demand: V for `gain`, rad/s for `p`/`pi`.
    pub fn turn_request_per_pct(&self) -> f64 {
        match self.kind {
            DcmcKind::Gain | DcmcKind::GainPi => self.turn_gain_v_pct.abs(),
            DcmcKind::P | DcmcKind::Pi => {
                (self.speed_per_pct_rad_s * self.turn_gain_v_pct / self.forward_gain_v_pct).abs()
            }
        }
    }

    /// A side's request per percent of (forward) demand: V for `gain`, rad/s for `p`/`pi`.
    pub fn request_per_pct(&self) -> f64 {
        match self.kind {
            DcmcKind::Gain | DcmcKind::GainPi => self.forward_gain_v_pct,
            DcmcKind::P | DcmcKind::Pi => self.speed_per_pct_rad_s,
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
            let half_diff = (0.5 * (v[1] - v[0])).bounded(-a, a);
            let room = a - half_diff.abs();
            let common = common.bounded(-room, room);
            [common - half_diff, common + half_diff]
        } else {
            [v[0].bounded(-a, a), v[1].bounded(-a, a)]
        }
    }
}

impl Dcmc {
    /// One control step of length `dt`.
    pub fn step(&self, s: &mut DcmcState, u: &DcmcInput, dt: f64) -> DcmcOutput {
        if !u.enabled {
            s.enabled_since_s = None;
            s.fault = None;
            s.integral_rad = [0.0; 2];
            s.forward_request = [0.0; 2];
            s.turn_request = [0.0; 2];
            s.shaped_request = [0.0; 2];
            return self.brake(u);
        }
        let since = *s.enabled_since_s.get_or_insert(u.t_s);
        if s.fault.is_none() && self.faults {
            let demanding =
                u.forward_pct.abs() > ZERO_DEMAND_PCT || u.turn_pct.abs() > ZERO_DEMAND_PCT;
            if demanding && u.t_s - since < self.params.enable_delay_s {
                s.fault = Some(DcmcFault::EnableDelay);
            } else if u.forward_pct.abs() + u.turn_pct.abs() > self.params.combined_fault_pct {
                s.fault = Some(DcmcFault::CombinedDemand);
            } else if u.low_battery {
                s.fault = Some(DcmcFault::LowVoltage);
            }
        }
        if s.fault.is_some() {
            s.integral_rad = [0.0; 2];
            s.forward_request = [0.0; 2];
            s.turn_request = [0.0; 2];
            s.shaped_request = [0.0; 2];
            return self.brake(u);
        }
        let shaped = self.shape(s, u.forward_pct, u.turn_pct, dt);
        let Some((gains, setpoints)) = self.speed_loop_on(shaped) else {
            let limited =
                self.limit_current(self.params.limit(shaped, u.available_v), u.back_emf_v);
            return DcmcOutput {
                voltage_v: limited,
                braking: false,
            };
        };
        let integrates = self.params.kind != DcmcKind::P;
        let mut request = [0.0; 2];
        for i in 0..2 {
            let error = setpoints[i] - u.motor_speed_rad_s[i];
            if integrates {
                s.integral_rad[i] += error * dt;
            }
            request[i] = gains.voltage_v(setpoints[i], u.motor_speed_rad_s[i], s.integral_rad[i]);
        }
        let limited = self.limit_current(self.params.limit(request, u.available_v), u.back_emf_v);
        if integrates {
            // Anti-windup: do not integrate while the output is clipped.
            for i in 0..2 {
                if (limited[i] - request[i]).abs() > 1e-9 {
                    s.integral_rad[i] -= (setpoints[i] - u.motor_speed_rad_s[i]) * dt;
                }
            }
        }
        DcmcOutput {
            voltage_v: limited,
            braking: false,
        }
    }

    /// The speed loop's gains and each side's set-point (rad/s) for the shaped request, if
    /// the unit closes one: `p`/`pi` on their set-points; `gain_pi` feeds its voltage
    /// forward and sets the speed it gives the unloaded motor.
    fn speed_loop_on(&self, shaped: [f64; 2]) -> Option<(SpeedLoopGains, [f64; 2])> {
        match self.params.kind {
            DcmcKind::Gain => None,
            DcmcKind::P | DcmcKind::Pi => {
                let gains = SpeedLoopGains {
                    feedforward_v_s_rad: 0.0,
                    kp_v_s_rad: self.params.kp_v_s_rad,
                    ki_v_rad: self.params.ki_v_rad,
                };
                Some((gains, shaped))
            }
            DcmcKind::GainPi => {
                let gains = SpeedLoopGains::calibrated_to_motor(
                    self.back_emf_v_s_rad,
                    self.params.ki_v_rad,
                );
                Some((gains, shaped.map(|v| gains.calibrated_setpoint_rad_s(v))))
            }
        }
    }

    /// Keeps each armature current within the limit: `|V - emf| <= R I_max`.
    pub fn limit_current(&self, v: [f64; 2], back_emf_v: [f64; 2]) -> [f64; 2] {
        let band = self.armature_resistance_ohm * self.params.current_limit_a;
        [
            v[0].bounded(back_emf_v[0] - band, back_emf_v[0] + band),
            v[1].bounded(back_emf_v[1] - band, back_emf_v[1] + band),
        ]
    }

    /// Active braking: drive each motor towards zero speed.
    fn brake(&self, u: &DcmcInput) -> DcmcOutput {
        let a = u.available_v.max(0.0);
        let v = [
            (-self.params.brake_gain_v_s_rad * u.motor_speed_rad_s[0]).bounded(-a, a),
            (-self.params.brake_gain_v_s_rad * u.motor_speed_rad_s[1]).bounded(-a, a),
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

    #[test]
    fn each_kind_is_named_as_a_scene_reads_it() {
        for k in [DcmcKind::Gain, DcmcKind::P, DcmcKind::Pi, DcmcKind::GainPi] {
            let text = format!("kind = \"{}\"", k.name());
            let back: DcmcParams = toml::from_str(&text).unwrap();
            assert_eq!(back.kind, k, "{text}");
        }
    }

    pub(super) fn dcmc() -> Dcmc {
        Dcmc {
            params: DcmcParams {
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
                response_time_left_s: 0.0,
                response_time_right_s: 0.0,
                ..DcmcParams::default()
            },
            armature_resistance_ohm: 0.35,
            back_emf_v_s_rad: 0.063,
            faults: true,
        }
    }

    pub(super) fn input(t: f64, f: f64, turn: f64) -> DcmcInput {
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

    /// `gain_pi`: at the set-point its gain voltage would give the unloaded motor it
    /// applies exactly that voltage; held below it (a load), the integral raises the
    /// voltage by `ki` times the accumulated speed error.
    #[test]
    fn a_unit_calibrated_to_its_motor_feeds_its_gain_forward_and_integrates_the_error() {
        let mut d = dcmc();
        d.params.kind = DcmcKind::GainPi;
        let gain_v = 0.235 * 40.0;
        let set = gain_v / d.back_emf_v_s_rad;
        let mut s = DcmcState::default();
        let at = |w: f64, t: f64| DcmcInput {
            motor_speed_rad_s: [w, w],
            ..input(t, 40.0, 0.0)
        };
        let resting = DcmcInput {
            motor_speed_rad_s: [0.0; 2],
            ..input(0.0, 0.0, 0.0)
        };
        d.step(&mut s, &resting, 0.001);
        let out = d.step(&mut s, &at(set, 0.6), 0.001);
        assert!((out.voltage_v[0] - gain_v).abs() < 1e-9, "{out:?}");
        let slow = set - 10.0;
        let mut out = out;
        for k in 0..100 {
            out = d.step(&mut s, &at(slow, 0.601 + 0.001 * k as f64), 0.001);
        }
        let expected = gain_v + d.params.ki_v_rad * 10.0 * 0.1;
        assert!(
            (out.voltage_v[0] - expected).abs() < 1e-9,
            "{out:?} against {expected}"
        );
    }

    #[test]
    fn turn_priority_slows_the_inner_wheel_and_keeps_the_turn() {
        let d = dcmc();
        let v = d
            .params
            .limit([100.0 * 0.235 - 6.0, 100.0 * 0.235 + 6.0], 23.5);
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
