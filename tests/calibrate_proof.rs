//! The calibration's proof ([`agvsim::calibrate::prove`]): round trips through the
//! simulator, one test per recording kind.

use agvsim::calibrate::prove::{cases, render, run, Kind, Outcome};

fn prove_kind(kind: Kind, seed: u64) -> Vec<Outcome> {
    let only = std::env::var("AGVSIM_PROOF_CASE").ok();
    let mut out = vec![];
    for case in cases(&[kind]).unwrap() {
        if only.as_ref().is_some_and(|o| !case.name.contains(o.as_str())) {
            continue;
        }
        if let Ok(dir) = std::env::var("AGVSIM_PROOF_DUMP") {
            let (machine, _, belief) = agvsim::calibrate::prove::setup(&case, seed).unwrap();
            let (text, _) = agvsim::calibrate::prove::record_text(&case, &machine, seed).unwrap();
            let stem = case.name.replace('/', "_");
            std::fs::create_dir_all(&dir).unwrap();
            std::fs::write(format!("{dir}/{stem}.csv"), text).unwrap();
            std::fs::write(format!("{dir}/{stem}.machine.toml"), machine.to_toml()).unwrap();
            std::fs::write(format!("{dir}/{stem}.belief.toml"), belief.to_toml()).unwrap();
        }
        let t = std::time::Instant::now();
        let (o, c) = run(&case, seed).unwrap();
        eprintln!("{} ({:.1} s)\n{}", case.name, t.elapsed().as_secs_f64(), agvsim::calibrate::write::render(&c));
        for (k, truth, v, sd) in &o.keys {
            eprintln!("   truth {k:<34} {truth:<12.6} fitted {v:<12.6} sd {sd:?} z {:.1}", sd.map_or(f64::NAN, |s| (v - truth) / s));
        }
        out.push(o);
    }
    eprintln!("{}", render(&out));
    out
}

#[test]
#[ignore]
fn axis_voltage() {
    prove_kind(Kind::AxisVoltage, 1);
}
#[test]
#[ignore]
fn axis_demand() {
    prove_kind(Kind::AxisDemand, 1);
}
#[test]
#[ignore]
fn pair_demand() {
    prove_kind(Kind::PairDemand, 1);
}
#[test]
#[ignore]
fn vehicle_voltage() {
    prove_kind(Kind::VehicleVoltage, 1);
}
#[test]
#[ignore]
fn base_velocity() {
    prove_kind(Kind::BaseVelocity, 1);
}
