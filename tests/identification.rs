//! Identification (issue 3): virtual experiments on the simulated AGV, then grey-box fits
//! whose answers are known from the scene.

use std::path::{Path, PathBuf};

use agvsim::experiment::{run_experiment, ExperimentKind, ExperimentOptions};
use agvsim::ident::{identify, IdentifyOptions, Identification, ModelChoice};
use agvsim::record::Recording;
use agvsim::rig::Rig;
use agvsim::scene::Scene;

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("agvsim-ident-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn experiment(kind: ExperimentKind, scene: &Scene, dir: &Path, name: &str, seed: u64, rig_error: f64) -> (Rig, PathBuf, Recording) {
    let out = run_experiment(
        kind,
        scene,
        &ExperimentOptions {
            out_dir: dir.to_owned(),
            name: Some(name.into()),
            seed: Some(seed),
            rig_error,
            ..ExperimentOptions::default()
        },
    )
    .unwrap();
    (
        Rig::load(&out.rig).unwrap(),
        out.rig.clone(),
        Recording::load(&out.recording).unwrap(),
    )
}

fn ident(rig: &Rig, rig_path: &Path, rec: &Recording, model: Option<ModelChoice>) -> Identification {
    identify(
        rig,
        rig_path,
        rec,
        None,
        &IdentifyOptions {
            model,
            ..IdentifyOptions::default()
        },
    )
    .unwrap()
}

/// The thesis's case-1 A and B from the scene's physics: each lifted motor is
/// J dw/dt = K (V - K w)/R - b w with V = g_f fwd -/+ g_t turn (left/right), J the rotor
/// plus the wheel reflected through the gear ratio.
fn true_gain_model(s: &Scene) -> Vec<(&'static str, f64)> {
    let m = &s.motor;
    let j = m.rotor_inertia_kg_m2 + s.wheel.inertia_kg_m2 / s.gearbox.ratio.powi(2);
    let k = m.torque_constant_Nm_A;
    let a = -(m.viscous_Nm_s_rad + k * k / m.resistance_ohm) / j;
    let beta = k / (m.resistance_ohm * j);
    let (gf, gt) = (s.dcmc.forward_gain_V_pct, s.dcmc.turn_gain_V_pct);
    vec![
        ("a_left_1_s", a),
        ("a_right_1_s", a),
        ("b_left_fwd_rad_s2_pct", beta * gf),
        ("b_left_turn_rad_s2_pct", -beta * gt),
        ("b_right_fwd_rad_s2_pct", beta * gf),
        ("b_right_turn_rad_s2_pct", beta * gt),
    ]
}

/// Acceptance 1: from rig beliefs up to 20 % off, identification recovers the scene's A and
/// B within 5 %, and the 1-sigma intervals cover the truth at about their nominal 68 %.
#[test]
fn lifted_random_demand_recovers_the_scene_and_its_intervals_are_honest() {
    let scene = Scene::load(Path::new("scenes/lifted_identification.toml"), &[]).unwrap();
    let truth = true_gain_model(&scene);
    let dir = tmp("coverage");
    let (mut inside, mut total) = (0, 0);
    let mut worst_rel: f64 = 0.0;
    for seed in 0..20u64 {
        let (rig, rig_path, rec) = experiment(ExperimentKind::LiftedRandomDemand, &scene, &dir, &format!("s{seed}"), seed, 0.2);
        let id = ident(&rig, &rig_path, &rec, Some(ModelChoice::Gain));
        for (name, t) in &truth {
            let v = id.value(name).unwrap();
            let s = id.std(name).expect("determined");
            worst_rel = worst_rel.max(((v - t) / t).abs());
            total += 1;
            if (v - t).abs() <= s {
                inside += 1;
            }
        }
    }
    let coverage = inside as f64 / total as f64;
    println!(
        "lifted random demand, 20 seeds x 6 parameters: worst relative error {:.3} %, 1-sigma coverage {:.1} % ({inside}/{total})",
        100.0 * worst_rel,
        100.0 * coverage
    );
    assert!(worst_rel < 0.05, "worst relative error {worst_rel}");
    // Nominal 68.3 %; 120 intervals (correlated within a seed) give a spread of several
    // percent, and the acceptance band of honest coverage is 55-85 %.
    assert!((0.55..=0.85).contains(&coverage), "coverage {coverage}");
}
