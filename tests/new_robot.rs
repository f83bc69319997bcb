//! `agvsim new` and `agvsim check` as a user meets them: three robots unlike the thesis
//! machine written from their datasheet numbers drive at the speed the motor, gear and
//! wheel imply; the thesis machine's own numbers give back its scene; and the faults of a
//! scene copied from the thesis machine are each named with the key, the value and what
//! was expected.

mod common;
use common::{text, tmp as scratch};

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn agvsim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_agvsim"))
        .args(args)
        .output()
        .expect("agvsim runs")
}

/// A robot's datasheet numbers.
struct Robot {
    name: &'static str,
    battery_v: f64,
    no_load_rpm: f64,
    ratio: f64,
    wheel_radius_m: f64,
    extra: &'static [&'static str],
}

/// Writes the robot's scene, runs it at full forward demand and returns the steady speed
/// (the last second's mean, m/s), the speed its numbers imply at the scene's drive
/// limit, and the run's text.
fn drive(r: &Robot) -> (f64, f64, String) {
    let dir = scratch(r.name);
    let scene = dir.join(format!("{}.toml", r.name));
    let s = |v: f64| v.to_string();
    let (b, rpm, ratio, wheel) = (
        s(r.battery_v),
        s(r.no_load_rpm),
        s(r.ratio),
        s(r.wheel_radius_m),
    );
    let mut args = vec![
        "new",
        scene.to_str().unwrap(),
        "--battery-V",
        &b,
        "--motor-no-load-rpm",
        &rpm,
        "--gear-ratio",
        &ratio,
        "--wheel-radius-m",
        &wheel,
    ];
    args.extend_from_slice(r.extra);
    // Constant full demand, straight ahead: the top speed (a velocity-commanded base, the
    // default, would drive its square).
    args.extend(["--guidance", "open-loop"]);
    let o = agvsim(&args);
    assert!(o.status.success(), "{}", text(&o));
    assert!(!text(&o).contains("warning"), "{}", text(&o));
    let o = agvsim(&[
        "run",
        scene.to_str().unwrap(),
        "--set",
        "controller.open_loop_forward_pct=100",
        "--out",
        dir.join("run").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let scene_text = std::fs::read_to_string(&scene).unwrap();
    let drive_v: f64 = agvsim::scene::Scene::from_toml(&scene_text, &scene, &[])
        .unwrap()
        .battery
        .drive_limit_v;
    // The motor's no-load speed scales with its voltage: at the drive limit, through the
    // gear, at the wheel's rim.
    let implied = r.no_load_rpm * std::f64::consts::TAU / 60.0 * (drive_v / r.battery_v) / r.ratio
        * r.wheel_radius_m;
    let csv = std::fs::read_to_string(dir.join("run").join(format!("{}.csv", r.name))).unwrap();
    let rows: Vec<Vec<f64>> = csv
        .lines()
        .filter(|l| !l.starts_with('#'))
        .skip(1)
        .map(|l| {
            l.split(',')
                .map(|c| c.parse().unwrap_or(f64::NAN))
                .collect()
        })
        .collect();
    let header: Vec<&str> = csv
        .lines()
        .find(|l| !l.starts_with('#'))
        .unwrap()
        .split(',')
        .collect();
    let col = |n: &str| header.iter().position(|h| *h == n).unwrap();
    let (t, x) = (col("t_s"), col("x_m"));
    let last = rows.last().unwrap();
    let second = rows.iter().rev().find(|r| r[t] <= last[t] - 1.0).unwrap();
    let speed = (last[x] - second[x]) / (last[t] - second[t]);
    (speed, implied, text(&o))
}

fn assert_top_speed(r: &Robot) {
    let (speed, implied, run) = drive(r);
    // Loaded by rolling resistance, castors and friction the robot runs below its no-load
    // speed, but not by more than a tenth for a drive sized to its mass.
    assert!(
        speed < implied && speed > 0.9 * implied,
        "{}: {speed:.4} m/s against {implied:.4} m/s implied\n{run}",
        r.name
    );
}

#[test]
fn a_60_kg_indoor_robot_on_12_v_drives_at_its_implied_speed() {
    assert_top_speed(&Robot {
        name: "indoor60",
        battery_v: 12.0,
        no_load_rpm: 3000.0,
        ratio: 20.0,
        wheel_radius_m: 0.05,
        extra: &[
            "--mass-kg",
            "60",
            "--track-m",
            "0.4",
            "--motor-stall-current-A",
            "60",
            "--tyre",
            "soft_rubber",
        ],
    });
}

#[test]
fn a_400_kg_tugger_on_48_v_drives_at_its_implied_speed() {
    assert_top_speed(&Robot {
        name: "tugger400",
        battery_v: 48.0,
        no_load_rpm: 3000.0,
        ratio: 25.0,
        wheel_radius_m: 0.1,
        extra: &[
            "--mass-kg",
            "400",
            "--track-m",
            "0.6",
            "--motor-stall-torque-Nm",
            "22",
            "--length-m",
            "1.6",
            "--width-m",
            "0.8",
        ],
    });
}

#[test]
fn a_5_kg_educational_robot_without_castors_drives_at_its_implied_speed() {
    assert_top_speed(&Robot {
        name: "edu5",
        battery_v: 6.0,
        no_load_rpm: 12000.0,
        ratio: 48.0,
        wheel_radius_m: 0.03,
        extra: &[
            "--mass-kg",
            "5",
            "--track-m",
            "0.15",
            "--motor-stall-current-A",
            "1.5",
            "--castors",
            "no",
            "--tyre",
            "soft_rubber",
        ],
    });
}

#[test]
fn the_thesis_machines_numbers_give_back_its_shipped_values_but_the_stated_ones() {
    let dir = scratch("thesis");
    let scene = dir.join("thesis.toml");
    let rpm = (24.0 / 0.063 * 60.0 / std::f64::consts::TAU).to_string();
    let o = agvsim(&[
        "new",
        scene.to_str().unwrap(),
        "--mass-kg",
        "120",
        "--track-m",
        "0.5",
        "--wheel-radius-m",
        "0.075",
        "--battery-V",
        "24",
        "--motor-no-load-rpm",
        &rpm,
        "--motor-stall-current-A",
        "68.5714",
        "--gear-ratio",
        "23.41",
        "--backlash-rad",
        "0.17453292519943295",
        "--guidance",
        "wire",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let new = agvsim::scene::Scene::load(&scene, &[]).unwrap();
    let shipped = agvsim::scene::Scene::default();
    let mut differ = vec![];
    for (k, _) in agvsim::scene::keys::table().numbers() {
        match (k.get(&new), k.get(&shipped)) {
            (Some(a), Some(b)) if (a - b).abs() <= 1e-3 * b.abs().max(1e-9) => {}
            (None, None) => {}
            _ => differ.push(k.key.clone()),
        }
    }
    let stated: Vec<String> = agvsim::scene::robot::THESIS_DIFFERENCES
        .iter()
        .map(|(k, _)| k.to_string())
        .collect();
    assert_eq!(differ, stated);
    // And it is as plausible as the shipped scene.
    let o = agvsim(&["check", scene.to_str().unwrap()]);
    assert!(
        text(&o).contains("no plausibility warnings"),
        "{}",
        text(&o)
    );
}

/// A scene copied from the thesis machine for a 60 kg, 12 V robot by editing values.
fn copied_scene(dir: &Path) -> PathBuf {
    let p = dir.join("copied.toml");
    std::fs::write(
        &p,
        "description = \"my robot, copied from the thesis scene\"\n\
         [chassis]\nmass_kg = 60.0\ntrack_width_m = 0.40\nfront_m = 0.3\nrear_m = 0.3\nwidth_m = 0.5\n\
         [wheel]\nradius_m = 0.05\n\
         [battery]\nopen_circuit_V = 12.0\nlow_voltage_fault_V = 11.0\n",
    )
    .unwrap();
    p
}

#[test]
fn values_copied_from_the_thesis_machine_are_named_with_what_was_expected() {
    let dir = scratch("copied");
    let scene = copied_scene(&dir);
    let s = scene.to_str().unwrap();
    let o = agvsim(&["check", s]);
    let out = text(&o);
    assert!(o.status.success(), "{out}");
    // 14 kg m^2 on 60 kg over 0.6 x 0.5 m (3.05 expected); the 23.5 V drive limit on a
    // 12 V battery; 0.1623 V/pct asking 16.2 V at full demand.
    for needle in [
        "`chassis.yaw_inertia_kg_m2` = 14 kg m^2: expected about 3.05 kg m^2",
        "`battery.drive_limit_V` = 23.5 V: expected at most battery.open_circuit_V = 12 V",
        "`dcmc.forward_gain_V_pct` = 0.1623 V/pct: expected at most 0.12 V/pct",
    ] {
        assert!(out.contains(needle), "missing {needle:?} in\n{out}");
    }
    // The file does not set these: each is named as the default it is.
    assert!(
        out.contains("copied.toml (key not in the file: its default)"),
        "{out}"
    );
    // A friction no tyre reaches and a track wider than the body.
    let o = agvsim(&[
        "check",
        s,
        "--set",
        "tyre.peak_mu=50",
        "--set",
        "chassis.track_width_m=2",
    ]);
    let out = text(&o);
    assert!(
        out.contains("--set tyre.peak_mu=50: `tyre.peak_mu` = 50: expected 0.1 to 1.3"),
        "{out}"
    );
    assert!(
        out.contains("`chassis.track_width_m` = 2 m: expected at most the body's width"),
        "{out}"
    );
    // A wheel larger than the body is named before the simulator's own refusal.
    let o = agvsim(&[
        "run",
        s,
        "--set",
        "wheel.radius_m=100",
        "--duration",
        "0.1",
        "--out",
        dir.join("r").to_str().unwrap(),
    ]);
    let out = text(&o);
    assert!(
        out.contains("`wheel.radius_m` = 100 m: expected a wheel smaller than the body"),
        "{out}"
    );
}

#[test]
fn errors_name_the_set_or_the_line_the_value_and_its_unit() {
    let dir = scratch("errors");
    let scene = copied_scene(&dir);
    let s = scene.to_str().unwrap();
    let err = |extra: &[&str]| {
        let mut a = vec!["check", s];
        a.extend_from_slice(extra);
        let o = agvsim(&a);
        assert_eq!(o.status.code(), Some(2), "{}", text(&o));
        text(&o)
    };
    let e = err(&["--set", "chassis.mass_kg=-5"]);
    assert!(
        e.contains("--set chassis.mass_kg=-5: `chassis.mass_kg` = -5 kg: expected a finite number greater than zero, in kg"),
        "{e}"
    );
    let e = err(&["--set", "battery.open_circuit_V=twelve"]);
    assert!(e.contains("`battery.open_circuit_V` = the text \"twelve\": expected a finite number greater than zero, in V"), "{e}");
    // A derived rule in the file: the line, the values and a fix.
    let text_with_fault = std::fs::read_to_string(&scene)
        .unwrap()
        .replace("11.0", "22.0");
    std::fs::write(&scene, text_with_fault).unwrap();
    let e = err(&[]);
    assert!(
        e.contains("copied.toml:12: `battery.low_voltage_fault_V` = 22 V"),
        "{e}"
    );
    assert!(
        e.contains("below battery.open_circuit_V = 12 V") && e.contains("about 11.0 V"),
        "{e}"
    );
    // A number too large for TOML's integers is still a number, refused by its range
    // and echoed short.
    let e = err(&["--set", "sim.duration_s=10000000000000000000"]);
    assert!(
        e.contains("`sim.duration_s` = 1e19 s: expected a run of at most sim.max_steps"),
        "{e}"
    );
}

#[test]
fn a_scene_made_from_a_shipped_one_drops_its_claims_and_derives_only_from_what_changed() {
    let dir = scratch("from");
    let out = dir.join("lighter.toml");
    let o = agvsim(&[
        "new",
        out.to_str().unwrap(),
        "--from",
        "scenes/lab_offset_120mm.toml",
        "--mass-kg",
        "60",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let written = std::fs::read_to_string(&out).unwrap();
    assert!(
        !written.lines().any(|l| l.trim() == "[expect]"),
        "{written}"
    );
    let scene = agvsim::scene::Scene::load(&out, &[]).unwrap();
    // 60 (1.0^2 + 0.62^2) / 12 = 6.92 kg m^2; the motor as the shipped scene has it.
    assert!((scene.chassis.yaw_inertia_kg_m2 - 6.922).abs() < 0.001);
    assert_eq!(scene.motor.resistance_ohm, 0.35);
    assert_eq!(scene.controller.kp_den, 20);
    // It does not overwrite a file.
    let o = agvsim(&[
        "new",
        out.to_str().unwrap(),
        "--from",
        "scenes/lab_offset_120mm.toml",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o).contains("exists"), "{}", text(&o));
}

#[test]
fn millimetres_typed_as_metres_are_warned_by_new_and_check() {
    let dir = scratch("millimetres");
    let path = dir.join("mm.toml");
    let p = path.to_str().unwrap();
    let o = agvsim(&[
        "new",
        p,
        "--mass-kg",
        "60",
        "--track-m",
        "400",
        "--wheel-radius-m",
        "50",
        "--battery-V",
        "12",
        "--motor-no-load-rpm",
        "3000",
        "--motor-stall-current-A",
        "60",
        "--gear-ratio",
        "20",
    ]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    for said in [
        "`chassis.track_width_m` = 400 m: expected 0.03 to 5 m",
        "`wheel.radius_m` = 50 m: expected 0.005 to 1 m",
        "millimetres",
        "gives 769 m/s",
        // And the 50 m wheel turns the motors' 35 A x 0.0382 N m/A x 20 x 2 into 1.07 N
        // against 589 N of weight.
        "push 1.07 N, 0.00182 times the 60 kg robot's weight",
    ] {
        assert!(t.contains(said), "`{said}` not in:\n{t}");
    }
    let o = agvsim(&["check", p]);
    let t = text(&o);
    assert!(t.contains("4 plausibility warnings"), "{t}");
}
