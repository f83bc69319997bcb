//! One physics: on the same inputs and parameters, the simulator (`replay`, the scene's
//! lifted drive) and the drive-axis fitting model that diagnosis fits (`RotaryAxis`, built
//! from the simulator's motor, gear and friction blocks) give the same outputs, with and
//! without Coulomb friction and gear play.

use std::path::Path;

use agvsim::ident::data::Dataset;
use agvsim::ident::effects::Effect;
use agvsim::ident::model::Predictor;
use agvsim::ident::models::rotary_axis::{AxisInput, RotaryAxis, WHEEL_SHARE_PARAM};
use agvsim::record::Recording;
use agvsim::replay::{replay, report::simulated_csv};
use agvsim::rig::Rig;
use agvsim::scene::Scene;

const SCENE: &str = "scenes/lab_offset_120mm.toml";

/// The lab scene's drive with its tooth contact set to the fitting block's (5000 N m/rad,
/// 3 N m s/rad), which the fit holds fixed, and the settings given.
fn machine(set: &[&str]) -> Scene {
    let mut all = vec![
        "gearbox.tooth_stiffness_Nm_rad=5000",
        "gearbox.tooth_damping_Nm_s_rad=3",
    ];
    all.extend(set);
    let all: Vec<String> = all.iter().map(|s| s.to_string()).collect();
    Scene::load(Path::new(SCENE), &all).unwrap()
}

/// The scene's drive as a rig file: what a user's rig would state.
fn rig_of(s: &Scene) -> Rig {
    let m = &s.motor;
    let text = format!(
        "rig = \"drive_axis\"\n[motor]\nresistance_ohm = {}\ninductance_H = {}\ntorque_constant_Nm_A = {}\nrotor_inertia_kg_m2 = {}\nviscous_Nm_s_rad = {}\n[gearbox]\nratio = {}\n[wheel]\nradius_m = {}\ninertia_kg_m2 = {}\n[supply]\nvoltage_V = {}\n",
        m.resistance_ohm,
        m.inductance_H,
        m.torque_constant_Nm_A,
        m.rotor_inertia_kg_m2,
        m.viscous_Nm_s_rad,
        s.gearbox.ratio,
        s.wheel.radius_m,
        s.wheel.inertia_kg_m2,
        s.battery.open_circuit_V,
    );
    Rig::parse(&text, Path::new("scene.rig.toml")).unwrap()
}

/// The simulator's replay of the shipped multisine voltages (8 s, up to 14 V, every
/// 5 ms) on `scene`, as a recording.
fn simulated(scene: &Scene, name: &str) -> Recording {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("one-physics-{name}"));
    std::fs::create_dir_all(&dir).unwrap();
    let inputs = Recording::load(Path::new("data/calibrate_example/multisine_inputs.csv")).unwrap();
    let r = replay(scene, &inputs).unwrap();
    let path = dir.join("sim.csv");
    std::fs::write(&path, simulated_csv(&r, &inputs, Path::new(SCENE))).unwrap();
    Recording::load(&path).unwrap()
}

/// Largest RMS difference between the simulator and the model over the outputs, as a
/// share of each output's range.
fn disagreement(rec: &Recording, model: &RotaryAxis, p: &[f64]) -> f64 {
    let outputs = ["motor_speed_rad_s".to_string(), "current_A".to_string()];
    let data = Dataset::from_recording(rec, &["voltage_V".to_string()], &outputs).unwrap();
    let y = model.predict(p, &data).unwrap();
    let mut worst: f64 = 0.0;
    for (j, name) in outputs.iter().enumerate() {
        let sim: Vec<f64> = data.outputs[j].iter().map(|v| v.unwrap()).collect();
        let range = sim.iter().cloned().fold(f64::MIN, f64::max)
            - sim.iter().cloned().fold(f64::MAX, f64::min);
        let rms = (sim
            .iter()
            .zip(&y[j])
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            / sim.len() as f64)
            .sqrt();
        println!(
            "{name}: RMS difference {:.3} % of the range",
            100.0 * rms / range
        );
        worst = worst.max(rms / range);
    }
    worst
}

fn axis(scene: &Scene) -> RotaryAxis {
    RotaryAxis::from_rig(
        &rig_of(scene),
        Path::new("scene.rig.toml"),
        AxisInput::Voltage,
    )
    .unwrap()
}

fn nominal(m: &RotaryAxis) -> Vec<f64> {
    m.param_specs().iter().map(|s| s.nominal).collect()
}

#[test]
fn the_lifted_drive_and_its_fitting_model_agree_without_friction_or_play() {
    let s = machine(&["gearbox.backlash_rad=0", "motor.coulomb_Nm=0"]);
    let m = axis(&s);
    let d = disagreement(&simulated(&s, "plain"), &m, &nominal(&m));
    assert!(d < 0.005, "{d}");
}

#[test]
fn the_lifted_drive_and_its_fitting_model_agree_with_coulomb_friction() {
    let s = machine(&["gearbox.backlash_rad=0", "motor.coulomb_Nm=0.05"]);
    let m = axis(&s).with_effect(Effect::CoulombFriction, 0.05, 0.0, 1.0, 200.0);
    let d = disagreement(&simulated(&s, "coulomb"), &m, &nominal(&m));
    assert!(d < 0.005, "{d}");
}

/// With 0.05 rad of play; the fitting block's share of viscous friction on the wheel side
/// set to the simulator's (none: all of it acts at the motor shaft). The simulator steps
/// at 0.5 ms: at the scene's 1 ms the teeth's impacts fall on a coarser grid and the
/// current differs by 0.53 % of its range; at 0.5 ms and at 0.25 ms alike, by 0.35 %.
#[test]
fn the_lifted_drive_and_its_fitting_model_agree_through_gear_play() {
    let s = machine(&[
        "gearbox.backlash_rad=0.05",
        "motor.coulomb_Nm=0",
        "sim.dt_s=0.0005",
    ]);
    let m = axis(&s).with_effect(Effect::Backlash, 0.05, 1e-4, 0.5, 200.0);
    let mut p = nominal(&m);
    let share = m
        .param_specs()
        .iter()
        .position(|s| s.name == WHEEL_SHARE_PARAM)
        .unwrap();
    p[share] = 0.0;
    let d = disagreement(&simulated(&s, "play"), &m, &p);
    assert!(d < 0.005, "{d}");
}
