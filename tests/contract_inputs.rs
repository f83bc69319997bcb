//! Every input column the contract defines drives the fitting models: a linear axis
//! commanded in force (`force_N`), a rotary axis behind a torque amplifier (`torque_Nm`,
//! or `command_V` through `drive.torque_per_volt_Nm_V`) and one in closed loop from its
//! position reference (`reference_rad`). Each record is made by the model with known
//! values 20-30 % off the rig's beliefs and 0.2 % sensor noise; the fit must bring the
//! values back within 2 % (a few standard deviations at this noise).

mod common;
use common::tmp;

use std::path::{Path, PathBuf};

use agvsim::diagnose::{diagnose, DiagnoseOptions};
use agvsim::ident::data::Dataset;
use agvsim::ident::effects::Effect;
use agvsim::ident::model::GreyBox;
use agvsim::ident::models::linear_axis::LinearAxis;
use agvsim::ident::models::rotary_axis::{AxisInput, RotaryAxis, TorqueCommand};
use agvsim::ident::{identify, IdentifyOptions};
use agvsim::record::Recording;
use agvsim::rig::Rig;

fn rig(dir: &Path, text: &str) -> (Rig, PathBuf) {
    let p = dir.join("axis.rig.toml");
    std::fs::write(&p, text).unwrap();
    (Rig::load(&p).unwrap(), p)
}

/// A multisine-like excitation with steps, so that speed reverses often.
fn excitation(t: f64, amplitude: f64) -> f64 {
    let s = (std::f64::consts::TAU * 0.7 * t).sin() + 0.5 * (std::f64::consts::TAU * 2.3 * t).sin();
    amplitude
        * if s > 0.2 {
            1.0
        } else if s < -0.2 {
            -0.8
        } else {
            s
        }
}

/// Simulates `model` at `p` on the input columns and writes a contract recording with
/// them and the model's outputs.
fn record(
    dir: &Path,
    name: &str,
    model: &dyn GreyBox,
    p: &[f64],
    inputs: &[(&str, Vec<f64>)],
    dt_s: f64,
) -> Recording {
    let n = inputs[0].1.len();
    let t: Vec<f64> = (0..n).map(|k| k as f64 * dt_s).collect();
    let outputs = model.output_names();
    let data = Dataset {
        name: name.into(),
        t_s: t.clone(),
        input_names: inputs.iter().map(|(c, _)| c.to_string()).collect(),
        inputs: inputs.iter().map(|(_, v)| v.clone()).collect(),
        output_names: outputs.clone(),
        outputs: vec![vec![Some(0.0); n]; outputs.len()],
        segment_starts: vec![0],
    };
    let mut y = model.simulate_record(p, &data).unwrap();
    // Sensor noise of 0.2 % of each output's range, seeded.
    use rand::SeedableRng;
    use rand_distr::Distribution;
    let mut rng = rand_pcg::Pcg64::seed_from_u64(7);
    for col in &mut y {
        let range = col.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let noise = rand_distr::Normal::new(0.0, 0.002 * range.max(1e-12)).unwrap();
        for v in col.iter_mut() {
            *v += noise.sample(&mut rng);
        }
    }
    let mut text = String::from("# agvsim-recording: 1\n# rig: drive_axis\nt_s");
    for (c, _) in inputs {
        text.push_str(&format!(",{c}"));
    }
    for o in &outputs {
        text.push_str(&format!(",{o}"));
    }
    text.push('\n');
    for k in 0..n {
        text.push_str(&format!("{}", t[k]));
        for (_, v) in inputs {
            text.push_str(&format!(",{}", v[k]));
        }
        for col in &y {
            text.push_str(&format!(",{}", col[k]));
        }
        text.push('\n');
    }
    let path = dir.join(format!("{name}.csv"));
    std::fs::write(&path, text).unwrap();
    Recording::load(&path).unwrap()
}

fn value(id: &agvsim::ident::Identification, name: &str) -> f64 {
    id.params
        .iter()
        .find(|p| p.name == name)
        .unwrap_or_else(|| panic!("{name} not reported"))
        .value
}

const ROTARY_RIG: &str = "rig = \"drive_axis\"\n\n[motor]\nrotor_inertia_kg_m2 = 2.0e-4\nviscous_Nm_s_rad = 1.0e-4\n\n[gearbox]\nratio = 10.0\n\n[wheel]\nradius_m = 0.075\ninertia_kg_m2 = 0.01\n\n[drive]\ntorque_per_volt_Nm_V = 0.05\nlimit_V = 10.0\n\n[feedback]\nkind = \"position_velocity_cascade\"\nkp_1_s = 20.0\nkv_V_s_rad = 2.0\n";

/// The rotary model a recording's columns select, built as `identify` does.
fn rotary(rig: &Rig, path: &Path, columns: &[&str]) -> RotaryAxis {
    let c = TorqueCommand::from_columns(rig, path, |c| columns.contains(&c))
        .unwrap()
        .unwrap();
    RotaryAxis::from_rig(rig, path, AxisInput::Torque(c)).unwrap()
}

/// A linear axis commanded in force: no amplifier gain is needed, and the mass and
/// friction come back within 2 %.
#[test]
fn a_force_commanded_linear_axis_is_fitted_from_force_n() {
    let dir = tmp("force");
    // No [drive]: the force is recorded.
    let (rig, rig_path) = rig(
        &dir,
        "rig = \"drive_axis\"\nmotion = \"linear\"\n\n[load]\nmass_kg = 80.0\nviscous_N_s_m = 170.0\n",
    );
    let mut truth = LinearAxis::from_rig(&rig, &rig_path, true).unwrap();
    truth.force_input = true;
    let force: Vec<f64> = (0..4000)
        .map(|k| excitation(k as f64 * 1e-3, 150.0))
        .collect();
    let rec = record(
        &dir,
        "force",
        &truth,
        &[96.0, 221.0],
        &[("force_N", force)],
        1e-3,
    );
    let id = identify(&rig, &rig_path, &rec, None, &IdentifyOptions::default()).unwrap();
    println!("{}", agvsim::ident::report::render(&id));
    assert!(id.model.contains("open loop"), "{}", id.model);
    assert!((value(&id, "load.mass_kg") / 96.0 - 1.0).abs() < 0.02);
    assert!((value(&id, "load.viscous_N_s_m") / 221.0 - 1.0).abs() < 0.02);
    assert!(id.ignored_inputs.is_empty(), "{:?}", id.ignored_inputs);
}

/// A rotary axis behind a torque amplifier, driven by `torque_Nm` and by `command_V`:
/// the inertia and friction come back, and the armature's values, which do not act, are
/// not reported.
#[test]
fn a_torque_driven_rotary_axis_is_fitted_from_torque_nm_or_command_v() {
    let dir = tmp("torque");
    let (rig, rig_path) = rig(&dir, ROTARY_RIG);
    // Truth: rotor inertia 25 % above and viscous friction 30 % above the belief.
    let truth_p = |m: &RotaryAxis| {
        let mut p = m.nominal();
        p[m.param_index("motor.rotor_inertia_kg_m2").unwrap()] = 2.5e-4;
        p[m.param_index("motor.viscous_Nm_s_rad").unwrap()] = 1.3e-4;
        p
    };
    for (column, amplitude) in [("torque_Nm", 0.2), ("command_V", 4.0)] {
        let truth = rotary(&rig, &rig_path, &[column]);
        let u: Vec<f64> = (0..4000)
            .map(|k| excitation(k as f64 * 1e-3, amplitude))
            .collect();
        let rec = record(&dir, column, &truth, &truth_p(&truth), &[(column, u)], 1e-3);
        let id = identify(&rig, &rig_path, &rec, None, &IdentifyOptions::default()).unwrap();
        println!("{column}:\n{}", agvsim::ident::report::render(&id));
        assert!(id.model.contains("torque"), "{}", id.model);
        let j = value(&id, "motor.rotor_inertia_kg_m2");
        let b = value(&id, "motor.viscous_Nm_s_rad");
        assert!((j / 2.5e-4 - 1.0).abs() < 0.02, "{column}: J {j}");
        assert!((b / 1.3e-4 - 1.0).abs() < 0.02, "{column}: b {b}");
        assert!(
            !id.params
                .iter()
                .any(|p| p.name.starts_with("motor.resistance")
                    || p.name.starts_with("motor.torque_constant")),
            "armature values reported for a torque-driven axis"
        );
        assert!(id.ignored_inputs.is_empty(), "{:?}", id.ignored_inputs);
    }
}

/// A rotary axis recorded in closed loop: the input is the position reference, the
/// command is an output the model predicts through the rig's cascade, and the diagnosis
/// finds the Coulomb friction the rig leaves out, within 10 %.
#[test]
fn a_closed_loop_rotary_axis_is_fitted_from_reference_rad_and_its_friction_found() {
    let dir = tmp("closed");
    let (rig, rig_path) = rig(&dir, ROTARY_RIG);
    let base = rotary(&rig, &rig_path, &["reference_rad", "command_V"]);
    let truth = base.with_effect(Effect::CoulombFriction, 0.02, 0.0, 1.0, 10.0);
    let mut p = truth.nominal();
    p[truth.param_index("motor.rotor_inertia_kg_m2").unwrap()] = 2.4e-4;
    p[truth.param_index("motor.viscous_Nm_s_rad").unwrap()] = 1.2e-4;
    let reference: Vec<f64> = (0..5000)
        .map(|k| excitation(k as f64 * 1e-3, 1.0))
        .collect();
    let rec = record(
        &dir,
        "closed",
        &truth,
        &p,
        &[("reference_rad", reference)],
        1e-3,
    );
    assert!(rec.column("command_V").is_some());
    let id = identify(&rig, &rig_path, &rec, None, &IdentifyOptions::default()).unwrap();
    assert!(id.model.contains("cascade"), "{}", id.model);
    let d = diagnose(&rig, &rig_path, &rec, None, &DiagnoseOptions::default()).unwrap();
    println!("{}", agvsim::diagnose::report::render(&d));
    let found: Vec<&str> = d.findings.iter().map(|f| f.effect.name()).collect();
    assert_eq!(found, vec!["coulomb_friction"], "{found:?}");
    let c = d.findings[0].value;
    assert!((c / 0.02 - 1.0).abs() < 0.1, "Coulomb {c} N m against 0.02");
}

/// The simulated AGV has DC motors behind its DCMC, no current amplifier: replaying a
/// torque-commanded record is refused with the reason, naming the column.
#[test]
fn replay_names_the_inputs_the_simulated_machine_cannot_take() {
    let dir = tmp("replay");
    let (rig, rig_path) = rig(&dir, ROTARY_RIG);
    let m = rotary(&rig, &rig_path, &["torque_Nm"]);
    let u: Vec<f64> = (0..500).map(|k| excitation(k as f64 * 1e-3, 0.2)).collect();
    let rec = record(&dir, "torque", &m, &m.nominal(), &[("torque_Nm", u)], 1e-3);
    let scene = agvsim::scene::Scene::load(Path::new("scenes/lab_offset_120mm.toml"), &[]).unwrap();
    let err = agvsim::replay::replay(&scene, &rec)
        .expect_err("refused")
        .to_string();
    println!("{err}");
    assert!(
        err.contains("torque_Nm") && err.contains("current amplifier"),
        "{err}"
    );
}
