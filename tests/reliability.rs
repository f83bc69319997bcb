//! Reliability (issue 18, first findings): bad input gets a clear refusal that names the
//! file, key or cell, never a silent wrong answer. Each test fails on the code before.

mod common;
use common::tmp;

use std::path::{Path, PathBuf};

use agvsim::experiment::{run_experiment, ExperimentKind, ExperimentOptions};
use agvsim::ident::{identify, IdentifyOptions, ModelChoice};
use agvsim::record::Recording;
use agvsim::rig::Rig;
use agvsim::scene::Scene;

/// A lifted-wheel run on the estimator's known-truth rig.
fn lifted(dir: &Path, duration_s: f64) -> (Rig, PathBuf, PathBuf) {
    let scene = Scene::load(Path::new("scenes/lifted_identification.toml"), &[]).unwrap();
    let out = run_experiment(
        ExperimentKind::LiftedRandomDemand,
        &scene,
        &ExperimentOptions {
            out_dir: dir.to_owned(),
            duration_s,
            seed: Some(3),
            ..ExperimentOptions::default()
        },
    )
    .unwrap();
    (Rig::load(&out.rig).unwrap(), out.rig, out.recording)
}

fn gain_fit(rig: &Rig, rig_path: &Path, rec: &Recording) -> Result<(), String> {
    identify(
        rig,
        rig_path,
        rec,
        None,
        &IdentifyOptions {
            model: Some(ModelChoice::Gain),
            ..IdentifyOptions::default()
        },
    )
    .map(|_| ())
    .map_err(|e| e.to_string())
}

/// Spreadsheets write a UTF-8 byte-order mark: a recording and a rig that start with one
/// read as without it.
#[test]
fn byte_order_marks_are_skipped() {
    let text = "# agvsim-recording: 1\n# rig: drive_axis\nt_s,voltage_V,motor_speed_rad_s\n0,0,0\n0.001,1,0.5\n";
    let plain = Recording::parse(text, Path::new("r.csv")).unwrap();
    let marked = Recording::parse(&format!("\u{feff}{text}"), Path::new("r.csv")).unwrap();
    assert_eq!(plain.t_s, marked.t_s);
    let rig = "rig = \"drive_axis\"\n[motor]\nresistance_ohm = 0.35\n";
    let a = Rig::parse(rig, Path::new("r.rig.toml")).unwrap();
    let b = Rig::parse(&format!("\u{feff}{rig}"), Path::new("r.rig.toml")).unwrap();
    assert_eq!(a.get("motor.resistance_ohm"), b.get("motor.resistance_ohm"));
}

/// Ten rows for six parameters: refused, naming the counts (it used to report a 100 %
/// fit with V = 0 and AIC = -inf).
#[test]
fn a_record_too_short_to_fit_is_refused() {
    let dir = tmp("short");
    let (rig, rig_path, rec_path) = lifted(&dir, 0.225);
    let rec = Recording::load(&rec_path).unwrap();
    assert_eq!(rec.t_s.len(), 10);
    let err = gain_fit(&rig, &rig_path, &rec).unwrap_err();
    println!("{err}");
    assert!(
        err.contains("too few samples") && err.contains("6 free parameters"),
        "{err}"
    );
}

/// One output cell of 1e300: the recording's reader refuses it naming its line and column
/// (no vehicle's quantity reaches 1e12); a recording holding one all the same (made in
/// memory) gives a loss that cannot be computed, and that is an error naming the
/// recording and the cell's size, not a NaN report with exit 0.
#[test]
fn a_fit_whose_loss_is_not_finite_is_an_error() {
    let dir = tmp("huge");
    let (rig, rig_path, rec_path) = lifted(&dir, 3.0);
    let text = std::fs::read_to_string(&rec_path).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let row = lines.len() - 20;
    let mut cells: Vec<String> = lines[row].split(',').map(String::from).collect();
    *cells.last_mut().unwrap() = "1e300".into();
    lines[row] = cells.join(",");
    let bad = dir.join("huge.csv");
    std::fs::write(&bad, lines.join("\n") + "\n").unwrap();
    let refused = Recording::load(&bad).unwrap_err().to_string();
    assert!(
        refused.contains(&format!("huge.csv:{}", row + 1)) && refused.contains("1e300"),
        "{refused}"
    );
    let mut held = Recording::load(&rec_path).unwrap();
    held.path = bad.clone();
    let last = held.columns.len() - 1;
    let at = held.t_s.len() - 20;
    held.columns[last][at] = Some(1e300);
    let err = gain_fit(&rig, &rig_path, &held).unwrap_err();
    println!("{err}");
    assert!(
        err.contains("huge.csv") && err.contains("loss") && err.contains("1e300"),
        "{err}"
    );
    // The clean record still fits.
    gain_fit(&rig, &rig_path, &Recording::load(&rec_path).unwrap()).unwrap();
}

/// `--name` cannot lead out of `--out`, and `--rig-error` of 100 % or more (which can
/// make a resistance negative) is refused.
#[test]
fn experiment_names_stay_inside_out_and_rig_errors_stay_below_one() {
    let dir = tmp("escape");
    let scene = Scene::load(Path::new("scenes/lifted_identification.toml"), &[]).unwrap();
    let run = |name: Option<&str>, rig_error: f64| {
        run_experiment(
            ExperimentKind::CoastDown,
            &scene,
            &ExperimentOptions {
                out_dir: dir.join("out"),
                name: name.map(String::from),
                rig_error,
                ..ExperimentOptions::default()
            },
        )
        .map_err(|e| e.to_string())
    };
    let err = run(Some("../../escape"), 0.0).unwrap_err();
    assert!(
        err.contains("--name") && err.contains("plain file stem"),
        "{err}"
    );
    assert!(!dir.join("escape.csv").exists() && !dir.parent().unwrap().join("escape.csv").exists());
    let err = run(None, 5.0).unwrap_err();
    assert!(err.contains("--rig-error 5"), "{err}");
    let ok = run(Some("fine"), 0.5).unwrap();
    assert!(ok.recording.starts_with(dir.join("out")));
}

/// A key both set and varied in a sweep: the set value would be silently ignored.
#[test]
fn sweep_refuses_a_key_both_set_and_varied() {
    use agvsim::sweep::{parse_vary, SweepOptions};
    let text = std::fs::read_to_string("scenes/high_gain_slip.toml").unwrap();
    let vary = parse_vary("controller.gain_scale=1,2").unwrap();
    let err = SweepOptions::from_text(
        Path::new("scenes/high_gain_slip.toml"),
        text,
        vec!["controller.gain_scale=5".into()],
        vec![vary],
        1,
    )
    .expect_err("refused")
    .to_string();
    println!("{err}");
    assert!(
        err.contains("controller.gain_scale=5") && err.contains("also varied"),
        "{err}"
    );
}

/// An obstacle with neither shape key says so (it used to read "= half_extents_m and
/// radius_m").
#[test]
fn an_obstacle_without_a_shape_says_which_keys_are_missing() {
    let err = Scene::from_toml(
        "[[obstacles]]\ncenter_m = [3.0, 0.0]\n",
        Path::new("o.toml"),
        &[],
    )
    .unwrap_err()
    .to_string();
    println!("{err}");
    assert!(err.contains("neither half_extents_m nor radius_m"), "{err}");
}

/// A bad `--set` value is quoted alone (it used to be quoted with the command's own
/// `sim.duration_s=2`), and a bad `--vary` value is called a `--vary` value.
#[test]
fn bad_override_values_are_quoted_as_the_user_typed_them() {
    use agvsim::sweep::{parse_vary, SweepOptions};
    let err = Scene::load(
        Path::new("scenes/high_gain_slip.toml"),
        &["chassis.mass_kg=abc".into(), "sim.duration_s=2".into()],
    )
    .unwrap_err()
    .to_string();
    println!("{err}");
    assert!(
        err.starts_with("--set chassis.mass_kg=abc:") && !err.contains("duration"),
        "{err}"
    );
    let text = std::fs::read_to_string("scenes/high_gain_slip.toml").unwrap();
    let err = SweepOptions::from_text(
        Path::new("scenes/high_gain_slip.toml"),
        text,
        vec![],
        vec![parse_vary("controller.gain_scale=a,b").unwrap()],
        1,
    )
    .expect_err("refused")
    .to_string();
    println!("{err}");
    assert!(
        err.starts_with("--vary controller.gain_scale: value `a`"),
        "{err}"
    );
}

/// A value that makes the castor swivel mode too fast for the step names the keys that
/// set the mode (it used to blame only `sim.dt_s`, with a bound printed as 0.00000).
#[test]
fn a_too_fast_castor_mode_names_its_keys() {
    let scene = Scene::load(
        Path::new("scenes/high_gain_slip.toml"),
        &["castors.mass_kg=1e-9".into()],
    )
    .unwrap();
    let err = agvsim::sim::Sim::new(&scene)
        .err()
        .expect("refused")
        .to_string();
    println!("{err}");
    assert!(
        err.contains("castors.mass_kg (0.000000001 kg)") && err.contains("chassis.mass_kg"),
        "{err}"
    );
    assert!(
        !err.contains("0.00000\n") && err.contains("sim.dt_s <= 6.99"),
        "{err}"
    );
}

/// Scene geometry that used to be accepted silently: a wire point with a third
/// coordinate (dropped), wire points at 1e300 m (the coils read 0 and the run reported
/// "settled, RMS 0.0 mm"), and a concave floor region (docs/scene-reference.md promises convex).
#[test]
fn scene_geometry_that_cannot_be_meant_is_refused() {
    let load = |toml: &str| {
        Scene::from_toml(toml, Path::new("g.toml"), &[])
            .err()
            .map(|e| e.to_string())
    };
    let err = load("[wire]\npoints_m = [[0.0, 0.0, 5.0], [10.0, 0.0]]\n").expect("refused");
    println!("{err}");
    assert!(
        err.contains("g.toml") && err.contains("point 0 has 3 coordinates"),
        "{err}"
    );
    let err = load("[wire]\npoints_m = [[-1e300, 0.0], [1e300, 0.0]]\n").expect("refused");
    println!("{err}");
    assert!(
        err.contains("wire.points_m[0]") && err.contains("1e5 m"),
        "{err}"
    );
    let concave = "[[floor.regions]]\nsurface = \"bare_concrete\"\npolygon_m = [[0.0, 0.0], [4.0, 0.0], [1.0, 1.0], [0.0, 4.0]]\n";
    let err = load(concave).expect("refused");
    println!("{err}");
    assert!(
        err.contains("floor.regions[0].polygon_m[2]") && err.contains("convex"),
        "{err}"
    );
    let convex = "[[floor.regions]]\nsurface = \"bare_concrete\"\npolygon_m = [[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]]\n";
    assert_eq!(load(convex), None);
    // Clockwise outlines are as convex as counter-clockwise ones.
    let clockwise = "[[floor.regions]]\nsurface = \"bare_concrete\"\npolygon_m = [[0.0, 0.0], [0.0, 4.0], [4.0, 4.0], [4.0, 0.0]]\n";
    assert_eq!(load(clockwise), None);
}

/// A Rerun file that cannot be written stops the run before it writes anything (it used
/// to leave a header-only CSV and the scene behind).
#[test]
fn an_unwritable_rerun_file_leaves_no_partial_output() {
    use agvsim::commands::run::{run, RunRequest};
    let dir = tmp("save").join("out");
    let err = run(
        &RunRequest {
            scene: PathBuf::from("scenes/high_gain_slip.toml"),
            out: Some(dir.clone()),
            set: Default::default(),
            duration_s: Some(0.1),
            seed: None,
            rerun: agvsim::commands::flags::RerunFlags {
                save: Some(PathBuf::from("/no/such/dir/y.rrd")),
                ..Default::default()
            },
            rerun_interval_s: 0.02,
        },
        &|_| {},
    )
    .expect_err("refused")
    .to_string();
    println!("{err}");
    assert!(err.contains("/no/such/dir/y.rrd"), "{err}");
    assert!(
        !dir.exists(),
        "left {:?}",
        std::fs::read_dir(&dir).map(|d| d.count())
    );
}

/// One input cell of 1e300 makes the model diverge; the error points into the recording
/// (time, largest input), not only at the rig. A one-row recording is "too few samples",
/// not "no output column the model can compare with".
#[test]
fn a_diverging_start_or_a_single_row_points_at_the_recording() {
    let dir = tmp("input");
    let (rig, rig_path, rec_path) = lifted(&dir, 3.0);
    let text = std::fs::read_to_string(&rec_path).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let row = lines.len() - 40;
    let mut cells: Vec<String> = lines[row].split(',').map(String::from).collect();
    cells[1] = "1e300".into();
    lines[row] = cells.join(",");
    let bad = dir.join("input.csv");
    std::fs::write(&bad, lines.join("\n") + "\n").unwrap();
    assert!(Recording::load(&bad)
        .unwrap_err()
        .to_string()
        .contains("beyond any physical value"));
    // Held in memory all the same, it makes the model diverge.
    let mut held = Recording::load(&rec_path).unwrap();
    held.path = bad.clone();
    let at = held.t_s.len() - 40;
    held.columns[0][at] = Some(1e300);
    let err = gain_fit(&rig, &rig_path, &held).unwrap_err();
    println!("{err}");
    assert!(
        err.contains("input.csv") && err.contains("largest |input|") && err.contains("1e300"),
        "{err}"
    );
    let header_end = text.lines().position(|l| l.starts_with("t_s")).unwrap();
    let one: Vec<&str> = text.lines().take(header_end + 2).collect();
    let single = dir.join("single.csv");
    std::fs::write(&single, one.join("\n") + "\n").unwrap();
    let err = gain_fit(&rig, &rig_path, &Recording::load(&single).unwrap()).unwrap_err();
    println!("{err}");
    assert!(
        err.contains("single.csv") && err.contains("too few samples: 1 row"),
        "{err}"
    );
}

/// An obstacle on the start pose is refused (the vehicle used to be thrown 0.5 m
/// sideways at its first step); the shipped bumper scene, whose obstacle is ahead, runs.
#[test]
fn an_obstacle_on_the_start_pose_is_refused() {
    let scene = Scene::load(
        Path::new("scenes/high_gain_slip.toml"),
        &["obstacles=[{center_m = [0.2, 0.0], radius_m = 0.1}]".into()],
    )
    .unwrap();
    let err = agvsim::sim::Sim::new(&scene)
        .err()
        .expect("refused")
        .to_string();
    println!("{err}");
    assert!(
        err.contains("obstacles[0]") && err.contains("start pose"),
        "{err}"
    );
    let bumper = Scene::load(Path::new("scenes/bumper_stop.toml"), &[]).unwrap();
    assert!(agvsim::sim::Sim::new(&bumper).is_ok());
}

/// Values that make the drivetrain's sub-step rule explode are refused up front, naming
/// the keys (they used to run at 31-265 s of wall time per simulated second, or never
/// finish a millisecond); the shipped scenes need far fewer sub-steps than the limit.
#[test]
fn drivetrain_values_that_would_hang_a_run_are_refused() {
    use agvsim::sim::{SimParams, MAX_SUBSTEPS};
    for (set, key) in [
        ("wheel.radius_m=100", "wheel.radius_m"),
        (
            "motor.rotor_inertia_kg_m2=1e-15",
            "motor.rotor_inertia_kg_m2",
        ),
        (
            "gearbox.tooth_stiffness_Nm_rad=1e15",
            "gearbox.tooth_stiffness_Nm_rad",
        ),
        ("tyre.relaxation_length_m=1e-12", "tyre.relaxation_length_m"),
    ] {
        let scene = Scene::load(Path::new("scenes/high_gain_slip.toml"), &[set.into()]).unwrap();
        let err = agvsim::sim::Sim::new(&scene).err().expect(set).to_string();
        println!("{set}: {err}");
        assert!(err.contains(key), "{set}: {err}");
    }
    for file in [
        "lab_offset_120mm",
        "high_gain_slip",
        "soft_tyres",
        "bumper_stop",
        "open_day_loop",
    ] {
        let scene = Scene::load(Path::new(&format!("scenes/{file}.toml")), &[]).unwrap();
        let n = SimParams::from_scene(&scene).unwrap().substeps;
        assert!(n * 10 < MAX_SUBSTEPS, "{file}: {n}");
    }
}

/// A grid a typing slip made huge is refused before any run, naming its size and the
/// way to allow it; a sweep whose `--out` is a file fails before any run is spent.
#[test]
fn a_runaway_grid_and_a_file_as_out_folder_are_refused_up_front() {
    use agvsim::sweep::{check_size, parse_vary, run_sweep, Shard, SweepOptions, DEFAULT_MAX_RUNS};
    let big = vec![
        parse_vary("controller.gain_scale=0.5..4:1000").unwrap(),
        parse_vary("tyre.mu_peak=0.1..1:1000").unwrap(),
    ];
    let err = check_size(&big, 1, DEFAULT_MAX_RUNS)
        .unwrap_err()
        .to_string();
    println!("{err}");
    assert!(
        err.contains("1000000 runs") && err.contains("--max-runs"),
        "{err}"
    );
    assert!(
        check_size(&big, 1, 1_000_000).is_ok(),
        "an explicit limit allows it"
    );
    assert!(check_size(&big[..1], 3, DEFAULT_MAX_RUNS).is_ok());

    let dir = tmp("out-file");
    let file = dir.join("results_here");
    std::fs::write(&file, "not a folder").unwrap();
    let opts = SweepOptions::new(
        Path::new("scenes/lab_offset_120mm.toml"),
        vec!["sim.duration_s=1".into()],
        vec![parse_vary("controller.gain_scale=1,2").unwrap()],
        1,
        Shard::WHOLE,
        1,
        false,
        file.clone(),
    )
    .unwrap();
    let runs = std::sync::atomic::AtomicUsize::new(0);
    let err = run_sweep(&opts, &|_, _| {
        runs.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
    })
    .expect_err("refused")
    .to_string();
    println!("{err}");
    assert!(
        err.contains("--out") && err.contains("not a folder"),
        "{err}"
    );
    assert_eq!(runs.into_inner(), 0, "no run was spent before the refusal");
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "not a folder");
}

/// A parameter whose search ends at a bound is reported as such (text and JSON), with no
/// standard deviation: here a rig whose resistance belief is 30 times too small, so the
/// search's upper bound (10 times the belief) stops it.
#[test]
fn a_parameter_at_its_search_bound_is_not_reported_as_an_estimate() {
    let dev = Path::new("../shared/data/dev");
    if !dev.exists() {
        println!("skipped: ../shared/data/dev is not beside the checkout");
        return;
    }
    let dir = tmp("at-bound");
    let rig_text = std::fs::read_to_string(dev.join("dev_axis_05.rig.toml"))
        .unwrap()
        .replace("resistance_ohm = 0.2741", "resistance_ohm = 0.009");
    let rig_path = dir.join("bad.rig.toml");
    std::fs::write(&rig_path, rig_text).unwrap();
    let rig = Rig::load(&rig_path).unwrap();
    let rec = Recording::load(&dev.join("dev_axis_05.csv")).unwrap();
    let id = identify(&rig, &rig_path, &rec, None, &IdentifyOptions::default()).unwrap();
    let r = id
        .params
        .iter()
        .find(|p| p.name == "motor.resistance_ohm")
        .unwrap();
    println!("{r:?}");
    assert_eq!(r.at_bound, Some(0.09));
    assert!(r.std.is_none());
    let text = agvsim::ident::report::render(&id);
    assert!(
        text.contains("AT BOUND 0.09 ohm: not an estimate"),
        "{text}"
    );
    let json = serde_json::to_value(&id).unwrap();
    let p = json["params"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["name"] == "motor.resistance_ohm")
        .unwrap()
        .clone();
    assert_eq!(p["at_bound"], serde_json::json!(0.09));
}

/// `sweep merge` checks every row against the sweep's grid (an edited value is named
/// with its line), refuses to merge into a shard's own folder, and reads quoted fields
/// with newlines; a sweep rerun into its folder leaves no stale traces.
#[test]
fn merges_check_rows_and_shards_and_reruns_leave_no_stale_files() {
    use agvsim::sweep::{merge, parse_vary, run_sweep, Shard, SweepOptions};
    let dir = tmp("merge");
    let shard = |i: usize, traces: bool, values: &str, out: &Path| {
        let o = SweepOptions::new(
            Path::new("scenes/lab_offset_120mm.toml"),
            vec!["sim.duration_s=1".into()],
            vec![parse_vary(&format!("controller.gain_scale={values}")).unwrap()],
            1,
            Shard { index: i, count: 2 },
            1,
            traces,
            out.to_owned(),
        )
        .unwrap();
        run_sweep(&o, &|_, _| {}).unwrap();
    };
    let (a, b) = (dir.join("a"), dir.join("b"));
    shard(1, false, "1,2,3,4", &a);
    shard(2, false, "1,2,3,4", &b);
    let err = merge(&[a.clone(), b.clone()], &a).unwrap_err().to_string();
    println!("{err}");
    assert!(err.contains("is one of the shard folders"), "{err}");
    // A quoted field holding a comma and a newline reads back (it used to split the row).
    let results = b.join("results.csv");
    let text = std::fs::read_to_string(&results).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let last = lines.len() - 1;
    let cells: Vec<&str> = lines[last].split(',').collect();
    let n = cells.len();
    let mut edited: Vec<String> = cells.iter().map(|c| c.to_string()).collect();
    edited[n - 1] = "\"note, with\na newline\"".into();
    lines[last] = edited.join(",");
    std::fs::write(&results, lines.join("\n") + "\n").unwrap();
    merge(&[a.clone(), b.clone()], &dir.join("m1")).unwrap();
    // An edited grid value is named.
    let text = std::fs::read_to_string(&results).unwrap();
    std::fs::write(&results, text.replacen(",4,0,", ",9,0,", 1)).unwrap();
    let err = merge(&[a.clone(), b.clone()], &dir.join("m2"))
        .unwrap_err()
        .to_string();
    println!("{err}");
    assert!(
        err.contains("controller.gain_scale = `9`")
            && err.contains("where the sweep's grid has `4`"),
        "{err}"
    );
    // Ten runs with traces, then two into the same folder: no old traces remain.
    let c = dir.join("c");
    let o = |values: &str, traces: bool| {
        SweepOptions::new(
            Path::new("scenes/lab_offset_120mm.toml"),
            vec!["sim.duration_s=0.5".into()],
            vec![parse_vary(&format!("controller.gain_scale={values}")).unwrap()],
            1,
            Shard::WHOLE,
            1,
            traces,
            c.clone(),
        )
        .unwrap()
    };
    run_sweep(&o("1..2:10", true), &|_, _| {}).unwrap();
    assert_eq!(std::fs::read_dir(c.join("traces")).unwrap().count(), 10);
    run_sweep(&o("1,2", false), &|_, _| {}).unwrap();
    assert!(!c.join("traces").exists(), "stale traces left");
    let rows = std::fs::read_to_string(c.join("results.csv"))
        .unwrap()
        .lines()
        .count();
    assert_eq!(rows, 3);
}

/// `identify --json` under a file and `diagnose --report` on a file fail at once, naming
/// the option, instead of after the whole analysis ("File exists").
#[test]
fn output_paths_are_checked_before_the_work() {
    use agvsim::commands::diagnose::{run as diagnose_job, DiagnoseRequest as DiagnoseJob};
    use agvsim::commands::identify::{run as identify_job, IdentifyRequest as IdentifyJob};
    let dir = tmp("targets");
    let (_, rig, rec) = lifted(&dir, 4.0);
    let file = dir.join("a_file");
    std::fs::write(&file, "x").unwrap();
    let started = std::time::Instant::now();
    let err = identify_job(
        &IdentifyJob {
            rig: rig.clone(),
            recordings: vec![rec.clone()],
            validate: None,
            json: Some(file.join("x.json")),
            plot_dir: None,
            save_rrd: None,
            ..Default::default()
        },
        &|_| {},
    )
    .expect_err("refused")
    .to_string();
    println!("{err}");
    assert!(err.contains("--json") && err.contains("is a file"), "{err}");
    let err = diagnose_job(
        &DiagnoseJob {
            rig: Some(rig),
            scene: None,
            recordings: vec![rec],
            validate: None,
            json: None,
            report_dir: Some(file.clone()),
            save_rrd: None,
            ..Default::default()
        },
        &|_| {},
    )
    .expect_err("refused")
    .to_string();
    println!("{err}");
    assert!(
        err.contains("--report") && err.contains("give a folder"),
        "{err}"
    );
    println!("both refused in {:?}", started.elapsed());
}

/// A run killed mid-way leaves no recording that looks like a finished, shorter run: the
/// rows stream into `NAME.csv.partial`, renamed only when the run ends.
#[test]
fn a_killed_run_leaves_no_finished_looking_recording() {
    let dir = tmp("killed");
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_agvsim"))
        .args([
            "run",
            "scenes/lab_offset_120mm.toml",
            // Within the default step budget (10^7 steps at 1 ms), far longer than the wait.
            "--duration",
            "9000",
            "--out",
        ])
        .arg(&dir)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Wait until rows are being written, then kill.
    let partial = dir.join("lab_offset_120mm.csv.partial");
    for _ in 0..1200 {
        if std::fs::metadata(&partial).is_ok_and(|m| m.len() > 10_000) {
            break;
        }
        if let Some(status) = child.try_wait().unwrap() {
            let mut stderr = String::new();
            std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut stderr).unwrap();
            panic!("the run ended before it was killed ({status}): {stderr}");
        }
        std::thread::sleep(std::time::Duration::from_millis(25));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(partial.exists(), "the run had started writing");
    assert!(
        !dir.join("lab_offset_120mm.csv").exists(),
        "a killed run left a finished-looking CSV"
    );
}

/// A linear axis in closed loop with known force pulses on its load (`disturbance_force_N`,
/// a contract input): fitted with the column, the mass and friction come back and the fit
/// is near perfect; with the column left out the pulses are unexplained residual and the
/// fit is clearly worse. A rotary axis given the column names it as ignored.
#[test]
fn known_disturbance_forces_are_used_and_unusable_columns_are_named() {
    use agvsim::ident::data::Dataset;
    use agvsim::ident::model::simulate;
    use agvsim::ident::models::linear_axis::LinearAxis;
    let dir = tmp("disturbance");
    let rig_text = "rig = \"drive_axis\"\nmotion = \"linear\"\n\n[load]\nmass_kg = 80.0\nviscous_N_s_m = 170.0\n\n[drive]\nforce_per_volt_N_V = 35.15\nlimit_V = 10.0\n\n[feedback]\nkind = \"position_velocity_cascade\"\nkp_1_s = 160.18\nkv_V_s_m = 243.45\n";
    let rig_path = dir.join("axis.rig.toml");
    std::fs::write(&rig_path, rig_text).unwrap();
    let rig = Rig::load(&rig_path).unwrap();
    // The truth: 20 % heavier, 30 % more friction than the belief; 200 N pulses.
    let mut truth = LinearAxis::from_rig(&rig, &rig_path, false).unwrap();
    truth.disturbance_input = true;
    let n = 4000;
    let t: Vec<f64> = (0..n).map(|k| k as f64 * 0.001).collect();
    let reference: Vec<f64> = t
        .iter()
        .map(|t| 0.05 * (std::f64::consts::TAU * 0.5 * t).sin())
        .collect();
    let pulse: Vec<f64> = t
        .iter()
        .map(|t| {
            if (t % 1.0) > 0.3 && (t % 1.0) < 0.45 {
                200.0
            } else {
                0.0
            }
        })
        .collect();
    let outputs = vec![
        "position_m".to_string(),
        "speed_m_s".to_string(),
        "command_V".to_string(),
    ];
    let data = Dataset {
        name: "truth".into(),
        t_s: t.clone(),
        input_names: vec!["reference_m".into(), "disturbance_force_N".into()],
        inputs: vec![reference.clone(), pulse.clone()],
        output_names: outputs.clone(),
        outputs: vec![vec![Some(0.0); n]; 3],
        segment_starts: vec![0],
    };
    let y = simulate(&truth, &[96.0, 221.0], &data).unwrap();
    let mut with = String::from("# agvsim-recording: 1\n# rig: drive_axis\nt_s,reference_m,disturbance_force_N,command_V,position_m,speed_m_s\n");
    let mut without = String::from("# agvsim-recording: 1\n# rig: drive_axis\nt_s,reference_m,command_V,position_m,speed_m_s\n");
    for k in 0..n {
        with.push_str(&format!(
            "{},{},{},{},{},{}\n",
            t[k], reference[k], pulse[k], y[2][k], y[0][k], y[1][k]
        ));
        without.push_str(&format!(
            "{},{},{},{},{}\n",
            t[k], reference[k], y[2][k], y[0][k], y[1][k]
        ));
    }
    let (pw, pwo) = (dir.join("with.csv"), dir.join("without.csv"));
    std::fs::write(&pw, with).unwrap();
    std::fs::write(&pwo, without).unwrap();
    let fit = |p: &Path| {
        identify(
            &rig,
            &rig_path,
            &Recording::load(p).unwrap(),
            None,
            &IdentifyOptions::default(),
        )
        .unwrap()
    };
    let a = fit(&pw);
    let b = fit(&pwo);
    let mass = |id: &agvsim::ident::Identification| {
        id.params
            .iter()
            .find(|p| p.name == "load.mass_kg")
            .unwrap()
            .value
    };
    println!(
        "with the column: mass {:.2} kg, fit {:.2} %; without: mass {:.2} kg, fit {:.2} %",
        mass(&a),
        a.estimation.fit_pct_mean,
        mass(&b),
        b.estimation.fit_pct_mean
    );
    assert!((mass(&a) / 96.0 - 1.0).abs() < 0.01);
    assert!(a.estimation.fit_pct_mean > 99.0);
    assert!(b.estimation.fit_pct_mean < a.estimation.fit_pct_mean - 5.0);
    assert!(a.ignored_inputs.is_empty());
}

/// A rotary axis has no load-force input: a `disturbance_force_N` column is named as
/// ignored, in the identification and its report.
#[test]
fn a_rotary_axis_names_a_load_force_column_as_ignored() {
    let dir = tmp("disturbance-rotary");
    let (rig2, rig2_path, rec2) = lifted(&dir, 4.0);
    let text = std::fs::read_to_string(&rec2).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let h = lines.iter().position(|l| l.starts_with("t_s")).unwrap();
    for (i, l) in lines.iter_mut().enumerate().skip(h) {
        l.push_str(if i == h { ",disturbance_force_N" } else { ",0" });
    }
    let p2 = dir.join("rotary_with_force.csv");
    std::fs::write(&p2, lines.join("\n") + "\n").unwrap();
    let id = identify(
        &rig2,
        &rig2_path,
        &Recording::load(&p2).unwrap(),
        None,
        &IdentifyOptions {
            model: Some(ModelChoice::Gain),
            ..IdentifyOptions::default()
        },
    )
    .unwrap();
    assert_eq!(id.ignored_inputs, vec!["disturbance_force_N".to_string()]);
    let text = agvsim::ident::report::render(&id);
    assert!(text.contains("Ignored: disturbance_force_N"), "{text}");
}

/// A sweep stopped mid-way (as SIGINT or SIGTERM do, through the stop flag) keeps the
/// finished runs as a valid prefix in `results.csv.partial`, which `sweep merge` names as
/// unfinished; `--resume` runs the rest, and the result is byte for byte the uninterrupted
/// sweep's, also when a kill cut the last row short. A folder of another sweep is not
/// resumed.
#[test]
fn an_interrupted_sweep_keeps_its_finished_runs_and_resumes_to_the_same_bytes() {
    use agvsim::sweep::{merge, parse_vary, run_sweep, Shard, SweepError, SweepOptions};
    use std::sync::atomic::{AtomicBool, Ordering};
    let dir = tmp("resume");
    let opts = |out: &Path, values: &str, jobs: usize| {
        SweepOptions::new(
            Path::new("scenes/lab_offset_120mm.toml"),
            vec!["sim.duration_s=0.5".into()],
            vec![parse_vary(&format!("controller.gain_scale={values}")).unwrap()],
            1,
            Shard::WHOLE,
            jobs,
            false,
            out.to_owned(),
        )
        .unwrap()
    };
    let whole = dir.join("whole");
    run_sweep(&opts(&whole, "1..2:12", 1), &|_, _| {}).unwrap();
    let expected = std::fs::read(whole.join("results.csv")).unwrap();

    let cut = dir.join("cut");
    let stop: &'static AtomicBool = Box::leak(Box::new(AtomicBool::new(false)));
    let mut o = opts(&cut, "1..2:12", 2);
    o.stop = Some(stop);
    let err = run_sweep(&o, &|done, _| {
        if done == 5 {
            stop.store(true, Ordering::SeqCst);
        }
    })
    .unwrap_err();
    println!("{err}");
    let SweepError::Interrupted { done, total, .. } = err else {
        panic!("not an interruption: {err}")
    };
    assert!((5..12).contains(&done) && total == 12, "{done} of {total}");
    assert!(!cut.join("results.csv").exists(), "looks finished");
    let partial = cut.join("results.csv.partial");
    let text = std::fs::read_to_string(&partial).unwrap();
    assert_eq!(text.lines().count(), 1 + done, "{text}");
    assert!(expected.starts_with(text.as_bytes()), "not a prefix");
    let err = merge(std::slice::from_ref(&cut), &dir.join("m"))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("interrupted shard") && err.contains("--resume"),
        "{err}"
    );

    // A kill in the middle of a row: the cut row is dropped and run again.
    std::fs::write(
        &partial,
        format!("{text}{}", &text[text.len() - 40..text.len() - 1]),
    )
    .unwrap();
    let mut o = opts(&cut, "1..2:12", 2);
    o.resume = true;
    let out = run_sweep(&o, &|_, _| {}).unwrap();
    assert_eq!(out.resumed, done);
    assert_eq!(out.results.len(), 12 - done);
    assert_eq!(std::fs::read(cut.join("results.csv")).unwrap(), expected);
    assert!(!partial.exists());

    // Resuming a complete sweep, or with other arguments, is refused.
    let err = run_sweep(&o, &|_, _| {}).unwrap_err().to_string();
    assert!(err.contains("already complete"), "{err}");
    let mut other = opts(&cut, "1..3:12", 2);
    other.resume = true;
    let err = run_sweep(&other, &|_, _| {}).unwrap_err().to_string();
    assert!(err.contains("holds another sweep"), "{err}");
    assert_eq!(std::fs::read(cut.join("results.csv")).unwrap(), expected);
}

/// A run longer than the scene's step budget (`sim.max_steps`, 10^7 physics steps by
/// default) is refused before it starts, naming the key and how to raise the budget: a
/// typed `--duration 1e7` used to run for days without a word.
#[test]
fn a_run_beyond_its_step_budget_is_refused_up_front() {
    let scene = Path::new("scenes/high_gain_slip.toml");
    let err = Scene::load(scene, &["sim.duration_s=1e7".into()])
        .expect_err("refused")
        .to_string();
    println!("{err}");
    assert!(
        err.contains("sim.duration_s") && err.contains("sim.max_steps") && err.contains("1.000e10"),
        "{err}"
    );
    // Raised on purpose, it is accepted.
    Scene::load(
        scene,
        &[
            "sim.duration_s=1e7".into(),
            "sim.max_steps=10000000000".into(),
        ],
    )
    .unwrap();
}

/// Rig values that mean something at zero are taken where the model can use them: no
/// viscous friction believed (the fit finds the friction the record has, searched up
/// from zero), a wheel inertia lumped into the rotor's (the sum comes back). Where the
/// model cannot use a zero it says why: the armature needs its inductance, a linear
/// axis its friction belief.
#[test]
fn zero_rig_values_are_taken_where_meaningful_and_refused_with_the_reason_elsewhere() {
    let dev = Path::new("../shared/data/dev");
    if !dev.exists() {
        println!("skipped: ../shared/data/dev is not beside the checkout");
        return;
    }
    let dir = tmp("zero-rig");
    let rec = Recording::load(&dev.join("dev_axis_05.csv")).unwrap();
    let text = std::fs::read_to_string(dev.join("dev_axis_05.rig.toml")).unwrap();
    let fit = |edit: &str, with: &str| {
        let p = dir.join(format!("{}.rig.toml", with.replace(['.', ' ', '='], "_")));
        let line = text.lines().find(|l| l.starts_with(edit)).unwrap();
        std::fs::write(&p, text.replace(line, with)).unwrap();
        Rig::load(&p).map_err(|e| e.to_string()).and_then(|rig| {
            identify(&rig, &p, &rec, None, &IdentifyOptions::default()).map_err(|e| e.to_string())
        })
    };
    let value = |id: &agvsim::ident::Identification, n: &str| {
        id.params.iter().find(|p| p.name == n).unwrap().value
    };
    let base = fit("viscous_Nm_s_rad", "viscous_Nm_s_rad = 7.48e-05").unwrap();
    let no_viscous = fit("viscous_Nm_s_rad", "viscous_Nm_s_rad = 0.0").unwrap();
    let (b0, b1) = (
        value(&base, "motor.viscous_Nm_s_rad"),
        value(&no_viscous, "motor.viscous_Nm_s_rad"),
    );
    println!("viscous from a belief of 7.48e-5: {b0:e}; from 0: {b1:e}");
    assert!(b1 > 0.0 && (b1 / b0 - 1.0).abs() < 0.01);
    let lumped = fit("inertia_kg_m2", "inertia_kg_m2 = 0.0").unwrap();
    let total = |id: &agvsim::ident::Identification| {
        value(id, "motor.rotor_inertia_kg_m2") + value(id, "wheel.inertia_kg_m2") / 23.41f64.powi(2)
    };
    println!(
        "inertia at the motor: {:e} (rig) against {:e} (wheel lumped)",
        total(&base),
        total(&lumped)
    );
    assert!((total(&lumped) / total(&base) - 1.0).abs() < 0.01);
    let err = fit("inductance_H", "inductance_H = 0.0").unwrap_err();
    assert!(
        err.contains("motor.inductance_H") && err.contains("needs the inductance"),
        "{err}"
    );
}
