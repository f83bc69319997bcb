//! Keys a scene has that its run does not read: the `[base]` speed loops and limits and
//! the `[manoeuvre]` of a scene whose controller is the thesis's firmware, not a
//! velocity-commanded base. Setting or sweeping one changes nothing, which a user must
//! be told rather than left to read identical runs as physics.

use super::Scene;
use crate::firmware::ControllerKind;
use crate::model::base_controller::BaseParams;

/// `[base]` keys only the velocity-commanded base reads (`base.wheel_radius_m` is the
/// odometry's radius for every scene, so it is not among them).
const BASE_LOOP_KEYS: &[&str] = &[
    BaseParams::max_linear_m_s.key(),
    BaseParams::max_linear_accel_m_s2.key(),
    BaseParams::max_angular_rad_s.key(),
    BaseParams::max_angular_accel_rad_s2.key(),
    BaseParams::speed_kp_v_s_rad.key(),
    BaseParams::speed_ki_v_rad.key(),
    BaseParams::wheel_separation_m.key(),
];

/// Why `key` has no effect on a run of `scene`, or `None` when the run reads it.
pub fn inert_reason(scene: &Scene, key: &str) -> Option<String> {
    if scene.controller.kind == ControllerKind::Velocity {
        return None;
    }
    let section = if BASE_LOOP_KEYS.contains(&key) {
        "the [base] speed loops and limits"
    } else if key.starts_with("manoeuvre.") {
        "the [manoeuvre]"
    } else {
        return None;
    };
    // The kind as the scene file spells it.
    let kind = serde_json::to_value(scene.controller.kind)
        .ok()
        .and_then(|v| v.as_str().map(String::from))
        .unwrap_or_default();
    Some(format!(
        "{section} drive a velocity-commanded scene (controller.kind = \"velocity\"); this scene's controller is `{kind}`, so every value gives the same run"
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base_loop_keys_are_inert_under_the_firmware_and_read_by_a_velocity_base() {
        let mut scene = Scene::default();
        assert!(inert_reason(&scene, "base.speed_kp_V_s_rad").is_some());
        assert!(inert_reason(&scene, "manoeuvre.side_m").is_some());
        // The odometry's radius is read whatever drives the run.
        assert_eq!(inert_reason(&scene, "base.wheel_radius_m"), None);
        assert_eq!(inert_reason(&scene, "motor.resistance_ohm"), None);
        scene.controller.kind = ControllerKind::Velocity;
        assert_eq!(inert_reason(&scene, "base.speed_kp_V_s_rad"), None);
    }
}
