//! Simulated seconds per wall second: 10 s of `lab_offset_120mm` at each fidelity level.

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

criterion_group!(benches, levels);
criterion_main!(benches);
