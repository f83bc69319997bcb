//! Other people's formats: WPILib SysId logs (JSON and DataLog `.wpilog`, built here
//! from their published descriptions), MATLAB MAT-files (read against files SciPy wrote,
//! and the EMPS benchmark's layout), and the linearisation exported for MATLAB and SciPy.

mod common;
use common::tmp;

use std::path::Path;
use std::process::Command;

use agvsim::import::wpilib::{self, datalog, wpilog::Choice, Assumptions};
use agvsim::matfile::{self, Data};
use agvsim::record::Recording;

fn agvsim(args: &[&str]) -> (bool, String, String) {
    let o = Command::new(env!("CARGO_BIN_EXE_agvsim"))
        .args(args)
        .output()
        .unwrap();
    (
        o.status.success(),
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// A small deterministic noise source (a linear congruential generator), +-amp uniform.
struct Noise(u64);
impl Noise {
    fn next(&mut self, amp: f64) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        amp * (2.0 * ((self.0 >> 11) as f64 / (1u64 << 53) as f64) - 1.0)
    }
}

/// Truth of the simulated drivetrain side: kS V, kV V/(m/s), kA V/(m/s^2).
const KS: f64 = 0.35;
const KV: f64 = 2.6;
const KA: f64 = 0.45;
const DT: f64 = 0.005;

/// One side of a drivetrain with Coulomb friction, stepped exactly over each held
/// voltage while it moves (and held by static friction below kS at rest): (t, u, v).
fn side(volts: &[f64]) -> Vec<(f64, f64, f64)> {
    let a = (-KV / KA * DT).exp();
    let mut v: f64 = 0.0;
    let mut out = Vec::new();
    for (k, &u) in volts.iter().enumerate() {
        out.push((k as f64 * DT, u, v));
        let s = if v != 0.0 { v.signum() } else { u.signum() };
        let next = if v == 0.0 && u.abs() <= KS {
            0.0
        } else {
            a * v + (1.0 - a) * (u - KS * s) / KV
        };
        v = if v != 0.0 && next * v < 0.0 {
            0.0
        } else {
            next
        };
    }
    out
}

/// SysId's four tests: ramps at 0.25 V/s and 7 V steps, forward and backward.
fn tests_volts() -> Vec<(&'static str, Vec<f64>)> {
    let ramp: Vec<f64> = (0..1400).map(|k| 0.25 * k as f64 * DT).collect();
    let step = vec![7.0; 400];
    vec![
        ("slow-forward", ramp.clone()),
        ("slow-backward", ramp.iter().map(|u| -u).collect()),
        ("fast-forward", step.clone()),
        ("fast-backward", step.iter().map(|u| -u).collect()),
    ]
}

const UPR: f64 = 0.478_778_720_407_084_5; // metres per rotation of a 6-inch wheel

/// A SysId JSON drivetrain file, speeds with encoder-like noise, in rotations as SysId
/// stores them (times unitsPerRotation gives metres).
fn drivetrain_json() -> String {
    let mut noise = Noise(7);
    let mut obj = serde_json::Map::new();
    obj.insert("sysid".into(), true.into());
    obj.insert("test".into(), "Drivetrain".into());
    obj.insert("units".into(), "Meters".into());
    obj.insert("unitsPerRotation".into(), UPR.into());
    for (i, (name, volts)) in tests_volts().into_iter().enumerate() {
        let mut x = 0.0;
        let rows: Vec<serde_json::Value> = side(&volts)
            .into_iter()
            .map(|(t, u, v)| {
                x += v * DT;
                let (vl, vr) = (v + noise.next(0.006), v + noise.next(0.006));
                serde_json::json!([
                    20.0 * i as f64 + t,
                    u,
                    u,
                    x / UPR,
                    x / UPR,
                    vl / UPR,
                    vr / UPR,
                    0.0,
                    noise.next(0.003)
                ])
            })
            .collect();
        obj.insert(name.into(), rows.into());
    }
    serde_json::Value::Object(obj).to_string()
}

/// SysId's regression computed here on its own: pairs of consecutive rows of one test
/// and side with |v| above 2 % of the largest speed, v[k+1] on (v, u, sgn v) by the
/// normal equations solved with Cramer's rule.
fn independent_ks(json: &str) -> f64 {
    let root: serde_json::Value = serde_json::from_str(json).unwrap();
    let mut series: Vec<Vec<(f64, f64)>> = Vec::new();
    for name in [
        "slow-forward",
        "slow-backward",
        "fast-forward",
        "fast-backward",
    ] {
        for (uc, vc) in [(1, 5), (2, 6)] {
            series.push(
                root[name]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|r| (r[uc].as_f64().unwrap(), r[vc].as_f64().unwrap() * UPR))
                    .collect(),
            );
        }
    }
    let peak = series
        .iter()
        .flatten()
        .fold(0.0f64, |m, p| m.max(p.1.abs()));
    let mut m = [[0.0; 3]; 3];
    let mut r = [0.0; 3];
    for s in &series {
        for w in s.windows(2) {
            let (u, v) = w[0];
            if v.abs() <= 0.02 * peak {
                continue;
            }
            let x = [v, u, v.signum()];
            for i in 0..3 {
                for j in 0..3 {
                    m[i][j] += x[i] * x[j];
                }
                r[i] += x[i] * w[1].1;
            }
        }
    }
    let det = |m: &[[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let solve = |col: usize| {
        let mut c = m;
        for i in 0..3 {
            c[i][col] = r[i];
        }
        det(&c) / det(&m)
    };
    let (beta, gamma) = (solve(1), solve(2));
    -gamma / beta
}

#[test]
fn a_sysid_json_drivetrain_imports_to_four_vehicle_recordings_and_its_ks_is_sysids() {
    let dir = tmp("json");
    let file = dir.join("drive.json");
    let json = drivetrain_json();
    std::fs::write(&file, &json).unwrap();
    let out = dir.join("out");
    let (ok, stdout, stderr) = agvsim(&[
        "import",
        "wpilib",
        file.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{stderr}");
    println!("{stdout}");
    for name in [
        "slow-forward",
        "slow-backward",
        "fast-forward",
        "fast-backward",
    ] {
        let rec = Recording::load(&out.join(format!("drive_{name}.csv"))).unwrap();
        assert_eq!(rec.rig.as_str(), "vehicle");
        assert_eq!(rec.t_s[0], 0.0, "time counts from the test's first row");
        assert!(rec.meta.contains_key("time_origin_s"));
        // Speeds in m/s: rotations x unitsPerRotation.
        let v = rec.column("left_wheel_speed_m_s").unwrap();
        let raw: serde_json::Value = serde_json::from_str(&json).unwrap();
        let r5 = raw[name][100][5].as_f64().unwrap();
        assert_eq!(v[100], Some(r5 * UPR));
    }
    agvsim::rig::Rig::load(&out.join("drive.rig.toml")).unwrap();
    let imported = wpilib::import(&file, &Choice::default(), &Assumptions::default()).unwrap();
    let ks = imported.feedforward.ks_v.value;
    let reference = independent_ks(&json);
    assert!(
        (ks - reference).abs() <= 0.01 * reference.abs(),
        "kS {ks} against the independent {reference}"
    );
    // And both near the truth: the regression is SysId's model of this machine.
    assert!((ks - KS).abs() < 0.1 * KS, "kS {ks} against the truth {KS}");
    assert!((imported.feedforward.kv_v_s_per_unit.value - KV).abs() < 0.05 * KV);
    assert!((imported.feedforward.ka_v_s2_per_unit.value - KA).abs() < 0.1 * KA);
    let says = |s: &str| stdout.contains(s);
    assert!(says("kS = ") && says("kV = ") && says("kA = "), "{stdout}");
}

fn check_json_refused(edit: impl Fn(&mut serde_json::Value), expected: &str) {
    let mut v: serde_json::Value = serde_json::from_str(&drivetrain_json()).unwrap();
    edit(&mut v);
    let dir = tmp("bad-json");
    let file = dir.join("bad.json");
    std::fs::write(&file, v.to_string()).unwrap();
    let e = wpilib::import(&file, &Choice::default(), &Assumptions::default())
        .unwrap_err()
        .to_string();
    println!("{e}");
    assert!(e.contains(expected), "expected `{expected}` in: {e}");
    assert!(e.contains("bad.json"), "{e}");
}

#[test]
fn malformed_sysid_json_is_refused_naming_the_field_test_and_row() {
    check_json_refused(
        |v| {
            v.as_object_mut().unwrap().remove("units");
        },
        "`units`: missing",
    );
    check_json_refused(|v| v["units"] = "Furlongs".into(), "`units` = \"Furlongs\"");
    check_json_refused(|v| v["test"] = "Swerve".into(), "`test` = \"Swerve\"");
    check_json_refused(
        |v| {
            v.as_object_mut().unwrap().remove("fast-backward");
        },
        "`fast-backward`: missing",
    );
    check_json_refused(
        |v| v["slow-forward"][3] = serde_json::json!([1.0, 2.0]),
        "`slow-forward`, row 3: expected a list of 9 numbers",
    );
    check_json_refused(
        |v| v["slow-forward"][5][6] = serde_json::Value::Null,
        "`slow-forward`, row 5, column 6",
    );
    // A repeated and a backwards time stamp are reported, not fixed.
    check_json_refused(
        |v| {
            let t = v["fast-forward"][9][0].clone();
            v["fast-forward"][10][0] = t;
        },
        "test `fast-forward`, row 10: timestamp",
    );
    check_json_refused(|v| v["fast-forward"][10][0] = 0.0.into(), "goes back from");
    // One time stamp mistyped as 1e12 s at the end of a test: no kA of 6e9 from it.
    check_json_refused(
        |v| {
            let n = v["slow-forward"].as_array().unwrap().len();
            v["slow-forward"][n - 1][0] = 1e12.into();
        },
        "a corrupt time stamp?",
    );
    check_json_refused(
        |v| {
            v.as_object_mut().unwrap().remove("sysid");
        },
        "not a SysId data file",
    );
    let dir = tmp("nan-json");
    let file = dir.join("nan.json");
    std::fs::write(&file, "{\"sysid\": true, \"x\": NaN}").unwrap();
    let e = wpilib::import(&file, &Choice::default(), &Assumptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("line 1, column"), "{e}");
}

/// A DataLog as SysIdRoutineLog writes it: the state entry, and voltage, position and
/// velocity of one motor `flywheel` of routine `shooter`, in rotations, with the unit in
/// each entry's metadata; values a few microseconds apart in each 5 ms loop.
fn flywheel_wpilog(position_unit: &str, nan_at: Option<usize>) -> Vec<u8> {
    let entries = [
        ("sysid-test-state-shooter", "string", ""),
        ("voltage-flywheel-shooter", "double", "Volts"),
        ("position-flywheel-shooter", "double", position_unit),
        ("velocity-flywheel-shooter", "double", "RotationsPerSecond"),
    ];
    let mut records = Vec::new();
    let mut t_us = 1_000_000i64;
    let mut row = 0;
    for (state, volts) in [
        ("quasistatic-forward", tests_volts()[0].1.clone()),
        ("dynamic-reverse", tests_volts()[3].1.clone()),
    ] {
        records.push((0, t_us, state.as_bytes().to_vec()));
        let mut angle = 0.0;
        for (_, u, v) in side(&volts) {
            let rps = v / 0.5; // this flywheel's "metres" are half-turns: any first-order shaft
            angle += rps * DT;
            let vel = if nan_at == Some(row) { f64::NAN } else { rps };
            records.push((1, t_us, u.to_le_bytes().to_vec()));
            records.push((2, t_us + 3, f64::to_le_bytes(angle).to_vec()));
            records.push((3, t_us + 5, vel.to_le_bytes().to_vec()));
            t_us += 5000;
            row += 1;
        }
        records.push((0, t_us, b"none".to_vec()));
        t_us += 500_000;
    }
    datalog::write("agvsim test", &entries, &records)
}

#[test]
fn a_wpilog_sysid_routine_imports_test_by_test_with_units_from_its_metadata() {
    let dir = tmp("wpilog");
    let file = dir.join("shooter.wpilog");
    std::fs::write(&file, flywheel_wpilog("Rotations", None)).unwrap();
    let imported = wpilib::import(&file, &Choice::default(), &Assumptions::default()).unwrap();
    let names: Vec<&str> = imported
        .recordings
        .iter()
        .map(|r| r.test.as_str())
        .collect();
    assert_eq!(names, ["quasistatic-forward", "dynamic-reverse"]);
    assert_eq!(imported.log.mechanism, wpilib::Mechanism::Simple);
    let rec = Recording::parse(&imported.recordings[0].text, Path::new("q.csv")).unwrap();
    assert_eq!(rec.rig.as_str(), "drive_axis");
    // Rotations per second to rad/s: 2 pi.
    let w = rec.column("motor_speed_rad_s").unwrap();
    let expected = side(&tests_volts()[0].1)[700].2 / 0.5 * std::f64::consts::TAU;
    assert!(
        (w[700].unwrap() - expected).abs() < 1e-12,
        "{:?} against {expected}",
        w[700]
    );
    // kS of the shaft in V: the same friction in volts, whatever the speed unit.
    let ks = imported.feedforward.ks_v.value;
    assert!((ks - KS).abs() < 0.02 * KS, "kS {ks}");
    agvsim::rig::Rig::parse(&imported.rig, Path::new("r.rig.toml")).unwrap();
    assert!(
        imported.rig.contains("ASSUMED"),
        "the rig says what it assumed:\n{}",
        imported.rig
    );
}

#[test]
fn malformed_wpilogs_are_refused_naming_the_entry_or_byte() {
    let dir = tmp("bad-wpilog");
    let file = dir.join("bad.wpilog");
    let fail = |bytes: Vec<u8>| {
        std::fs::write(&file, bytes).unwrap();
        let e = wpilib::import(&file, &Choice::default(), &Assumptions::default())
            .unwrap_err()
            .to_string();
        println!("{e}");
        e
    };
    assert!(fail(flywheel_wpilog("", None)).contains("declares no unit"));
    assert!(fail(flywheel_wpilog("Parsecs", None)).contains("`Parsecs` is not one SysId uses"));
    assert!(fail(flywheel_wpilog("Rotations", Some(42))).contains("velocity-flywheel-shooter"));
    let mut cut = flywheel_wpilog("Rotations", None);
    cut.truncate(cut.len() - 4);
    assert!(fail(cut).contains("ends inside"));
    let no_routine = datalog::write(
        "",
        &[("voltage", "double", "Volts")],
        &[(0, 1, 1.0f64.to_le_bytes().to_vec())],
    );
    assert!(fail(no_routine).contains("not a log of a WPILib SysIdRoutine"));
    let mut bad_magic = flywheel_wpilog("Rotations", None);
    bad_magic[0] = b'X';
    assert!(fail(bad_magic).contains("neither a DataLog"));
}

#[test]
fn mat_files_written_by_scipy_read_the_same_compressed_or_not() {
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/mat");
    for name in ["scipy_plain.mat", "scipy_compressed.mat"] {
        let vars = matfile::read(&std::fs::read(fixtures.join(name)).unwrap()).unwrap();
        let get = |n: &str| {
            vars.iter()
                .find(|v| v.name == n)
                .unwrap_or_else(|| panic!("{name}: no {n}"))
        };
        assert_eq!(
            get("t").data,
            Data::Numeric(vec![0.0, 0.001, 0.002, 0.003]),
            "{name}"
        );
        assert_eq!(
            get("qm").data,
            Data::Numeric(vec![1.5, -2.25, 3.0, 4.125]),
            "{name}"
        );
        assert_eq!(
            get("counts").data,
            Data::Numeric(vec![1.0, -2.0, 300.0, -400.0]),
            "{name}"
        );
        assert_eq!(get("m").dims, vec![2, 3]);
        assert_eq!(
            get("m").data,
            Data::Numeric(vec![1.0, 4.0, 2.0, 5.0, 3.0, 6.0])
        );
        assert_eq!(get("label").data, Data::Text("EMPS axis".into()));
    }
}

const EMPS_MAP: &str = r#"
rig = "drive_axis"
description = "EMPS estimation record: bang-bang acceleration trajectories, closed loop"
time = { column = "t" }
[columns]
reference_m = { column = "qg" }
command_V = { column = "vir" }
position_m = { column = "qm" }
"#;

#[test]
fn the_emps_layout_as_a_compressed_mat_file_imports_to_the_shipped_recording_value_for_value() {
    let csv = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/real/emps/data_emps.csv");
    let shipped = Recording::load(&csv).unwrap();
    let col = |n: &str| -> Vec<f64> {
        shipped
            .column(n)
            .unwrap()
            .iter()
            .map(|v| v.unwrap())
            .collect()
    };
    let n = shipped.t_s.len();
    let mut w = matfile::Writer::new("EMPS layout");
    w.matrix("t", n, 1, &shipped.t_s)
        .matrix("qg", n, 1, &col("reference_m"))
        .matrix("vir", n, 1, &col("command_V"))
        .matrix("qm", n, 1, &col("position_m"));
    let dir = tmp("emps");
    let (mat, map) = (dir.join("DATA_EMPS.mat"), dir.join("emps.toml"));
    std::fs::write(&mat, matfile::compress(&w.finish())).unwrap();
    std::fs::write(&map, EMPS_MAP).unwrap();
    let import_mat = || {
        agvsim(&[
            "import",
            "mat",
            mat.to_str().unwrap(),
            "--map",
            map.to_str().unwrap(),
            "--out",
            dir.to_str().unwrap(),
        ])
    };
    let (ok, _, stderr) = import_mat();
    assert!(ok, "{stderr}");
    let got = Recording::load(&dir.join("DATA_EMPS.csv")).unwrap();
    assert_eq!(got.t_s, shipped.t_s);
    for name in &shipped.names {
        assert_eq!(got.column(name), shipped.column(name), "{name}");
    }
    // A variable the map names but the file lacks, and one of another length.
    std::fs::write(&map, EMPS_MAP.replace("\"qm\"", "\"qx\"")).unwrap();
    let (ok, _, stderr) = import_mat();
    assert!(
        !ok && stderr.contains("variable `qx` is not in"),
        "{stderr}"
    );
    let mut w = matfile::Writer::new("short");
    w.matrix("t", 3, 1, &[0.0, 1.0, 2.0])
        .matrix("qg", 2, 1, &[0.0, 1.0])
        .matrix("vir", 3, 1, &[0.0; 3])
        .matrix("qm", 3, 1, &[0.0; 3]);
    std::fs::write(&mat, w.finish()).unwrap();
    std::fs::write(&map, EMPS_MAP).unwrap();
    let (ok, _, stderr) = import_mat();
    assert!(!ok && stderr.contains("`qg` has 2 values"), "{stderr}");
}

#[test]
fn linearize_exports_named_discrete_matrices_as_mat_and_json() {
    let dir = tmp("linearize");
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/lab_offset_120mm.toml");
    let (mat, json) = (dir.join("agv.mat"), dir.join("agv.json"));
    for f in [&mat, &json] {
        let (ok, _, stderr) = agvsim(&[
            "linearize",
            scene.to_str().unwrap(),
            "--export",
            f.to_str().unwrap(),
        ]);
        assert!(ok, "{stderr}");
    }
    let vars = matfile::read(&std::fs::read(&mat).unwrap()).unwrap();
    let get = |n: &str| vars.iter().find(|v| v.name == n).unwrap();
    assert_eq!(get("A").dims, vec![11, 11]);
    assert_eq!(get("B").dims, vec![11, 2]);
    assert_eq!(get("C").dims, vec![2, 11]);
    assert_eq!(get("D").dims, vec![2, 2]);
    let Data::Texts(states) = &get("state_names").data else {
        panic!()
    };
    assert_eq!(states[3], "speed_m_s");
    let Data::Texts(units) = &get("state_units").data else {
        panic!()
    };
    assert_eq!(units[3], "m/s");
    let j: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    // The same numbers in both forms (MAT column-major, JSON by rows; serde_json's
    // default decimal parsing may land one unit in the last place away).
    let Data::Numeric(a) = &get("A").data else {
        panic!()
    };
    for i in 0..11 {
        for k in 0..11 {
            let (m, t) = (a[k * 11 + i], j["A"][i][k].as_f64().unwrap());
            assert!(
                (m - t).abs() <= 4.0 * f64::EPSILON * m.abs(),
                "A[{i}][{k}]: {m} against {t}"
            );
        }
    }
    assert_eq!(
        Data::Numeric(vec![j["Ts_s"].as_f64().unwrap()]),
        get("Ts").data
    );
    // The forward speed's pole is inside the unit circle: the exported A is the plant's.
    assert!(j["A"][3][3].as_f64().unwrap() < 1.0);
    let (ok, _, stderr) = agvsim(&[
        "linearize",
        scene.to_str().unwrap(),
        "--export",
        dir.join("agv.txt").to_str().unwrap(),
    ]);
    assert!(
        !ok && stderr.contains("expected a name ending in .mat or .json"),
        "{stderr}"
    );
}
