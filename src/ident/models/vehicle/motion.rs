//! How the vehicle moves within one evaluation: what the gear trains deliver to the
//! wheels, the wheels and chassis rolling together or joined by the tyres' slip forces,
//! the castors' drag, and the longest integration step the tyres' stiffness allows.

use crate::ident::models::rotary_axis::{drivetrain_state, MESH_STEP_RATE};
use crate::model::tyre::{steady_slip_force, ContactKinematics};

use crate::ident::effects::Effect;

use super::blocks::VehicleBlocks;
use super::{Vehicle, BODY, SIDE, SLIP_SPEED_FLOOR_M_S};

impl Vehicle {
    /// Longest integration step, s, with the tyres' slip measured against a contact speed
    /// of `slip_denominator_m_s` (at least the floor of a tyre at rest).
    pub(super) fn step_bound(&self, b: &VehicleBlocks, slip_denominator_m_s: f64) -> f64 {
        let d = &b.drivetrain;
        let mut h = d.motor.electrical_time_constant_s();
        if b.play {
            h = h.min(MESH_STEP_RATE / d.mesh_rate());
        }
        if b.peak_mu.is_none() && !self.creeping_tyres {
            // Rolling without slip: no tyre between wheel and floor to resolve.
            return h;
        }
        let load = b.drive_wheel_load_n;
        let [long_stiffness, lat_stiffness] = b.tyre_stiffness_per_n;
        // The tyre's slip force is a stiff damper on the rim speed: explicit RK4 needs
        // h lambda below 2.8; at 2 the fast mode still decays monotonically enough, as it
        // does physically, while the slow dynamics are integrated accurately.
        let rim_damping = load * long_stiffness / slip_denominator_m_s;
        let wheel_j = b.body.wheel_inertia_kg_m2;
        let r = d.wheel.radius_m;
        let lambda_long = rim_damping * r * r / wheel_j;
        let lambda_lat = 2.0 * load * lat_stiffness / slip_denominator_m_s / b.body.mass_kg;
        h.min(2.0 / lambda_long.max(lambda_lat))
    }

    /// One side's gear twist across the play (rad, its motor's angle through the ratio
    /// less its wheel's) and the twist's rate (rad/s), from the side's states.
    pub(super) fn twist(b: &VehicleBlocks, x: &[f64], side: usize) -> (f64, f64) {
        b.drivetrain.twist(&drivetrain_state(&x[side * SIDE..]))
    }

    /// Torque the gear train delivers to each wheel's axle (N m), writing the motor side's
    /// speed rate when a gear play separates motor and wheel. `driving` is each motor's
    /// torque before its friction. Rigid gears: the motor's torque less its friction,
    /// times the ratio (the rotor turns with the wheel: `VehicleBlocks::body`).
    fn wheel_side(
        &self,
        b: &VehicleBlocks,
        x: &[f64],
        driving: [f64; 2],
        dx: &mut [f64],
    ) -> [f64; 2] {
        let d = &b.drivetrain;
        let eps = self.coulomb_eps_rad_s;
        let mut torque = [0.0; 2];
        for side in 0..2 {
            let s = drivetrain_state(&x[side * SIDE..]);
            let w = s.motor.speed_rad_s;
            if b.play {
                let tooth = d.tooth_torque_nm(&s);
                let net = driving[side] - tooth / d.gearbox.ratio;
                dx[side * SIDE + 1] =
                    d.motor
                        .rotor_acceleration_rad_s2(net, w, eps, d.motor.rotor_inertia_kg_m2);
                torque[side] = tooth - d.wheel_bearing_torque_nm(s.wheel_speed_rad_s);
            } else {
                torque[side] =
                    d.gearbox.ratio * (driving[side] - d.motor.friction_torque_nm(w, eps));
            }
        }
        torque
    }

    /// Wheels that roll without slipping: the chassis and everything turning with the
    /// wheels accelerate together (the simulator's no-slip body), the wheel speeds
    /// following the chassis's motion.
    pub(super) fn rolling(&self, b: &VehicleBlocks, x: &[f64], driving: [f64; 2], dx: &mut [f64]) {
        let torque = self.wheel_side(b, x, driving, dx);
        let body = &b.body;
        let (fwd, yaw_rate) = (x[BODY], x[BODY + 2]);
        let drag = self.castor_drag(b, fwd, 0.0, yaw_rate);
        let [acc, yaw_acc] = body.accelerations(fwd, yaw_rate, torque, [drag[0], drag[2]]);
        let rim_acc = body.rim_speeds_m_s(acc, yaw_acc);
        for (side, rim_acc) in rim_acc.iter().enumerate() {
            self.set_wheel_rates(x, side * SIDE, rim_acc / body.wheel_radii_m[side], dx);
        }
        dx[BODY] = acc;
        dx[BODY + 1] = 0.0;
        dx[BODY + 2] = yaw_acc;
    }

    /// Wheels and chassis joined by the tyres' slip forces: their creep, and with the
    /// wheel-slip block their grip limited by the friction coefficient.
    pub(super) fn slipping(&self, b: &VehicleBlocks, x: &[f64], driving: [f64; 2], dx: &mut [f64]) {
        let (fwd, lat, yaw_rate) = (x[BODY], x[BODY + 1], x[BODY + 2]);
        let torque = self.wheel_side(b, x, driving, dx);
        let wheel_inertia = b.body.wheel_inertia_kg_m2;
        let (r, track) = (b.body.wheel_radii_m[0], b.body.track_width_m);
        let mut force = [[0.0; 2]; 2];
        for side in 0..2 {
            let s = side * SIDE;
            let ww = self.wheel_speed_rad_s(x, s);
            // Left wheel at +track/2 in the chassis frame (y to the left).
            let offset = if side == 0 { -0.5 } else { 0.5 } * track;
            let kin = ContactKinematics {
                forward_m_s: fwd + yaw_rate * offset,
                lateral_m_s: lat,
                rim_m_s: ww * r,
            };
            let f = steady_slip_force(
                kin,
                b.drive_wheel_load_n,
                b.tyre_stiffness_per_n,
                SLIP_SPEED_FLOOR_M_S,
                b.peak_mu,
            );
            // The ground pushes the chassis forward by f[0] and resists the wheel by f[0] R.
            self.set_wheel_rates(x, s, (torque[side] - f[0] * r) / wheel_inertia, dx);
            force[side] = f;
        }
        let drag = self.castor_drag(b, fwd, lat, yaw_rate);
        let fx = force[0][0] + force[1][0] + drag[0];
        let fy = force[0][1] + force[1][1] + drag[1];
        let yaw_torque = (force[1][0] - force[0][0]) * 0.5 * track + drag[2];
        let mass = b.body.mass_kg;
        dx[BODY] = fx / mass + lat * yaw_rate;
        dx[BODY + 1] = fy / mass - fwd * yaw_rate;
        dx[BODY + 2] = yaw_torque / b.body.yaw_inertia_kg_m2;
    }

    /// Speed of the wheel of the side whose states start at `s`, rad/s: its own state
    /// behind a gear play, the motor's over the ratio through rigid gears.
    pub(super) fn wheel_speed_rad_s(&self, x: &[f64], s: usize) -> f64 {
        if self.effect(Effect::Backlash).is_some() {
            x[s + 3]
        } else {
            x[s + 1] / self.ratio
        }
    }

    /// Writes the rates of a side's wheel states for a wheel acceleration (rad/s^2): the
    /// wheel's own speed behind a gear play, else the motor's (the ratio times it).
    fn set_wheel_rates(&self, x: &[f64], s: usize, wheel_acc: f64, dx: &mut [f64]) {
        if self.effect(Effect::Backlash).is_some() {
            dx[s + 3] = wheel_acc;
        } else {
            dx[s + 1] = self.ratio * wheel_acc;
            dx[s + 3] = 0.0;
        }
        dx[s + 4] = self.wheel_speed_rad_s(x, s);
    }

    /// The castor-drag block's forward and lateral force (N) and yaw moment (N m) on the
    /// chassis; zero without the block. The idlers' rolling drag is lumped at a distance
    /// `lever` from the axle midpoint: it opposes their contact's motion over the floor,
    /// which is the chassis's motion plus the turn's sweep, so it resists turning as well.
    fn castor_drag(&self, b: &VehicleBlocks, fwd: f64, lat: f64, yaw_rate: f64) -> [f64; 3] {
        let Some(c) = b.castors else {
            return [0.0; 3];
        };
        let [f_fwd, f_lat, f_sweep] = crate::model::castor::rolling_drag_n(
            c.drag_n,
            [fwd, lat, yaw_rate * c.lever_m],
            self.drag_eps_m_s,
        );
        [f_fwd, f_lat, c.lever_m * f_sweep]
    }
}
