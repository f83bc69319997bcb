//! One identification, and one full diagnosis (with and without the terms outside the
//! vocabulary), of a 30 s, 1 kHz drive-axis recording: a
//! lifted wheel of the lab scene (nonlinear level: Coulomb friction, no backlash) driven by
//! a random voltage, motor speed through a 1024-count encoder and a noisy current, from rig
//! beliefs about 20 % off (five free parameters, three starts).

use std::f64::consts::TAU;
use std::fmt::Write;
use std::path::Path;

use criterion::{criterion_group, criterion_main, Criterion};
use rand::{Rng, SeedableRng};

use agvsim::diagnose::{diagnose, DiagnoseOptions};
use agvsim::ident::effects::Effect;
use agvsim::ident::{identify, IdentifyOptions};
use agvsim::record::Recording;
use agvsim::rig::Rig;
use agvsim::scene::Scene;
use agvsim::sim::{Actuation, Sim};

fn recording() -> Recording {
    let scene = Scene::load(
        Path::new("scenes/lab_offset_120mm.toml"),
        &[
            "sim.wheels_lifted=true".into(),
            "sim.fidelity=nonlinear".into(),
        ],
    )
    .unwrap();
    let mut sim = Sim::new(&scene).unwrap();
    let mut rng = rand_pcg::Pcg64::seed_from_u64(30);
    let mut csv = String::from("# agvsim-recording: 1\n# rig: drive_axis\n# sample_time_s: 0.001\nt_s,voltage_V,motor_speed_rad_s,current_A\n");
    let (mut v, mut last) = (0.0, 0.0);
    for k in 0..=30_000 {
        if k % 50 == 0 {
            v = rng.random_range(-12.0..12.0);
        }
        let d = &sim.drivetrains()[0].motor;
        let counts = (d.angle_rad * 1024.0 / TAU).floor();
        let speed = if k == 0 {
            0.0
        } else {
            (counts - last) * TAU / 1024.0 / 0.001
        };
        last = counts;
        let i = d.current_a + 0.2 * (rng.random::<f64>() - 0.5);
        let _ = writeln!(csv, "{:.3},{v:.4},{speed:.4},{i:.3}", k as f64 * 0.001);
        sim.set_actuation(Actuation::Voltage([v, v]));
        sim.step().unwrap();
    }
    Recording::parse(&csv, Path::new("bench_axis.csv")).unwrap()
}

fn bench(c: &mut Criterion) {
    let rec = recording();
    let rig_text = "rig = \"drive_axis\"\n[motor]\nresistance_ohm = 0.42\ninductance_H = 0.00064\ntorque_constant_Nm_A = 0.0756\nrotor_inertia_kg_m2 = 1.6e-4\nviscous_Nm_s_rad = 1.2e-4\n[gearbox]\nratio = 23.41\n[wheel]\ninertia_kg_m2 = 0.02\n[sensors]\nmotor_encoder_counts_per_rev = 1024\n";
    let rig = Rig::parse(rig_text, Path::new("bench.rig.toml")).unwrap();
    let opts = IdentifyOptions::default();
    let once = identify(&rig, Path::new("bench.rig.toml"), &rec, None, &opts).unwrap();
    println!(
        "identify 30 s at 1 kHz: {} iterations, {} simulations, fit {:.2} %",
        once.iterations, once.evaluations, once.estimation.fit_pct_mean
    );
    let mut g = c.benchmark_group("identify_drive_axis_30s_1khz");
    g.sample_size(10);
    g.bench_function("rotary_voltage_5_free", |b| {
        b.iter(|| {
            identify(&rig, Path::new("bench.rig.toml"), &rec, None, &opts)
                .unwrap()
                .iterations
        })
    });
    g.finish();
    let d = diagnose(
        &rig,
        Path::new("bench.rig.toml"),
        &rec,
        None,
        &DiagnoseOptions::default(),
    )
    .unwrap();
    println!(
        "diagnose 30 s at 1 kHz: found {:?}, fit {:.2} % -> {:.2} %",
        d.findings
            .iter()
            .map(|f| (f.effect.name(), f.value))
            .collect::<Vec<_>>(),
        d.baseline_fit_pct,
        d.final_fit_pct
    );
    let mut g = c.benchmark_group("diagnose_drive_axis_30s_1khz");
    g.sample_size(10);
    g.bench_function("rotary_voltage_all_effects", |b| {
        b.iter(|| {
            diagnose(
                &rig,
                Path::new("bench.rig.toml"),
                &rec,
                None,
                &DiagnoseOptions::default(),
            )
            .unwrap()
            .findings
            .len()
        })
    });
    // The same diagnosis with the effects named, which leaves out the terms outside the
    // vocabulary: the pair measures what the library search adds.
    let vocabulary = DiagnoseOptions {
        effects: agvsim::ident::effects::Choice::Named(vec![
            Effect::Backlash,
            Effect::CoulombFriction,
            Effect::FrictionAsymmetry,
            Effect::Offset,
            Effect::VoltageSaturation,
            Effect::BatterySag,
            Effect::TransportDelay,
        ]),
        ..Default::default()
    };
    g.bench_function("rotary_voltage_vocabulary_only", |b| {
        b.iter(|| {
            diagnose(&rig, Path::new("bench.rig.toml"), &rec, None, &vocabulary)
                .unwrap()
                .findings
                .len()
        })
    });
    g.finish();
}

/// A whole vehicle: the development recording with wheel slip (20 s, encoders at 200 Hz,
/// tracker pose at 50 Hz, from an independent simulator), all seven candidate effects.
/// Skipped when `../shared` is not beside the project.
fn bench_vehicle(c: &mut Criterion) {
    let dir = Path::new("../shared/data/dev");
    let rig_path = dir.join("dev_vehicle_01.rig.toml");
    let (Ok(rig), Ok(rec)) = (
        Rig::load(&rig_path),
        Recording::load(&dir.join("dev_vehicle_01.csv")),
    ) else {
        println!("diagnose vehicle: skipped, ../shared/data/dev/dev_vehicle_01 not found");
        return;
    };
    let mut g = c.benchmark_group("diagnose_vehicle_20s");
    g.sample_size(10);
    g.bench_function("vehicle_voltages_all_effects", |b| {
        b.iter(|| {
            diagnose(&rig, &rig_path, &rec, None, &DiagnoseOptions::default())
                .unwrap()
                .findings
                .len()
        })
    });
    g.finish();
}

criterion_group!(benches, bench, bench_vehicle);
criterion_main!(benches);
