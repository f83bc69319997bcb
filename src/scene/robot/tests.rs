//! Tests of the robot builder: its numbers, guesses and refusals.

use super::*;

/// The thesis machine's numbers: 24 V; its motor's back-EMF constant 0.063 V s/rad
/// (no-load 3637.8 rpm at 24 V) and 0.35 ohm (stall 68.57 A).
fn thesis_spec() -> RobotSpec {
    RobotSpec {
        mass_kg: Some(120.0),
        track_m: Some(0.5),
        wheel_radius_m: Some(0.075),
        battery_v: Some(24.0),
        motor: Some(MotorDatasheet {
            rated_v: 24.0,
            no_load_rpm: 24.0 / 0.063 * 60.0 / std::f64::consts::TAU,
            stall_current_a: Some(24.0 / 0.35),
            stall_torque_nm: None,
        }),
        gear_ratio: Some(23.41),
        backlash_rad: Some(Scene::default().gearbox.backlash_rad),
        tyre: Some("hard_polyurethane".into()),
        castors: Some(true),
        guidance: Some(Guidance::Wire),
        ..Default::default()
    }
}

#[test]
fn the_thesis_numbers_give_back_the_thesis_machine_but_for_the_stated_differences() {
    let new = new_scene(&thesis_spec(), None, "test").unwrap();
    let shipped = Scene::default();
    for (k, _) in keys::table().numbers() {
        let (a, b) = (k.get(&new.scene), k.get(&shipped));
        let same = match (a, b) {
            (Some(a), Some(b)) => (a - b).abs() <= 1e-3 * b.abs().max(1e-12),
            (a, b) => a == b,
        };
        let stated = THESIS_DIFFERENCES.iter().any(|(d, _)| *d == k.key);
        assert!(
            same != stated,
            "{}: new {a:?}, shipped {b:?}, stated {stated}",
            k.key
        );
    }
    // The one stated difference of physics stays small.
    let i = new.scene.chassis.yaw_inertia_kg_m2;
    assert!((i - 14.0).abs() / 14.0 < 0.02, "{i}");
}

#[test]
fn without_from_the_datasheet_numbers_are_needed() {
    let e = new_scene(&RobotSpec::default(), None, "t")
        .unwrap_err()
        .to_string();
    assert!(e.contains("--mass-kg") && e.contains("--gear-ratio"), "{e}");
}

#[test]
fn from_a_scene_only_the_values_of_the_numbers_given_change() {
    let base = Scene::default();
    let spec = RobotSpec {
        mass_kg: Some(200.0),
        ..Default::default()
    };
    let new = new_scene(&spec, Some((Path::new("base.toml"), &base)), "t").unwrap();
    assert_eq!(new.scene.chassis.mass_kg, 200.0);
    // 200 (1.0^2 + 0.62^2) / 12
    assert!((new.scene.chassis.yaw_inertia_kg_m2 - 23.07).abs() < 0.01);
    assert_eq!(new.scene.motor.resistance_ohm, base.motor.resistance_ohm);
    assert_eq!(
        new.scene.dcmc.forward_gain_v_pct,
        base.dcmc.forward_gain_v_pct
    );
    assert!(new.text.contains("from base.toml"));
}

#[test]
fn a_mass_not_given_is_sized_from_the_outline_not_carried_over() {
    // A 0.2 m track from the thesis machine (as `import ros2` takes a robot): its body
    // 0.4 x 0.32 m, the thesis machine's 1.0 x 0.62 m; 120 kg (0.128 / 0.62)^1.5.
    let base = Scene::default();
    let spec = RobotSpec {
        track_m: Some(0.2),
        ..Default::default()
    };
    let new = new_scene(&spec, Some((Path::new("base.toml"), &base)), "t").unwrap();
    let expected = 120.0 * (0.4 * 0.32 / 0.62f64).powf(1.5);
    let m = new.scene.chassis.mass_kg;
    assert!((m / expected - 1.0).abs() < 1e-3, "{m} for {expected}");
    assert!(new.text.contains("not given: sized from the body's"));
    // The outline's plausibility rule has nothing to say of it, nor of what follows
    // from the mass (the castors' share of it).
    let warnings = crate::scene::plausibility::warnings(&new.scene);
    assert!(
        !warnings
            .iter()
            .any(|w| w.key == ChassisParams::mass_kg.key()),
        "{warnings:?}"
    );
    assert!((new.scene.castors.mass_kg - 0.01 * m).abs() < 1e-3 * m);
    // Given, the mass is the user's.
    let given = RobotSpec {
        mass_kg: Some(4.0),
        ..spec
    };
    let new = new_scene(&given, Some((Path::new("base.toml"), &base)), "t").unwrap();
    assert_eq!(new.scene.chassis.mass_kg, 4.0);
}

#[test]
fn a_drive_not_given_is_sized_for_the_robot_where_the_start_only_stands_in() {
    // OptiOdom's robot as `import ros2` takes it: 4 kg, 0.042 m wheels, a 0.2 m track,
    // from the thesis machine; once with its 43.7:1 gear, once without.
    let base = Scene::default();
    let from = Some((Path::new("base.toml"), &base));
    let spec = RobotSpec {
        mass_kg: Some(4.0),
        track_m: Some(0.2),
        wheel_radius_m: Some(0.042),
        size_drive: true,
        ..Default::default()
    };
    let thesis = DriveProportions::of(&base);
    let plausibility = crate::scene::plausibility::warnings;
    for gear in [Some(43.7), None] {
        let spec = RobotSpec {
            gear_ratio: gear,
            ..spec.clone()
        };
        let s = new_scene(&spec, from, "t").unwrap().scene;
        let p = DriveProportions::of(&s);
        // Written to four figures: the proportions within their rounding.
        assert!(
            (p.top_speed_m_s / thesis.top_speed_m_s - 1.0).abs() < 1e-3,
            "{p:?}"
        );
        let push = p.stall_push_per_weight / thesis.stall_push_per_weight;
        assert!((push - 1.0).abs() < 1e-3, "{p:?}");
        assert_eq!(s.gearbox.ratio, gear.unwrap_or(13.11), "{gear:?}");
        // The thesis motor on this robot pushes 25 times its weight: no longer.
        let w = plausibility(&s);
        assert!(
            !w.iter().any(|w| w.key == MotorParams::resistance_ohm.key()),
            "{w:?}"
        );
    }
    // `agvsim new --from` carries the starting drive: the user's own machine's.
    let carried = new_scene(
        &RobotSpec {
            size_drive: false,
            ..spec
        },
        from,
        "t",
    )
    .unwrap();
    assert_eq!(
        carried.scene.motor.resistance_ohm,
        base.motor.resistance_ohm
    );
    assert_eq!(carried.scene.gearbox.ratio, base.gearbox.ratio);
    let w = plausibility(&carried.scene);
    assert!(
        w.iter().any(|w| w.key == MotorParams::resistance_ohm.key()),
        "{w:?}"
    );
}

#[test]
fn stall_torque_stands_in_for_stall_current() {
    let mut spec = thesis_spec();
    let m = spec.motor.as_mut().unwrap();
    m.stall_current_a = None;
    m.stall_torque_nm = Some(0.063 * 24.0 / 0.35);
    let new = new_scene(&spec, None, "t").unwrap();
    assert!((new.scene.motor.resistance_ohm - 0.35).abs() < 1e-4);
}
