//! The reduced base's chassis: one planar rigid body under its tyres' and castors' forces.
//! In its own frame, with `(u, v)` the axle midpoint's velocity, `r` the yaw rate and the
//! centre of gravity at `c` (ahead, left of the axle midpoint):
//! `m (d/dt (u - r c_y) - r (v + r c_x)) = F_x`, `m (d/dt (v + r c_x) + r (u - r c_y)) = F_y`,
//! `I_z dr/dt = sum (p - c) x F` (each force `F` at its point `p`), integrated
//! semi-implicitly (velocities, then the pose at the midpoint heading).
//!
//! The castors push at their swivels as [`castor`](super::castor) says: trailing wheels
//! held by their swivel friction until their tyres' bristles carry it. The simulator's
//! castors are bodies on their tyres; what this leaves out, their forks' swing after a
//! reversal, is a few per cent of the yaw rate's range on hard steps
//! (`tests/one_physics.rs`).

use super::ReducedBase;

impl ReducedBase {
    /// The chassis over a sub-step `h` under the tyres' forces (wheel frame, N: the left
    /// wheel's at `+track/2`, the right's at `-track/2`) and the castors'.
    pub(super) fn advance_body(&mut self, tyre_n: [[f64; 2]; 2], h: f64) {
        let c = &self.params.chassis;
        let (m, iz, cg) = (self.fixed.mass_kg, self.fixed.yaw_inertia_kg_m2, c.cg_m);
        let half = 0.5 * c.track_width_m;
        let [u, v] = self.body.velocity_m_s;
        let w = self.body.yaw_rate_rad_s;
        let mut force = [0.0; 2];
        let mut moment = 0.0;
        let wheels = [[0.0, half], [0.0, -half]];
        for (p, f) in wheels.iter().zip(tyre_n) {
            force[0] += f[0];
            force[1] += f[1];
            moment += (p[0] - cg[0]) * f[1] - (p[1] - cg[1]) * f[0];
        }
        for k in 0..4 {
            let p = self.fixed.castor_points_m[k];
            let pivot_m_s = [u - w * p[1], v + w * p[0]];
            let (f, _) = self.fixed.castors[k].force(&mut self.castors[k], pivot_m_s, w, h);
            force[0] += f[0];
            force[1] += f[1];
            moment += (p[0] - cg[0]) * f[1] - (p[1] - cg[1]) * f[0];
        }
        let yaw_acc = moment / iz;
        let du = force[0] / m + w * (v + w * cg[0]) + cg[1] * yaw_acc;
        let dv = force[1] / m - w * (u - w * cg[1]) - cg[0] * yaw_acc;
        let b = &mut self.body;
        b.velocity_m_s = [u + h * du, v + h * dv];
        b.yaw_rate_rad_s = w + h * yaw_acc;
        let [u, v] = b.velocity_m_s;
        // At the midpoint heading, turned on from the heading's direction rather than
        // worked out from its angle: no sine or cosine in the sub-step.
        let half_turn = 0.5 * h * b.yaw_rate_rad_s;
        let [co, s] = turned(self.heading_dir, half_turn);
        b.pose.x_m += h * (u * co - v * s);
        b.pose.y_m += h * (u * s + v * co);
        b.pose.heading_rad += h * b.yaw_rate_rad_s;
        self.heading_dir = turned([co, s], half_turn);
    }
}

/// A direction (cosine, sine) turned by `angle` (rad): the small turns of a step through
/// their series (to the fifth power: within 3e-11 of the closed form below 0.05 rad),
/// renormalised so that rounding does not grow it; larger turns in closed form.
pub(super) fn turned([c, s]: [f64; 2], angle: f64) -> [f64; 2] {
    let (sin, cos) = if angle.abs() < 0.05 {
        let a2 = angle * angle;
        (
            angle * (1.0 - a2 / 6.0 * (1.0 - a2 / 20.0)),
            1.0 - a2 / 2.0 * (1.0 - a2 / 12.0),
        )
    } else {
        angle.sin_cos()
    };
    let (c2, s2) = (c * cos - s * sin, s * cos + c * sin);
    // One Newton step towards unit length.
    let norm = 0.5 * (3.0 - (c2 * c2 + s2 * s2));
    [c2 * norm, s2 * norm]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_direction_turned_in_small_steps_stays_a_unit_vector_on_its_angle() {
        // A quarter turn in 1000 steps of 1.57 mrad, and one large step.
        let mut d = [1.0, 0.0];
        let n = 1000;
        for _ in 0..n {
            d = turned(d, std::f64::consts::FRAC_PI_2 / n as f64);
        }
        assert!(d[0].abs() < 1e-9 && (d[1] - 1.0).abs() < 1e-9, "{d:?}");
        let d = turned([1.0, 0.0], 1.0);
        assert!((d[0] - 1f64.cos()).abs() < 1e-12 && (d[1] - 1f64.sin()).abs() < 1e-12);
    }
}
