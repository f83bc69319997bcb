//! Castor rolling resistance: the idler wheels' drag opposing their contact's motion over
//! the floor. The castors' lateral grip is a tyre (`tyre`); this is what rolling costs.

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
