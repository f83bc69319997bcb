//! Helpers the test binaries share (`mod common;` in each).
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Output;

/// A fresh, empty scratch folder for one test: inside cargo's folder for test files,
/// named after the test binary and `name`, so binaries running at once never share one.
pub fn tmp(name: &str) -> PathBuf {
    let d =
        Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("{}-{name}", env!("CARGO_CRATE_NAME")));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A command's standard output then its standard error, as text.
pub fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// Another writer holding the lock file `lock` as the kernel keeps it (util-linux
/// `flock -o`, an independent taker, so killing the child ends the writer): returned once
/// a non-blocking try sees the lock taken.
pub fn hold_lock(lock: &Path) -> std::process::Child {
    use std::process::Command;
    let other = Command::new("flock")
        .arg("-o")
        .arg(lock)
        .args(["sleep", "30"])
        .spawn()
        .unwrap();
    let t0 = std::time::Instant::now();
    while Command::new("flock")
        .arg("-n")
        .arg(lock)
        .arg("true")
        .status()
        .unwrap()
        .success()
    {
        assert!(t0.elapsed().as_secs() < 10, "flock never took the lock");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    other
}

/// `agvsim` run from the package's folder with `args`.
pub fn agvsim_output(args: &[&str]) -> Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_agvsim"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(args)
        .output()
        .expect("agvsim runs")
}

/// Three one-second recordings of the lab machine at gains 0.9, 1.0 and 1.1, as a fleet
/// folder `DIR/fleet` of `robot0.csv` ... `robot2.csv`.
pub fn small_fleet(dir: &Path) -> PathBuf {
    let fleet = dir.join("fleet");
    std::fs::create_dir_all(&fleet).unwrap();
    for (i, gain) in ["0.9", "1.0", "1.1"].iter().enumerate() {
        let out = dir.join(format!("run{i}"));
        let o = agvsim_output(&[
            "run",
            "scenes/lab_offset_120mm.toml",
            "--duration",
            "1",
            "--set",
            &format!("controller.gain_scale={gain}"),
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", text(&o));
        std::fs::copy(
            out.join("lab_offset_120mm.csv"),
            fleet.join(format!("robot{i}.csv")),
        )
        .unwrap();
    }
    fleet
}

/// `agvsim batch merge SHARDS --out DIR/merged` (an earlier merge removed first).
pub fn batch_merge(dir: &Path, shards: &[&Path]) -> Output {
    let mut args = vec!["batch", "merge"];
    args.extend(shards.iter().map(|s| s.to_str().unwrap()));
    let out = dir.join("merged");
    let _ = std::fs::remove_dir_all(&out);
    args.extend(["--out", out.to_str().unwrap()]);
    agvsim_output(&args)
}

/// The numbers of the robot the shipped example bag was made from (`data/ros2_example`'s
/// README): `import ros2`'s options for it, with its controller file.
pub const EXAMPLE_BAG_ROBOT: [&str; 12] = [
    "--mass-kg",
    "40",
    "--gear-ratio",
    "20",
    "--motor-no-load-rpm",
    "3000",
    "--motor-stall-current-A",
    "40",
    "--battery-V",
    "24",
    "--controller-yaml",
    "data/ros2_example/controller.yaml",
];

/// The calibrate proof's case of `kind` whose name ends with `name_end` (`"/clean"`,
/// `"/wheel_geometry"`).
pub fn proof_case(
    kind: agvsim::calibrate::prove::Kind,
    name_end: &str,
) -> agvsim::calibrate::prove::Case {
    agvsim::calibrate::prove::cases(&[kind])
        .unwrap()
        .into_iter()
        .find(|c| c.name.ends_with(name_end))
        .unwrap_or_else(|| panic!("no {kind:?} case ends with {name_end}"))
}
