//! A real differential-drive robot (`../shared/data/real/optiodom`: twelve ROS 2 bags of
//! the OptiOdom data set, a robot with motion capture, and the published calibration of
//! its wheel geometry), taken as docs/ros2.md says: each bag imported with its URDF's
//! nominal geometry as the configured one, the geometry calibrated on one square run.
//!
//! - the effective track moves from the nominal 0.200 m to within 1 % of the published
//!   value, and each wheel's effective diameter too;
//! - the calibrated scene replays every other run (squares and circles) better than the
//!   nominal one;
//! - calibrated on each square run alone, the runs' standard deviations are, on average,
//!   not smaller than the spread of their estimates;
//! - logged without its encoders (commands and the pose alone), the open question still
//!   finds the base's turn-rate limit first (ignored in the debug build).
//!
//! Skipped (with a line saying so) where `../shared` is not beside the project.

mod common;
use common::{text, tmp as scratch};

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The published effective geometry of the square runs (OptiOdom's own method, the data
/// set's `data.xlsx`, sheet `diff-Sousa`): right and left wheel diameter and track, m.
const PUBLISHED_SQUARE: (f64, f64, f64) = (0.083714, 0.083780, 0.200628);

fn data() -> Option<PathBuf> {
    let d = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/real/optiodom");
    d.is_dir().then_some(d)
}

fn agvsim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_agvsim"))
        .args(args)
        .output()
        .expect("agvsim runs")
}

/// Imports a run: its recording and its scene (a 4 kg robot, the 43.7:1 gear the data
/// set states; motor assumed), as docs/ros2.md's recipe does.
fn import(bags: &Path, run: &str, out: &Path) -> (PathBuf, PathBuf) {
    let (scene, rec, _) = import_saying(bags, run, out);
    (scene, rec)
}

/// [`import`], with what the import said.
fn import_saying(bags: &Path, run: &str, out: &Path) -> (PathBuf, PathBuf, String) {
    let o = agvsim(&[
        "import",
        "ros2",
        bags.join(run).to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--mass-kg",
        "4",
        "--gear-ratio",
        "43.7",
    ]);
    let said = text(&o);
    assert!(o.status.success(), "{said}");
    (
        out.join(format!("{run}.scene.toml")),
        out.join(format!("{run}.csv")),
        said,
    )
}

/// The wheel geometry a calibration of `scene` on `rec` gives: (left radius, its std),
/// (right radius, its std), (track, its std), from its JSON.
fn calibrate(scene: &Path, rec: &Path, json: &Path, write: Option<&Path>) -> [(f64, f64); 3] {
    let mut args = vec![
        "calibrate",
        "--scene",
        scene.to_str().unwrap(),
        "--recording",
        rec.to_str().unwrap(),
        "--effects",
        "wheel_geometry",
        "--free",
        "none",
        "--json",
        json.to_str().unwrap(),
    ];
    if let Some(w) = write {
        args.extend(["--write", w.to_str().unwrap()]);
    }
    let o = agvsim(&args);
    assert!(o.status.success(), "{}", text(&o));
    println!("{}", text(&o));
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(json).unwrap()).unwrap();
    let g = &j["wheel_geometry"];
    assert!(g.is_object(), "no geometry in {j:#}\n{}", text(&o));
    let v = |k: &str| g[k].as_f64().unwrap();
    [
        (v("left_radius_m"), v("left_radius_std_m")),
        (v("right_radius_m"), v("right_radius_std_m")),
        (v("track_m"), v("track_std_m")),
    ]
}

/// The mean replay fit of a scene on a recording, %.
fn replay_fit(scene: &Path, rec: &Path, out: &Path) -> f64 {
    let o = agvsim(&[
        "replay",
        "--scene",
        scene.to_str().unwrap(),
        "--recording",
        rec.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let t = text(&o);
    t.lines()
        .find(|l| l.starts_with("mean"))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no mean fit in {t}"))
}

fn runs(bags: &Path) -> Vec<String> {
    let mut r: Vec<String> = std::fs::read_dir(bags)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains("_run"))
        .collect();
    r.sort();
    r
}

#[test]
fn the_geometry_calibrated_on_a_square_run_holds_on_every_other_run() {
    let Some(bags) = data() else {
        println!("skipped: ../shared/data/real/optiodom not found");
        return;
    };
    let dir = scratch("one");
    let (scene, rec) = import(&bags, "square_230620202042_run1", &dir);
    let calibrated = dir.join("calibrated.toml");
    let [l, r, b] = calibrate(&scene, &rec, &dir.join("c.json"), Some(&calibrated));
    let (pub_r, pub_l, pub_b) = PUBLISHED_SQUARE;
    for (what, got, published) in [
        ("left diameter", 2.0 * l.0, pub_l),
        ("right diameter", 2.0 * r.0, pub_r),
        ("track", b.0, pub_b),
    ] {
        println!("{what}: {got:.6} m against the published {published} m");
        assert!(
            (got / published - 1.0).abs() < 0.01,
            "{what}: {got} against the published {published}"
        );
    }
    // The nominal track moved: it was 0.200, 0.3 % from the published.
    assert!((b.0 - 0.2).abs() > 1e-4, "{b:?}");
    for other in runs(&bags)
        .iter()
        .filter(|n| *n != "square_230620202042_run1")
    {
        let d = dir.join(other);
        let (_, rec) = import(&bags, other, &d);
        let before = replay_fit(&scene, &rec, &d.join("before"));
        let after = replay_fit(&calibrated, &rec, &d.join("after"));
        println!("{other}: replay fit {before:.1} % -> {after:.1} %");
        assert!(after > before, "{other}: {before} -> {after}");
    }
}

/// Issue 57's real-robot acceptance: each square run calibrated alone, its printed 95 %
/// interval (1.96 standard deviations) holds the mean of the other runs' estimates for at
/// least 90 % of the runs and keys. The runs are of one robot on one floor on one day, so
/// the other runs' mean is the best value this run's interval can be held against; it is
/// itself uncertain by the spread over the square root of their number (five), which
/// widens the difference a run's interval must hold by at most 10 % where the spread is
/// below the run's deviation (measured at 4c5da24: 18 of 18, the largest difference 1.29
/// of a run's deviations; with the pose windows' starts smoothed over 0.5 s, 0.82). The
/// deviations' mean must also reach the spread between runs.
#[test]
fn each_square_runs_uncertainty_covers_the_spread_between_runs() {
    let Some(bags) = data() else {
        println!("skipped: ../shared/data/real/optiodom not found");
        return;
    };
    let dir = scratch("each");
    let squares: Vec<String> = runs(&bags)
        .into_iter()
        .filter(|n| n.starts_with("square"))
        .collect();
    let fits: Vec<[(f64, f64); 3]> = squares
        .iter()
        .map(|run| {
            let d = dir.join(run);
            let (scene, rec) = import(&bags, run, &d);
            calibrate(&scene, &rec, &d.join("c.json"), None)
        })
        .collect();
    let (mut held, mut judged) = (0, 0);
    for (i, key) in ["left radius", "right radius", "track"].iter().enumerate() {
        let values: Vec<f64> = fits.iter().map(|f| f[i].0).collect();
        let n = values.len() as f64;
        let mean = values.iter().sum::<f64>() / n;
        let spread = (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        let mean_std = fits.iter().map(|f| f[i].1).sum::<f64>() / n;
        println!("{key}: estimates {values:?}, spread {spread:.6} m, mean standard deviation {mean_std:.6} m");
        assert!(
            mean_std >= spread,
            "{key}: standard deviations {mean_std} against a spread of {spread}"
        );
        for (run, f) in squares.iter().zip(&fits) {
            let others = (values.iter().sum::<f64>() - f[i].0) / (n - 1.0);
            let z = (f[i].0 - others) / f[i].1;
            println!(
                "  {run}: {:.6} ± {:.6} m, the other runs' mean {others:.6} m: {z:+.2} deviations",
                f[i].0, f[i].1
            );
            judged += 1;
            held += usize::from(z.abs() <= 1.96);
        }
    }
    assert!(
        held * 10 >= judged * 9,
        "the 95 % intervals held the other runs' mean for {held} of {judged} runs and keys"
    );
}

/// Asked the open question: a default `calibrate` (every effect, the default keys) of a
/// square run, validated on the other square run. It names the wheel geometry within
/// 0.6 % of the published values and the base's own limits (the turn rate the robot never
/// exceeds while `/cmd_vel` asks four times as much), the calibrated scene replays both
/// runs with a positive fit, and every effect it accepted improves the other run.
///
/// Ignored in the debug build the README's `cargo test` makes (it replays a 100 s run
/// through the simulator a few hundred times); run it with
/// `cargo test --release --test optiodom_real -- --ignored`.
#[test]
#[ignore]
fn the_open_question_on_a_square_run_names_the_geometry_and_the_base_limits() {
    let Some(bags) = data() else {
        println!("skipped: ../shared/data/real/optiodom is not beside the project");
        return;
    };
    let out = scratch("optiodom-open");
    let (scene, rec) = import(&bags, "square_230620202042_run1", &out);
    let (_, other) = import(&bags, "square_230620202042_run2", &out);
    let json = out.join("open.json");
    let o = agvsim(&[
        "calibrate",
        "--scene",
        scene.to_str().unwrap(),
        "--recording",
        rec.to_str().unwrap(),
        "--validate",
        other.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
    ]);
    let shown = text(&o);
    println!("{shown}");
    assert!(o.status.success(), "{shown}");
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let g = &j["wheel_geometry"];
    let (right_d, left_d, track) = PUBLISHED_SQUARE;
    let near = |v: f64, published: f64| (v / published - 1.0).abs() < 0.006;
    let v = |k: &str| g[k].as_f64().unwrap_or(f64::NAN);
    assert!(near(v("track_m"), track), "track {}\n{shown}", v("track_m"));
    assert!(near(2.0 * v("left_radius_m"), left_d), "{shown}");
    assert!(near(2.0 * v("right_radius_m"), right_d), "{shown}");
    assert!(
        shown
            .lines()
            .any(|l| l.starts_with("base_limits") && l.contains("accepted")),
        "{shown}"
    );
    // `mean  A % -> B % ...` and `validate  NAME: A % -> B %`: the calibrated fit, B.
    let fit_after = |start: &str| -> f64 {
        let line = shown
            .lines()
            .find(|l| l.starts_with(start))
            .unwrap_or_else(|| panic!("no {start} line in {shown}"));
        line.split("->")
            .nth(1)
            .and_then(|s| s.split_whitespace().next())
            .and_then(|s| s.parse().ok())
            .unwrap_or_else(|| panic!("{line}"))
    };
    assert!(fit_after("mean") > 0.0, "{shown}");
    assert!(fit_after("validate") > 0.0, "{shown}");
}

/// A robot logged without its encoders (the held-out kind: commands and a motion-capture
/// pose only), asked the open question: square run 1 with its wheel columns taken out.
/// The base's turn-rate limit shows in the tracked pose's yaw rate as in the wheels', and
/// is fitted before anything else is asked to explain the corners; the wheel geometry,
/// which the pose alone cannot tell from that limit on a run that turns only at it, is not
/// named at a track away from the published one (before, the corners' missing turn rate
/// was read as a track of 0.153 m for the published 0.2006).
///
/// Ignored in the debug build, as the test above; run it with
/// `cargo test --release --test optiodom_real -- --ignored`.
#[test]
#[ignore]
fn without_its_encoders_the_open_question_names_the_base_limits_first() {
    let Some(bags) = data() else {
        println!("skipped: ../shared/data/real/optiodom is not beside the project");
        return;
    };
    let out = scratch("optiodom-no-encoders");
    let (scene, rec) = import(&bags, "square_230620202042_run1", &out);
    let csv = std::fs::read_to_string(&rec).unwrap();
    let mut keep: Vec<bool> = vec![];
    let mut stripped = String::new();
    for line in csv.lines() {
        if line.starts_with('#') {
            if !line.contains("wheel") {
                stripped.push_str(line);
                stripped.push('\n');
            }
            continue;
        }
        let cells: Vec<&str> = line.split(',').collect();
        if keep.is_empty() {
            keep = cells.iter().map(|c| !c.contains("wheel")).collect();
        }
        let kept: Vec<&str> = cells
            .iter()
            .zip(&keep)
            .filter(|(_, k)| **k)
            .map(|(c, _)| *c)
            .collect();
        stripped.push_str(&kept.join(","));
        stripped.push('\n');
    }
    assert!(!stripped.contains("wheel_speed"), "{}", &stripped[..400]);
    let pose_only = out.join("pose_only.csv");
    std::fs::write(&pose_only, stripped).unwrap();
    let json = out.join("pose_only.json");
    let o = agvsim(&[
        "calibrate",
        "--scene",
        scene.to_str().unwrap(),
        "--recording",
        pose_only.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
    ]);
    let shown = text(&o);
    println!("{shown}");
    assert!(o.status.success(), "{shown}");
    assert!(
        shown.contains("the tracked pose's speeds never follow"),
        "{shown}"
    );
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let effect = |name: &str| {
        j["effects"]
            .as_array()
            .unwrap()
            .iter()
            .find(|e| e["name"] == name)
            .unwrap_or_else(|| panic!("{name} not tried: {shown}"))
            .clone()
    };
    assert_eq!(effect("base_limits")["accepted"], true, "{shown}");
    let geometry = effect("wheel_geometry");
    let track = geometry["value"].as_f64().unwrap_or(f64::NAN);
    assert!(
        geometry["accepted"] != true || (track / PUBLISHED_SQUARE.2 - 1.0).abs() < 0.05,
        "track {track} accepted: {shown}"
    );
}

/// The import says what the commands show of the base's own limits, with the numbers: on a
/// square run `/cmd_vel` asks turns at the corners the wheels never reach. The commanded
/// peak it says is the recording's own, and the wheels' reach lies beyond the rule's
/// margin below it (1.5 times).
#[test]
fn the_import_says_the_turn_rate_limit_the_commands_show() {
    let Some(bags) = data() else {
        println!("skipped: ../shared/data/real/optiodom not found");
        return;
    };
    let dir = scratch("limits");
    let run = "square_230620202042_run1";
    let (_, rec, t) = import_saying(&bags, run, &dir);
    let line = t
        .lines()
        .find(|l| l.starts_with("limits") && l.contains("base.max_angular_rad_s"))
        .unwrap_or_else(|| panic!("no turn-rate limit said:\n{t}"));
    let numbers: Vec<f64> = line
        .split_whitespace()
        .filter_map(|w| w.trim_end_matches(',').parse().ok())
        .collect();
    let (asked, reached) = (numbers[0], numbers[1]);
    let csv = std::fs::read_to_string(rec).unwrap();
    let mut lines = csv.lines().filter(|l| !l.starts_with('#'));
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = header
        .iter()
        .position(|c| *c == "cmd_angular_rad_s")
        .unwrap();
    let peak = lines
        .filter_map(|l| l.split(',').nth(col)?.parse::<f64>().ok())
        .fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(
        (asked / peak - 1.0).abs() < 0.01,
        "{asked} against {peak}: {line}"
    );
    assert!(reached > 0.0 && 1.5 * reached < asked, "{line}");
    // docs/ros2.md quotes this run's line: up to 1.6 rad/s asked, about 0.48 reached.
    assert!(
        (asked - 1.6).abs() < 0.05 && (reached - 0.48).abs() < 0.01,
        "{line}"
    );
}

/// The reduced base, on which calibrate's fits of a velocity-commanded recording run, and
/// the simulator replay square run 1 alike at the keys a calibration of it reaches (a 1 kg
/// robot, its yaw inertia, the base's limits): each pose output's RMS difference between
/// the two engines is within `sqrt(JUDGE_SHARE)` of the model's own misfit there, the
/// share beyond which calibrate hands the judging to the simulator (and takes three times
/// as long). On this light robot the castors' tyres take a fifth of a second to carry
/// their swivel friction at each corner; castors that pushed it at once turned the
/// reduced base late at every corner (at these keys its heading 0.078 rad RMS from the
/// simulator's against a misfit of 0.095; 0.0074 with the castors on their tyres).
#[test]
fn the_reduced_base_and_the_simulator_replay_a_square_run_alike() {
    use agvsim::calibrate::JUDGE_SHARE;
    use agvsim::record::Recording;
    use agvsim::replay::{replay_with, Engine};
    use agvsim::scene::Scene;
    let Some(bags) = data() else {
        println!("skipped: ../shared/data/real/optiodom not found");
        return;
    };
    let dir = scratch("engines");
    let (scene, rec) = import(&bags, "square_230620202042_run1", &dir);
    let calibrated: Vec<String> = [
        "chassis.mass_kg=1.05",
        "chassis.yaw_inertia_kg_m2=0.38",
        "base.max_angular_rad_s=0.29",
        "base.max_angular_accel_rad_s2=0.56",
        "base.max_linear_accel_m_s2=0.0154",
    ]
    .map(String::from)
    .to_vec();
    let scene = Scene::load(&scene, &calibrated).unwrap();
    let rec = Recording::load(&rec).unwrap();
    let full = replay_with(&scene, &rec, Engine::Simulator).unwrap();
    let reduced = replay_with(&scene, &rec, Engine::ReducedBase).unwrap();
    let rms = |d: &mut dyn Iterator<Item = f64>| {
        let (sum, n) = d.fold((0.0, 0), |(s, n), v| (s + v * v, n + 1));
        (sum / n as f64).sqrt()
    };
    let mut worst: f64 = 0.0;
    for (a, b) in full.outputs.iter().zip(&reduced.outputs) {
        assert_eq!(a.name, b.name);
        let apart = rms(&mut a.simulated.iter().zip(&b.simulated).map(|(x, y)| x - y));
        let misfit = a.rms_error;
        println!("{}: engines {apart:.4} apart, misfit {misfit:.4}", a.name);
        if ["x_m", "y_m", "heading_rad"].contains(&a.name.as_str()) {
            worst = worst.max(apart / misfit);
        }
    }
    assert!(
        worst < JUDGE_SHARE.sqrt(),
        "the engines differ by {worst} of the misfit"
    );
}
