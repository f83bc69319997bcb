//! Simulated seconds per wall second: 10 s of `lab_offset_120mm` at each fidelity level;
//! the Rerun logging overhead of a run; a 100-run sweep on one and two jobs.

use std::path::Path;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};

use agvsim::scene::{Fidelity, Scene};
use agvsim::sim::Sim;

fn levels(c: &mut Criterion) {
    let mut group = c.benchmark_group("lab_offset_120mm_10s");
    group.sample_size(10);
    // Throughput in "elements" = simulated milliseconds, so criterion reports the
    // simulated-time rate alongside the wall time.
    group.throughput(Throughput::Elements(10_000));
    for level in Fidelity::ALL {
        let scene = Scene::load(
            Path::new("scenes/lab_offset_120mm.toml"),
            &[
                format!("sim.fidelity={}", level.name()),
                "sim.duration_s=10".to_string(),
            ],
        )
        .expect("lab scene");
        group.bench_function(level.name(), |b| {
            b.iter(|| {
                let mut sim = Sim::new(&scene).unwrap();
                for _ in 0..10_000 {
                    sim.step().unwrap();
                }
                sim.pose()
            })
        });
    }
    group.finish();
}

/// Rerun logging overhead: `agvsim run` of 20 s of the lab scene, a typical run (CSV recording and metrics),
/// with and without saving a Rerun recording at the default frame interval (0.02 s).
fn logging(c: &mut Criterion) {
    use agvsim::commands::flags::RerunFlags;
    use agvsim::commands::run::{run, RunRequest};
    let dir = std::env::temp_dir().join(format!("agvsim_bench_{}", std::process::id()));
    let mut group = c.benchmark_group("run_lab_20s");
    group.sample_size(10);
    for (name, save) in [
        ("csv_only", None),
        ("csv_and_rerun", Some(dir.join("bench.rrd"))),
    ] {
        let req = RunRequest {
            scene: "scenes/lab_offset_120mm.toml".into(),
            out: Some(dir.clone()),
            set: Default::default(),
            duration_s: Some(20.0),
            seed: None,
            rerun: RerunFlags {
                save,
                ..Default::default()
            },
            rerun_interval_s: 0.02,
        };
        group.bench_function(name, |b| b.iter(|| run(&req, &|_| {}).unwrap()));
    }
    group.finish();
}

/// A 100-run sweep (gain x payload, 1 s of the full level each) on 1 and 2 jobs.
fn sweep_jobs(c: &mut Criterion) {
    use agvsim::sweep::{parse_vary, run_sweep, Shard, SweepOptions};
    let mut group = c.benchmark_group("sweep_100_runs");
    group.sample_size(10);
    for jobs in [1usize, 2] {
        let opts = SweepOptions::new(
            Path::new("scenes/studies/tyre_compounds.toml"),
            vec!["sim.duration_s=1".into()],
            vec![
                parse_vary("controller.gain_scale=0.5..3:20").unwrap(),
                parse_vary("payload.mass_kg=0,50,100,150,200").unwrap(),
            ],
            1,
            Shard::WHOLE,
            jobs,
            false,
            std::env::temp_dir().join(format!("agvsim_bench_sweep_{}_{jobs}", std::process::id())),
        )
        .unwrap();
        group.bench_function(format!("jobs_{jobs}"), |b| {
            b.iter(|| run_sweep(&opts, &|_, _| {}).unwrap().results.len())
        });
    }
    group.finish();
}

criterion_group!(benches, levels, logging, sweep_jobs);
criterion_main!(benches);
