//! The whole-vehicle model's behaviour: the motor law at steady speed, turning, the
//! friction limit, rolling against gripping tyres, and joined tests.

use super::*;
use crate::ident::model::simulate;
use crate::model::chassis::ChassisParams;
use crate::model::GRAVITY_M_S2;
use crate::record::channels as chan;

fn rig() -> Rig {
    Rig::parse(
        r#"rig = "vehicle"
[motor]
resistance_ohm = 0.35
inductance_H = 0.0008
torque_constant_Nm_A = 0.063
rotor_inertia_kg_m2 = 2.0e-4
viscous_Nm_s_rad = 1.0e-4
[gearbox]
ratio = 23.41
[wheel]
radius_m = 0.075
inertia_kg_m2 = 0.02
[chassis]
mass_kg = 120.0
yaw_inertia_kg_m2 = 14.0
track_width_m = 0.5
drive_load_fraction = 0.6
"#,
        Path::new("test.rig.toml"),
    )
    .unwrap()
}

/// Constant voltages for `duration` s, sampled every 10 ms.
fn run(model: &Vehicle, p: &[f64], v: [f64; 2], duration: f64) -> (Dataset, Vec<Vec<f64>>) {
    let n = (duration / 0.01) as usize + 1;
    let outputs = [
        chan::X_M,
        chan::Y_M,
        chan::HEADING_RAD,
        chan::LEFT_MOTOR_SPEED_RAD_S,
        chan::RIGHT_MOTOR_SPEED_RAD_S,
    ];
    let data = Dataset {
        name: "test".into(),
        t_s: (0..n).map(|k| k as f64 * 0.01).collect(),
        input_names: model.input_names(),
        inputs: vec![vec![v[0]; n], vec![v[1]; n]],
        output_names: outputs.map(String::from).to_vec(),
        outputs: vec![vec![Some(0.0); n]; outputs.len()],
        segment_starts: vec![0],
    };
    let y = simulate(model, p, &data).unwrap();
    (data, y)
}

/// Castor drag is a candidate only while castors carry part of the weight.
#[test]
fn castor_drag_is_looked_for_only_where_castors_carry_weight() {
    let path = Path::new("r.rig.toml");
    let with_castors = Vehicle::from_rig(&rig(), path).unwrap();
    assert!(with_castors.applicable().contains(&Effect::CastorDrag));
    let mut all_on_drive = rig();
    all_on_drive.set(ChassisParams::drive_load_fraction.key(), 1.0);
    let tank = Vehicle::from_rig(&all_on_drive, path).unwrap();
    assert!(!tank.applicable().contains(&Effect::CastorDrag));
    assert!(tank.applicable().contains(&Effect::CoulombFriction));
}

/// Straight run at constant voltage: with no force needed at constant speed, the motor
/// settles at K V / (K^2 + R b), the tyres stop creeping, and the vehicle moves at the
/// rim speed, straight along x.
#[test]
fn straight_run_settles_at_the_motor_law_and_rolls_without_creep() {
    let m = Vehicle::from_rig(&rig(), Path::new("test.rig.toml")).unwrap();
    let p = m.nominal();
    let (_, y) = run(&m, &p, [12.0, 12.0], 6.0);
    let w = 0.063 * 12.0 / (0.063 * 0.063 + 0.35 * 1.0e-4);
    let last = y[3].len() - 1;
    assert!((y[3][last] - w).abs() < 1e-3 * w, "{} vs {w}", y[3][last]);
    let ground = w / 23.41 * 0.075;
    let speed = (y[0][last] - y[0][last - 100]) / 1.0;
    assert!(
        (speed - ground).abs() < 1e-3 * ground,
        "{speed} vs {ground}"
    );
    assert!(y[1][last].abs() < 1e-9 && y[2][last].abs() < 1e-9);
}

/// Opposite voltages spin the vehicle on the spot at 2 r w / (N track).
#[test]
fn opposite_voltages_turn_on_the_spot() {
    let m = Vehicle::from_rig(&rig(), Path::new("test.rig.toml")).unwrap();
    let p = m.nominal();
    let (_, y) = run(&m, &p, [-6.0, 6.0], 4.0);
    let last = y[2].len() - 1;
    let w = y[4][last];
    let yaw_rate = (y[2][last] - y[2][last - 100]) / 1.0;
    let expected = 2.0 * w / 23.41 * 0.075 / 0.5;
    assert!(
        (yaw_rate - expected).abs() < 1e-3 * expected,
        "{yaw_rate} vs {expected}"
    );
    assert!(y[0][last].abs() < 1e-6 && y[1][last].abs() < 1e-6);
}

/// With the wheel-slip block, the floor limits traction: a full-voltage start cannot
/// accelerate the vehicle faster than mu times the drive wheels' share of g (and, the
/// wheels spinning, keeps at least the law's sliding share of it), while without the
/// block the same start accelerates far harder.
#[test]
fn friction_limit_caps_the_acceleration() {
    let nominal = Vehicle::from_rig(&rig(), Path::new("test.rig.toml")).unwrap();
    let slip = nominal.with_effect(Effect::WheelSlip, 0.1, 0.05, 4.0, 300.0);
    let mut p = nominal.nominal();
    p.push(0.1);
    let cap = 0.1 * 0.6 * GRAVITY_M_S2;
    let peak_accel = |y: &[Vec<f64>]| {
        let v: Vec<f64> = y[0].windows(2).map(|w| (w[1] - w[0]) / 0.01).collect();
        v.windows(2)
            .map(|w| (w[1] - w[0]) / 0.01)
            .fold(0.0, f64::max)
    };
    let (_, y) = run(&slip, &p, [24.0, 24.0], 1.0);
    let a = peak_accel(&y);
    // A spinning wheel keeps sin(c pi / 2) of the peak grip (the law's full-slide end).
    let sliding = (crate::model::tyre::SATURATION_SHAPE * std::f64::consts::FRAC_PI_2).sin();
    assert!(
        a <= cap * 1.01 && a > 0.99 * sliding * cap,
        "{a} vs cap {cap}"
    );
    let (_, y) = run(&nominal, &nominal.nominal(), [24.0, 24.0], 1.0);
    assert!(peak_accel(&y) > 2.0 * cap);
}

/// The nominal wheels roll without slipping (the simulator's no-slip body); the
/// wheel-slip block's tyres, with grip to spare, only creep: slip F / (C N), which for a
/// tyre pulling half its load at the default stiffness C = 30 is 1.7 %. On a turning
/// start the two agree on motor speeds and pose within 2 % of each output's range.
#[test]
fn rolling_and_gripping_tyres_agree_where_nothing_slides() {
    let mut rolling = Vehicle::from_rig(&rig(), Path::new("test.rig.toml")).unwrap();
    rolling.creeping_tyres = false;
    let gripping = rolling.with_effect(Effect::WheelSlip, 4.0, 0.05, 4.0, 300.0);
    let p = rolling.nominal();
    let mut pg = p.clone();
    pg.push(4.0);
    let (_, a) = run(&rolling, &p, [6.0, 9.0], 4.0);
    let (_, b) = run(&gripping, &pg, [6.0, 9.0], 4.0);
    for j in 0..a.len() {
        let range = a[j].iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let worst = a[j]
            .iter()
            .zip(&b[j])
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        assert!(worst < 0.02 * range, "output {j}: {worst} of {range}");
    }
}

/// A record joined from two tests is simulated test by test, each from rest: the same
/// as simulating each alone (to rounding: the second test's times are shifted).
#[test]
fn joined_tests_are_simulated_each_from_rest() {
    let m = Vehicle::from_rig(&rig(), Path::new("test.rig.toml")).unwrap();
    let p = m.nominal();
    let (da, ya) = run(&m, &p, [6.0, 6.0], 1.0);
    let (db, yb) = run(&m, &p, [-3.0, 4.0], 1.0);
    let mut joined = da.clone();
    let shift = da.t_s[da.len() - 1] + 0.01;
    joined.t_s.extend(db.t_s.iter().map(|t| t + shift));
    for (u, v) in joined.inputs.iter_mut().zip(&db.inputs) {
        u.extend(v);
    }
    for (y, v) in joined.outputs.iter_mut().zip(&db.outputs) {
        y.extend(v);
    }
    joined.segment_starts = vec![0, da.len()];
    let y = simulate(&m, &p, &joined).unwrap();
    for j in 0..y.len() {
        let expected: Vec<f64> = ya[j].iter().chain(&yb[j]).copied().collect();
        let scale = expected.iter().fold(1e-12f64, |m, v| m.max(v.abs()));
        for (k, (a, b)) in y[j].iter().zip(&expected).enumerate() {
            assert!(
                (a - b).abs() <= 1e-9 * scale,
                "output {j} row {k}: {a} vs {b}"
            );
        }
    }
}
