//! The rotary axis's dynamics: the simulator's blocks (motor, gear train with its play,
//! wheel bearings, the DCMC's speed loop, the battery and bridges) built from one
//! parameter vector as named values, and the order one evaluation runs them in.

use crate::ident::data::Dataset;
use crate::ident::effects::{Effect, SupplyBlocks};
use crate::ident::model::{Dynamics, GreyBox, OutputKind, ParamSpec};
use crate::model::drivetrain::{DrivetrainParams, DrivetrainState};
use crate::model::gearbox::GearboxParams;
use crate::model::motor::{MotorParams, MotorState};
use crate::model::speed_loop::SpeedLoopGains;
use crate::model::term::{self, TermParams};
use crate::model::wheel::WheelParams;
use crate::model::Bounded;
use crate::record::channels as chan;

use super::{
    play_gearbox, AxisInput, AxisParams, PlayShare, RotaryAxis, TorqueCommand, DEMAND_GAIN,
    INDUCTANCE, MESH_STEP_RATE, RESISTANCE, ROTOR_INERTIA, TORQUE_CONSTANT, VISCOUS,
};

/// The simulator's blocks this model assembles, with the values of one parameter vector.
#[derive(Debug, Clone, Copy)]
pub struct AxisBlocks {
    /// Motor (with the friction effects switched on), gear train and wheel. Through rigid
    /// gears all viscous friction is the motor's and the gear has no play.
    pub drivetrain: DrivetrainParams,
    /// Whether a play separates the motor's and the wheel's motion (the backlash block).
    pub play: bool,
    /// The DCMC's voltage per percent of demand, V/pct (demand-driven axes).
    pub demand_gain_v_pct: f64,
    /// The DCMC's own speed loop (the speed-feedback block).
    pub speed_loop: Option<SpeedLoopGains>,
    /// The bridges' limit, the sagging battery and the command's dead time (the
    /// supply effects' blocks).
    pub supply: SupplyBlocks,
    /// Mechanical time constant of the motor and wheel, s.
    pub mechanical_time_constant_s: f64,
    /// The term outside the vocabulary, when one is on (its family's coefficients; the
    /// others zero).
    pub term: Option<TermParams>,
}

/// The states of the drive train, named: `[current, motor speed, motor angle, wheel speed,
/// wheel angle]`, the layout both fitting models use per side.
#[inline]
pub(crate) fn drivetrain_state(x: &[f64]) -> DrivetrainState {
    DrivetrainState {
        motor: MotorState {
            current_a: x[0],
            speed_rad_s: x[1],
            angle_rad: x[2],
        },
        wheel_speed_rad_s: x[3],
        wheel_angle_rad: x[4],
        term: Default::default(),
    }
}

/// One drive's motor, gear train and wheel from the declared motor, gear train (its play
/// when the backlash block is on) and wheel, with the blocks of the effects switched on:
/// a gear play with `play.wheel_viscous_share` of the viscous friction in the wheel's
/// bearings, Coulomb friction, a direction-dependent viscous friction and a bias torque
/// (the motor's own keys). Through rigid gears all viscous friction is the motor's and the
/// gear has no play.
#[inline(always)]
pub(crate) fn drivetrain_blocks(
    motor: &MotorParams,
    gearbox: &GearboxParams,
    wheel: &WheelParams,
    play: Option<&PlayShare>,
    wheel_radius_m: f64,
) -> DrivetrainParams {
    let ratio = gearbox.ratio;
    let (gearbox, wheel_share) = match play {
        Some(share) => (
            play_gearbox(ratio, gearbox.backlash_rad),
            share.wheel_viscous_share,
        ),
        None => (play_gearbox(ratio, 0.0), 0.0),
    };
    let total_viscous = motor.viscous_nm_s_rad;
    DrivetrainParams {
        motor: MotorParams {
            viscous_nm_s_rad: total_viscous * (1.0 - wheel_share),
            ..*motor
        },
        gearbox,
        wheel: WheelParams {
            radius_m: wheel_radius_m,
            inertia_kg_m2: wheel.inertia_kg_m2,
            viscous_nm_s_rad: total_viscous * wheel_share * ratio * ratio,
            ..*wheel
        },
        // The fitting model integrates a term itself (its heat and clock are states of
        // the model: `AxisBlocks::term`), with the same laws.
        term: None,
    }
}

/// Where the speed loop's integral is kept.
const SPEED_LOOP_INTEGRAL: usize = 5;
/// Where the thermal-drift term's heat (the squared current low-passed, A^2) is kept.
const HEAT: usize = 6;
/// Where the time since the record's start is kept (a time-drift term's clock), s.
const CLOCK: usize = 7;

impl RotaryAxis {
    /// The blocks of the declared parameters `a`.
    #[inline]
    pub(super) fn blocks_of(&self, a: &AxisParams) -> AxisBlocks {
        let on = |e: Effect| self.effect(e).is_some();
        let gearbox = GearboxParams {
            ratio: self.ratio,
            ..a.gearbox
        };
        AxisBlocks {
            // The lifted wheel's radius does not enter its dynamics.
            drivetrain: drivetrain_blocks(
                &a.motor,
                &gearbox,
                &a.wheel,
                on(Effect::Backlash).then_some(&a.play),
                1.0,
            ),
            play: on(Effect::Backlash),
            demand_gain_v_pct: self.demand_gain_v_pct(a),
            // The vocabulary's speed loop: the DCMC's `gain_pi`.
            speed_loop: on(Effect::SpeedFeedback).then(|| {
                SpeedLoopGains::calibrated_to_motor(a.motor.torque_constant_nm_a, a.dcmc.ki_v_rad)
            }),
            supply: SupplyBlocks::of(
                &self.effects,
                &a.battery,
                a.dcmc.command_delay_s,
                self.supply_v,
            ),
            mechanical_time_constant_s: self.mechanical_time_constant_s(a),
            term: self.term.map(|_| a.term),
        }
    }

    /// Terminal voltage and the speed loop's integral rate for an input value, through the
    /// DCMC (gain, speed loop), the bridges' limit and the battery's sag.
    #[inline]
    fn terminal_voltage(
        &self,
        b: &AxisBlocks,
        s: &DrivetrainState,
        integral: f64,
        u: f64,
    ) -> (f64, f64) {
        let mut v = self.command_voltage(b.demand_gain_v_pct, u);
        let mut integral_rate = 0.0;
        if let Some(gains) = b.speed_loop {
            let setpoint = gains.calibrated_setpoint_rad_s(v);
            v = gains.voltage_v(setpoint, s.motor.speed_rad_s, integral);
            integral_rate = setpoint - s.motor.speed_rad_s;
        }
        if let Some(limit) = b.supply.drive_limit_v {
            v = v.bounded(-limit, limit);
        }
        if let Some(battery) = b.supply.battery {
            v = battery.bridges_output_v([v], [s.motor.current_a])[0];
        }
        (v, integral_rate)
    }

    /// Wheel speed, rad/s: its own state once a play separates it from the motor.
    fn wheel_speed(&self, x: &[f64]) -> f64 {
        match self.effect(Effect::Backlash) {
            Some(_) => x[3],
            None => x[1] / self.ratio,
        }
    }
}

impl RotaryAxis {
    /// The drive's own input: the voltage, the demand or the torque command (or the
    /// position loop's reference).
    fn drive_input_names(&self) -> Vec<String> {
        match self.input {
            AxisInput::Voltage => vec![chan::VOLTAGE_V.into()],
            AxisInput::Demand => vec![chan::DEMAND_PCT.into()],
            AxisInput::Torque(TorqueCommand {
                feedback: None,
                column,
                ..
            }) => {
                vec![column.into()]
            }
            AxisInput::Torque(_) => vec![chan::REFERENCE_RAD.into()],
        }
    }

    /// Whether a periodic term is on, fitted on the measured angle.
    pub fn measured_angle(&self) -> bool {
        self.term.is_some_and(|t| {
            matches!(
                t.family,
                crate::model::term::Family::PeriodicMotorAngle
                    | crate::model::term::Family::PeriodicWheelAngle
            )
        })
    }
}

impl GreyBox for RotaryAxis {
    fn name(&self) -> String {
        match self.input {
            AxisInput::Voltage => "rotary drive axis, voltage-driven".into(),
            AxisInput::Demand => "rotary drive axis, demand through a controller gain".into(),
            AxisInput::Torque(TorqueCommand { feedback: None, .. }) => {
                "rotary drive axis, current (torque) amplifier, open loop".into()
            }
            AxisInput::Torque(_) => {
                "rotary drive axis, current (torque) amplifier, position-velocity cascade".into()
            }
        }
    }

    fn params(&self) -> &[ParamSpec] {
        &self.specs
    }

    fn params_mut(&mut self) -> &mut [ParamSpec] {
        &mut self.specs
    }

    fn sysid_terms(&self, p: &[f64], speed_unit: &str) -> Option<crate::ident::sysid_law::Terms> {
        // SysId regresses the motor's speed on its terminal voltage.
        if self.input != AxisInput::Voltage || speed_unit != "rad/s" {
            return None;
        }
        let a = self.declared(p);
        Some(
            crate::ident::sysid_law::DcDrive {
                resistance_ohm: a.motor.resistance_ohm,
                torque_constant_nm_a: a.motor.torque_constant_nm_a,
                coulomb_nm: a.motor.coulomb_nm,
                viscous_nm_s_rad: a.motor.viscous_nm_s_rad,
                inertia_kg_m2: self.inertia_at_motor(&a),
                motor_rad_per_unit: 1.0,
            }
            .terms(),
        )
    }

    fn default_free(&self, outputs: &[String]) -> Vec<usize> {
        // Only the sum of the inertias is seen through a rigid gear train: the wheel's stays
        // at the rig value and the rotor's absorbs the difference. Without a current
        // measurement R and L are not separable from K and J, so they stay fixed.
        let mut free = if matches!(self.input, AxisInput::Torque(_)) {
            vec![ROTOR_INERTIA, VISCOUS]
        } else if outputs.iter().any(|o| o == chan::CURRENT_A) {
            vec![
                RESISTANCE,
                INDUCTANCE,
                TORQUE_CONSTANT,
                ROTOR_INERTIA,
                VISCOUS,
            ]
        } else {
            vec![TORQUE_CONSTANT, ROTOR_INERTIA, VISCOUS]
        };
        if self.input == AxisInput::Demand {
            free.push(DEMAND_GAIN);
        }
        self.indices_of(&free)
    }

    fn input_names(&self) -> Vec<String> {
        let mut names = self.drive_input_names();
        if self.measured_angle() {
            names.extend([
                crate::ident::data::MEASURED_ANGLE_INTERCEPT.to_string(),
                crate::ident::data::MEASURED_ANGLE_RATE.to_string(),
            ]);
        }
        names
    }

    fn output_names(&self) -> Vec<String> {
        let mut o: Vec<String> = [
            chan::MOTOR_SPEED_RAD_S,
            chan::MOTOR_ANGLE_RAD,
            chan::WHEEL_ANGLE_RAD,
        ]
        .map(String::from)
        .to_vec();
        match self.input {
            // The armature current follows the command, not a law of this model.
            AxisInput::Torque(TorqueCommand {
                feedback: Some(_),
                column,
                ..
            }) => o.push(column.into()),
            AxisInput::Torque(_) => {}
            AxisInput::Voltage | AxisInput::Demand => o.insert(1, chan::CURRENT_A.into()),
        }
        o
    }

    fn reports(&self, i: usize) -> bool {
        let armature = [RESISTANCE, INDUCTANCE, TORQUE_CONSTANT];
        !(matches!(self.input, AxisInput::Torque(_))
            && armature.contains(&self.specs[i].name.as_str()))
    }
}

impl Dynamics for RotaryAxis {
    type Blocks = AxisBlocks;
    type Output = AxisOutput;

    #[inline]
    fn blocks(&self, p: &[f64]) -> AxisBlocks {
        self.blocks_of(&self.declared(p))
    }

    fn n_held(&self) -> usize {
        1
    }

    fn hold(&self, _b: &AxisBlocks, _t_s: f64, x: &[f64], u: &[f64], held: &mut [f64]) {
        held[0] = match self.input {
            AxisInput::Torque(TorqueCommand {
                feedback: Some(c),
                limit,
                ..
            }) => {
                // The digital loop samples the wheel and holds its command.
                (c.kv_v_s_rad * (c.kp_1_s * (u[0] - x[4]) - self.wheel_speed(x)))
                    .bounded(-limit, limit)
            }
            _ => u[0],
        };
    }

    /// Current, motor speed, motor angle, wheel speed and angle (backlash block), the
    /// speed-loop integral (speed-feedback block), the heat (thermal-drift term) and the
    /// time since the record's start (time-drift term).
    fn n_states(&self) -> usize {
        8
    }

    fn initial_state(&self, _b: &AxisBlocks, data: &Dataset) -> Vec<f64> {
        let angle = data
            .first_measured(chan::MOTOR_ANGLE_RAD)
            .or_else(|| {
                data.first_measured(chan::WHEEL_ANGLE_RAD)
                    .map(|a| a * self.ratio)
            })
            .unwrap_or(0.0);
        // The clock reads the record's time (a time drift's, the measured angle's line's).
        let t0 = data.t_s.first().copied().unwrap_or(0.0);
        vec![0.0, 0.0, angle, 0.0, angle / self.ratio, 0.0, 0.0, t0]
    }

    fn max_step_s(&self, b: &AxisBlocks) -> f64 {
        // RK4 is accurate to 2 % on a decaying mode at h = its time constant.
        let d = &b.drivetrain;
        let mut h = match self.input {
            AxisInput::Torque(_) => 0.2 * b.mechanical_time_constant_s,
            _ => d
                .motor
                .electrical_time_constant_s()
                .min(0.2 * b.mechanical_time_constant_s),
        };
        if b.play {
            h = h.min(MESH_STEP_RATE / d.mesh_rate());
        }
        h
    }

    fn input_delay_s(&self, b: &AxisBlocks) -> f64 {
        b.supply.delay_s
    }

    fn event_fraction(&self, b: &AxisBlocks, before: &[f64], after: &[f64], h: f64) -> Option<f64> {
        if !b.play {
            return None;
        }
        let d = &b.drivetrain;
        let (twist_before, twist_rate) = d.twist(&drivetrain_state(before));
        let twist_after = d.twist(&drivetrain_state(after)).0;
        d.gearbox
            .flank_crossing(twist_before, twist_after, twist_rate * h)
    }

    /// The order of one evaluation: the terminal voltage (DCMC, bridges, battery), the
    /// armature (or the torque amplifier's command), the rotor's torque balance, then the
    /// wheel: turning with the rotor through rigid gears, or on its own side of the play,
    /// driven by the teeth and braked by its bearings.
    fn derivatives(&self, b: &AxisBlocks, x: &[f64], u: &[f64], held: &[f64], dx: &mut [f64]) {
        let d = &b.drivetrain;
        let s = drivetrain_state(x);
        let (v, integral_rate) = self.terminal_voltage(b, &s, x[SPEED_LOOP_INTEGRAL], u[0]);
        dx[SPEED_LOOP_INTEGRAL] = integral_rate;
        dx[CLOCK] = 1.0;
        // A term that changes the motor (heat, a drift, a falling torque constant) does so
        // before the armature and the rotor are evaluated.
        let changed;
        let motor = match &b.term {
            Some(t) => {
                dx[HEAT] =
                    term::heat_rate_a2_s(x[HEAT], s.motor.current_a, t.thermal_time_constant_s);
                changed = t.motor_at(&d.motor, s.motor.current_a, x[HEAT], x[CLOCK]);
                &changed
            }
            None => {
                dx[HEAT] = 0.0;
                &d.motor
            }
        };
        let w = s.motor.speed_rad_s;
        let motor_torque = match self.input {
            AxisInput::Torque(c) => {
                dx[0] = 0.0;
                let command = if c.feedback.is_some() { held[0] } else { u[0] };
                Self::commanded_torque(&c, command)
            }
            AxisInput::Voltage | AxisInput::Demand => {
                dx[0] = motor.current_rate_a_s(v, s.motor.current_a, w);
                motor.electromagnetic_torque_nm(s.motor.current_a)
            }
        };
        let eps = self.coulomb_eps_rad_s;
        // The term's torques: motor-side (a periodic torque, friction as a share of the
        // torque carried) and wheel-side (drag, a periodic torque), N m.
        let (motor_side, wheel_side) = match &b.term {
            Some(t) => {
                // A periodic term is fitted on the angle the encoder measured (its line
                // over the sample interval, inputs 1 and 2), the others on the model's own.
                let (motor_angle, wheel_angle) = if self.measured_angle() {
                    let a = u[1] + u[2] * x[CLOCK];
                    (a, a / self.ratio)
                } else {
                    (s.motor.angle_rad, s.wheel_angle_rad)
                };
                (
                    t.motor_side_torque_nm(motor_angle)
                        + term::load_friction_torque_nm(
                            t.load_friction_ratio,
                            motor_torque,
                            w,
                            eps,
                        ),
                    t.wheel_side_torque_nm(wheel_angle, self.wheel_speed(x)),
                )
            }
            None => (0.0, 0.0),
        };
        if b.play {
            let n = d.gearbox.ratio;
            let tooth = d.tooth_torque_nm(&s);
            let driving = motor.driving_torque_nm(motor_torque + motor_side, tooth / n);
            dx[1] = motor.rotor_acceleration_rad_s2(driving, w, eps, motor.rotor_inertia_kg_m2);
            let ww = s.wheel_speed_rad_s;
            dx[3] = (tooth - d.wheel_bearing_torque_nm(ww) + wheel_side) / d.wheel.inertia_kg_m2;
            dx[4] = ww;
        } else {
            let driving =
                motor.driving_torque_nm(motor_torque + motor_side + wheel_side / self.ratio, 0.0);
            let inertia =
                motor.rotor_inertia_kg_m2 + d.wheel.inertia_kg_m2 / (self.ratio * self.ratio);
            dx[1] = motor.rotor_acceleration_rad_s2(driving, w, eps, inertia);
            dx[3] = 0.0;
            dx[4] = w / self.ratio;
        }
        dx[2] = w;
    }

    fn output_of(&self, name: &str) -> AxisOutput {
        match name {
            chan::COMMAND_V => AxisOutput::Command,
            chan::MOTOR_SPEED_RAD_S => AxisOutput::MotorSpeed,
            chan::CURRENT_A => AxisOutput::Current,
            chan::MOTOR_ANGLE_RAD => AxisOutput::MotorAngle,
            chan::WHEEL_ANGLE_RAD => AxisOutput::WheelAngle,
            _ => AxisOutput::Other,
        }
    }

    fn output_kind(&self, o: AxisOutput) -> OutputKind {
        if o == AxisOutput::MotorSpeed && self.encoder {
            OutputKind::IntervalRate(2)
        } else {
            OutputKind::Instant
        }
    }

    fn output(&self, _b: &AxisBlocks, o: AxisOutput, x: &[f64], _u: &[f64], held: &[f64]) -> f64 {
        match o {
            AxisOutput::Command => held[0],
            AxisOutput::MotorSpeed => x[1],
            AxisOutput::Current => x[0],
            AxisOutput::MotorAngle => x[2],
            AxisOutput::WheelAngle => x[4],
            AxisOutput::Other => f64::NAN,
        }
    }
}

/// What a drive axis's output column is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AxisOutput {
    /// `command_V`, as the loop held it.
    Command,
    /// `motor_speed_rad_s`.
    MotorSpeed,
    /// `current_A`.
    Current,
    /// `motor_angle_rad`.
    MotorAngle,
    /// `wheel_angle_rad`.
    WheelAngle,
    /// A column the model does not produce.
    Other,
}
