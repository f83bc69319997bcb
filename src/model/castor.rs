//! Castor rolling resistance: the idler wheels' drag opposing their contact's motion over
//! the floor. The castors' lateral grip is a tyre (`tyre`); this is what rolling costs.
//! [`CastorParams`] declares the four idlers: where they stand, their forks and
//! wheels, and the lumped drag the no-slip levels use instead of castor bodies.

use super::tyre_presets;

/// What `castors.compound` takes.
fn compound_choice() -> String {
    format!("one of {}", tyre_presets::compound_names())
}

crate::declare_params! {
    /// The four castor idlers at the corners (scene section `[castors]`).
    #[derive(Debug, Clone, PartialEq)]
    pub struct CastorParams in "castors" {
        /// Swivel axes of the front castors ahead of the drive axle (*assumed*).
        front_x_m: f64 = 0.40, "m", Positive;
        /// Swivel axes of the rear castors (negative: behind the axle; *assumed*).
        rear_x_m: f64 = -0.35, "m", Negative;
        /// Swivel axes left and right of the centre line (*assumed*).
        half_spacing_m: f64 = 0.24, "m", Positive;
        /// Trail: the contact patch behind the swivel axis (*assumed*).
        trail_m: f64 = 0.04, "m", Positive;
        /// Mass of one castor fork and wheel (*assumed*).
        mass_kg: f64 = 1.2, "kg", Positive;
        /// Swivel (Coulomb) friction torque (*assumed*).
        swivel_friction_nm as "swivel_friction_Nm": f64 = 0.3, "N m", NonNegative;
        /// Rolling resistance coefficient of a castor wheel (force over normal load).
        rolling_resistance: f64 = 0.02, "", NonNegative;
        /// Tyre compound of the castor wheels (their friction).
        compound: String = "hard_polyurethane".into(), "", other(compound_choice);
        /// Initial swivel angle relative to the body (0: trailing straight ahead).
        initial_angle_rad: f64 = 0.0, "rad", Finite;
        /// Lumped castor drag for the no-slip levels (Johnson & Aylor): linear.
        lumped_linear_drag_n_s_m as "lumped_linear_drag_N_s_m": f64 = 10.0, "N s/m", NonNegative;
        /// Lumped castor drag for the no-slip levels: angular.
        lumped_angular_drag_nm_s_rad as "lumped_angular_drag_Nm_s_rad": f64 = 2.0, "N m s/rad", NonNegative;
    }
}

/// Rolling drag opposing a contact's velocity, per component, N:
/// `-F v / sqrt(|v|^2 + eps^2)` for a drag of magnitude `level_n` (rolling resistance
/// times load). The smoothing speed `eps` (m/s) makes the law continuous through rest: a
/// castor at rest is not driven to and fro by a switching force within a step, and a fit
/// can differentiate it. The velocity may carry any components (along the wheel; or
/// forward, lateral and a turn's sweep), each opposed in proportion.
pub fn rolling_drag_n<const N: usize>(
    level_n: f64,
    velocity_m_s: [f64; N],
    smoothing_m_s: f64,
) -> [f64; N] {
    // A root of the sum of squares rather than `hypot`: the arguments are speeds, far
    // from overflow, and this sits in the fitting vehicle's innermost loop.
    let speed = velocity_m_s
        .iter()
        .fold(smoothing_m_s * smoothing_m_s, |sum, v| sum + v * v)
        .sqrt();
    velocity_m_s.map(|v| -level_n * v / speed)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn drag_opposes_motion_at_its_level_and_vanishes_through_rest() {
        let [f] = rolling_drag_n(3.0, [0.5], 0.005);
        assert!((f + 3.0).abs() < 1e-3, "{f}");
        let [fx, fy] = rolling_drag_n(3.0, [-0.3, 0.4], 0.0);
        assert!((fx - 1.8).abs() < 1e-12 && (fy + 2.4).abs() < 1e-12);
        assert_eq!(rolling_drag_n(3.0, [0.0], 0.005), [0.0]);
    }
}
