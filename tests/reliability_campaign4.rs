//! The fourth reliability campaign's findings (issue "bags that lie about their topics,
//! runs that outlive their commands, seals that anyone can forge"), each built from its
//! description with inputs made here. The bag findings are in tests/ros2_import.rs (their
//! bags written by rosbags).

mod common;
use common::{batch_merge, hold_lock, small_fleet, text, tmp};

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn agvsim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_agvsim"))
        .args(args)
        .output()
        .expect("agvsim runs")
}

/// A velocity-commanded robot's scene written by `agvsim new` (top speed 1.23 m/s: 3000
/// rpm at 23.5 V through 20:1 to a 0.08 m wheel), its square's `sim.duration_s` 22.57 s.
fn velocity_scene(dir: &Path) -> PathBuf {
    let scene = dir.join("robot.toml");
    let o = agvsim(&[
        "new",
        scene.to_str().unwrap(),
        "--mass-kg",
        "40",
        "--track-m",
        "0.4",
        "--wheel-radius-m",
        "0.08",
        "--battery-V",
        "24",
        "--motor-no-load-rpm",
        "3000",
        "--motor-stall-current-A",
        "40",
        "--gear-ratio",
        "20",
        "--force",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    scene
}

/// The scene driving the commands CSV `rows` (t_s, cmd_linear_m_s, cmd_angular_rad_s).
fn commands_scene(dir: &Path, name: &str, rows: &str) -> PathBuf {
    let scene = velocity_scene(dir);
    let csv = dir.join(format!("{name}.csv"));
    std::fs::write(
        &csv,
        format!(
            "# agvsim-recording: 1\n# rig: vehicle\nt_s,cmd_linear_m_s,cmd_angular_rad_s\n{rows}"
        ),
    )
    .unwrap();
    let text = std::fs::read_to_string(&scene).unwrap();
    let commands = text
        .lines()
        .map(|l| {
            if l.starts_with("kind = \"square\"") {
                "kind = \"commands\"".to_string()
            } else if l.starts_with("commands = ") {
                format!("commands = \"{name}.csv\"")
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, commands).unwrap();
    path
}

fn run(scene: &Path, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "run",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend(extra);
    agvsim(&args)
}

/// "simulated  T s, D m travelled": (T, D).
fn simulated(t: &str) -> (f64, f64) {
    let line = t
        .lines()
        .find(|l| l.starts_with("simulated"))
        .unwrap_or_else(|| panic!("{t}"));
    let n: Vec<f64> = line
        .split_whitespace()
        .filter_map(|w| w.parse().ok())
        .collect();
    (n[0], n[1])
}

/// A commands file runs for its span and the rest after it, not the square's
/// `sim.duration_s`: one row of 0.4 m/s drives a second (the rest), about 0.35 m with the
/// start's acceleration, not 22.57 s and 9 m. With `--duration` the run keeps that length
/// and says what it held or cut; a file whose commands all lie past the run's end, or so
/// far out that no run reaches them, is refused naming the file.
#[test]
fn a_commands_run_lasts_its_commands_and_says_what_it_held_or_cut() {
    let dir = tmp("commands_span");
    let one = commands_scene(&dir, "one", "0,0.4,0\n");
    let o = run(&one, &dir.join("one_out"), &[]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    let (secs, metres) = simulated(&t);
    assert_eq!(secs, 1.0, "{t}");
    assert!(metres > 0.2 && metres < 0.4, "{t}");
    assert!(
        t.contains("the last command held for manoeuvre.rest_s"),
        "{t}"
    );
    let o = run(&one, &dir.join("one_long"), &["--duration", "5"]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(
        t.contains("the last (0.4 m/s, 0 rad/s at 0 s) is held to the run's end at 5 s"),
        "{t}"
    );
    let steps = commands_scene(&dir, "steps", "0,0,0\n1,0.3,0\n2,0.2,0.5\n4,0,0\n");
    let o = run(&steps, &dir.join("steps_cut"), &["--duration", "3"]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(t.contains("the last 1 (from 4 s on) are not run"), "{t}");
    assert!(!t.contains("the base rests"), "{t}");
    let late = commands_scene(&dir, "late", "1000000,0.4,0\n1000001,0,0\n");
    for extra in [&[][..], &["--duration", "5"][..]] {
        let out = dir.join("late_out");
        let o = run(&late, &out, extra);
        let t = text(&o);
        assert_eq!(o.status.code(), Some(2), "{t}");
        assert!(
            t.contains("manoeuvre.commands = ")
                && t.contains("late.csv")
                && t.contains("1000000 s"),
            "{t}"
        );
        assert!(!out.join("late.csv").exists(), "{t}");
    }
}

/// Commands above the base's top speed are said (the wheels saturate), naming the worst row.
#[test]
fn commands_above_the_top_speed_are_said_to_saturate() {
    let dir = tmp("saturate");
    let fast = commands_scene(&dir, "fast", "0,0,0\n0.5,100,0\n1,0.2,0\n");
    let o = run(&fast, &dir.join("out"), &[]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(
        t.contains(
            "warning: 1 of 3 command rows ask a wheel for more than the base's top speed 1.23 m/s"
        ) && t.contains("100 m/s and 0 rad/s at 0.5 s"),
        "{t}"
    );
    let calm = commands_scene(&dir, "calm", "0,0,0\n0.5,1,0\n1,0.2,0\n");
    let t = text(&run(&calm, &dir.join("calm_out"), &[]));
    assert!(!t.contains("top speed"), "{t}");
}

/// A square or circle faster than the base can drive is refused naming the key (a speed of
/// 1e300 m/s travelled nothing and said the square closed); a shape the run's length cuts
/// short is said to be cut, not given a heading error of -359999999635 deg.
#[test]
fn shapes_the_base_cannot_drive_are_refused_and_cut_shapes_are_said() {
    let dir = tmp("shapes");
    let scene = velocity_scene(&dir);
    for (set, key) in [
        (
            "manoeuvre.speed_m_s=1e300",
            "manoeuvre.speed_m_s = 1e300 m/s",
        ),
        (
            "manoeuvre.turn_rate_rad_s=7",
            "manoeuvre.turn_rate_rad_s = 7 rad/s",
        ),
    ] {
        let out = dir.join("refused");
        let o = run(&scene, &out, &["--set", set]);
        let t = text(&o);
        assert_eq!(o.status.code(), Some(2), "{t}");
        assert!(t.contains(key) && t.contains("top speed 1.23 m/s"), "{t}");
        assert!(!out.exists(), "{t}");
    }
    let o = run(
        &scene,
        &dir.join("circle"),
        &[
            "--set",
            "manoeuvre.kind=\"circle\"",
            "--set",
            "manoeuvre.speed_m_s=1.1",
        ],
    );
    assert!(
        text(&o).contains("outer wheel's speed on the circle would be 1.32 m/s"),
        "{}",
        text(&o)
    );
    let o = run(
        &scene,
        &dir.join("laps"),
        &["--set", "manoeuvre.laps=1000000000", "--duration", "5"],
    );
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(t.contains("cut short at 5.00 s by sim.duration_s"), "{t}");
    assert!(!t.contains("deg off"), "{t}");
}

/// A controller file whose wheel separation is 40 times the robot's track (16 m for
/// 0.4 m: another robot's, or millimetres) is warned of naming the file; a `--set` of the
/// configured separation or radius, or a rolling radius, far from the wheels is warned of
/// on `run`.
#[test]
fn configured_sizes_far_from_the_wheels_are_warned_of_naming_their_source() {
    let dir = tmp("configured");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let yaml = std::fs::read_to_string(root.join("data/ros2_example/controller.yaml")).unwrap();
    assert!(yaml.contains("wheel_separation: 0.4\n"), "{yaml}");
    let wide = dir.join("wide.yaml");
    std::fs::write(
        &wide,
        yaml.replace("wheel_separation: 0.4\n", "wheel_separation: 16\n"),
    )
    .unwrap();
    let o = agvsim(&[
        "import",
        "ros2",
        root.join("data/ros2_example/robot_square")
            .to_str()
            .unwrap(),
        "--out",
        dir.join("import").to_str().unwrap(),
        "--mass-kg",
        "40",
        "--controller-yaml",
        wide.to_str().unwrap(),
    ]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(
        t.contains("warning: --controller-yaml ")
            && t.contains("`base.wheel_separation_m` = 16 m")
            && t.contains("40 times it"),
        "{t}"
    );
    let scene = velocity_scene(&dir);
    for (set, key) in [
        (
            "base.wheel_separation_m=1e5",
            "`base.wheel_separation_m` = 100000 m",
        ),
        (
            "base.wheel_radius_m=1e-300",
            "`base.wheel_radius_m` = 1e-300 m",
        ),
        (
            "wheel.left_rolling_radius_m=1e-300",
            "`wheel.left_rolling_radius_m` = 1e-300 m",
        ),
    ] {
        let o = run(
            &scene,
            &dir.join("set"),
            &["--set", set, "--duration", "0.5"],
        );
        let t = text(&o);
        assert!(t.contains(key), "{set}: {t}");
    }
}

/// A plain `t_s,cmd_linear_m_s,cmd_angular_rad_s` CSV, as docs/own-robot.md and `keys`
/// describe a commands file, runs without the recording's metadata lines; a breach in it is
/// still named by its line.
#[test]
fn a_plain_commands_csv_runs_without_the_recording_header() {
    let dir = tmp("plain_commands");
    let scene = commands_scene(&dir, "plain", "0,0,0\n");
    std::fs::write(
        dir.join("plain.csv"),
        "t_s,cmd_linear_m_s,cmd_angular_rad_s\n0,0.3,0\n1,0,0\n",
    )
    .unwrap();
    let o = run(&scene, &dir.join("out"), &[]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(!t.contains("3 rows") && t.contains("2 rows from"), "{t}");
    std::fs::write(
        dir.join("plain.csv"),
        "t_s,cmd_linear_m_s,cmd_angular_rad_s\n0,0.3,0\n1,fast,0\n",
    )
    .unwrap();
    let t = text(&run(&scene, &dir.join("bad"), &[]));
    assert!(
        t.contains("plain.csv:3") && t.contains("`fast` is not a number"),
        "{t}"
    );
}

/// Lost output: a `--json` (or `--write`, `--html`) file another live agvsim writes is
/// refused before any work, naming the option and the holder (held here by util-linux
/// `flock`, an independent taker, on the lock file beside it). (That a lock taken is
/// removed when its command ends: src/output.rs's unit test.)
#[test]
fn an_output_file_another_agvsim_writes_is_refused_naming_it() {
    let dir = tmp("file_lock");
    let json = dir.join("result.json");
    let lock = dir.join(".result.json.agvsim.lock");
    std::fs::write(&lock, "process 4242 on another-host\n").unwrap();
    let mut other = hold_lock(&lock);
    let o = agvsim(&[
        "run",
        "scenes/lifted_identification.toml",
        "--duration",
        "1",
        "--out",
        dir.join("rec").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let rec = dir.join("rec/lifted_identification.csv");
    let calibrate = |extra: &[&str]| {
        let mut args = vec![
            "calibrate",
            "--scene",
            "scenes/lifted_identification.toml",
            "--recording",
            rec.to_str().unwrap(),
        ];
        args.extend(extra);
        Command::new(env!("CARGO_BIN_EXE_agvsim"))
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .args(&args)
            .output()
            .unwrap()
    };
    for (option, file) in [("--json", &json), ("--write", &dir.join("result.json"))] {
        let o = calibrate(&[option, file.to_str().unwrap()]);
        let t = text(&o);
        assert_eq!(o.status.code(), Some(2), "{t}");
        assert!(
            t.contains(option)
                && t.contains("another agvsim (process 4242 on another-host) is writing there"),
            "{t}"
        );
    }
    other.kill().unwrap();
    other.wait().unwrap();
    assert!(!json.exists());
}

/// Batch merge: a manifest cut to fewer recordings and one shard, or its `--effects`
/// edited, is refused by its seal (it named "the recording changed"); a result resealed
/// by hand (the seal is unkeyed: anyone can recompute it, docs/fleet.md says so) with a
/// fit of 123456 % is refused as impossible.
#[test]
fn batch_merge_refuses_edited_manifests_and_impossible_results() {
    let dir = tmp("batch_seal");
    let fleet = small_fleet(&dir);
    let shard = dir.join("s1");
    let o = agvsim(&[
        "batch",
        "calibrate",
        fleet.to_str().unwrap(),
        "--scene",
        "scenes/lab_offset_120mm.toml",
        "--effects",
        "coulomb_friction",
        "--out",
        shard.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(batch_merge(&dir, &[&shard]).status.success());
    let refused = |says: &str| {
        let o = batch_merge(&dir, &[&shard]);
        let t = text(&o);
        assert!(!o.status.success(), "accepted: {t}");
        assert!(t.contains(says), "expected `{says}` in: {t}");
        assert!(!dir.join("merged/summary.csv").exists(), "{t}");
    };
    let manifest_path = shard.join("batch.json");
    let original = std::fs::read_to_string(&manifest_path).unwrap();
    let mut m: serde_json::Value = serde_json::from_str(&original).unwrap();
    // Cut to the first two recordings.
    m["items"].as_array_mut().unwrap().truncate(2);
    m["fingerprints"].as_array_mut().unwrap().truncate(2);
    std::fs::write(&manifest_path, serde_json::to_string_pretty(&m).unwrap()).unwrap();
    refused("batch.json: its contents differ from what the batch wrote");
    std::fs::write(
        &manifest_path,
        original.replace("\"coulomb_friction\"", "\"viscous_friction\""),
    )
    .unwrap();
    refused("batch.json: its contents differ from what the batch wrote");
    std::fs::write(&manifest_path, &original).unwrap();
    // A result with an impossible fit, sealed again as the batch seals.
    let seal = serde_json::from_str::<serde_json::Value>(&original).unwrap()["seal"]
        .as_str()
        .unwrap()
        .to_string();
    let result = shard.join("results/robot1.json");
    let text_before = std::fs::read_to_string(&result).unwrap();
    let mut entry: agvsim::batch::Entry = serde_json::from_str(&text_before).unwrap();
    entry.fit_after_pct = Some(123456.0);
    let forged = entry.sealed(&seal);
    assert!(forged.seal_holds(&seal));
    std::fs::write(&result, serde_json::to_string_pretty(&forged).unwrap()).unwrap();
    refused("fit_after_pct = 123456: a fit is at most 100 %");
    std::fs::write(&result, &text_before).unwrap();
    assert!(batch_merge(&dir, &[&shard]).status.success());
}

/// An obstacle's `angle_rad = nan` is named as itself, on its line (it was blamed on
/// `center_m`, a key not in the file).
#[test]
fn an_obstacles_bad_angle_is_named_on_its_line() {
    let dir = tmp("obstacle_angle");
    let scene = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/bumper_stop.toml"),
    )
    .unwrap();
    let at = scene.find("[[obstacles]]\n").unwrap() + "[[obstacles]]\n".len();
    let edited = format!("{}angle_rad = nan\n{}", &scene[..at], &scene[at..]);
    let line = edited[..at].lines().count() + 1;
    let path = dir.join("bumper.toml");
    std::fs::write(&path, &edited).unwrap();
    let o = run(&path, &dir.join("out"), &["--duration", "0.1"]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(
        t.contains(&format!(
            "bumper.toml:{line}: `obstacles[0].angle_rad` = NaN"
        )),
        "{t}"
    );
}

/// `--free` with a key the scene does not have is named by its option before any replay.
#[test]
fn a_free_key_that_is_no_scene_key_is_named_by_its_option() {
    let dir = tmp("free_key");
    let o = agvsim(&[
        "run",
        "scenes/lifted_identification.toml",
        "--duration",
        "1",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let o = agvsim(&[
        "calibrate",
        "--scene",
        "scenes/lifted_identification.toml",
        "--recording",
        dir.join("lifted_identification.csv").to_str().unwrap(),
        "--free",
        "motor.resistance_ohm,base.nope",
    ]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(
        t.contains("error: --free base.nope: no such scene key"),
        "{t}"
    );
    assert!(!t.contains("calibrate  "), "no fit began: {t}");
}

/// A CSV map with `t_s` under `[columns]` is refused naming the map and saying where the
/// time goes; a `scale` that carries a cell beyond any physical value is refused naming
/// the source file's line and column and the conversion (it blamed a line of the output,
/// not yet written).
#[test]
fn a_csv_maps_time_column_and_absurd_scale_are_named_in_the_users_files() {
    let dir = tmp("csv_map");
    let raw = dir.join("raw.csv");
    std::fs::write(&raw, "time_ms,volts\n0,1\n10,2\n20,3\n").unwrap();
    let import = |map_text: &str| {
        let map = dir.join("map.toml");
        std::fs::write(&map, map_text).unwrap();
        agvsim(&[
            "import",
            "csv",
            raw.to_str().unwrap(),
            "--map",
            map.to_str().unwrap(),
            "--out",
            dir.join("out").to_str().unwrap(),
        ])
    };
    let head = "rig = \"drive_axis\"\ntime = { column = \"time_ms\", unit = \"ms\" }\n[columns]\n";
    let o = import(&format!(
        "{head}t_s = {{ column = \"volts\" }}\nvoltage_V = {{ column = \"volts\" }}\n"
    ));
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(t.contains("map.toml: [columns] names `t_s`"), "{t}");
    let o = import(&format!(
        "{head}voltage_V = {{ column = \"volts\", scale = 1e308 }}\n"
    ));
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(
        t.contains(
            "raw.csv:2: column `volts`: 1 converted to voltage_V by the map (1 x 1e308) is 1e308"
        ),
        "{t}"
    );
    assert!(!dir.join("out").exists(), "{t}");
}
