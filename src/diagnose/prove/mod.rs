//! The in-project proof: recordings from agvsim's own full simulator, each with one effect
//! present but concealed (its contribution about the size of the encoder quantisation and
//! current noise), diagnosed against a nominal rig that omits the effect and is 5-25 % off
//! in every uncertain value. Each effect must be found with its parameter within 15 %, and
//! nothing on the clean case.
//!
//! Effects the simulator itself has on a lifted drive axis: backlash, Coulomb friction and
//! voltage saturation (the bridges' limit); on the floor (full level): wheel slip (the
//! drive tyres' friction limit) and castor drag (the castors' rolling resistance). Battery
//! sag and the DCMC's speed loop (`dcmc.kind = "gain_pi"`, the vocabulary's
//! `speed_feedback`) act on other inputs (duty-setting bridges, demands) than this proof's
//! voltages; their round trips are the calibration tests'.

use crate::model::gearbox::GearboxParams;
use crate::model::motor::MotorParams;
use crate::model::wheel::WheelParams;
use crate::record::channels as chan;
use crate::rig::blocks::Instruments;
use crate::rig::keys::alias;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, StandardNormal};
use rand_pcg::Pcg64;

mod vehicle;

use super::{diagnose, DiagnoseOptions};
use crate::experiment::{EncoderSpeed, ENCODER_COUNTS};
use crate::ident::effects::Effect;
use crate::ident::IdentError;
use crate::record::{Recording, RecordingError};
use crate::rig::Rig;
use crate::scene::Scene;
use crate::sim::{Actuation, Sim, SimError};
use vehicle::{nominal_vehicle_rig, record_vehicle, vehicle_specs, vehicle_truth, VEHICLE_RATE_HZ};

/// Why the proof could not be run (a case that fails is a result, not an error).
#[derive(Debug, thiserror::Error)]
pub enum ProveError {
    /// A `--case` name that is not a proof case.
    #[error("--case: no proof case `{case}`; the cases are: {known}")]
    UnknownCase {
        /// The name given.
        case: String,
        /// The cases, comma-separated.
        known: String,
    },
    /// A case's scene or simulation failed.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// A case's scene did not load.
    #[error(transparent)]
    Scene(#[from] crate::scene::SceneError),
    /// A recording written did not read back.
    #[error(transparent)]
    Recording(#[from] RecordingError),
    /// The diagnosis of a case could not be done.
    #[error(transparent)]
    Ident(#[from] IdentError),
    /// A file could not be written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
}

/// Largest relative error of a found effect's parameter.
pub const PARAM_TOLERANCE: f64 = 0.15;

/// One proof case and its outcome.
#[derive(Debug, Clone)]
pub struct ProofCase {
    /// The case's name.
    pub name: String,
    /// The concealed effect (`None`: a clean case).
    pub effect: Option<Effect>,
    /// The effect's true parameter (0 for a clean case).
    pub truth: f64,
    /// What the diagnosis found, with each parameter.
    pub found: Vec<(Effect, f64)>,
    /// The baseline's fit, %.
    pub baseline_fit_pct: f64,
    /// The diagnosed model's fit, %.
    pub final_fit_pct: f64,
    /// Whether the effect was found within 15 % (nothing, on a clean case).
    pub passed: bool,
    /// The case's recording.
    pub recording: PathBuf,
}

impl ProofCase {
    /// The found parameter's error relative to the truth, if the effect was found.
    pub fn relative_error(&self) -> Option<f64> {
        let (e, v) = self.found.first()?;
        (Some(*e) == self.effect).then(|| (v - self.truth) / self.truth)
    }
}

/// The table `agvsim prove` prints: each case's truth, what was found, the error of the
/// parameter and the fit before and after.
pub fn render(cases: &[ProofCase]) -> String {
    let mut out = format!(
        "{:<20} {:<20} {:>10} {:<34} {:>8} {:>15}  result\n",
        "case", "truth", "value", "found", "error", "fit"
    );
    for c in cases {
        let found = c
            .found
            .iter()
            .map(|(e, v)| format!("{} {v:.4}", e.name()))
            .collect::<Vec<_>>()
            .join(", ");
        let _ = writeln!(
            out,
            "{:<20} {:<20} {:>10.4} {:<34} {:>8} {:>6.2}->{:>6.2} %  {}",
            c.name,
            c.effect.map_or("none", |e| e.name()),
            c.truth,
            if found.is_empty() {
                "(none)".into()
            } else {
                found
            },
            c.relative_error()
                .map_or("-".into(), |e| format!("{:+.1}%", 100.0 * e)),
            c.baseline_fit_pct,
            c.final_fit_pct,
            if c.passed { "pass" } else { "FAIL" }
        );
    }
    out
}

struct Spec {
    name: &'static str,
    effect: Option<Effect>,
    truth: f64,
    overrides: Vec<String>,
    peak_v: f64,
}

fn specs() -> Vec<Spec> {
    // A stiff mesh outside the backlash case: the default tooth spring's compliance is
    // physics the vocabulary has no name for.
    let stiff = "gearbox.tooth_stiffness_Nm_rad=100000".to_string();
    let base = |fid: &str| {
        vec![
            format!("sim.fidelity={fid}"),
            "sim.wheels_lifted=true".into(),
            "motor.coulomb_Nm=0".into(),
        ]
    };
    vec![
        Spec {
            name: "clean",
            effect: None,
            truth: 0.0,
            overrides: [base("nonlinear"), vec![stiff.clone()]].concat(),
            peak_v: 15.0,
        },
        Spec {
            name: "coulomb_friction",
            effect: Some(Effect::CoulombFriction),
            truth: 0.02,
            overrides: [
                base("nonlinear"),
                vec![stiff.clone(), "motor.coulomb_Nm=0.02".into()],
            ]
            .concat(),
            peak_v: 15.0,
        },
        Spec {
            name: "backlash",
            effect: Some(Effect::Backlash),
            truth: 0.035,
            overrides: [base("complex"), vec!["gearbox.backlash_rad=0.035".into()]].concat(),
            peak_v: 15.0,
        },
        Spec {
            name: "voltage_saturation",
            effect: Some(Effect::VoltageSaturation),
            truth: 21.0,
            overrides: [
                base("nonlinear"),
                vec![stiff, "battery.drive_limit_V=21".into()],
            ]
            .concat(),
            peak_v: 23.0,
        },
    ]
}

/// A lifted-axis recording: random voltage levels held 20-100 ms, left motor speed through
/// a 1024-count encoder, current with 0.2 A noise rounded to 0.05 A.
fn record(
    scene: &Scene,
    duration_s: f64,
    rate_hz: f64,
    peak_v: f64,
    rng: &mut Pcg64,
) -> Result<String, ProveError> {
    let mut sim = Sim::new(scene).map_err(ProveError::from)?;
    let (per, interval, n) = sampling(&sim, rate_hz, duration_s);
    let mut csv = crate::record::header(
        crate::rig::RigKind::DriveAxis,
        &[
            (
                "description",
                "agvsim proof case, lifted wheel, random voltage".into(),
            ),
            ("sample_time_s", format!("{interval}")),
            ("source", simulation_source(&sim)),
        ],
        &[
            chan::T_S,
            chan::VOLTAGE_V,
            chan::MOTOR_SPEED_RAD_S,
            chan::CURRENT_A,
        ],
    );
    let (mut v, mut hold) = (0.0, 0usize);
    let mut encoder = EncoderSpeed::new(sim.drivetrains()[0].motor.angle_rad);
    for k in 0..=n {
        if hold == 0 {
            v = rng.random_range(-peak_v..=peak_v);
            hold = rng
                .random_range((0.02 / interval) as usize..=(0.1 / interval) as usize)
                .max(1);
        }
        hold -= 1;
        let m = sim.drivetrains()[0].motor;
        let speed = encoder.read(m.angle_rad, interval);
        let i = current_sense(m.current_a, rng);
        let _ = writeln!(csv, "{:.6},{v:.4},{speed:.4},{i:.2}", k as f64 * interval);
        sim.set_actuation(Actuation::Voltage([v, v]));
        for _ in 0..per {
            sim.step().map_err(ProveError::from)?;
        }
    }
    Ok(csv)
}

/// An armature current as the DCMC's current sense reads it: 0.2 A RMS noise, 0.05 A steps.
fn current_sense(current_a: f64, rng: &mut Pcg64) -> f64 {
    let noise: f64 = StandardNormal.sample(rng);
    ((current_a + 0.2 * noise) / 0.05).round() * 0.05
}

/// The rig an experimenter would write: the scene's values, each off by 5-25 % either way,
/// and no word of the effect.
fn nominal_rig(scene: &Scene, rng: &mut Pcg64) -> Rig {
    let mut off = |x: f64| {
        let sign = if rng.random::<bool>() { 1.0 } else { -1.0 };
        x * (1.0 + sign * rng.random_range(0.05..0.25))
    };
    let m = &scene.motor;
    let mut rig = Rig::new(crate::rig::RigKind::DriveAxis);
    // In this order: each belief draws its error in turn.
    rig.set(MotorParams::resistance_ohm.key(), off(m.resistance_ohm));
    rig.set(MotorParams::inductance_h.key(), off(m.inductance_h));
    rig.set(
        MotorParams::torque_constant_nm_a.key(),
        off(m.torque_constant_nm_a),
    );
    rig.set(
        MotorParams::rotor_inertia_kg_m2.key(),
        off(m.rotor_inertia_kg_m2),
    );
    rig.set(MotorParams::viscous_nm_s_rad.key(), off(m.viscous_nm_s_rad));
    rig.set(GearboxParams::ratio.key(), scene.gearbox.ratio);
    rig.set(WheelParams::radius_m.key(), scene.wheel.radius_m);
    rig.set(
        WheelParams::inertia_kg_m2.key(),
        off(scene.wheel.inertia_kg_m2),
    );
    rig.set(alias::SUPPLY_VOLTAGE_V.key(), scene.battery.open_circuit_v);
    rig.set(
        Instruments::motor_encoder_counts_per_rev.key(),
        ENCODER_COUNTS,
    );
    rig.set(Instruments::current_noise_a.key(), 0.2);
    rig
}

/// Runs the proof: `quick` keeps the clean, Coulomb-friction and voltage-saturation cases at
/// 8 s, otherwise all cases at 20 s. Files go to `out_dir`.
pub fn prove(
    out_dir: &Path,
    quick: bool,
    seed: u64,
    only: &[String],
) -> Result<Vec<ProofCase>, ProveError> {
    let wanted = |name: &str| only.is_empty() || only.iter().any(|o| o == name);
    let all: Vec<&str> = specs()
        .iter()
        .map(|s| s.name)
        .chain(vehicle_specs().iter().map(|s| s.name))
        .collect();
    if let Some(bad) = only.iter().find(|o| !all.contains(&o.as_str())) {
        return Err(ProveError::UnknownCase {
            case: bad.clone(),
            known: all.join(", "),
        });
    }
    std::fs::create_dir_all(out_dir).map_err(|source| ProveError::Io {
        path: out_dir.to_owned(),
        source,
    })?;
    let mut out = Vec::new();
    for (i, spec) in specs().into_iter().enumerate() {
        if (quick && spec.name == "backlash") || !wanted(spec.name) {
            continue;
        }
        let mut rng = Pcg64::seed_from_u64(seed.wrapping_mul(31).wrapping_add(i as u64));
        let scene = Scene::from_toml("", Path::new("<proof>"), &spec.overrides)
            .map_err(ProveError::from)?;
        let csv = record(
            &scene,
            if quick { 8.0 } else { 20.0 },
            500.0,
            spec.peak_v,
            &mut rng,
        )?;
        let rig = nominal_rig(&scene, &mut rng);
        out.push(check(
            out_dir,
            spec.name,
            spec.effect,
            spec.truth,
            &csv,
            &rig,
        )?);
    }
    if !quick {
        for (i, spec) in vehicle_specs().into_iter().enumerate() {
            if !wanted(spec.name) {
                continue;
            }
            let mut rng = Pcg64::seed_from_u64(seed.wrapping_mul(37).wrapping_add(100 + i as u64));
            let scene = Scene::from_toml("", Path::new("<proof>"), &spec.overrides)
                .map_err(ProveError::from)?;
            let csv = record_vehicle(&scene, 16.0, VEHICLE_RATE_HZ, &mut rng)?;
            let rig = nominal_vehicle_rig(&scene, &mut rng)?;
            let truth = vehicle_truth(&scene, spec.effect)?;
            out.push(check(out_dir, spec.name, spec.effect, truth, &csv, &rig)?);
        }
    }
    Ok(out)
}

/// Writes a case's recording and rig, diagnoses it and judges the outcome.
fn check(
    out_dir: &Path,
    name: &str,
    effect: Option<Effect>,
    truth: f64,
    csv: &str,
    rig: &Rig,
) -> Result<ProofCase, ProveError> {
    let rec_path = out_dir.join(format!("prove_{name}.csv"));
    let rig_path = out_dir.join(format!("prove_{name}.rig.toml"));
    let io = |p: &Path, source: std::io::Error| ProveError::Io {
        path: p.to_owned(),
        source,
    };
    crate::output::write_atomically(&rec_path, csv).map_err(|e| io(&rec_path, e))?;
    crate::output::write_atomically(&rig_path, rig.to_toml()).map_err(|e| io(&rig_path, e))?;
    let rec = Recording::load(&rec_path)?;
    let d = diagnose(rig, &rig_path, &rec, None, &DiagnoseOptions::default())?;
    let found: Vec<(Effect, f64)> = d.findings.iter().map(|f| (f.effect, f.value)).collect();
    let passed = match effect {
        None => found.is_empty(),
        Some(e) => found
            .first()
            .is_some_and(|(fe, v)| *fe == e && ((v - truth) / truth).abs() <= PARAM_TOLERANCE),
    };
    let json = out_dir.join(format!("prove_{name}.json"));
    crate::output::write_atomically(
        &json,
        serde_json::to_string_pretty(&d.contract_json()).expect("json"),
    )
    .map_err(|e| io(&json, e))?;
    Ok(ProofCase {
        name: name.into(),
        effect,
        truth,
        found,
        baseline_fit_pct: d.baseline_fit_pct,
        final_fit_pct: d.final_fit_pct,
        passed,
        recording: rec_path,
    })
}

/// The recording's sampling on the simulator's step: steps per row, the row interval (s)
/// and the number of rows over `duration_s`.
fn sampling(sim: &Sim, rate_hz: f64, duration_s: f64) -> (usize, f64, usize) {
    let dt = sim.params().sim.dt_s;
    let per = ((1.0 / rate_hz) / dt).round().max(1.0) as usize;
    let interval = per as f64 * dt;
    (per, interval, (duration_s / interval) as usize)
}

/// A proof recording's `source`: this agvsim's simulation at the scene's level.
fn simulation_source(sim: &Sim) -> String {
    format!(
        "agvsim {} simulation, fidelity {}",
        env!("CARGO_PKG_VERSION"),
        sim.params().sim.fidelity.name()
    )
}
