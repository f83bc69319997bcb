//! Terms outside the vocabulary (issue 56): when no effect of the vocabulary explains the
//! residual, the diagnosis names the family of the term that does, with its order or
//! exponent and its coefficient, and claims nothing on a clean recording.
//!
//! Two independent sources: the development set made by another team's truth simulator
//! (`../shared/data/dev_open`, answers in its key files), and recordings this test makes
//! with its own small integrator of a DC motor and gear train (not agvsim's models), one
//! per family the development set does not hold.

use std::path::Path;

use agvsim::diagnose::{diagnose, DiagnoseOptions, Diagnosis};
use agvsim::record::Recording;
use agvsim::rig::Rig;

mod common;

fn diagnose_files(rig_path: &Path, csv: &Path) -> Diagnosis {
    let rig = Rig::load(rig_path).unwrap();
    let rec = Recording::load(csv).unwrap();
    diagnose(&rig, rig_path, &rec, None, &DiagnoseOptions::default()).unwrap()
}

/// The first thing a diagnosis found, as the contract's JSON lists it.
fn first_effect(d: &Diagnosis) -> Option<serde_json::Value> {
    d.contract_json()["effects"].as_array()?.first().cloned()
}

/// Each hidden term of the development set is named first, with its order or exponent,
/// and its main coefficient within 20 % of the key's; the clean case gives nothing (not
/// even "unexplained"). The answers are read from the key files.
#[test]
fn the_development_sets_hidden_terms_are_named_with_order_and_coefficient() {
    let dir = Path::new("../shared/data/dev_open");
    for n in 1..=5 {
        let name = format!("dev_open_0{n}");
        let key: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(dir.join(format!("{name}.key.json"))).unwrap(),
        )
        .unwrap();
        let d = diagnose_files(
            &dir.join(format!("{name}.rig.toml")),
            &dir.join(format!("{name}.csv")),
        );
        println!("{name}\n{}", agvsim::diagnose::report::render(&d));
        let family = key["family"].as_str().unwrap();
        if family == "none" {
            assert!(d.found_names().is_empty(), "{name}: {:?}", d.found_names());
            assert!(d.unexplained.is_none(), "{name}: {:?}", d.unexplained);
            continue;
        }
        let found = first_effect(&d).unwrap_or_else(|| panic!("{name}: nothing found"));
        assert_eq!(found["name"], family, "{name}");
        assert_eq!(found["outside_vocabulary"], true, "{name}");
        let truth = key["effects"][0]["params"].as_object().unwrap();
        let (main, value) = truth.iter().next().unwrap();
        let fitted = found["params"][main].as_f64().unwrap();
        let truth = value.as_f64().unwrap();
        assert!(
            (fitted - truth).abs() <= 0.2 * truth.abs(),
            "{name}: {main} {fitted} against {truth}"
        );
        let order = match family {
            "speed_power" => "exponent",
            _ => "order",
        };
        assert_eq!(found["params"][order].as_f64(), key["n"].as_f64(), "{name}");
        assert!(d.final_fit_pct > d.baseline_fit_pct, "{name}");
        // The evidence plot: an output's residual, binned by the quantity the term
        // depends on, follows it before (its binned means spread at least twice as far)
        // and is flat after. A periodic torque's response lags its phase by the drive's
        // dynamics, by more as the chirp speeds up, which blurs its bins (dev_open_04:
        // 2.4 times; the speed powers 9 and 33 times).
        let (_, x) = d.terms[0].quantity.as_ref().expect("a measured quantity");
        let data = d.baseline.data.as_ref().unwrap();
        let ratio = |j: usize| {
            let spread = |pred: &[f64]| {
                let r: Vec<f64> = data.outputs[j]
                    .iter()
                    .zip(pred)
                    .map(|(v, p)| v.unwrap() - p)
                    .collect();
                binned_spread(x, &r, 24)
            };
            spread(&d.baseline.predicted[j]) / spread(&d.diagnosed.predicted[j])
        };
        let best = (0..data.output_names.len()).map(ratio).fold(0.0, f64::max);
        println!("{name}: binned residual spread {best:.1} times smaller after");
        assert!(best > 2.0, "{name}: {best}");
        let figures = agvsim::diagnose::plots::figures(&d).unwrap();
        let file = format!("term_{family}_current_A.svg");
        assert!(figures.iter().any(|f| f.file == file), "{name}: {file}");
    }
}

/// The spread of `y`'s means in `bins` equal bins of `x` over its range: their standard
/// deviation with each bin weighed by its samples (a bin at the range's edge holds a few
/// noisy samples).
fn binned_spread(x: &[f64], y: &[f64], bins: usize) -> f64 {
    let lo = x.iter().cloned().fold(f64::INFINITY, f64::min);
    let hi = x.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let mut sum = vec![0.0; bins];
    let mut count = vec![0.0; bins];
    for (a, b) in x.iter().zip(y) {
        let k = (((a - lo) / (hi - lo) * bins as f64) as usize).min(bins - 1);
        sum[k] += b;
        count[k] += 1.0;
    }
    let n: f64 = count.iter().sum();
    let m = sum.iter().sum::<f64>() / n;
    let var: f64 = (0..bins)
        .filter(|&k| count[k] > 0.0)
        .map(|k| count[k] * (sum[k] / count[k] - m).powi(2))
        .sum();
    (var / n).sqrt()
}

/// The truth of this test's own recordings: a DC motor through a rigid 23.41:1 gear to a
/// lifted wheel, with one term of a family.
#[derive(Clone, Copy)]
struct Truth {
    resistance_ohm: f64,
    inductance_h: f64,
    torque_constant_nm_a: f64,
    /// Rotor plus wheel inertia at the motor shaft.
    inertia_kg_m2: f64,
    viscous_nm_s_rad: f64,
    ratio: f64,
}

const TRUTH: Truth = Truth {
    resistance_ohm: 0.62,
    inductance_h: 0.0011,
    torque_constant_nm_a: 0.072,
    inertia_kg_m2: 0.00032 + 0.0196 / (23.41 * 23.41),
    viscous_nm_s_rad: 1.2e-4,
    ratio: 23.41,
};

/// A term as this test's integrator applies it.
#[derive(Clone, Copy, Debug)]
enum Term {
    /// Wheel-side torque `A sin(n theta_w + phi)`, N m at the wheel.
    PeriodicWheel {
        amplitude_nm: f64,
        order: f64,
        phase_rad: f64,
    },
    /// Motor-side friction `-mu |K i| sign(w)`.
    LoadFriction { ratio: f64 },
    /// `R = R0 (1 + a q)`, `tau dq/dt = i^2 - q`.
    Thermal { coefficient_1_a2: f64, tau_s: f64 },
    /// `K (1 - k |i|^n)` (torque and back-EMF).
    CurrentPower { coefficient: f64, exponent: f64 },
    /// `K (1 + r t)`.
    TorqueConstantDrift { rate_1_s: f64 },
}

/// Voltage at time t: a multisine around a mean (so the wheel travels many turns one way
/// and the current swings widely).
fn voltage(t: f64) -> f64 {
    let tones = [
        (0.23, 0.0),
        (0.61, 1.3),
        (1.37, 2.1),
        (2.9, 0.4),
        (5.3, 2.9),
    ];
    let wave: f64 = tones
        .iter()
        .map(|(f, ph)| (std::f64::consts::TAU * f * t + ph).sin())
        .sum();
    (7.0 + 2.2 * wave).clamp(-12.0, 12.0)
}

/// The state's rates: current, motor speed, motor angle, heat, at time t.
fn rates(p: &Truth, term: Term, t: f64, x: [f64; 4]) -> [f64; 4] {
    let [i, w, theta, q] = x;
    let (mut r, mut k, mut extra) = (p.resistance_ohm, p.torque_constant_nm_a, 0.0);
    let mut dq = 0.0;
    match term {
        Term::PeriodicWheel {
            amplitude_nm,
            order,
            phase_rad,
        } => extra = amplitude_nm * (order * theta / p.ratio + phase_rad).sin() / p.ratio,
        Term::LoadFriction { .. } => {}
        Term::Thermal {
            coefficient_1_a2,
            tau_s,
        } => {
            r *= 1.0 + coefficient_1_a2 * q;
            dq = (i * i - q) / tau_s;
        }
        Term::CurrentPower {
            coefficient,
            exponent,
        } => k *= (1.0 - coefficient * i.abs().powf(exponent)).max(0.0),
        Term::TorqueConstantDrift { rate_1_s } => k *= 1.0 + rate_1_s * t,
    }
    if let Term::LoadFriction { ratio } = term {
        extra = -ratio * (k * i).abs() * (w / 0.5).tanh();
    }
    let di = (voltage(t) - r * i - k * w) / p.inductance_h;
    let dw = (k * i - p.viscous_nm_s_rad * w + extra) / p.inertia_kg_m2;
    [di, dw, w, dq]
}

/// A recording of `seconds` at 400 Hz in the contract's format: the voltage, the speed a
/// 1024-count encoder gives (count difference over the interval) and the current with
/// 0.08 A of noise; RK4 at 20 steps per sample.
fn record(term: Term, seconds: f64, seed: u64) -> String {
    use rand::SeedableRng;
    use rand_distr::Distribution;
    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
    let noise = rand_distr::Normal::new(0.0, 0.08).unwrap();
    let (dt, sub) = (1.0 / 400.0, 20);
    let h = dt / sub as f64;
    let counts = |theta: f64| (theta * 1024.0 / std::f64::consts::TAU).floor();
    let mut x = [0.0; 4];
    let mut t = 0.0;
    let mut text = String::from(
        "# agvsim-recording: 1\n# rig: drive_axis\n# description: test integrator, one term\n# sample_time_s: 0.0025\nt_s,voltage_V,motor_speed_rad_s,current_A\n",
    );
    let rows = (seconds / dt).round() as usize;
    let mut last_count = 0.0;
    for k in 0..=rows {
        let c = counts(x[2]);
        let speed = if k == 0 {
            0.0
        } else {
            (c - last_count) * std::f64::consts::TAU / 1024.0 / dt
        };
        last_count = c;
        let i = x[0] + noise.sample(&mut rng);
        text.push_str(&format!("{t:.4},{:.5},{speed:.5},{i:.5}\n", voltage(t)));
        for _ in 0..sub {
            let add = |a: [f64; 4], b: [f64; 4], s: f64| std::array::from_fn(|j| a[j] + s * b[j]);
            let k1 = rates(&TRUTH, term, t, x);
            let k2 = rates(&TRUTH, term, t + h / 2.0, add(x, k1, h / 2.0));
            let k3 = rates(&TRUTH, term, t + h / 2.0, add(x, k2, h / 2.0));
            let k4 = rates(&TRUTH, term, t + h, add(x, k3, h));
            x = std::array::from_fn(|j| {
                x[j] + h / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j])
            });
            t += h;
        }
        t = (k + 1) as f64 * dt;
    }
    text
}

/// The rig: the truth's values 10-20 % off, as a user's datasheet beliefs are.
fn rig_text() -> String {
    format!(
        "rig = \"drive_axis\"\n[motor]\nresistance_ohm = {}\ninductance_H = {}\ntorque_constant_Nm_A = {}\nrotor_inertia_kg_m2 = {}\nviscous_Nm_s_rad = {}\n[gearbox]\nratio = 23.41\n[wheel]\nradius_m = 0.075\ninertia_kg_m2 = 0.0196\n[supply]\nvoltage_V = 24.0\n[sensors]\nmotor_encoder_counts_per_rev = 1024\ncurrent_noise_A = 0.08\n",
        TRUTH.resistance_ohm * 1.15,
        TRUTH.inductance_h * 0.85,
        TRUTH.torque_constant_nm_a * 0.9,
        0.00032 * 1.2,
        TRUTH.viscous_nm_s_rad * 1.2,
    )
}

/// One family's round trip: the term in this test's integrator, recorded with noise,
/// named first by the diagnosis with its order and its main coefficient within 20 %.
fn round_trip(
    name: &str,
    term: Term,
    family: &str,
    main: &str,
    truth: f64,
    order: Option<(&str, f64)>,
) {
    round_trip_of(name, term, SECONDS, family, main, truth, order)
}

/// The length of a round trip's recording, s.
const SECONDS: f64 = 16.0;

/// A round trip over a recording of `seconds`.
fn round_trip_of(
    name: &str,
    term: Term,
    seconds: f64,
    family: &str,
    main: &str,
    truth: f64,
    order: Option<(&str, f64)>,
) {
    let dir = common::tmp(&format!("terms_{name}"));
    let rig = dir.join("axis.rig.toml");
    let csv = dir.join(format!("{name}.csv"));
    std::fs::write(&rig, rig_text()).unwrap();
    std::fs::write(&csv, record(term, seconds, 7)).unwrap();
    let d = diagnose_files(&rig, &csv);
    println!("{name}\n{}", agvsim::diagnose::report::render(&d));
    let found = first_effect(&d).unwrap_or_else(|| panic!("{name}: nothing found"));
    assert_eq!(found["name"], family, "{name}");
    let fitted = found["params"][main].as_f64().unwrap();
    assert!(
        (fitted - truth).abs() <= 0.2 * truth.abs(),
        "{name}: {main} {fitted} against {truth}"
    );
    if let Some((key, n)) = order {
        assert_eq!(found["params"][key].as_f64(), Some(n), "{name}");
    }
}

#[test]
fn an_out_of_round_wheel_is_two_periods_per_wheel_turn() {
    round_trip(
        "oval_wheel",
        Term::PeriodicWheel {
            amplitude_nm: 0.9,
            order: 2.0,
            phase_rad: 1.1,
        },
        "periodic_wheel_angle",
        "amplitude_Nm",
        0.9,
        Some(("order", 2.0)),
    );
}

#[test]
fn gears_losing_a_share_of_their_torque_are_load_dependent_friction() {
    round_trip(
        "gear_efficiency",
        Term::LoadFriction { ratio: 0.08 },
        "load_dependent_friction",
        "friction_ratio",
        0.08,
        None,
    );
}

#[test]
fn a_torque_constant_falling_with_current_is_magnetic_saturation() {
    round_trip(
        "saturation",
        Term::CurrentPower {
            coefficient: 0.02,
            exponent: 1.0,
        },
        "current_power",
        "coefficient",
        0.02,
        Some(("exponent", 1.0)),
    );
}

#[test]
fn a_torque_constant_drifting_over_the_recording_is_a_time_drift() {
    // -0.6 % per second over 16 s: the torque constant ends 9.6 % below its start.
    round_trip(
        "drift",
        Term::TorqueConstantDrift { rate_1_s: -0.006 },
        "time_drift",
        "change_pct",
        -0.006 * SECONDS * 100.0,
        None,
    );
}

#[test]
fn windings_heating_up_are_a_thermal_drift() {
    let term = Term::Thermal {
        coefficient_1_a2: 0.03,
        tau_s: 10.0,
    };
    // The resistance's rise at the end, from the heat the truth's current made: read
    // from a noise-free integration of the same run.
    round_trip_thermal(term);
}

/// The thermal round trip: its main coefficient (the rise at the end) depends on the
/// current the run drew, so it is compared with the rise the truth's heat state reached.
fn round_trip_thermal(term: Term) {
    let Term::Thermal {
        coefficient_1_a2,
        tau_s,
    } = term
    else {
        unreachable!()
    };
    // Heating is told from a drift by its time constant: a run of several of them.
    let seconds = 40.0;
    let (mut x, mut t, h) = ([0.0f64; 4], 0.0, 1.0 / 8000.0);
    while t < seconds - 1e-12 {
        let k = rates(&TRUTH, term, t, x);
        x = std::array::from_fn(|j| x[j] + h * k[j]);
        t += h;
    }
    let rise_pct = 100.0 * coefficient_1_a2 * x[3];
    println!("truth: resistance rise {rise_pct:.2} % (tau {tau_s} s)");
    round_trip_of(
        "heating",
        term,
        seconds,
        "thermal_drift",
        "resistance_rise_pct",
        rise_pct,
        None,
    );
}
