//! `calibrate` with every effect its recording can show, on the three kinds of record the
//! speed goals name:
//!
//! - `lifted_axis_20s`: the thesis's lifted-wheel random-demand run (`agvsim experiment`,
//!   20 s, both drives, motor encoders) of the machine with its 10 degrees of gear play,
//!   calibrated from a scene without play and with the resistance 15 % off (goal: 5 s);
//! - `velocity_base_30s`: a velocity-commanded base (`agvsim new`'s 40 kg robot) on 30 s of
//!   random `cmd_vel` steps, its tyres gripping to 0.6 of the compound's friction and its
//!   chassis 15 % heavier than the scene says, wheel speeds, gyro and a tracked pose with
//!   1 % and 2 mm noise (goal: 20 s);
//! - `optiodom_real`: a real robot's ROS 2 bag (`../shared/data/real/optiodom`, about
//!   100 s), imported and calibrated as docs/ros2.md says (goal: a 2-minute log in 60 s);
//!   skipped where `../shared` is not beside the project.
//!
//!   Also asked the open question: every effect, the default keys, validated on the
//!   other square run (goal: 60 s);
//! - `replay_velocity_base_30s`: one fit evaluation on the 30 s base, through the
//!   simulator and through the reduced base calibrate fits on (goal: 50x cheaper).
//!
//! Each prints what it found once, then is timed (criterion's ten samples: minutes each).
//! `AGVSIM_BENCH_DUMP=DIR` writes the 30 s base's scene and recording to `DIR` as well.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use criterion::{criterion_group, criterion_main, Criterion};
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, StandardNormal};

use agvsim::calibrate::effects::Choice;
use agvsim::calibrate::{calibrate_telling, Request};
use agvsim::record::Recording;
use agvsim::replay::replay;
use agvsim::scene::Scene;

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("agvsim-bench-calibrate-{name}"));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn every_effect() -> Request {
    Request {
        free: vec![],
        effects: Choice::All,
        validate: None,
    }
}

fn lifted_axis_20s() -> (Scene, Recording) {
    use agvsim::experiment::{run_experiment, ExperimentKind, ExperimentOptions};
    let scene = |sets: &[&str]| {
        let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
        Scene::load(Path::new("scenes/lab_offset_120mm.toml"), &sets).unwrap()
    };
    let opts = ExperimentOptions {
        out_dir: scratch("lifted"),
        seed: Some(3),
        duration_s: 20.0,
        ..ExperimentOptions::default()
    };
    let out = run_experiment(ExperimentKind::LiftedRandomDemand, &scene(&[]), &opts).unwrap();
    let rec = Recording::load(&out.recording).unwrap();
    let belief = scene(&["gearbox.backlash_rad=0", "motor.resistance_ohm=0.4025"]);
    (belief, rec)
}

fn velocity_base_30s() -> (Scene, Recording) {
    use agvsim::calibrate::prove::{clean_machine, Kind};
    let belief = clean_machine(Kind::BaseVelocity).unwrap();
    let text = belief.to_toml();
    let machine = Scene::from_toml(
        &text,
        Path::new("machine.toml"),
        &["chassis.mass_kg=46".into(), "tyre.peak_mu=0.25".into()],
    )
    .unwrap();
    let mut rng = rand_pcg::Pcg64::seed_from_u64(30);
    let outputs = [
        "left_wheel_speed_m_s",
        "right_wheel_speed_m_s",
        "yaw_rate_rad_s",
        "x_m",
        "y_m",
        "heading_rad",
    ];
    let mut csv = format!(
        "# agvsim-recording: 1\n# rig: vehicle\nt_s,cmd_linear_m_s,cmd_angular_rad_s,{}\n",
        outputs.join(",")
    );
    let (mut v, mut w) = (0.0, 0.0);
    for k in 0..3000 {
        if k >= 50 && k % 100 == 50 {
            v = rng.random_range(-0.6..0.8);
            w = rng.random_range(-1.0..1.0);
        }
        let _ = writeln!(csv, "{},{v},{w},0,0,0,0,0,0", k as f64 * 0.01);
    }
    let inputs = Recording::parse(&csv, Path::new("base30.csv")).unwrap();
    let r = replay(&machine, &inputs).unwrap();
    let mut noisy = format!(
        "# agvsim-recording: 1\n# rig: vehicle\nt_s,cmd_linear_m_s,cmd_angular_rad_s,{}\n",
        outputs.join(",")
    );
    for k in 0..r.t_s.len() {
        let mut row = format!("{},{},{}", r.t_s[k], r.inputs[0][k], r.inputs[1][k]);
        for o in outputs {
            let y = &r.output(o).unwrap().simulated;
            let sd = match o {
                "x_m" | "y_m" => 0.002,
                "heading_rad" => 0.005,
                _ => {
                    let m = y.iter().sum::<f64>() / y.len() as f64;
                    0.01 * (y.iter().map(|v| (v - m).powi(2)).sum::<f64>() / y.len() as f64).sqrt()
                }
            };
            let e: f64 = StandardNormal.sample(&mut rng);
            let _ = write!(row, ",{}", y[k] + sd * e);
        }
        noisy.push_str(&row);
        noisy.push('\n');
    }
    dump_for_hand_timing(&belief, &noisy);
    (
        belief,
        Recording::parse(&noisy, Path::new("base30.csv")).unwrap(),
    )
}

/// Where `AGVSIM_BENCH_DUMP` names a folder, the 30 s base's believed scene and noisy
/// recording are written there (`base30.scene.toml`, `base30.csv`), so the command line
/// can be timed on them (`agvsim calibrate --scene ... --recording ...`, or farm-bench
/// pairing two binaries).
fn dump_for_hand_timing(belief: &Scene, recording_csv: &str) {
    let Some(dir) = std::env::var_os("AGVSIM_BENCH_DUMP") else {
        return;
    };
    let dir = PathBuf::from(dir);
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("base30.scene.toml"), belief.to_toml()).unwrap();
    std::fs::write(dir.join("base30.csv"), recording_csv).unwrap();
}

fn time_calibration(c: &mut Criterion, group: &str, name: &str, scene: &Scene, rec: &Recording) {
    let once = calibrate_telling(scene, rec, &every_effect(), &|_| {}).unwrap();
    println!(
        "{group}: accepted {:?}, removed {:?}, {} iterations",
        once.accepted_in_order(),
        once.removed.iter().map(|r| r.effect).collect::<Vec<_>>(),
        once.iterations
    );
    let mut g = c.benchmark_group(group);
    g.sample_size(10);
    g.bench_function(name, |b| {
        b.iter(|| {
            calibrate_telling(scene, rec, &every_effect(), &|_| {})
                .unwrap()
                .iterations
        })
    });
    g.finish();
}

fn bench_lifted(c: &mut Criterion) {
    let (scene, rec) = lifted_axis_20s();
    time_calibration(
        c,
        "calibrate_lifted_axis_20s",
        "random_demand_every_effect",
        &scene,
        &rec,
    );
}

fn bench_base(c: &mut Criterion) {
    let (scene, rec) = velocity_base_30s();
    time_calibration(
        c,
        "calibrate_velocity_base_30s",
        "cmd_vel_steps_every_effect",
        &scene,
        &rec,
    );
}

/// The real robot's run, imported as docs/ros2.md says (the binary's `import ros2`), its
/// wheel geometry calibrated with the scene's keys held (`--effects wheel_geometry --free
/// none`, the recipe). Skipped where `../shared` is not beside the project.
fn bench_optiodom(c: &mut Criterion) {
    let bag = Path::new("../shared/data/real/optiodom/square_230620202042_run1");
    if !bag.is_dir() {
        println!("calibrate optiodom: skipped, {} not found", bag.display());
        return;
    }
    let out = scratch("optiodom");
    let agvsim = env!("CARGO_BIN_EXE_agvsim");
    let status = std::process::Command::new(agvsim)
        .args([
            "import",
            "ros2",
            bag.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .args(["--mass-kg", "4", "--gear-ratio", "43.7"])
        .output()
        .unwrap();
    assert!(
        status.status.success(),
        "{}",
        String::from_utf8_lossy(&status.stderr)
    );
    let scene = Scene::load(&out.join("square_230620202042_run1.scene.toml"), &[]).unwrap();
    let rec = Recording::load(&out.join("square_230620202042_run1.csv")).unwrap();
    let request = || Request {
        free: vec!["none".into()],
        effects: Choice::Named(vec![agvsim::ident::effects::Effect::WheelGeometry]),
        validate: None,
    };
    let once = calibrate_telling(&scene, &rec, &request(), &|_| {}).unwrap();
    println!("calibrate optiodom: geometry {:?}", once.wheel_geometry());
    // The open question: every effect, the default keys, the other square run to
    // validate each finding on.
    let other = import_run(&out, "square_230620202042_run2");
    let open = || Request {
        validate: Some(other.clone()),
        ..every_effect()
    };
    let once = calibrate_telling(&scene, &rec, &open(), &|_| {}).unwrap();
    println!(
        "calibrate optiodom, every effect: accepted {:?}, removed {:?}",
        once.accepted_in_order(),
        once.removed.iter().map(|r| r.effect).collect::<Vec<_>>()
    );
    let mut g = c.benchmark_group("calibrate_optiodom_real_91s");
    g.sample_size(10);
    g.bench_function("wheel_geometry_recipe", |b| {
        b.iter(|| {
            calibrate_telling(&scene, &rec, &request(), &|_| {})
                .unwrap()
                .iterations
        })
    });
    g.bench_function("every_effect_validated", |b| {
        b.iter(|| {
            calibrate_telling(&scene, &rec, &open(), &|_| {})
                .unwrap()
                .iterations
        })
    });
    g.finish();
}

/// Another OptiOdom run imported beside the first (its recording only).
fn import_run(out: &Path, run: &str) -> Recording {
    let bag = Path::new("../shared/data/real/optiodom").join(run);
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_agvsim"))
        .args(["import", "ros2", bag.to_str().unwrap(), "--out"])
        .arg(out)
        .args(["--mass-kg", "4", "--gear-ratio", "43.7"])
        .output()
        .unwrap();
    assert!(
        status.status.success(),
        "{}",
        String::from_utf8_lossy(&status.stderr)
    );
    Recording::load(&out.join(format!("{run}.csv"))).unwrap()
}

/// One evaluation of a fit on the 30 s base: the recording replayed through the simulator
/// and through the reduced base calibrate's races and trials run on (issue 55's goal: at
/// least 50x cheaper).
fn bench_base_evaluation(c: &mut Criterion) {
    use agvsim::replay::{replay_with, Engine};
    let (scene, rec) = velocity_base_30s();
    let mut g = c.benchmark_group("replay_velocity_base_30s");
    g.sample_size(10);
    g.bench_function("simulator", |b| {
        b.iter(|| {
            replay_with(&scene, &rec, Engine::Simulator)
                .unwrap()
                .t_s
                .len()
        })
    });
    g.bench_function("reduced_base", |b| {
        b.iter(|| {
            replay_with(&scene, &rec, Engine::ReducedBase)
                .unwrap()
                .t_s
                .len()
        })
    });
    g.finish();
}

criterion_group!(
    benches,
    bench_base_evaluation,
    bench_lifted,
    bench_base,
    bench_optiodom
);
criterion_main!(benches);
