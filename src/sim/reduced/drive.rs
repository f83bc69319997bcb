//! The reduced base's drivetrains: armature, rigid gears (or rigid flanks across a play),
//! wheel and bristle tyre, one sub-step at a time against the chassis's motion.

use super::ReducedBase;
use crate::model::motor::{coulomb_viscous_update, viscous_coefficient};
use crate::model::tyre::ContactKinematics;

impl ReducedBase {
    /// Both drivetrains over a sub-step `h` against the chassis's motion at its start.
    /// Returns the tyres' forces on the chassis (wheel frame, N).
    pub(super) fn advance_drivetrains(&mut self, h: f64) -> [[f64; 2]; 2] {
        let kin = self.contact_kinematics();
        let load = self.params.loads.drive_n;
        let mut force = [[0.0; 2]; 2];
        for i in 0..2 {
            self.armature(i);
            force[i] = if self.fixed.play {
                self.play_substep(i, kin[i], load[i], h)
            } else {
                let w = self.drive[i].wheel_speed_rad_s;
                self.geared_motion(i, w, kin[i], load[i], h)
            };
        }
        self.tyre_force_n = force;
        force
    }

    /// Each wheel's contact motion (forward, lateral, m/s) at the chassis's motion now:
    /// the left wheel at `+track/2` (y to the left), the right at `-track/2`.
    fn contact_kinematics(&self) -> [ContactKinematics; 2] {
        let [u, v] = self.body.velocity_m_s;
        let w = self.body.yaw_rate_rad_s;
        let half = 0.5 * self.params.chassis.track_width_m;
        [half, -half].map(|y| ContactKinematics {
            forward_m_s: u - w * y,
            lateral_m_s: v,
            rim_m_s: 0.0,
        })
    }

    /// The armature of side `i` over a sub-step: its exact first-order solution at the
    /// step's voltage and the motor's speed at its start (the simulator's
    /// `MotorParams::current_after`, its decay worked out once).
    fn armature(&mut self, i: usize) {
        let m = &self.params.drivetrain.motor;
        let s = &mut self.drive[i].motor;
        let steady = (self.motor_v[i] - m.back_emf_v(s.speed_rad_s)) / m.resistance_ohm;
        s.current_a = steady + (s.current_a - steady) * self.fixed.armature_decay;
    }

    /// The simulator's bristle tyre of wheel `i` over `h` at the rim speed `rim_m_s`: the
    /// force of the ground on the chassis (wheel frame, N); it resists the wheel by the
    /// forward part times the rolling radius. Its state moves on.
    fn tyre_force(
        &mut self,
        i: usize,
        kin: ContactKinematics,
        rim_m_s: f64,
        load: f64,
        h: f64,
    ) -> [f64; 2] {
        let kin = ContactKinematics { rim_m_s, ..kin };
        let bristles = self.fixed.bristles[i];
        self.fixed
            .tyre
            .step_force_with(&mut self.tyres[i], kin, load, bristles, h)
            .force_n
    }

    /// Wheel `i`'s tyre as the wheel's update sees it at rim speed `rim_m_s`, its state
    /// unmoved: the forward force (N) and its rate in the rim speed over the sub-step (N
    /// s/m), `(k h + c) / (1 + h |v| / L)` of the bristles' implicit update (0 on the
    /// friction limit). The stiff bristles then load the wheel implicitly: its new speed
    /// is solved with the force at the new rim speed, so no sub-step has to resolve them.
    fn tyre_rate(
        &self,
        i: usize,
        kin: ContactKinematics,
        rim_m_s: f64,
        load: f64,
        h: f64,
    ) -> (f64, f64) {
        let t = &self.fixed.tyre;
        let b = self.fixed.bristles[i];
        let kin = ContactKinematics { rim_m_s, ..kin };
        let mut trial = self.tyres[i];
        let out = t.step_force_with(&mut trial, kin, load, b, h);
        if out.sliding || load <= 0.0 {
            return (out.force_n[0], 0.0);
        }
        let speed = kin.forward_m_s.abs().max(rim_m_s.abs());
        let relax = 1.0 + h * speed / t.relaxation_length_m;
        let rate = (b.stiffness_n_m[0] * h + b.damping_n_s_m[0]) / relax;
        (out.force_n[0], rate)
    }

    /// Wheel `i` and its motor turning as one from the wheel speed `w` (rad/s) over `h`:
    /// the motor's torque through the gear against the friction of motor and bearings
    /// (Coulomb set-valued, as the simulator's rotor: [`coulomb_viscous_update`]) and the
    /// tyre. Returns the tyre's force.
    pub(super) fn geared_motion(
        &mut self,
        i: usize,
        w: f64,
        kin: ContactKinematics,
        load: f64,
        h: f64,
    ) -> [f64; 2] {
        let d = self.params.drivetrain;
        let (m, n) = (&d.motor, d.gearbox.ratio);
        let r = self.params.rolling_radii_m[i];
        // The tyre's force at the new rim speed, F0 + rate r (w' - w): a torque now and a
        // damping on the new speed.
        let (f0, rate) = self.tyre_rate(i, kin, w * r, load, h);
        let driving = n * m.driving_torque_nm(
            m.electromagnetic_torque_nm(self.drive[i].motor.current_a),
            0.0,
        );
        let viscous = n * n * viscous_coefficient(m.viscous_nm_s_rad, m.viscous_ratio, w)
            + d.wheel.viscous_nm_s_rad
            + rate * r * r;
        let w_new = coulomb_viscous_update(
            w,
            driving - r * f0 + rate * r * r * w,
            viscous,
            n * m.coulomb_nm,
            self.fixed.geared_kg_m2,
            h,
        );
        let force = self.tyre_force(i, kin, w_new * r, load, h);
        let s = &mut self.drive[i];
        s.wheel_speed_rad_s = w_new;
        s.wheel_angle_rad += h * w_new;
        s.motor.speed_rad_s = n * w_new;
        s.motor.angle_rad += h * n * w_new;
        force
    }

    /// Wheel `i` behind a gear play over `h`, the teeth as rigid flanks: apart, the motor
    /// and the wheel each move alone (the motor against its friction, the wheel against
    /// its bearings and tyre); where that would close the play, the flanks meet without
    /// rebound (the two sides' momentum shared at the wheel) and turn as one
    /// ([`Self::geared_motion`]), the play held closed. Returns the tyre's force.
    fn play_substep(&mut self, i: usize, kin: ContactKinematics, load: f64, h: f64) -> [f64; 2] {
        let d = self.params.drivetrain;
        let (m, n) = (&d.motor, d.gearbox.ratio);
        let r = self.params.rolling_radii_m[i];
        let s = self.drive[i];
        let (w_m, w) = (s.motor.speed_rad_s, s.wheel_speed_rad_s);
        let motor_free = coulomb_viscous_update(
            w_m,
            m.driving_torque_nm(m.electromagnetic_torque_nm(s.motor.current_a), 0.0),
            viscous_coefficient(m.viscous_nm_s_rad, m.viscous_ratio, w_m),
            m.coulomb_nm,
            m.rotor_inertia_kg_m2,
            h,
        );
        let (f0, rate) = self.tyre_rate(i, kin, w * r, load, h);
        let j = d.wheel.inertia_kg_m2;
        let wheel_free = (w + h * (rate * r * r * w - r * f0) / j)
            / (1.0 + h * (d.wheel.viscous_nm_s_rad + rate * r * r) / j);
        let half = d.gearbox.half_play_rad();
        let twist = d.twist(&s).0 + h * (motor_free / n - wheel_free);
        if twist.abs() < half {
            let force = self.tyre_force(i, kin, wheel_free * r, load, h);
            let s = &mut self.drive[i];
            s.motor.speed_rad_s = motor_free;
            s.motor.angle_rad += h * motor_free;
            s.wheel_speed_rad_s = wheel_free;
            s.wheel_angle_rad += h * wheel_free;
            return force;
        }
        // The flanks meet: the momentum of both sides, at the wheel, shared.
        let rotor_at_wheel = n * n * m.rotor_inertia_kg_m2;
        let shared = (rotor_at_wheel * w_m / n + j * w) / (rotor_at_wheel + j);
        let force = self.geared_motion(i, shared, kin, load, h);
        let s = &mut self.drive[i];
        s.motor.angle_rad = n * (s.wheel_angle_rad + half * twist.signum());
        force
    }
}
