//! How the vehicle moves within one evaluation: what the gear trains deliver to the
//! wheels, the wheels and chassis rolling together or joined by the tyres' slip forces,
//! the castors' drag, and the longest integration step the tyres' stiffness allows.

use crate::ident::effects::Effect;
use crate::ident::models::rotary_axis::MESH_STEP_RATE;
use crate::model::chassis::NoSlipBody;
use crate::model::tyre::{steady_slip_force, ContactKinematics};

use super::{
    Vehicle, B, BODY, IZ, JM, JW, L, LAT_STIFFNESS, LONG_STIFFNESS, MASS, R, RW, SIDE,
    SLIP_SPEED_FLOOR_M_S, TRACK,
};

impl Vehicle {
    /// Longest integration step, s, with the tyres' slip measured against a contact speed
    /// of `slip_denominator_m_s` (at least the floor of a tyre at rest).
    pub(super) fn step_bound(&self, p: &[f64], slip_denominator_m_s: f64) -> f64 {
        let n2 = self.ratio * self.ratio;
        let mut h = p[L] / p[R];
        if let Some(play) = self.effect(Effect::Backlash) {
            let rate = self.gearbox(p, play).mesh_rate(p[JM] * n2, p[JW]);
            h = h.min(MESH_STEP_RATE / rate);
        }
        if self.effect(Effect::WheelSlip).is_none() && !self.creeping_tyres {
            // Rolling without slip: no tyre between wheel and floor to resolve.
            return h;
        }
        let load = self.drive_wheel_load_n(p);
        // The tyre's slip force is a stiff damper on the rim speed: explicit RK4 needs
        // h lambda below 2.8; at 2 the fast mode still decays monotonically enough, as it
        // does physically, while the slow dynamics are integrated accurately.
        let rim_damping = load * p[LONG_STIFFNESS] / slip_denominator_m_s;
        let wheel_j = if self.effect(Effect::Backlash).is_some() {
            p[JW]
        } else {
            p[JW] + p[JM] * n2
        };
        let lambda_long = rim_damping * p[RW] * p[RW] / wheel_j;
        let lambda_lat = 2.0 * load * p[LAT_STIFFNESS] / slip_denominator_m_s / p[MASS];
        h.min(2.0 / lambda_long.max(lambda_lat))
    }

    /// One side's gear twist across the play (rad, its motor's angle through the ratio
    /// less its wheel's) and the twist's rate (rad/s), from the side's states.
    pub(super) fn twist(&self, x: &[f64], side: usize) -> (f64, f64) {
        let s = side * SIDE;
        let n = self.ratio;
        (x[s + 2] / n - x[s + 4], x[s + 1] / n - x[s + 3])
    }

    /// Torque the gear train delivers to each wheel's axle (N m) and the inertia turning
    /// with the wheel there (kg m^2), writing the motor side's speed rate when a gear play
    /// separates motor and wheel. Rigid gears: the motor's torque less its viscous
    /// friction, times the ratio, with the rotor's inertia times the ratio squared.
    fn wheel_side(&self, p: &[f64], x: &[f64], drive: [f64; 2], dx: &mut [f64]) -> ([f64; 2], f64) {
        let n = self.ratio;
        let mut torque = [0.0; 2];
        let inertia = match self.effect(Effect::Backlash) {
            None => {
                for side in 0..2 {
                    let wm = x[side * SIDE + 1];
                    torque[side] = n * (drive[side] - p[B] * wm);
                }
                p[JW] + p[JM] * n * n
            }
            Some(play) => {
                let g = self.gearbox(p, play);
                let share = p[play - 1];
                let (b_motor, b_wheel) = (p[B] * (1.0 - share), p[B] * share * n * n);
                for side in 0..2 {
                    let s = side * SIDE;
                    let (wm, ww) = (x[s + 1], x[s + 3]);
                    let (twist, twist_rate) = self.twist(x, side);
                    let tooth = g.tooth_contact_torque(twist, twist_rate);
                    dx[s + 1] = (drive[side] - b_motor * wm - tooth / n) / p[JM];
                    torque[side] = tooth - b_wheel * ww;
                }
                p[JW]
            }
        };
        (torque, inertia)
    }

    /// Wheels that roll without slipping: the chassis and everything turning with the
    /// wheels accelerate together (the simulator's no-slip body, centre of mass at the
    /// axle), the wheel speeds following the chassis's motion.
    pub(super) fn rolling(&self, p: &[f64], x: &[f64], drive: [f64; 2], dx: &mut [f64]) {
        let (torque, wheel_inertia) = self.wheel_side(p, x, drive, dx);
        let body = NoSlipBody {
            mass_kg: p[MASS],
            yaw_inertia_kg_m2: p[IZ],
            cg_ahead_m: 0.0,
            track_width_m: p[TRACK],
            wheel_radius_m: p[RW],
            wheel_inertia_kg_m2: wheel_inertia,
        };
        let (fwd, yaw_rate) = (x[BODY], x[BODY + 2]);
        let drag = self.castor_drag(p, fwd, 0.0, yaw_rate);
        let [acc, yaw_acc] = body.accelerations(fwd, yaw_rate, torque, [drag[0], drag[2]]);
        let rim_acc = body.rim_speeds_m_s(acc, yaw_acc);
        for (side, rim_acc) in rim_acc.iter().enumerate() {
            let s = side * SIDE;
            self.set_wheel_rates(x, s, rim_acc / p[RW], dx);
        }
        dx[BODY] = acc;
        dx[BODY + 1] = 0.0;
        dx[BODY + 2] = yaw_acc;
    }

    /// Wheels and chassis joined by the tyres' slip forces: their creep, and with the
    /// wheel-slip block their grip limited by the friction coefficient `mu`.
    pub(super) fn slipping(
        &self,
        p: &[f64],
        x: &[f64],
        drive: [f64; 2],
        mu: Option<f64>,
        dx: &mut [f64],
    ) {
        let (fwd, lat, yaw_rate) = (x[BODY], x[BODY + 1], x[BODY + 2]);
        let load = self.drive_wheel_load_n(p);
        let (torque, wheel_inertia) = self.wheel_side(p, x, drive, dx);
        let mut force = [[0.0; 2]; 2];
        for side in 0..2 {
            let s = side * SIDE;
            let ww = self.wheel_speed_rad_s(x, s);
            // Left wheel at +track/2 in the chassis frame (y to the left).
            let offset = if side == 0 { -0.5 } else { 0.5 } * p[TRACK];
            let kin = ContactKinematics {
                forward_m_s: fwd + yaw_rate * offset,
                lateral_m_s: lat,
                rim_m_s: ww * p[RW],
            };
            let f = steady_slip_force(
                kin,
                load,
                [p[LONG_STIFFNESS], p[LAT_STIFFNESS]],
                SLIP_SPEED_FLOOR_M_S,
                mu,
            );
            // The ground pushes the chassis forward by f[0] and resists the wheel by f[0] R.
            self.set_wheel_rates(x, s, (torque[side] - f[0] * p[RW]) / wheel_inertia, dx);
            force[side] = f;
        }
        let drag = self.castor_drag(p, fwd, lat, yaw_rate);
        let fx = force[0][0] + force[1][0] + drag[0];
        let fy = force[0][1] + force[1][1] + drag[1];
        let yaw_torque = (force[1][0] - force[0][0]) * 0.5 * p[TRACK] + drag[2];
        dx[BODY] = fx / p[MASS] + lat * yaw_rate;
        dx[BODY + 1] = fy / p[MASS] - fwd * yaw_rate;
        dx[BODY + 2] = yaw_torque / p[IZ];
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
    fn castor_drag(&self, p: &[f64], fwd: f64, lat: f64, yaw_rate: f64) -> [f64; 3] {
        let Some(d) = self.effect(Effect::CastorDrag) else {
            return [0.0; 3];
        };
        let lever = p[d - 1];
        let [f_fwd, f_lat, f_sweep] = crate::model::castor::rolling_drag_n(
            p[d],
            [fwd, lat, yaw_rate * lever],
            self.drag_eps_m_s,
        );
        [f_fwd, f_lat, lever * f_sweep]
    }
}
