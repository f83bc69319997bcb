//! The third reliability campaign's findings (issue "hostile bags, clocks that disagree,
//! fleets merged wrong"), each built from its description with inputs made here.

mod common;
use common::{batch_merge, small_fleet, text, tmp};

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn agvsim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_agvsim"))
        .args(args)
        .output()
        .expect("agvsim runs")
}

fn example_bag() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data/ros2_example/robot_square")
}

/// A copy of the example rosbag2 folder whose metadata.yaml names `file` as its storage.
fn bag_naming(dir: &Path, file: &str) -> PathBuf {
    let bag = dir.join("bag");
    std::fs::create_dir_all(&bag).unwrap();
    std::fs::copy(
        example_bag().join("robot_square.mcap"),
        bag.join("robot_square.mcap"),
    )
    .unwrap();
    let meta = std::fs::read_to_string(example_bag().join("metadata.yaml")).unwrap();
    assert!(meta.contains("- robot_square.mcap"), "{meta}");
    std::fs::write(
        bag.join("metadata.yaml"),
        meta.replace("- robot_square.mcap", &format!("- {file}")),
    )
    .unwrap();
    bag
}

#[test]
fn a_bag_folder_reads_only_files_inside_it() {
    let dir = tmp("outside");
    for (name, file) in [
        ("etc", "/etc/passwd"),
        ("up", "../robot_square.mcap"),
        ("dev", "/dev/zero"),
    ] {
        let d = dir.join(name);
        let bag = bag_naming(&d, file);
        let o = agvsim(&[
            "import",
            "ros2",
            bag.to_str().unwrap(),
            "--out",
            d.join("out").to_str().unwrap(),
        ]);
        let t = text(&o);
        assert_eq!(o.status.code(), Some(2), "{file}: {t}");
        assert!(
            t.contains("relative_file_paths") && t.contains(file),
            "{file}: {t}"
        );
        assert!(
            !d.join("out").exists() || std::fs::read_dir(d.join("out")).unwrap().next().is_none()
        );
    }
    // A folder of its own file reads as before.
    let d = dir.join("own");
    let bag = bag_naming(&d, "robot_square.mcap");
    let o = agvsim(&[
        "import",
        "ros2",
        bag.to_str().unwrap(),
        "--out",
        d.join("out").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
}

#[test]
fn bags_named_in_other_scripts_keep_their_names() {
    let dir = tmp("unicode");
    let out = dir.join("out");
    for name in ["δοκιμή", "試験"] {
        let bag = dir.join(format!("{name}.mcap"));
        std::fs::copy(example_bag().join("robot_square.mcap"), &bag).unwrap();
        let o = agvsim(&[
            "import",
            "ros2",
            bag.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", text(&o));
    }
    // Two recordings, not one overwritten by the other.
    for name in ["δοκιμή", "試験"] {
        assert!(out.join(format!("{name}.csv")).exists(), "{name}");
    }
}

#[test]
fn shard_counts_near_the_integer_limit_do_not_overflow() {
    let dir = tmp("shard");
    let max = u64::MAX.to_string();
    let shard = format!("{max}/{max}");
    let o = agvsim(&[
        "sweep",
        "scenes/lab_offset_120mm.toml",
        "--vary",
        "controller.gain_scale=1,2",
        "--duration",
        "0.5",
        "--shard",
        &shard,
        "--out",
        dir.join("sweep").to_str().unwrap(),
    ]);
    let t = text(&o);
    assert!(
        !t.contains("panicked") && o.status.code() != Some(101),
        "{t}"
    );
    // The last of 2^64-1 shards of two runs holds the second run.
    if o.status.success() {
        let csv = std::fs::read_to_string(dir.join("sweep/results.csv")).unwrap();
        assert_eq!(csv.lines().count(), 2, "{csv}");
    }
}

#[test]
fn a_batch_whose_every_recording_failed_is_a_failed_job() {
    let dir = tmp("all-failed");
    let fleet = dir.join("fleet");
    std::fs::create_dir_all(&fleet).unwrap();
    for name in ["a", "b"] {
        std::fs::write(fleet.join(format!("{name}.csv")), "not a recording\n").unwrap();
    }
    let out = dir.join("out");
    let o = agvsim(&[
        "batch",
        "calibrate",
        fleet.to_str().unwrap(),
        "--scene",
        "scenes/lab_offset_120mm.toml",
        "--out",
        out.to_str().unwrap(),
    ]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(1), "{t}");
    assert!(t.contains("every one of the 2 recordings failed"), "{t}");
    // The summary says why, row by row.
    let summary = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    assert_eq!(summary.matches(",error,").count(), 2, "{summary}");
    assert!(summary.contains("missing metadata"), "{summary}");
}

#[test]
fn durations_are_named_as_the_option_given_and_a_run_of_no_row_is_refused() {
    let dir = tmp("duration");
    let o = run_lab(dir.join("a").as_ref(), "1e19", &[]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(
        t.contains("error: --duration 1e19: `sim.duration_s` = 1e19 s"),
        "{t}"
    );
    let o = run_lab(dir.join("b").as_ref(), "1e-9", &[]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(t.contains("at least one recording interval long"), "{t}");
    assert!(!dir.join("b/lab_offset_120mm.csv").exists());
}

/// The longest run of digits in a text (a 1e-300 printed plainly has over 300).
fn longest_digit_run(t: &str) -> usize {
    t.split(|c: char| !c.is_ascii_digit())
        .map(str::len)
        .max()
        .unwrap_or(0)
}

#[test]
fn absurd_numbers_given_to_new_are_named_by_their_options() {
    let dir = tmp("absurd-new");
    let base = [
        "--track-m",
        "0.4",
        "--wheel-radius-m",
        "0.05",
        "--battery-V",
        "12",
        "--motor-stall-current-A",
        "20",
    ];
    let new = |name: &str, extra: &[&str]| {
        let path = dir.join(name);
        let mut args = vec!["new", path.to_str().unwrap()];
        args.extend(base);
        args.extend(extra);
        agvsim(&args)
    };
    // Each warning names the option as typed; no number prints hundreds of digits.
    for (name, extra, says) in [
        (
            "grams.toml",
            &[
                "--mass-kg",
                "1e-300",
                "--gear-ratio",
                "20",
                "--motor-no-load-rpm",
                "3000",
            ][..],
            "warning: --mass-kg 1e-300 (",
        ),
        (
            "ratio.toml",
            &[
                "--mass-kg",
                "60",
                "--gear-ratio",
                "1e-300",
                "--motor-no-load-rpm",
                "3000",
            ],
            "warning: --gear-ratio 1e-300 (",
        ),
        (
            "rad_s.toml",
            &[
                "--mass-kg",
                "60",
                "--gear-ratio",
                "20",
                "--motor-no-load-rpm",
                "314",
            ],
            "warning: --motor-rated-V 12 --motor-no-load-rpm 314 (",
        ),
    ] {
        let o = new(name, extra);
        let t = text(&o);
        assert!(o.status.success(), "{name}: {t}");
        assert!(t.contains(says), "{name}: expected `{says}` in {t}");
        assert!(longest_digit_run(&t) < 30, "{name}: {t}");
    }
    // The rad/s typed as rpm: a top speed no robot that drives itself has.
    let o = agvsim(&["check", dir.join("rad_s.toml").to_str().unwrap()]);
    let t = text(&o);
    assert!(
        t.contains("expected a top speed of at least 0.1 m/s"),
        "{t}"
    );
    // A mass whose derived values are infinite: refused, naming the options first.
    let o = new(
        "huge.toml",
        &[
            "--mass-kg",
            "1e308",
            "--gear-ratio",
            "20",
            "--motor-no-load-rpm",
            "3000",
        ],
    );
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(t.starts_with("error: --mass-kg 1e308 "), "{t}");
    assert!(t.contains("beyond any wheeled robot's"), "{t}");
    assert!(longest_digit_run(&t) < 30, "{t}");
    assert!(!dir.join("huge.toml").exists());
}

#[test]
fn keys_at_1e308_stop_the_run_naming_the_key_instead_of_writing_nan_cells() {
    let dir = tmp("1e308");
    for key in [
        "controller.gain_scale",
        "castors.rolling_resistance",
        "battery.open_circuit_V",
        "battery.internal_resistance_ohm",
    ] {
        let out = dir.join(key);
        let o = run_lab(out.as_ref(), "2", &[&format!("{key}=1e308")]);
        let t = text(&o);
        assert!(!o.status.success(), "{key}: {t}");
        assert!(t.contains("the simulation diverged"), "{key}: {t}");
        assert!(t.contains(&format!("{key} = 1e308")), "{key}: {t}");
        assert!(!out.join("lab_offset_120mm.csv").exists(), "{key}");
        assert!(longest_digit_run(&t) < 30, "{key}: {t}");
    }
    // A sweep to 1e308 reports the run as failed, not "ok".
    let o = agvsim(&[
        "sweep",
        "scenes/lab_offset_120mm.toml",
        "--vary",
        "castors.rolling_resistance=0.02,1e308",
        "--set",
        "sim.duration_s=1",
        "--out",
        dir.join("sweep").to_str().unwrap(),
    ]);
    let t = text(&o);
    let results = std::fs::read_to_string(dir.join("sweep/results.csv")).unwrap();
    let row = results.lines().find(|l| l.starts_with("1,1e308")).unwrap();
    assert!(row.contains("error: the simulation diverged"), "{row}\n{t}");
    // An encoder noise of 1e308 rad/s is no encoder.
    let o = agvsim(&[
        "experiment",
        "coast-down",
        "scenes/lab_offset_120mm.toml",
        "--speed-noise",
        "1e308",
        "--out",
        dir.join("exp").to_str().unwrap(),
    ]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(
        t.contains("--speed-noise 1e308: expected an RMS noise"),
        "{t}"
    );
}

#[test]
fn a_recording_with_two_drives_says_which_one_drove_the_replay() {
    let dir = tmp("two-drives");
    let o = run_lab(dir.as_ref(), "1", &[]);
    assert!(o.status.success(), "{}", text(&o));
    let run = std::fs::read_to_string(dir.join("lab_offset_120mm.csv")).unwrap();
    let mut both = String::new();
    for l in run.lines() {
        both.push_str(l);
        if l.starts_with("t_s") {
            both.push_str(",cmd_linear_m_s,cmd_angular_rad_s");
        } else if !l.starts_with('#') {
            both.push_str(",0.3,0");
        }
        both.push('\n');
    }
    let rec = dir.join("both.csv");
    std::fs::write(&rec, both).unwrap();
    let o = replay_on_lab(&rec, &dir.join("replay"));
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(
        t.contains("driven by left_voltage_V and right_voltage_V; the velocity commands cmd_linear_m_s and cmd_angular_rad_s are in the recording too and were not used"),
        "{t}"
    );
}

#[test]
fn a_column_without_spread_is_left_out_and_reported_everywhere() {
    let dir = tmp("stuck");
    let o = run_lab(dir.as_ref(), "2", &[]);
    assert!(o.status.success(), "{}", text(&o));
    // The left wheel's encoder stuck at 0.25 m/s for the whole run.
    let run = std::fs::read_to_string(dir.join("lab_offset_120mm.csv")).unwrap();
    let mut col = None;
    let mut stuck = String::new();
    for l in run.lines() {
        if l.starts_with('#') {
            stuck.push_str(l);
        } else if l.starts_with("t_s") {
            col = l.split(',').position(|c| c == "left_wheel_speed_m_s");
            stuck.push_str(l);
        } else {
            let mut cells: Vec<&str> = l.split(',').collect();
            cells[col.unwrap()] = "0.25";
            stuck.push_str(&cells.join(","));
        }
        stuck.push('\n');
    }
    let rec = dir.join("stuck.csv");
    std::fs::write(&rec, stuck).unwrap();
    let o = replay_on_lab(&rec, &dir.join("replay"));
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    let line = t
        .lines()
        .find(|l| l.starts_with("left_wheel_speed_m_s"))
        .unwrap();
    assert!(line.contains("constant at 0.25: no spread to score"), "{t}");
    let mean = t.lines().find(|l| l.starts_with("mean")).unwrap();
    let mean: f64 = mean.split_whitespace().nth(1).unwrap().parse().unwrap();
    assert!(mean.is_finite() && mean > 50.0, "{t}");
    // Calibrate leaves it out of the fit and says why, in its report and its JSON.
    let json = dir.join("c.json");
    let o = agvsim(&[
        "calibrate",
        "--scene",
        "scenes/lab_offset_120mm.toml",
        "--recording",
        rec.to_str().unwrap(),
        "--effects",
        "coulomb_friction",
        "--json",
        json.to_str().unwrap(),
    ]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(
        t.contains("left_wheel_speed_m_s         left out: constant at 0.25 over its"),
        "{t}"
    );
    let j = std::fs::read_to_string(&json).unwrap();
    assert!(
        j.contains("\"output\":\"left_wheel_speed_m_s\"")
            || j.contains("\"output\": \"left_wheel_speed_m_s\""),
        "{j}"
    );
    assert!(!t.contains("-inf") && !j.contains("-inf"), "{t}");
}

#[test]
fn a_rig_with_a_wheel_and_no_gear_ratio_is_refused_naming_the_key() {
    let dir = tmp("no-ratio");
    let o = agvsim(&[
        "experiment",
        "lifted-random-demand",
        "scenes/lifted_identification.toml",
        "--duration",
        "3",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let rig = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.to_string_lossy().ends_with(".rig.toml"))
        .expect("a rig file");
    let csv = std::path::PathBuf::from(rig.to_string_lossy().replace(".rig.toml", ".csv"));
    let text_rig = std::fs::read_to_string(&rig).unwrap();
    assert!(text_rig.contains("[wheel]"), "{text_rig}");
    let stripped: String = text_rig
        .lines()
        .filter(|l| !l.starts_with("ratio") && !l.starts_with("[gearbox]"))
        .map(|l| format!("{l}\n"))
        .collect();
    let bad = dir.join("no_ratio.rig.toml");
    std::fs::write(&bad, stripped).unwrap();
    let o = agvsim(&[
        "identify",
        "--rig",
        bad.to_str().unwrap(),
        "--recording",
        csv.to_str().unwrap(),
    ]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(
        t.contains("no_ratio.rig.toml: `gearbox.ratio` is missing"),
        "{t}"
    );
}

/// The lab scene run for `duration` s with `set` (`KEY=VALUE`) into `out`.
fn run_lab(out: &Path, duration: &str, set: &[&str]) -> Output {
    let mut args = vec![
        "run",
        "scenes/lab_offset_120mm.toml",
        "--duration",
        duration,
    ];
    for s in set {
        args.extend(["--set", s]);
    }
    args.extend(["--out", out.to_str().unwrap()]);
    agvsim(&args)
}

/// `rec` replayed on the lab scene into `out`.
fn replay_on_lab(rec: &Path, out: &Path) -> Output {
    agvsim(&[
        "replay",
        "--scene",
        "scenes/lab_offset_120mm.toml",
        "--recording",
        rec.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ])
}

/// A 1 s run of the lab scene, its recording's text.
fn lab_run(dir: &Path) -> String {
    let o = run_lab(dir, "1", &[]);
    assert!(o.status.success(), "{}", text(&o));
    std::fs::read_to_string(dir.join("lab_offset_120mm.csv")).unwrap()
}

#[test]
fn a_time_column_nanoseconds_apart_is_refused_unless_stated() {
    let dir = tmp("ns");
    let run = lab_run(&dir);
    let mut ns = String::new();
    for l in run.lines() {
        if l.starts_with("# sample_time_s") {
            continue;
        }
        if l.starts_with('#') || l.starts_with("t_s") {
            ns.push_str(l);
        } else {
            let (t, rest) = l.split_once(',').unwrap();
            let t: f64 = t.parse().unwrap();
            ns.push_str(&format!("{:e},{rest}", t * 2.4e-7));
        }
        ns.push('\n');
    }
    let rec = dir.join("ns.csv");
    std::fs::write(&rec, &ns).unwrap();
    let replay = |rec: &Path| replay_on_lab(rec, &dir.join("replay"));
    let o = replay(&rec);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(
        t.contains("ns.csv: the time column's median interval is 2.40e-9 s"),
        "{t}"
    );
    assert!(t.contains("a time column in ns"), "{t}");
}

#[test]
fn sweep_merge_refuses_a_row_edited_to_nan() {
    let dir = tmp("merge-nan");
    for i in [1, 2] {
        let o = agvsim(&[
            "sweep",
            "scenes/lab_offset_120mm.toml",
            "--vary",
            "controller.gain_scale=0.8,1.2",
            "--set",
            "sim.duration_s=1",
            "--shard",
            &format!("{i}/2"),
            "--out",
            dir.join(format!("s{i}")).to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", text(&o));
    }
    let results = dir.join("s2/results.csv");
    let csv = std::fs::read_to_string(&results).unwrap();
    let mut lines: Vec<String> = csv.lines().map(String::from).collect();
    let header: Vec<&str> = lines[0].split(',').collect();
    let col = header
        .iter()
        .position(|h| *h == "rms_lateral_error_m")
        .unwrap();
    let mut cells: Vec<String> = lines[1].split(',').map(String::from).collect();
    cells[col] = "NaN".into();
    lines[1] = cells.join(",");
    std::fs::write(&results, lines.join("\n") + "\n").unwrap();
    let o = agvsim(&[
        "sweep",
        "merge",
        dir.join("s1").to_str().unwrap(),
        dir.join("s2").to_str().unwrap(),
        "--out",
        dir.join("merged").to_str().unwrap(),
    ]);
    let t = text(&o);
    assert!(!o.status.success(), "{t}");
    assert!(t.contains("s2/results.csv"), "{t}");
    assert!(
        t.contains("line 2: column `rms_lateral_error_m`: `NaN`"),
        "{t}"
    );
    assert!(!dir.join("merged/results.csv").exists());
}

#[test]
fn list_files_hold_names_with_spaces_and_hashes_and_a_csv_rig_is_one_error() {
    let dir = tmp("list");
    let run = lab_run(&dir);
    std::fs::write(dir.join("my run #1.csv"), &run).unwrap();
    // A byte-order mark, a quoted name with a space and a `#`, a comment, and a second
    // quoted name that is missing: the error is about line 3 and names it whole.
    let list = dir.join("fleet.txt");
    std::fs::write(
        &list,
        "\u{feff}\"my run #1.csv\"   # the first\n\n\"gone away.csv\"\n",
    )
    .unwrap();
    let o = agvsim(&[
        "batch",
        "calibrate",
        list.to_str().unwrap(),
        "--scene",
        "scenes/lab_offset_120mm.toml",
        "--out",
        dir.join("out").to_str().unwrap(),
    ]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(t.contains("line 3: "), "{t}");
    assert!(t.contains("gone away.csv is not a file"), "{t}");
    // A CSV given as the rig: one error, before any recording is worked on.
    std::fs::write(&list, "\"my run #1.csv\"\n").unwrap();
    let o = agvsim(&[
        "batch",
        "diagnose",
        list.to_str().unwrap(),
        "--rig",
        dir.join("my run #1.csv").to_str().unwrap(),
        "--out",
        dir.join("out2").to_str().unwrap(),
    ]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert_eq!(t.matches("my run #1.csv").count(), 1, "{t}");
    assert!(!dir.join("out2/summary.csv").exists());
}

#[test]
fn an_interrupted_rerun_leaves_no_new_scene_beside_the_old_recording() {
    let dir = tmp("rerun");
    lab_run(&dir);
    let csv = dir.join("lab_offset_120mm.csv");
    let scene = dir.join("lab_offset_120mm.scene.toml");
    assert!(csv.exists() && scene.exists());
    // A rerun with another gain, killed once its recording has started streaming.
    let mut child = Command::new(env!("CARGO_BIN_EXE_agvsim"))
        .args([
            "run",
            "scenes/lab_offset_120mm.toml",
            "--duration",
            "600",
            "--set",
            "controller.gain_scale=1.5",
            "--out",
            dir.to_str().unwrap(),
        ])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let partial = dir.join("lab_offset_120mm.csv.partial");
    let t0 = std::time::Instant::now();
    while !partial.exists() && t0.elapsed().as_secs() < 60 {
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(partial.exists(), "the rerun never started streaming");
    // Neither half of the old pair stands beside the other's replacement.
    assert!(!scene.exists(), "a scene stands without its recording");
    assert!(
        !csv.exists(),
        "the old recording stands after a rerun began"
    );
}

/// A fleet of three 1 s recordings of the lab scene with different gains.
fn batch_shard(fleet: &Path, out: &Path, shard: &str) -> Output {
    agvsim(&[
        "batch",
        "calibrate",
        fleet.to_str().unwrap(),
        "--scene",
        "scenes/lab_offset_120mm.toml",
        "--effects",
        "coulomb_friction",
        "--shard",
        shard,
        "--out",
        out.to_str().unwrap(),
    ])
}

#[test]
fn batch_merge_checks_each_shard_against_the_batch_and_the_recordings_as_they_are() {
    let dir = tmp("batch-merge");
    let fleet = small_fleet(&dir);
    let (s1, s2) = (dir.join("s1"), dir.join("s2"));
    for (out, shard) in [(&s1, "1/2"), (&s2, "2/2")] {
        let o = batch_shard(&fleet, out, shard);
        assert!(o.status.success(), "{}", text(&o));
        assert!(out.join("batch.json").exists());
    }
    let o = batch_merge(&dir, &[&s1, &s2]);
    assert!(o.status.success(), "{}", text(&o));
    let refused = |o: Output, says: &str| {
        let t = text(&o);
        assert!(!o.status.success(), "accepted: {t}");
        assert!(t.contains(says), "expected `{says}` in: {t}");
        assert!(!dir.join("merged/summary.csv").exists(), "{t}");
    };
    // A shard left out.
    refused(
        batch_merge(&dir, &[&s1]),
        "shard(s) 2/2 of the batch's 2 are missing",
    );
    // A shard of another fleet (one recording fewer).
    let other = dir.join("other");
    std::fs::create_dir_all(&other).unwrap();
    for i in 0..2 {
        std::fs::copy(
            fleet.join(format!("robot{i}.csv")),
            other.join(format!("robot{i}.csv")),
        )
        .unwrap();
    }
    let o2 = dir.join("o2");
    assert!(batch_shard(&other, &o2, "2/2").status.success());
    refused(
        batch_merge(&dir, &[&s1, &o2]),
        "is a shard of another batch",
    );
    // A result edited to 1e308.
    let result = s2.join("results/robot2.json");
    let original = std::fs::read_to_string(&result).unwrap();
    let v: serde_json::Value = serde_json::from_str(&original).unwrap();
    let fit = v["fit_after_pct"].to_string();
    std::fs::write(&result, original.replace(&fit, "1e308")).unwrap();
    refused(
        batch_merge(&dir, &[&s1, &s2]),
        "robot2.json: its contents differ from what the batch wrote",
    );
    std::fs::write(&result, &original).unwrap();
    assert!(batch_merge(&dir, &[&s1, &s2]).status.success());
    // A recording changed since its result, and one removed.
    let rec = fleet.join("robot1.csv");
    let bytes = std::fs::read(&rec).unwrap();
    std::fs::write(&rec, [&bytes[..], b"\n"].concat()).unwrap();
    refused(
        batch_merge(&dir, &[&s1, &s2]),
        "changed since this result was computed",
    );
    std::fs::remove_file(&rec).unwrap();
    refused(
        batch_merge(&dir, &[&s1, &s2]),
        "is gone since the batch ran",
    );
    // A shard folder reused for another count: its manifest is the new batch's.
    std::fs::write(&rec, &bytes).unwrap();
    assert!(batch_shard(&fleet, &s2, "2/3").status.success());
    refused(batch_merge(&dir, &[&s1, &s2]), "the shard count");
    // A manifest edited to a shard that cannot be.
    let manifest = s1.join("batch.json");
    let m = std::fs::read_to_string(&manifest).unwrap();
    assert!(m.contains("\"shard_index\": 1"), "{m}");
    std::fs::write(
        &manifest,
        m.replace("\"shard_index\": 1", "\"shard_index\": 0"),
    )
    .unwrap();
    refused(
        batch_merge(&dir, &[&s1, &s2]),
        "expected a shard from 1 to the count",
    );
}

#[test]
fn base_keys_set_or_swept_on_a_wire_following_scene_are_said_to_do_nothing() {
    let dir = tmp("inert");
    let o = run_lab(
        dir.join("run").as_ref(),
        "0.5",
        &["base.speed_kp_V_s_rad=5"],
    );
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(
        t.contains(
            "warning: --set base.speed_kp_V_s_rad=5: no effect on this run: the [base] speed loops"
        ),
        "{t}"
    );
    assert!(t.contains("this scene's controller is `pd`"), "{t}");
    let o = agvsim(&[
        "sweep",
        "scenes/lab_offset_120mm.toml",
        "--vary",
        "base.speed_ki_V_rad=1,8",
        "--set",
        "sim.duration_s=0.5",
        "--out",
        dir.join("sweep").to_str().unwrap(),
    ]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(
        t.contains("warning: --vary base.speed_ki_V_rad: the [base] speed loops"),
        "{t}"
    );
    // The odometry's radius is read by every scene: no warning.
    let o = run_lab(
        dir.join("run2").as_ref(),
        "0.5",
        &["base.wheel_radius_m=0.08"],
    );
    assert!(!text(&o).contains("no effect"), "{}", text(&o));
}

#[test]
fn a_validation_recording_of_another_rig_or_drive_is_refused_before_the_fit() {
    let dir = tmp("validate");
    let run = lab_run(&dir);
    let rec = dir.join("lab_offset_120mm.csv");
    // Another rig: a lifted axis's recording.
    let o = agvsim(&[
        "experiment",
        "lifted-random-demand",
        "scenes/lifted_identification.toml",
        "--duration",
        "2",
        "--out",
        dir.join("axis").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let axis = std::fs::read_dir(dir.join("axis"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.extension().is_some_and(|x| x == "csv"))
        .unwrap();
    // Another drive: the same run driven by velocity commands alone.
    let mut velocity = String::new();
    for l in run.lines() {
        if l.starts_with('#') {
            velocity.push_str(l);
        } else if l.starts_with("t_s") {
            velocity.push_str("t_s,cmd_linear_m_s,cmd_angular_rad_s,x_m,y_m");
        } else {
            let t = l.split(',').next().unwrap();
            velocity.push_str(&format!("{t},0.3,0,0,0"));
        }
        velocity.push('\n');
    }
    let vel = dir.join("velocity.csv");
    std::fs::write(&vel, velocity).unwrap();
    for (other, says) in [
        (axis, "recording, where the recording fitted is `vehicle`"),
        (vel, "driven by cmd_linear_m_s and cmd_angular_rad_s, where the recording fitted is driven by left_voltage_V"),
    ] {
        let o = agvsim(&[
            "calibrate",
            "--scene",
            "scenes/lab_offset_120mm.toml",
            "--recording",
            rec.to_str().unwrap(),
            "--validate",
            other.to_str().unwrap(),
        ]);
        let t = text(&o);
        assert_eq!(o.status.code(), Some(2), "{t}");
        assert!(t.contains("--validate"), "{t}");
        assert!(t.contains(says), "{t}");
        assert!(!t.contains("mean "), "the fit ran: {t}");
    }
}

#[test]
fn huge_wires_and_deeply_nested_scenes_are_refused_with_short_messages() {
    let dir = tmp("huge-scene");
    let base = std::fs::read_to_string("scenes/lab_offset_120mm.toml").unwrap();
    let run = |name: &str, text: &str| {
        let scene = dir.join(name);
        std::fs::write(&scene, text).unwrap();
        agvsim(&[
            "run",
            scene.to_str().unwrap(),
            "--duration",
            "0.5",
            "--out",
            dir.join("out").to_str().unwrap(),
        ])
    };
    // Two million wire points: refused by the file's size, before it is parsed.
    let mut points = String::from("\n[wire]\npoints_m = [");
    for i in 0..2_000_000 {
        points.push_str(&format!("[{}.0, 0.0],", i));
    }
    points.push_str("]\n");
    let o = run(
        "two_million.toml",
        &format!("{}{points}", base.replace("[wire]", "[old_wire]")),
    );
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{}", &t[..t.len().min(2000)]);
    assert!(
        t.contains("a scene may hold"),
        "{}",
        &t[..t.len().min(2000)]
    );
    assert!(t.len() < 2000, "{} bytes of message", t.len());
    // A value nested a hundred thousand deep: an error, not a crash, and a short one.
    let nested = format!(
        "{}\nx = {}{}\n",
        base,
        "[".repeat(100_000),
        "]".repeat(100_000)
    );
    let o = run("nested.toml", &nested);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{}", &t[..t.len().min(2000)]);
    assert!(t.len() < 5000, "{} bytes of message", t.len());
}

#[test]
fn a_body_faster_than_its_motors_can_drive_it_stops_the_run_naming_the_key() {
    // A yaw inertia of 1e-3 kg m^2 on a 120 kg AGV: the integration gains energy (it
    // travelled 68 m in 5 s, twelve times the drive's top speed).
    let dir = tmp("yaw-inertia");
    let o = run_lab(dir.as_ref(), "5", &["chassis.yaw_inertia_kg_m2=1e-3"]);
    let t = text(&o);
    assert!(!o.status.success(), "{t}");
    assert!(t.contains("the simulation diverged"), "{t}");
    assert!(t.contains("chassis.yaw_inertia_kg_m2 = 0.001"), "{t}");
    assert!(!dir.join("lab_offset_120mm.csv").exists());
}
