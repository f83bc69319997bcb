//! A real robot's SysId log (`../shared/data/real/frc_drivetrain/`, a competition
//! drivetrain), imported by agvsim itself and diagnosed as a WPILib user would: the physics
//! the imported linear machine leaves out is its static friction, so the first effect named
//! must be `coulomb_friction`, its kS-equivalent within 5 % of SysId's own regression on the
//! four tests, and no baseline parameter may end at a search bound. On all four tests
//! together and on each slow (quasi-static) test alone, where the mass cannot be told and
//! must stay at what the import believed.

use std::path::{Path, PathBuf};
use std::process::Command;

const LOG: &str = "../shared/data/real/frc_drivetrain/sysid_data.json";
const TESTS: [&str; 4] = [
    "slow-forward",
    "slow-backward",
    "fast-forward",
    "fast-backward",
];

fn tmp(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("frc-{name}"));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn agvsim(args: &[String]) -> std::process::Child {
    Command::new(env!("CARGO_BIN_EXE_agvsim"))
        .args(args)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap()
}

fn finish(child: std::process::Child) -> String {
    let o = child.wait_with_output().unwrap();
    let out = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        o.status.success(),
        "{out}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    out
}

/// The diagnosis of `tests` (names of the log's tests) with the imported rig, started.
fn diagnose(dir: &Path, tests: &[&str], json: &Path) -> std::process::Child {
    let mut args = vec![
        "diagnose".to_string(),
        "--rig".into(),
        dir.join("sysid_data.rig.toml").display().to_string(),
    ];
    for t in tests {
        args.push("--recording".into());
        args.push(
            dir.join(format!("sysid_data_{t}.csv"))
                .display()
                .to_string(),
        );
    }
    args.extend(["--json".into(), json.display().to_string()]);
    agvsim(&args)
}

fn read(json: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(json).unwrap()).unwrap()
}

/// Checks one diagnosis against SysId's kS (of the four tests together).
fn check(what: &str, d: &serde_json::Value, sysid_ks_v: f64) {
    let effects: Vec<&str> = d["effects"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["name"].as_str().unwrap())
        .collect();
    assert_eq!(effects.first(), Some(&"coulomb_friction"), "{what}: {d:#}");
    let ks = d["sysid_feedforward"]["diagnosed_ks_v"].as_f64().unwrap();
    println!(
        "{what}: effects {effects:?}, kS-equivalent {ks:.4} V against SysId's {sysid_ks_v:.4} V ({:+.1} %)",
        100.0 * (ks / sysid_ks_v - 1.0)
    );
    assert!((ks / sysid_ks_v - 1.0).abs() < 0.05, "{what}: kS {ks}");
    // A baseline parameter on a bound is allowed only where the report says the record
    // cannot determine it (held at its belief).
    let at_bound = d["baseline"]["at_bound"].as_object().unwrap();
    for key in at_bound.keys() {
        let est = d["baseline"]["estimates"]
            .as_array()
            .unwrap()
            .iter()
            .find(|e| e["name"] == key.as_str())
            .unwrap();
        assert!(
            est["held"].as_bool().unwrap(),
            "{what}: {key} at a bound, not held: {est}"
        );
    }
}

#[test]
fn the_real_drivetrain_log_is_diagnosed_as_static_friction_with_sysid_ks() {
    let dir = tmp("import");
    let out = finish(agvsim(&[
        "import".into(),
        "wpilib".into(),
        LOG.into(),
        "--out".into(),
        dir.display().to_string(),
    ]));
    println!("{out}");
    let jsons: Vec<PathBuf> = ["all", "slow-forward", "slow-backward"]
        .iter()
        .map(|n| dir.join(format!("{n}.json")))
        .collect();
    // The three diagnoses run side by side (each is mostly serial).
    let children = vec![
        diagnose(&dir, &TESTS, &jsons[0]),
        diagnose(&dir, &TESTS[..1], &jsons[1]),
        diagnose(&dir, &TESTS[1..2], &jsons[2]),
    ];
    for c in children {
        println!("{}", finish(c));
    }
    let all = read(&jsons[0]);
    let sysid_ks_v = all["sysid_feedforward"]["gains"]["ks_v"]["value"]
        .as_f64()
        .unwrap();
    // The import printed the same regression.
    assert!(out.contains(&format!("kS = {sysid_ks_v:.4}")), "{out}");
    check("all four tests", &all, sysid_ks_v);
    check("slow-forward alone", &read(&jsons[1]), sysid_ks_v);
    check("slow-backward alone", &read(&jsons[2]), sysid_ks_v);
    // The gyro of straight runs is left out of the fit, and said so.
    let left_out = all["left_out"].as_array().unwrap();
    assert!(
        left_out.iter().any(|l| l["output"] == "yaw_rate_rad_s"),
        "{all:#}"
    );
}
