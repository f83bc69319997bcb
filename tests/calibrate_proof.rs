//! The calibration's proof ([`agvsim::calibrate::prove`]): round trips through the
//! simulator, one test per recording kind. Every case must pass: the concealed effect
//! accepted first with its key within 10 %, nothing accepted on a clean recording. The
//! 1-sigma coverage of the fitted keys is printed (`cargo test --test calibrate_proof --
//! --nocapture`; over every kind, `agvsim prove --calibrate`).

use agvsim::calibrate::prove::{cases, coverage, render, run, Kind, Outcome};

fn prove_kind(kind: Kind) -> Vec<Outcome> {
    let only = std::env::var("AGVSIM_PROOF_CASE").ok();
    let mut out = vec![];
    for case in cases(&[kind]).unwrap() {
        if only
            .as_ref()
            .is_some_and(|o| !case.name.contains(o.as_str()))
        {
            continue;
        }
        if let Ok(dir) = std::env::var("AGVSIM_PROOF_DUMP") {
            let (machine, _, belief) = agvsim::calibrate::prove::setup(&case, 1).unwrap();
            let (text, _) = agvsim::calibrate::prove::record_text(&case, &machine, 1).unwrap();
            let stem = case.name.replace('/', "_");
            std::fs::create_dir_all(&dir).unwrap();
            std::fs::write(format!("{dir}/{stem}.csv"), text).unwrap();
            std::fs::write(format!("{dir}/{stem}.machine.toml"), machine.to_toml()).unwrap();
            std::fs::write(format!("{dir}/{stem}.belief.toml"), belief.to_toml()).unwrap();
        }
        let (o, c) = run(&case, 1).unwrap();
        println!("{}\n{}", case.name, agvsim::calibrate::write::render(&c));
        for (k, truth, v, sd) in &o.keys {
            println!(
                "   truth {k:<34} {truth:<12.6} fitted {v:<12.6} sd {sd:?} z {:.1}",
                sd.map_or(f64::NAN, |s| (v - truth) / s)
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

#[test]
fn thesis_lifted_pair_on_random_demands() {
    prove_kind(Kind::PairDemand);
}

#[test]
fn floor_vehicle_on_voltage_multisines() {
    prove_kind(Kind::VehicleVoltage);
}

#[test]
fn velocity_commanded_base_on_random_cmd_vel_steps() {
    prove_kind(Kind::BaseVelocity);
}
