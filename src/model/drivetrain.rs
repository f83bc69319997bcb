//! One side's drivetrain: motor, gearbox (with backlash) and wheel, and the sub-step that
//! keeps the stiff tooth contact stable.

use super::gearbox::GearboxParams;
use super::motor::{MotorParams, MotorState, Terminal};
use super::term::{self, TermParams};
use super::wheel::WheelParams;

/// Motor, gearbox and wheel of one side.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DrivetrainParams {
    /// The motor.
    pub motor: MotorParams,
    /// The gear train.
    pub gearbox: GearboxParams,
    /// The wheel with its output gear and bearings (on the wheel's side of the play).
    pub wheel: WheelParams,
    /// A term outside the vocabulary acting in the drivetrain (`[term]`), if any.
    pub term: Option<TermParams>,
}

/// What is integrated: the motor and the wheel (the gear output angle is motor angle / ratio).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DrivetrainState {
    /// The motor's state.
    pub motor: MotorState,
    /// Wheel speed, rad/s.
    pub wheel_speed_rad_s: f64,
    /// Wheel angle, rad.
    pub wheel_angle_rad: f64,
    /// What a term outside the vocabulary integrates (unused without one).
    pub term: TermState,
}

/// The state a term brings: the windings' heat and the time it has acted.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TermState {
    /// The square of the current low-passed over the thermal time constant, A^2
    /// ([`term::heat_after_a2`]).
    pub heat_a2: f64,
    /// Time since the run's start, s (what a steady drift has acted over).
    pub elapsed_s: f64,
    /// What a periodic term adds to the motor angle it is read at, rad: zero in a run; in
    /// a replay, the recording's encoder angle less the simulated one at the last row
    /// (the replay's angle drifts from the machine's by its speed error, and a periodic
    /// torque must act at the machine's phase).
    pub phase_correction_rad: f64,
}

impl DrivetrainState {
    /// Both sides of the play centred (teeth not touching) and at rest.
    pub fn at_rest() -> Self {
        DrivetrainState::default()
    }
}

impl DrivetrainParams {
    /// Gear output angle minus wheel angle, rad, and its rate.
    #[inline]
    pub fn twist(&self, s: &DrivetrainState) -> (f64, f64) {
        let n = self.gearbox.ratio;
        (
            s.motor.angle_rad / n - s.wheel_angle_rad,
            s.motor.speed_rad_s / n - s.wheel_speed_rad_s,
        )
    }

    /// Torque the teeth pass to the wheel now, N m.
    #[inline]
    pub fn tooth_torque_nm(&self, s: &DrivetrainState) -> f64 {
        let (twist, rate) = self.twist(s);
        self.gearbox.tooth_contact_torque(twist, rate)
    }

    /// The wheel bearings' friction torque at a wheel speed, N m (opposing it).
    #[inline]
    pub fn wheel_bearing_torque_nm(&self, wheel_speed_rad_s: f64) -> f64 {
        self.wheel.bearing_torque_nm(wheel_speed_rad_s)
    }

    /// Fastest rate of the tooth mesh between the rotor and the wheel, 1/s
    /// ([`GearboxParams::mesh_rate`]).
    #[inline]
    pub fn mesh_rate(&self) -> f64 {
        self.gearbox
            .mesh_rate(self.reflected_motor_inertia(), self.wheel.inertia_kg_m2)
    }

    /// Motor inertia seen at the wheel, kg m^2.
    #[inline]
    pub fn reflected_motor_inertia(&self) -> f64 {
        self.motor.rotor_inertia_kg_m2 * self.gearbox.ratio.powi(2)
    }

    /// Sub-steps needed in a step of `dt`: the semi-implicit update of a spring-damper of
    /// natural frequency w and damping rate c/J is stable for h (w + c/J) < 2; we take
    /// h (w + c/J) <= 0.3 for the tooth mesh and for any extra ground stiffness (the tyre)
    /// acting on the wheel, which also keeps the phase error of the mesh ringing small.
    /// `ground_stiffness_n_m` and `ground_damping_n_s_m` are the tyre's at the rim.
    pub fn substeps(&self, dt: f64, ground_stiffness_n_m: f64, ground_damping_n_s_m: f64) -> usize {
        let jw = self.wheel.inertia_kg_m2;
        let mesh_rate = self.mesh_rate();
        let r2 = self.wheel.radius_m.powi(2);
        let ground_rate = (ground_stiffness_n_m * r2 / jw).sqrt() + ground_damping_n_s_m * r2 / jw;
        let rate = mesh_rate.max(ground_rate);
        ((dt * rate / 0.3).ceil() as usize).max(1)
    }

    /// Motor half of a sub-step: the armature and rotor, loaded by the teeth. A term
    /// changes the motor first (its resistance with the heat or a drift, its torque
    /// constant with the current), adds its motor-side periodic torque, and raises the
    /// Coulomb level by its share of the torque carried (`load_dependent_friction`, the
    /// set-valued law as the motor's own Coulomb friction); its heat and clock then move
    /// on over the sub-step.
    pub fn motor_substep(
        &self,
        s: &mut DrivetrainState,
        terminal: Terminal,
        tooth_torque_nm: f64,
        h: f64,
    ) {
        let load_nm = tooth_torque_nm / self.gearbox.ratio;
        let Some(t) = &self.term else {
            self.motor.step(&mut s.motor, terminal, load_nm, h);
            return;
        };
        let current_a = s.motor.current_a;
        let mut motor = t.motor_at(&self.motor, current_a, s.term.heat_a2, s.term.elapsed_s);
        motor.coulomb_nm +=
            t.load_friction_ratio * motor.electromagnetic_torque_nm(current_a).abs();
        let periodic_nm = t.motor_side_torque_nm(s.motor.angle_rad + s.term.phase_correction_rad);
        motor.step(&mut s.motor, terminal, load_nm - periodic_nm, h);
        s.term.heat_a2 = term::heat_after_a2(
            s.term.heat_a2,
            s.motor.current_a,
            t.thermal_time_constant_s,
            h,
        );
        s.term.elapsed_s += h;
    }

    /// The wheel-side torque of a term at the wheel now (drag, a periodic torque), N m;
    /// zero without one.
    #[inline]
    pub fn wheel_term_torque_nm(&self, s: &DrivetrainState) -> f64 {
        self.term.as_ref().map_or(0.0, |t| {
            let phase = s.wheel_angle_rad + s.term.phase_correction_rad / self.gearbox.ratio;
            t.wheel_side_torque_nm(phase, s.wheel_speed_rad_s)
        })
    }

    /// Wheel half of a sub-step when the wheel turns on its own (lifted, or on a tyre whose
    /// torque about the axle is `ground_torque_nm`, positive forward), with a term's
    /// wheel-side torque; the bearings' viscous friction implicit, as the motor's is.
    pub fn wheel_substep(
        &self,
        s: &mut DrivetrainState,
        tooth_torque_nm: f64,
        ground_torque_nm: f64,
        h: f64,
    ) {
        let j = self.wheel.inertia_kg_m2;
        let driving = tooth_torque_nm + ground_torque_nm + self.wheel_term_torque_nm(s);
        let trial = s.wheel_speed_rad_s + h * driving / j;
        s.wheel_speed_rad_s = trial / (1.0 + h * self.wheel.viscous_nm_s_rad / j);
        s.wheel_angle_rad += h * s.wheel_speed_rad_s;
    }
}
