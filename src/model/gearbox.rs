//! Gear train: ratio, and backlash as a dead band between the gear output and the wheel,
//! the teeth a damped spring once the play is taken up (the thesis's Fig. 2.18).

crate::declare_params! {
    /// Gear train between motor and wheel (scene section `[gearbox]`): backlash is a dead
    /// band between the gear output and the wheel, the teeth a damped spring once the
    /// play is taken up. Angles and torques are referred to the wheel side.
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct GearboxParams in "gearbox" {
        /// Motor turns per wheel turn.
        ratio: f64 = 23.41, "", Positive;
        /// Total play at the wheel (about 10 degrees on the thesis AGV).
        backlash_rad: f64 = 10.0_f64.to_radians(), "rad", closed_open(0.0, 1.0);
        /// Tooth (mesh) stiffness referred to the wheel (*assumed*; the thesis softened
        /// its tooth springs to keep a 5 ms step).
        tooth_stiffness_nm_rad as "tooth_stiffness_Nm_rad": f64 = 3000.0, "N m/rad", Positive;
        /// Tooth damping referred to the wheel (*assumed*).
        tooth_damping_nm_s_rad as "tooth_damping_Nm_s_rad": f64 = 4.0, "N m s/rad", NonNegative;
    }
}

/// Which flank of the teeth is in contact.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mesh {
    /// Gear output ahead of the wheel: driving forward.
    Forward,
    /// Inside the play: the motor free-wheels.
    Free,
    /// Gear output behind the wheel: driving backward (or braking forward motion).
    Reverse,
}

impl GearboxParams {
    /// Half the play, rad: the twist at which a flank engages.
    #[inline]
    pub fn half_play_rad(&self) -> f64 {
        0.5 * self.backlash_rad
    }

    /// Which flank touches at a twist (gear output angle minus wheel angle, rad).
    #[inline]
    pub fn mesh(&self, twist_rad: f64) -> Mesh {
        let half = self.half_play_rad();
        if twist_rad > half {
            Mesh::Forward
        } else if twist_rad < -half {
            Mesh::Reverse
        } else {
            Mesh::Free
        }
    }

    /// Where, as a fraction of a step that takes the twist from `before_rad` to
    /// `after_rad`, the teeth first meet or part (a flank at plus or minus half the play
    /// is crossed); `None` when the mesh does not change. The instant is estimated from
    /// the twist rate at the step's start (`before_rate_rad`: that rate times the step,
    /// rad), which the step's end does not yet feel; where that rate does not reach the
    /// flank (the crossing is the acceleration's doing), by linear interpolation.
    #[inline]
    pub fn flank_crossing(
        &self,
        before_rad: f64,
        after_rad: f64,
        before_rate_rad: f64,
    ) -> Option<f64> {
        if self.mesh(before_rad) == self.mesh(after_rad) {
            return None;
        }
        let half = self.half_play_rad();
        let at = |flank: f64| {
            let by_rate = (flank - before_rad) / before_rate_rad;
            if by_rate.is_finite() && by_rate > 0.0 && by_rate < 1.0 {
                by_rate
            } else {
                (flank - before_rad) / (after_rad - before_rad)
            }
        };
        [half, -half]
            .into_iter()
            .filter(|flank| (before_rad - flank).signum() != (after_rad - flank).signum())
            .map(at)
            .filter(|a| a.is_finite())
            .reduce(f64::min)
    }

    /// Fastest rate of the tooth mesh, 1/s: `sqrt(k / J) + c / J` on the reduced inertia of
    /// the two sides (`motor_side` referred to the wheel, `wheel_side`, kg m^2). Explicit
    /// integrators keep `h * rate` small against it.
    #[inline]
    pub fn mesh_rate(&self, motor_side_kg_m2: f64, wheel_side_kg_m2: f64) -> f64 {
        let j_red = motor_side_kg_m2 * wheel_side_kg_m2 / (motor_side_kg_m2 + wheel_side_kg_m2);
        (self.tooth_stiffness_nm_rad / j_red).sqrt() + self.tooth_damping_nm_s_rad / j_red
    }

    /// Torque the teeth pass to the wheel (N m, wheel side; the motor feels `-T/ratio`).
    /// A spring-damper on the penetration past the play; teeth push but never pull, so
    /// the damping term cannot make a separating contact sticky.
    #[inline]
    pub fn tooth_contact_torque(&self, twist_rad: f64, twist_rate_rad_s: f64) -> f64 {
        let half = self.half_play_rad();
        let k = self.tooth_stiffness_nm_rad;
        let c = self.tooth_damping_nm_s_rad;
        match self.mesh(twist_rad) {
            Mesh::Forward => (k * (twist_rad - half) + c * twist_rate_rad_s).max(0.0),
            Mesh::Reverse => (k * (twist_rad + half) + c * twist_rate_rad_s).min(0.0),
            Mesh::Free => 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn teeth_meet_and_part_where_the_twist_crosses_a_flank() {
        let g = GearboxParams {
            ratio: 23.41,
            backlash_rad: 0.2,
            tooth_stiffness_nm_rad: 1000.0,
            tooth_damping_nm_s_rad: 10.0,
        };
        // Flanks at +-0.1 rad: no change inside the play or within one contact.
        assert_eq!(g.flank_crossing(-0.05, 0.05, 0.1), None);
        assert_eq!(g.flank_crossing(0.12, 0.15, 0.03), None);
        // Approaching at 0.02 rad a step, the teeth meet half way through it (the step's
        // end, 0.13, shows the contact's braking, not the approach).
        assert!((g.flank_crossing(0.09, 0.13, 0.02).unwrap() - 0.5).abs() < 1e-12);
        // From rest, pushed by an acceleration: a quarter of the way from 0.09 to 0.13.
        assert!((g.flank_crossing(0.09, 0.13, 0.0).unwrap() - 0.25).abs() < 1e-12);
        // Crossing the whole play backwards: the forward flank is left first.
        assert!((g.flank_crossing(0.15, -0.25, -0.4).unwrap() - 0.125).abs() < 1e-12);
    }

    #[test]
    fn no_torque_inside_the_play_and_push_only_outside() {
        let g = GearboxParams {
            ratio: 23.41,
            backlash_rad: 0.2,
            tooth_stiffness_nm_rad: 1000.0,
            tooth_damping_nm_s_rad: 10.0,
        };
        assert_eq!(g.tooth_contact_torque(0.05, 5.0), 0.0);
        assert!((g.tooth_contact_torque(0.11, 0.0) - 10.0).abs() < 1e-9);
        assert!((g.tooth_contact_torque(-0.11, 0.0) + 10.0).abs() < 1e-9);
        // Separating fast: damping would pull; the teeth let go instead.
        assert_eq!(g.tooth_contact_torque(0.101, -10.0), 0.0);
    }
}
