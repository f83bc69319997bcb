//! The calibration's proof ([`agvsim::calibrate::prove`]): round trips through the
//! simulator, one test per recording kind. Every case must pass: the concealed effect
//! accepted first with its key within 10 %, nothing accepted on a clean recording. The
//! 1-sigma coverage of the fitted keys is printed (`cargo test --test calibrate_proof --
//! --nocapture`; over every kind, `agvsim prove --calibrate`).

mod common;

use agvsim::calibrate::prove::{cases, coverage, record_text, render, run, setup, Kind, Outcome};

fn prove_kind(kind: Kind) -> Vec<Outcome> {
    let only = std::env::var("AGVSIM_PROOF_CASE").ok();
    // Another seed's round trips, for looking into one (the test's own is 1).
    let seed: u64 = std::env::var("AGVSIM_PROOF_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1);
    let mut out = vec![];
    for case in cases(&[kind]).unwrap() {
        if only
            .as_ref()
            .is_some_and(|o| !case.name.contains(o.as_str()))
        {
            continue;
        }
        if let Ok(dir) = std::env::var("AGVSIM_PROOF_DUMP") {
            let (machine, _, belief) = setup(&case, seed).unwrap();
            let (text, _) = record_text(&case, &machine, seed).unwrap();
            let stem = case.name.replace('/', "_");
            std::fs::create_dir_all(&dir).unwrap();
            std::fs::write(format!("{dir}/{stem}.csv"), text).unwrap();
            std::fs::write(format!("{dir}/{stem}.machine.toml"), machine.to_toml()).unwrap();
            std::fs::write(format!("{dir}/{stem}.belief.toml"), belief.to_toml()).unwrap();
        }
        let (o, c) = run(&case, seed).unwrap();
        println!("{}\n{}", case.name, agvsim::calibrate::write::render(&c));
        for k in &o.keys {
            println!(
                "   truth {:<34} {:<12.6} fitted {:<12.6} sd {:?} z {:.1}{}",
                k.key,
                k.truth,
                k.calibrated,
                k.std,
                k.z().unwrap_or(f64::NAN),
                if k.conditional {
                    " (given a held key)"
                } else {
                    ""
                }
            );
        }
        out.push(o);
    }
    println!("{}", render(&out));
    let (share, n) = coverage(&out);
    println!(
        "{kind:?}: 1-sigma coverage {:.0} % of {n} keys",
        100.0 * share
    );
    let failed: Vec<&str> = out
        .iter()
        .filter(|o| !o.passed)
        .map(|o| o.case.name.as_str())
        .collect();
    assert!(failed.is_empty(), "failed: {failed:?}\n{}", render(&out));
    out
}

#[test]
fn lifted_axis_on_voltage_multisines_and_sysid_tests() {
    prove_kind(Kind::AxisVoltage);
}

#[test]
fn lifted_axis_on_demands_through_the_dcmc() {
    prove_kind(Kind::AxisDemand);
}

/// Besides every case passing: the lifted pair's motor speeds alone do not tell the
/// viscous friction from the torque constant's back-EMF damping (`b + kt^2 / R` is what
/// sets the speed), so on the clean recording the friction is held at the belief (5-20 %
/// off) and the torque constant, which leans on it, is said to hold only given it; the
/// intervals stated without that condition hold the machine's values within 3 standard
/// deviations.
#[test]
fn thesis_lifted_pair_on_random_demands() {
    let out = prove_kind(Kind::PairDemand);
    let clean = out
        .iter()
        .find(|o| o.case.effect.is_none() && o.case.truth.is_none())
        .expect("a clean case");
    let kt = clean
        .keys
        .iter()
        .find(|k| k.key == "motor.torque_constant_Nm_A")
        .expect("the torque constant fitted");
    assert!(kt.conditional, "{:?}", clean.keys);
    assert!(clean.keys.iter().all(|k| k.key != "motor.viscous_Nm_s_rad"));
    for k in clean.keys.iter().filter(|k| !k.conditional) {
        let z = k.z().expect("an estimate's deviation");
        assert!(z.abs() <= 3.0, "{}: z {z:.2}", k.key);
    }
}

#[test]
fn floor_vehicle_on_voltage_multisines() {
    prove_kind(Kind::VehicleVoltage);
}

#[test]
fn velocity_commanded_base_on_random_cmd_vel_steps() {
    prove_kind(Kind::BaseVelocity);
}

/// `agvsim diagnose --rig` on a velocity recording: the base known by a `base` rig.
#[test]
fn velocity_commanded_base_known_by_its_rig() {
    prove_kind(Kind::BaseRig);
}

/// The base known by its rig, its wheel geometry concealed, on the round trip of seed 2 (new
/// inputs, noise and beliefs): the reduced base and the simulator disagree there by more
/// than a tenth of the residual after the first stage, so the simulator judges the
/// evidence; the fits on the reduced base carry its defect at the scene's keys from then
/// on, so that the geometry they claim is the one the simulator sees. Without the defect,
/// the geometry's fit ended where the simulator's replay was worse (AIC gain -150) and
/// nothing was accepted.
#[test]
fn a_base_known_by_its_rig_has_its_geometry_found_where_the_simulator_judges() {
    let case = common::proof_case(Kind::BaseRig, "/wheel_geometry");
    let (o, c) = run(&case, 2).unwrap();
    println!("{}", agvsim::calibrate::write::render(&c));
    assert!(o.passed, "{}", render(&[o]));
}

/// `agvsim diagnose --rig` itself on a base's velocity recording: the wheel-geometry case of
/// the base known by its rig, its rig and recording written as files. The contract's JSON
/// names the geometry first, its track within the proof's 10 % (the case's truth), and the
/// console says it as a diagnosis.
#[test]
fn diagnose_with_a_base_rig_names_the_wheel_geometry() {
    let case = common::proof_case(Kind::BaseRig, "/wheel_geometry");
    let (machine, _, belief) = setup(&case, 1).unwrap();
    let (recording, _) = record_text(&case, &machine, 1).unwrap();
    let dir = common::tmp("base-rig");
    let (csv, rig, json) = (
        dir.join("run.csv"),
        dir.join("robot.rig.toml"),
        dir.join("diagnosis.json"),
    );
    std::fs::write(&csv, recording).unwrap();
    std::fs::write(&rig, agvsim::rig::Rig::of_base_scene(&belief).to_toml()).unwrap();
    let path = |p: &std::path::Path| p.to_str().unwrap().to_string();
    let o = common::agvsim_output(&[
        "diagnose",
        "--rig",
        &path(&rig),
        "--recording",
        &path(&csv),
        "--json",
        &path(&json),
    ]);
    let t = common::text(&o);
    assert!(o.status.success(), "{t}");
    assert!(t.contains("Found: wheel_geometry"), "{t}");
    let d: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let first = &d["effects"][0];
    assert_eq!(first["name"], "wheel_geometry", "{d:#}");
    let (_, truth) = case.truth.unwrap();
    let track = first["params"]["track_m"].as_f64().unwrap();
    assert!(
        (track / truth - 1.0).abs() <= 0.10,
        "track {track} for {truth}\n{t}"
    );
}

/// The lifted axis's clean recordings measured by its own sensors (encoder counts over each
/// sample, a current sensor's noise low-passed over 20 ms; the white noise's deviations):
/// coloured noise is not physics, and nothing is accepted. With the encoder's count taken
/// over the interval before each sample instead, its half-sample lag was accepted as a
/// transport delay of 1.5-2 ms on both.
#[test]
fn coloured_sensor_noise_on_a_clean_lifted_axis_names_nothing() {
    use agvsim::calibrate::prove::SensorNoise;
    for end in ["multisine/clean", "sysid/clean"] {
        let case = agvsim::calibrate::prove::Case {
            noise: SensorNoise::Sensors,
            ..common::proof_case(Kind::AxisVoltage, end)
        };
        let (o, c) = run(&case, 1).unwrap();
        println!("{}", agvsim::calibrate::write::render(&c));
        assert!(o.passed, "{}", render(&[o]));
    }
}

/// Issue 57's "honest when the model is wrong": the lifted axis with a Coulomb friction
/// the calibration is not allowed to name. Its keys then bend to explain the friction and
/// their intervals miss, so the model check must say the model is wrong (the residual's
/// level follows the speed's) and that the intervals are not to be trusted; with the
/// friction offered, the same recording's check passes.
#[test]
fn a_model_left_without_its_friction_says_its_intervals_are_not_to_be_trusted() {
    let case = common::proof_case(Kind::AxisVoltage, "multisine/coulomb_friction");
    let (o, c) = run(&case, 1).unwrap();
    assert!(o.passed && !o.model_flagged(), "{}", render(&[o]));
    let left_out = agvsim::calibrate::prove::Case {
        left_out: true,
        ..case
    };
    let (o, c_wrong) = run(&left_out, 1).unwrap();
    let text = agvsim::calibrate::write::render(&c_wrong);
    println!("{text}");
    assert!(o.model_flagged(), "{}", render(&[o]));
    assert!(
        text.contains("MODEL CHECK FAILED") && text.contains("not to be trusted"),
        "{text}"
    );
    assert!(!agvsim::calibrate::write::render(&c).contains("MODEL CHECK FAILED"));
}
