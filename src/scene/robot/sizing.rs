//! What a robot's numbers not given are, sized from the robot as a starting machine's are
//! for it: its mass from its body's outline, and its motor and gear from its mass, wheel
//! and supply. Robots of one kind keep proportions (density, top speed, push per weight)
//! better than they keep numbers: the thesis machine's 120 kg or 0.35 ohm motor on a
//! 0.2 m-track robot is another machine's, which `check` calls implausible.

use super::Scene;
use crate::model::GRAVITY_M_S2 as G_M_S2;

/// A robot's mass sized from its body's outline (length and width, m) as a starting
/// machine's (`base_kg` on `base_outline_m`): in proportion to the outline's area to the
/// power 1.5, a box as tall as it is wide (robots of one kind are about as dense: the
/// thesis machine 246 kg/m^3 so, a TurtleBot 3 about 260; `scene::plausibility`).
pub(super) fn sized_mass_kg(base_kg: f64, base_outline_m: [f64; 2], outline_m: [f64; 2]) -> f64 {
    let area = |o: [f64; 2]| o[0] * o[1];
    base_kg * (area(outline_m) / area(base_outline_m)).powf(1.5)
}

/// The proportions of a drive that carry over to a robot of another size: its top speed
/// (the motors' no-load speed at the wheel) and the push of its two motors at stall over
/// its weight, both on the battery's open-circuit voltage.
///
/// A DC motor of torque constant `K` (N m/A) and resistance `R` (ohm) through a gear `N` to a
/// wheel of radius `r` (m) on `V` (V) gives `v_top = V r / (K N)` and a stall push
/// `2 N K (V / R) / r`. Keeping `v_top` fixes the product `K N = V r / v_top`; keeping the
/// push per weight `p` of a mass `m` then fixes `R = 2 V^2 / (v_top p m g)`. The speed
/// loops' gains follow `K` (`agvsim new`'s derivations), so the loops close at about the
/// starting machine's bandwidth: `N^2 K k_p / (R J)` with `J ~ m r^2` is unchanged.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DriveProportions {
    /// The motors' no-load speed at the wheel, m/s.
    pub top_speed_m_s: f64,
    /// Both motors' push at stall over the robot's weight (dimensionless).
    pub stall_push_per_weight: f64,
}

impl DriveProportions {
    /// The proportions of a scene's drive.
    pub fn of(scene: &Scene) -> Self {
        let v = scene.battery.open_circuit_v;
        let push_n =
            2.0 * scene.gearbox.ratio * scene.motor.stall_torque_nm(v) / scene.wheel.radius_m;
        Self {
            top_speed_m_s: scene.top_speed_m_s(v),
            stall_push_per_weight: push_n / (scene.chassis.mass_kg * G_M_S2),
        }
    }

    /// The gear ratio that gives a motor of torque constant `k_nm_a` on `supply_v` this
    /// top speed on a wheel of `wheel_radius_m`.
    pub fn ratio(&self, supply_v: f64, k_nm_a: f64, wheel_radius_m: f64) -> f64 {
        supply_v * wheel_radius_m / (k_nm_a * self.top_speed_m_s)
    }

    /// The torque constant, N m/A, that gives this top speed through `ratio` on a wheel of
    /// `wheel_radius_m` on `supply_v`.
    pub fn torque_constant_nm_a(&self, supply_v: f64, ratio: f64, wheel_radius_m: f64) -> f64 {
        supply_v * wheel_radius_m / (ratio * self.top_speed_m_s)
    }

    /// The resistance, ohm, whose stall current on `supply_v` pushes a robot of `mass_kg`
    /// in this proportion to its weight (at this top speed).
    pub fn resistance_ohm(&self, supply_v: f64, mass_kg: f64) -> f64 {
        2.0 * supply_v * supply_v
            / (self.top_speed_m_s * self.stall_push_per_weight * mass_kg * G_M_S2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_thesis_machine_sized_for_itself_keeps_its_drive() {
        let s = Scene::default();
        let p = DriveProportions::of(&s);
        let v = s.battery.open_circuit_v;
        // 24 V / 0.063 V s/rad / 23.41 x 0.075 m = 1.2205 m/s; 2 x 23.41 x 4.32 N m / 0.075 m
        // over 120 kg x 9.81 = 2.29.
        assert!((p.top_speed_m_s - 1.2205).abs() < 1e-3, "{p:?}");
        assert!((p.stall_push_per_weight - 2.292).abs() < 2e-3, "{p:?}");
        let k = s.motor.torque_constant_nm_a;
        assert!((p.ratio(v, k, s.wheel.radius_m) / s.gearbox.ratio - 1.0).abs() < 1e-12);
        let r = p.resistance_ohm(v, s.chassis.mass_kg);
        assert!((r / s.motor.resistance_ohm - 1.0).abs() < 1e-12, "{r}");
    }

    #[test]
    fn a_sized_drive_has_the_top_speed_and_push_it_was_sized_for() {
        let p = DriveProportions::of(&Scene::default());
        // A 4 kg robot on 0.042 m wheels through a 43.7:1 gear, on 12 V.
        let (v, n, r_wheel, m) = (12.0, 43.7, 0.042, 4.0);
        let k = p.torque_constant_nm_a(v, n, r_wheel);
        let r = p.resistance_ohm(v, m);
        let top = v / k / n * r_wheel;
        let push = 2.0 * n * k * (v / r) / r_wheel / (m * G_M_S2);
        assert!((top - p.top_speed_m_s).abs() < 1e-9, "{top}");
        assert!((push - p.stall_push_per_weight).abs() < 1e-9, "{push}");
        // Half the wheel: half the ratio for the same motor.
        let k0 = 0.063;
        assert!((p.ratio(24.0, k0, 0.0375) / p.ratio(24.0, k0, 0.075) - 0.5).abs() < 1e-12);
    }
}
