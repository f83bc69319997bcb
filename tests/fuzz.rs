//! Fuzzing with a fixed budget and seed (deterministic, a few seconds): the scene, rig and
//! recording parsers, the `--set`/`--vary` value parsers and the simulator's set-up are fed
//! mutated versions of real inputs and extreme values. Each must answer with a value or
//! an error, never a panic.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;

use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

use agvsim::record::Recording;
use agvsim::rig::Rig;
use agvsim::scene::Scene;
use agvsim::sim::Sim;
use agvsim::sweep::parse_vary;

/// Values that break naive number handling.
const NASTY: [&str; 16] = [
    "1e308",
    "-1e308",
    "1e-320",
    "0",
    "-0",
    "nan",
    "inf",
    "-inf",
    "\"\"",
    "[]",
    "{}",
    "true",
    "99999999999999999999",
    "-1",
    "0.0000001",
    "\"x\"",
];

/// One random edit: delete, duplicate or insert a character, swap a number for a nasty
/// value, or duplicate or drop a line.
fn mutate(text: &str, rng: &mut Pcg64) -> String {
    let chars: Vec<char> = text.chars().collect();
    if chars.is_empty() {
        return NASTY[rng.random_range(0..NASTY.len())].to_string();
    }
    let at = rng.random_range(0..chars.len());
    match rng.random_range(0..6) {
        0 => chars
            .iter()
            .enumerate()
            .filter(|(i, _)| *i != at)
            .map(|(_, c)| c)
            .collect(),
        1 => {
            let mut c = chars.clone();
            c.insert(at, chars[at]);
            c.into_iter().collect()
        }
        2 => {
            let pool = [
                '=', '[', ']', '"', ',', '\n', '#', '.', '-', 'e', '0', '9', ' ', '\u{feff}',
            ];
            let mut c = chars.clone();
            c.insert(at, pool[rng.random_range(0..pool.len())]);
            c.into_iter().collect()
        }
        3 => {
            // Replace the number that starts at or after `at`.
            let s: String = chars[at..].iter().collect();
            match s.find(|c: char| c.is_ascii_digit()) {
                Some(k) => {
                    let start = at + k;
                    let end = chars[start..]
                        .iter()
                        .position(|c| !(c.is_ascii_digit() || *c == '.' || *c == 'e' || *c == '-'))
                        .map_or(chars.len(), |e| start + e);
                    let head: String = chars[..start].iter().collect();
                    let tail: String = chars[end..].iter().collect();
                    format!("{head}{}{tail}", NASTY[rng.random_range(0..NASTY.len())])
                }
                None => text.to_string(),
            }
        }
        4 => {
            let lines: Vec<&str> = text.lines().collect();
            let k = rng.random_range(0..lines.len().max(1));
            let mut out: Vec<&str> = lines.clone();
            if !lines.is_empty() {
                out.insert(k, lines[k]);
            }
            out.join("\n")
        }
        _ => {
            let lines: Vec<&str> = text.lines().collect();
            let k = rng.random_range(0..lines.len().max(1));
            lines
                .iter()
                .enumerate()
                .filter(|(i, _)| *i != k)
                .map(|(_, l)| *l)
                .collect::<Vec<_>>()
                .join("\n")
        }
    }
}

fn no_panic<T>(what: &str, input: &str, f: impl FnOnce() -> T) {
    if catch_unwind(AssertUnwindSafe(f)).is_err() {
        panic!("{what} panicked on input:\n{input}");
    }
}

#[test]
fn scenes_mutated_parse_or_refuse_and_set_up_without_panicking() {
    let mut rng = Pcg64::seed_from_u64(18);
    let texts: Vec<String> = [
        "lab_offset_120mm",
        "open_day_loop",
        "bumper_stop",
        "lifted_identification",
    ]
    .iter()
    .map(|n| std::fs::read_to_string(format!("scenes/{n}.toml")).unwrap())
    .collect();
    let (mut ok, mut refused) = (0, 0);
    for case in 0..600 {
        let base = &texts[case % texts.len()];
        let mut text = base.clone();
        for _ in 0..rng.random_range(1..4) {
            text = mutate(&text, &mut rng);
        }
        no_panic("scene set-up", &text, || {
            match Scene::from_toml(&text, Path::new("fuzz.toml"), &[]) {
                Ok(scene) => {
                    ok += 1;
                    if let Ok(mut sim) = Sim::new(&scene) {
                        for _ in 0..5 {
                            if sim.step().is_err() {
                                break;
                            }
                        }
                    }
                }
                Err(_) => refused += 1,
            }
        });
    }
    println!("{ok} mutated scenes accepted, {refused} refused, 0 panics");
    assert!(ok > 0 && refused > 0);
}

#[test]
fn set_and_vary_values_parse_or_refuse_without_panicking() {
    let mut rng = Pcg64::seed_from_u64(19);
    let keys = [
        "controller.gain_scale",
        "chassis.mass_kg",
        "tyre.compound",
        "wire.points_m",
        "sim.dt_s",
        "nope.key",
        "",
    ];
    let text = std::fs::read_to_string("scenes/lab_offset_120mm.toml").unwrap();
    for _ in 0..400 {
        let key = keys[rng.random_range(0..keys.len())];
        let value = mutate(NASTY[rng.random_range(0..NASTY.len())], &mut rng);
        let arg = format!("{key}={value}");
        no_panic("--set", &arg, || {
            let _ = Scene::from_toml(&text, Path::new("lab.toml"), std::slice::from_ref(&arg));
        });
        let vary = format!("{key}={}", mutate("0.5..4:8", &mut rng));
        no_panic("--vary", &vary, || {
            let _ = parse_vary(&vary);
        });
    }
}

#[test]
fn recordings_and_rigs_mutated_parse_or_refuse_without_panicking() {
    let mut rng = Pcg64::seed_from_u64(20);
    let rec = "# agvsim-recording: 1\n# rig: drive_axis\n# sample_time_s: 0.005\nt_s,voltage_V,motor_speed_rad_s,current_A\n0,1,0,0\n0.005,1.2,3.5,1\n0.01,,4.1,\n0.015,0.5,5,0.9\n";
    let rig = "rig = \"drive_axis\"\n\n[motor]\nresistance_ohm = 0.27\ninductance_H = 0.0007\ntorque_constant_Nm_A = 0.05\nrotor_inertia_kg_m2 = 0.0002\nviscous_Nm_s_rad = 7e-5\n\n[gearbox]\nratio = 23.41\n\n[wheel]\nradius_m = 0.075\ninertia_kg_m2 = 0.0345\n\n[supply]\nvoltage_V = 24.0\n";
    let scene = Scene::load(Path::new("scenes/lab_offset_120mm.toml"), &[]).unwrap();
    for _ in 0..800 {
        let mut r = rec.to_string();
        let mut g = rig.to_string();
        for _ in 0..rng.random_range(1..4) {
            r = mutate(&r, &mut rng);
            g = mutate(&g, &mut rng);
        }
        no_panic("recording parse and replay", &r, || {
            if let Ok(parsed) = Recording::parse(&r, Path::new("fuzz.csv")) {
                let _ = agvsim::replay::replay(&scene, &parsed);
            }
        });
        no_panic("rig parse", &g, || {
            let _ = Rig::parse(&g, Path::new("fuzz.rig.toml"));
        });
    }
}
