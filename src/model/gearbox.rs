//! Gear train: ratio, and backlash as a dead band between the gear output and the wheel,
//! the teeth a damped spring once the play is taken up (the thesis's Fig. 2.18).

/// Gearbox parameters; angles and torques referred to the wheel side.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GearboxParams {
    /// Motor turns per wheel turn.
    pub ratio: f64,
    /// Total play at the wheel, rad.
    pub backlash_rad: f64,
    pub tooth_stiffness_nm_rad: f64,
    pub tooth_damping_nm_s_rad: f64,
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
    pub fn half_play_rad(&self) -> f64 {
        0.5 * self.backlash_rad
    }

    /// Which flank touches at a twist (gear output angle minus wheel angle, rad).
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

    /// Fastest rate of the tooth mesh, 1/s: `sqrt(k / J) + c / J` on the reduced inertia of
    /// the two sides (`motor_side` referred to the wheel, `wheel_side`, kg m^2). Explicit
    /// integrators keep `h * rate` small against it.
    pub fn mesh_rate(&self, motor_side_kg_m2: f64, wheel_side_kg_m2: f64) -> f64 {
        let j_red = motor_side_kg_m2 * wheel_side_kg_m2 / (motor_side_kg_m2 + wheel_side_kg_m2);
        (self.tooth_stiffness_nm_rad / j_red).sqrt() + self.tooth_damping_nm_s_rad / j_red
    }

    /// Torque the teeth pass to the wheel (N m, wheel side; the motor feels `-T/ratio`).
    /// A spring-damper on the penetration past the play; teeth push but never pull, so
    /// the damping term cannot make a separating contact sticky.
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
