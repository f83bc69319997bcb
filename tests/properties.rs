//! Property tests (proptest, a fixed seed and case count, so the run is the same every
//! time and takes seconds): the parsers a user's input reaches answer with a value or a
//! located error, never a panic, and what they accept keeps the contract's invariants.
//! `tests/fuzz.rs` mutates whole real files; these generate the values themselves.

use std::path::Path;

use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};

use agvsim::record::Recording;
use agvsim::rig::Rig;
use agvsim::scene::Scene;
use agvsim::sweep::parse_vary;

/// A fixed budget and seed; no regression files written into the tree.
fn config(cases: u32) -> Config {
    Config {
        cases,
        rng_seed: RngSeed::Fixed(18),
        failure_persistence: None,
        ..Config::default()
    }
}

/// Text shaped like a TOML or CSV value: digits, signs, exponents, the special floats,
/// brackets, quotes and separators, and now and then any character at all.
fn value_text() -> impl Strategy<Value = String> {
    prop_oneof![
        4 => "[-+0-9eE.,\\[\\] \"]{0,24}",
        2 => prop::sample::select(vec![
            "nan", "inf", "-inf", "1e308", "-1e308", "1e-320", "0", "-0", "\"\"", "[]", "{}",
            "true", "99999999999999999999", "[0,0,5]", "[[0,0],[1e300,0]]",
        ])
        .prop_map(str::to_string),
        1 => any::<String>(),
    ]
}

/// A number as a recording cell may hold it: ordinary, huge, tiny, or not finite.
fn cell() -> impl Strategy<Value = String> {
    prop_oneof![
        6 => (-1e3f64..1e3).prop_map(|v| format!("{v}")),
        1 => prop::sample::select(vec!["", "nan", "inf", "-inf", "1e300", "-1e300", "x", "1,5"])
            .prop_map(str::to_string),
    ]
}

/// A drive-axis recording of `rows` rows whose time steps and cells are generated.
fn recording_text() -> impl Strategy<Value = String> {
    prop::collection::vec(((-0.01f64..0.02), cell(), cell(), cell()), 0..12).prop_map(|rows| {
        let mut text = String::from(
            "# agvsim-recording: 1\n# rig: drive_axis\n# sample_time_s: 0.005\nt_s,voltage_V,motor_speed_rad_s,current_A\n",
        );
        let mut t = 0.0;
        for (dt, a, b, c) in rows {
            t += dt;
            text.push_str(&format!("{t},{a},{b},{c}\n"));
        }
        text
    })
}

const SET_KEYS: [&str; 9] = [
    "controller.gain_scale",
    "chassis.mass_kg",
    "tyre.compound",
    "wire.points_m",
    "sim.dt_s",
    "sim.max_steps",
    "gearbox.backlash_rad",
    "nope.key",
    "",
];

const RIG_KEYS: [&str; 8] = [
    "motor.resistance_ohm",
    "motor.inductance_H",
    "motor.viscous_Nm_s_rad",
    "motor.rotor_inertia_kg_m2",
    "gearbox.ratio",
    "wheel.radius_m",
    "wheel.inertia_kg_m2",
    "supply.voltage_V",
];

proptest! {
    #![proptest_config(config(300))]

    /// Any `--set KEY=VALUE` is taken or refused with a message that names the key.
    #[test]
    fn a_set_value_is_taken_or_refused_naming_its_key(
        key in prop::sample::select(SET_KEYS.to_vec()),
        value in value_text(),
    ) {
        let text = std::fs::read_to_string("scenes/lab_offset_120mm.toml").unwrap();
        let arg = format!("{key}={value}");
        if let Err(e) = Scene::from_toml(&text, Path::new("lab.toml"), std::slice::from_ref(&arg)) {
            let message = e.to_string();
            prop_assert!(!message.is_empty());
            if !key.is_empty() {
                prop_assert!(message.contains(key), "{arg}: {message}");
            }
        }
    }

    /// Any `--vary` range or list parses to finite values or is refused.
    #[test]
    fn a_vary_range_gives_finite_values_or_is_refused(
        key in prop::sample::select(SET_KEYS.to_vec()),
        spec in value_text(),
        low in -1e6f64..1e6, high in -1e6f64..1e6, count in 0u64..50,
    ) {
        if let Ok(vary) = parse_vary(&format!("{key}={spec}")) {
            prop_assert!(!vary.values.is_empty(), "{key}={spec}");
        }
        let arg = format!("{key}={low}..{high}:{count}");
        if let Ok(vary) = parse_vary(&arg) {
            prop_assert_eq!(vary.values.len() as u64, count, "{}", arg);
            for v in &vary.values {
                let x: f64 = v.parse().map_err(|_| TestCaseError::fail(format!("{arg} gave {v}")))?;
                prop_assert!(x.is_finite() && x >= low.min(high) - 1e-9 && x <= low.max(high) + 1e-9, "{arg} gave {x}");
            }
        }
    }

    /// A recording that parses has strictly increasing finite times and only finite cells;
    /// one that does not is refused with its file named.
    #[test]
    fn a_recording_parses_to_the_contract_or_is_refused(text in recording_text()) {
        match Recording::parse(&text, Path::new("gen.csv")) {
            Ok(rec) => {
                prop_assert!(rec.t_s.iter().all(|t| t.is_finite()));
                prop_assert!(rec.t_s.windows(2).all(|w| w[1] > w[0]), "{text}");
                for column in &rec.columns {
                    prop_assert_eq!(column.len(), rec.t_s.len());
                    prop_assert!(column.iter().flatten().all(|v| v.is_finite()), "{text}");
                }
            }
            Err(e) => prop_assert!(e.to_string().contains("gen.csv")),
        }
    }

    /// A rig value is taken when it is a positive finite number (or zero where zero means
    /// something) and otherwise refused naming the key.
    #[test]
    fn a_rig_value_is_taken_when_physical_or_refused_naming_it(
        key in prop::sample::select(RIG_KEYS.to_vec()),
        value in value_text(),
    ) {
        let (table, name) = key.split_once('.').unwrap();
        let mut text = String::from("rig = \"drive_axis\"\n");
        let base = [
            ("motor", "resistance_ohm", "0.27"), ("motor", "inductance_H", "0.0007"),
            ("motor", "torque_constant_Nm_A", "0.05"), ("motor", "rotor_inertia_kg_m2", "0.0002"),
            ("motor", "viscous_Nm_s_rad", "7e-5"), ("gearbox", "ratio", "23.41"),
            ("wheel", "radius_m", "0.075"), ("wheel", "inertia_kg_m2", "0.0345"),
            ("supply", "voltage_V", "24.0"),
        ];
        let mut current = "";
        for (t, k, v) in base {
            if t != current {
                text.push_str(&format!("\n[{t}]\n"));
                current = t;
            }
            let v = if t == table && k == name { value.as_str() } else { v };
            text.push_str(&format!("{k} = {v}\n"));
        }
        match Rig::parse(&text, Path::new("gen.rig.toml")) {
            Ok(_) => {
                let number: Option<f64> = value.trim().parse().ok();
                let zero_means_something =
                    ["motor.viscous_Nm_s_rad", "wheel.inertia_kg_m2", "motor.inductance_H"];
                prop_assert!(
                    number.is_some_and(|v| v.is_finite()
                        && (v > 0.0 || (v == 0.0 && zero_means_something.contains(&key)))),
                    "{key} = {value} was taken"
                );
            }
            Err(e) => prop_assert!(e.to_string().contains("gen.rig.toml"), "{e}"),
        }
    }
}
