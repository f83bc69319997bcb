//! The calibration's own proof: round trips through the simulator. Each case is a machine
//! (a scene) with one effect of the contract's vocabulary switched on, or none, recorded
//! on an excitation people use (the thesis's random demands, a voltage multisine, SysId's
//! ramps and steps, random velocity commands), the outputs with seeded measurement noise;
//! the scene calibrated against it is the machine with the effect off and its fitted keys
//! off by a seeded 5-20 %. With every effect the recording can show offered, the
//! concealed effect must be accepted first with its key within [`KEY_TOLERANCE`], and a
//! clean recording must accept nothing. Each case's truths are built from the machine's
//! physics (a share of its stall torque, of the voltages the excitation asks...), not
//! copied from any generator.
//!
//! Every fitted key's 1-sigma interval is checked against the machine's value too: over
//! many round trips about two thirds should cover it ([`coverage`]).

use crate::param::ParamKey;
use std::fmt::Write as _;
use std::path::Path;

use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, StandardNormal};
use rand_pcg::Pcg64;

use super::{calibrate_telling, effects::Choice, keys, CalibrateError, Calibration, Request};
use crate::ident::effects::Effect;
use crate::record::Recording;
use crate::replay::replay;
use crate::rig::RigKind;
use crate::scene::Scene;

/// Largest relative error of the concealed effect's key.
pub const KEY_TOLERANCE: f64 = 0.10;

/// What a case's machine is and how it is driven.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// The thesis machine's left drive, wheel lifted, on its terminal voltage.
    AxisVoltage,
    /// The same drive on a demand into the DCMC.
    AxisDemand,
    /// Both drives lifted, on forward and turn demands into the DCMC (the thesis's
    /// identification runs).
    PairDemand,
    /// The thesis vehicle on the floor, on its two motor voltages.
    VehicleVoltage,
    /// A velocity-commanded base (a ROS robot: `agvsim new`'s 40 kg robot) on `/cmd_vel`.
    BaseVelocity,
    /// The same base known only by a `base` rig (`agvsim diagnose --rig`'s path): the
    /// machine is the scene its rig makes, and the scene calibrated is the one the rig of
    /// its beliefs makes, written and read back as a file.
    BaseRig,
}

/// How a case's machine is excited.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Excitation {
    /// A sum of four sines (0.3 to 4.3 Hz) with seeded phases.
    Multisine,
    /// WPILib SysId's tests: a quasistatic ramp each way, then a step each way.
    SysId,
    /// The thesis's microcontroller pulses: random levels held 4 to 16 intervals of 25 ms.
    RandomDemand,
    /// Random velocity commands held a second each.
    CmdVelSteps,
}

impl Kind {
    fn name(self) -> &'static str {
        match self {
            Kind::AxisVoltage => "axis_voltage",
            Kind::AxisDemand => "axis_demand",
            Kind::PairDemand => "pair_demand",
            Kind::VehicleVoltage => "vehicle_voltage",
            Kind::BaseVelocity => "base_velocity",
            Kind::BaseRig => "base_rig",
        }
    }

    /// Every kind.
    pub const ALL: [Kind; 6] = [
        Kind::AxisVoltage,
        Kind::AxisDemand,
        Kind::PairDemand,
        Kind::VehicleVoltage,
        Kind::BaseVelocity,
        Kind::BaseRig,
    ];

    /// Whether the machine is a velocity-commanded base.
    fn is_base(self) -> bool {
        matches!(self, Kind::BaseVelocity | Kind::BaseRig)
    }
}

impl Excitation {
    fn name(self) -> &'static str {
        match self {
            Excitation::Multisine => "multisine",
            Excitation::SysId => "sysid",
            Excitation::RandomDemand => "random_demand",
            Excitation::CmdVelSteps => "cmd_vel_steps",
        }
    }
}

/// One round trip: the machine, the excitation, the concealed effect (if any) with its key's
/// true value, and the keys that switch it on.
#[derive(Debug, Clone)]
pub struct Case {
    /// `KIND/EXCITATION/EFFECT` (`.../clean` without one).
    pub name: String,
    /// The machine's kind.
    pub kind: Kind,
    /// Its excitation.
    pub excitation: Excitation,
    /// The concealed effect.
    pub effect: Option<Effect>,
    /// The effect's scene key and its value in the machine.
    pub truth: Option<(&'static str, f64)>,
    /// `--set` texts that make the machine from the kind's clean machine.
    pub machine: Vec<String>,
    /// `--set` texts the machine and the calibrated scene share (what the scene knows of
    /// the machine the effect's physics acts on: a viscous loss whose asymmetry it lacks).
    pub common: Vec<String>,
}

/// A case's outcome.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// The case.
    pub case: Case,
    /// The effects accepted, in the order of acceptance, with their keys' values.
    pub accepted: Vec<(Effect, f64)>,
    /// The concealed effect's key as calibrated, relative error to the truth.
    pub key_error: Option<f64>,
    /// Each fitted key: (key, truth, calibrated, standard deviation).
    pub keys: Vec<(String, f64, f64, Option<f64>)>,
    /// Mean replay fit before and after, %.
    pub fit_pct: (f64, f64),
    /// Whether the case passed: the concealed effect accepted first with its key within
    /// [`KEY_TOLERANCE`], or nothing accepted on a clean case (and on a payload case, the
    /// mass within it).
    pub passed: bool,
}

/// The clean machine of each kind: its scene (no play, no Coulomb friction; the
/// velocity-commanded base from `agvsim new`'s numbers for a 40 kg robot).
pub fn clean_machine(kind: Kind) -> Result<Scene, CalibrateError> {
    let key = |e: String| CalibrateError::Key(e);
    let lab = |extra: &[&str]| {
        let mut sets = vec![
            "gearbox.backlash_rad=0".to_string(),
            "motor.coulomb_Nm=0".to_string(),
        ];
        sets.extend(extra.iter().map(|s| s.to_string()));
        Scene::from_toml(
            include_str!("../../scenes/lab_offset_120mm.toml"),
            Path::new("scenes/lab_offset_120mm.toml"),
            &sets,
        )
        .map_err(|e| key(e.to_string()))
    };
    match kind {
        Kind::BaseVelocity => {
            use crate::scene::robot::{new_scene, Guidance, MotorDatasheet, RobotSpec};
            let spec = RobotSpec {
                mass_kg: Some(40.0),
                track_m: Some(0.4),
                wheel_radius_m: Some(0.08),
                battery_v: Some(24.0),
                motor: Some(MotorDatasheet {
                    rated_v: 24.0,
                    no_load_rpm: 3000.0,
                    stall_current_a: Some(40.0),
                    stall_torque_nm: None,
                }),
                gear_ratio: Some(20.0),
                backlash_rad: Some(0.0),
                guidance: Some(Guidance::None),
                ..RobotSpec::default()
            };
            let made = new_scene(&spec, None, "agvsim new").map_err(|e| key(e.to_string()))?;
            let text = made.text;
            Scene::from_toml(
                &text,
                Path::new("base.toml"),
                &["motor.coulomb_Nm=0".into()],
            )
            .map_err(|e| key(e.to_string()))
        }
        // The base's rig read back: what a rig cannot state (the gear mesh, the
        // battery's resistance) is what `diagnose --rig` makes of it.
        Kind::BaseRig => {
            let base = clean_machine(Kind::BaseVelocity)?;
            through_rig(&base)
        }
        _ => lab(&[]),
    }
}

/// The scene `agvsim diagnose --rig` makes of the `base` rig describing `scene`'s robot:
/// the rig written as a file's text, read back, and made a scene.
fn through_rig(scene: &Scene) -> Result<Scene, CalibrateError> {
    use crate::rig::Rig;
    let path = Path::new("base.rig.toml");
    let text = Rig::of_base_scene(scene).to_toml();
    let rig = Rig::parse(&text, path).map_err(|e| CalibrateError::Key(e.to_string()))?;
    rig.base_scene(path)
        .map_err(|e| CalibrateError::Key(e.to_string()))
}

/// The motor's stall torque at the drive limit, N m.
fn stall_nm(s: &Scene) -> f64 {
    s.motor.stall_torque_nm(s.battery.drive_limit_v)
}

/// Largest terminal voltage the excitation (its seed-1 rows) puts on a motor of `s`, V:
/// the clean machine run on it (a DCMC shapes and limits its demands, so the demand alone
/// does not tell); the drive limit for a velocity-commanded base (its loops ask what
/// they need).
fn peak_command_v(kind: Kind, excitation: Excitation, s: &Scene) -> Result<f64, CalibrateError> {
    use crate::sim::{Actuation, Sim};
    let (_, dt, rows) = excitation_rows(kind, excitation, &mut Pcg64::seed_from_u64(1));
    if kind.is_base() {
        return Ok(s.battery.drive_limit_v);
    }
    let mut scene = s.clone();
    scene.sim.wheels_lifted = !matches!(kind, Kind::VehicleVoltage);
    let mut sim = Sim::new(&scene).map_err(|e| CalibrateError::Data(e.to_string()))?;
    let per = (dt / sim.params().sim.dt_s).round().max(1.0) as usize;
    let mut peak = 0.0_f64;
    for u in &rows {
        sim.set_actuation(match kind {
            Kind::AxisVoltage => Actuation::Voltage([u[0], 0.0]),
            Kind::VehicleVoltage => Actuation::Voltage([u[0], u[1]]),
            Kind::AxisDemand => Actuation::Demand {
                forward_pct: u[0],
                turn_pct: 0.0,
            },
            _ => Actuation::Demand {
                forward_pct: u[0],
                turn_pct: u[1],
            },
        });
        for _ in 0..per {
            sim.step()
                .map_err(|e| CalibrateError::Data(e.to_string()))?;
            let snap = sim.snapshot();
            peak = peak.max(
                snap.sides[0]
                    .voltage_v
                    .abs()
                    .max(snap.sides[1].voltage_v.abs()),
            );
        }
    }
    Ok(peak)
}

fn peak_voltage(excitation: Excitation) -> f64 {
    match excitation {
        Excitation::SysId => 12.0,
        _ => 14.0,
    }
}

fn peak_demand(kind: Kind) -> f64 {
    match kind {
        Kind::PairDemand => 60.0,
        _ => 70.0,
    }
}

/// The effects a kind's recording can show (what `--effects all` offers it).
fn effects_of(kind: Kind) -> Vec<Effect> {
    use Effect::*;
    match kind {
        Kind::AxisVoltage => vec![
            Backlash,
            CoulombFriction,
            FrictionAsymmetry,
            Offset,
            VoltageSaturation,
            BatterySag,
            TransportDelay,
        ],
        Kind::AxisDemand => vec![
            Backlash,
            CoulombFriction,
            FrictionAsymmetry,
            Offset,
            VoltageSaturation,
            TransportDelay,
            SpeedFeedback,
        ],
        // Not the viscous friction's asymmetry: with no current measured, the speeds show
        // two combinations of the resistance, torque constant, inertia and viscous loss,
        // and an asymmetry of a loss whose level they cannot tell trades with the others
        // (the lifted axis on demands, its current measured, shows it).
        Kind::PairDemand => vec![
            Backlash,
            CoulombFriction,
            Offset,
            VoltageSaturation,
            TransportDelay,
            SpeedFeedback,
        ],
        Kind::VehicleVoltage => vec![
            WheelSlip,
            CastorDrag,
            Backlash,
            CoulombFriction,
            VoltageSaturation,
            BatterySag,
            TransportDelay,
        ],
        // Not Coulomb friction: the drivers' speed loops integrate a constant friction
        // away, and what a transient shows of it their gains absorb.
        Kind::BaseVelocity => vec![
            WheelSlip,
            CastorDrag,
            Backlash,
            TransportDelay,
            WheelGeometry,
        ],
        // What a ROS robot's log most often shows (the rig path's own cases; the other
        // effects' physics is the base's above).
        Kind::BaseRig => vec![WheelSlip, TransportDelay, WheelGeometry],
    }
}

/// The concealed effect's key, its true value and the keys that switch it on, built from
/// the clean machine's physics.
fn concealed(
    effect: Effect,
    peak_v: f64,
    clean: &Scene,
) -> (&'static str, f64, Vec<String>, Vec<String>) {
    let key = effect.scene_key();
    let stall = stall_nm(clean);
    let mut common = vec![];
    let (value, mut extra) = match effect {
        // A yaw rate limit at a third of the largest the excitation commands.
        Effect::BaseLimits => (0.33, vec![]),
        // A few degrees of play at the wheel.
        Effect::Backlash => (0.06, vec![]),
        // 1.2 % of the stall torque: the thesis motor's brushes and bearings.
        Effect::CoulombFriction => (0.012 * stall, vec![]),
        // Viscous friction two and a half times as strong forward, the viscous loss
        // raised to a fifth of the back-EMF damping so that it shows.
        Effect::FrictionAsymmetry => {
            let damping = 0.2 * clean.motor.electrical_damping_nm_s_rad();
            // The scene knows the loss, not its asymmetry.
            common.push(format!("motor.viscous_Nm_s_rad={damping}"));
            (2.5, vec![])
        }
        // A bias against forward rotation, 0.7 % of the stall torque.
        Effect::Offset => (-0.007 * stall, vec![]),
        // The bridges clip at three quarters of the largest voltage the excitation asks.
        Effect::VoltageSaturation => (0.75 * peak_v, vec![]),
        // Bridges setting duty against the battery, which sags a tenth of its voltage at
        // the stall current's quarter.
        Effect::BatterySag => {
            let b = clean.battery.open_circuit_v;
            let i = 0.25 * b / clean.motor.resistance_ohm;
            (0.1 * b / i, vec![format!("battery.bridge_rated_V={b}")])
        }
        // Four milliseconds of firmware per 5 ms sample: a dead time of 20 ms.
        Effect::TransportDelay => (0.02, vec![]),
        // Integral action correcting a speed error in about a fifth of a second.
        // (an error held for t raises the voltage by ki t times it, which moves the speed
        // by ki t / K times it: all of it at ki = K / t).
        Effect::SpeedFeedback => (
            clean.motor.torque_constant_nm_a / 0.2,
            vec!["dcmc.kind=\"gain_pi\"".into()],
        ),
        // Tyres that grip to 0.6 of the compound's friction.
        Effect::WheelSlip => {
            let p = crate::sim::SimParams::from_scene(clean).expect("the clean machine sets up");
            (0.6 * p.drive_tyre(p.floor.default).peak_mu, vec![])
        }
        // Castors rolling with 8 % of their load.
        Effect::CastorDrag => (0.08, vec![]),
        // The right wheel rolling on 1 % less than its radius, the wheels 2 % further
        // apart than drawn; the odometry and the base controller configured with the
        // drawing's (UMBmark's two systematic errors, at the sizes it finds).
        Effect::WheelGeometry => {
            let (r, b) = (clean.wheel.radius_m, clean.chassis.track_width_m);
            common.push(format!("base.wheel_radius_m={r}"));
            common.push(format!("base.wheel_separation_m={b}"));
            (
                1.02 * b,
                vec![format!("wheel.right_rolling_radius_m={}", 0.99 * r)],
            )
        }
    };
    extra.push(format!("{key}={value}"));
    (key, value, extra, common)
}

/// Every case of the proof for `kinds`: each effect its recording can show, and a clean one,
/// on each excitation people use for it.
pub fn cases(kinds: &[Kind]) -> Result<Vec<Case>, CalibrateError> {
    let mut out = vec![];
    for &kind in kinds {
        let clean = clean_machine(kind)?;
        let excitations: &[Excitation] = match kind {
            Kind::AxisVoltage => &[Excitation::Multisine, Excitation::SysId],
            Kind::AxisDemand => &[Excitation::Multisine],
            Kind::PairDemand => &[Excitation::RandomDemand],
            Kind::VehicleVoltage => &[Excitation::Multisine],
            Kind::BaseVelocity | Kind::BaseRig => &[Excitation::CmdVelSteps],
        };
        for &excitation in excitations {
            let name = |e: &str| format!("{}/{}/{e}", kind.name(), excitation.name());
            out.push(Case {
                name: name("clean"),
                kind,
                excitation,
                effect: None,
                truth: None,
                machine: vec![],
                common: vec![],
            });
            let peak_v = peak_command_v(kind, excitation, &clean)?;
            for effect in effects_of(kind) {
                let (key, value, machine, common) = concealed(effect, peak_v, &clean);
                out.push(Case {
                    name: name(effect.name()),
                    kind,
                    excitation,
                    effect: Some(effect),
                    truth: Some((key, value)),
                    machine,
                    common,
                });
            }
            if kind == Kind::BaseRig {
                out.push(payload_case(kind, excitation, &clean, &name("payload")));
            }
        }
    }
    Ok(out)
}

/// A payload the rig does not know: the machine carries a quarter more mass than the
/// rig states, which is physics of no effect (nothing may be accepted) but must show in
/// the fitted mass.
fn payload_case(kind: Kind, excitation: Excitation, clean: &Scene, name: &str) -> Case {
    let key = crate::model::chassis::ChassisParams::mass_kg.key();
    let mass = 1.25 * clean.chassis.mass_kg;
    Case {
        name: name.to_string(),
        kind,
        excitation,
        effect: None,
        truth: Some((key, mass)),
        machine: vec![format!("{key}={mass}")],
        common: vec![],
    }
}

/// The rows of an excitation: times and one value per input column.
fn excitation_rows(
    kind: Kind,
    excitation: Excitation,
    rng: &mut Pcg64,
) -> (Vec<&'static str>, f64, Vec<Vec<f64>>) {
    let tau = std::f64::consts::TAU;
    let phases: Vec<f64> = (0..8).map(|_| rng.random_range(0.0..tau)).collect();
    let sines = |t: f64, offset: usize, peak: f64| -> f64 {
        let parts = [(0.3, 1.0), (0.7, 0.8), (1.9, 0.6), (4.3, 0.4)];
        let sum: f64 = parts
            .iter()
            .enumerate()
            .map(|(i, (f, a))| a * (tau * f * t + phases[offset + i]).sin())
            .sum();
        peak * sum / 2.8
    };
    match (kind, excitation) {
        (Kind::AxisVoltage, Excitation::SysId) => (vec!["voltage_V"], SYSID_DT_S, sysid_voltages()),
        (Kind::AxisVoltage, _) => (
            vec!["voltage_V"],
            0.005,
            (0..1600)
                .map(|k| vec![sines(k as f64 * 0.005, 0, peak_voltage(excitation))])
                .collect(),
        ),
        (Kind::AxisDemand, _) => (
            vec!["demand_pct"],
            0.005,
            (0..1600)
                .map(|k| {
                    let t = k as f64 * 0.005;
                    // Zero until the DCMC's enable delay has passed.
                    vec![if t < 0.6 {
                        0.0
                    } else {
                        sines(t, 0, peak_demand(kind))
                    }]
                })
                .collect(),
        ),
        (Kind::PairDemand, _) => {
            let (mut level, mut hold) = ([0.0, 0.0], 0usize);
            let peak = peak_demand(kind);
            let rows = (0..600)
                .map(|k| {
                    if k >= 24 {
                        if hold == 0 {
                            level = [
                                rng.random_range(-peak..=peak),
                                rng.random_range(-0.5 * peak..=0.5 * peak),
                            ];
                            hold = rng.random_range(4..=16);
                        }
                        hold -= 1;
                    }
                    level.to_vec()
                })
                .collect();
            (vec!["demand_fwd_pct", "demand_turn_pct"], 0.025, rows)
        }
        (Kind::VehicleVoltage, _) => (
            vec!["left_voltage_V", "right_voltage_V"],
            0.005,
            (0..1600)
                .map(|k| {
                    let t = k as f64 * 0.005;
                    let p = peak_voltage(excitation);
                    vec![sines(t, 0, p), sines(t, 4, p)]
                })
                .collect(),
        ),
        (Kind::BaseVelocity | Kind::BaseRig, _) => {
            let (mut v, mut w) = (0.0, 0.0);
            let rows = (0..1000)
                .map(|k| {
                    if k >= 50 && k % 100 == 50 {
                        v = rng.random_range(-0.6..0.8);
                        w = rng.random_range(-1.0..1.0);
                    }
                    vec![v, w]
                })
                .collect();
            (vec!["cmd_linear_m_s", "cmd_angular_rad_s"], 0.01, rows)
        }
    }
}

/// The SysId test's sample interval, s.
const SYSID_DT_S: f64 = 0.005;

/// SysId's voltages: quasistatic 1.2 V/s each way for 5 s, then a 12 V step each way for
/// 2 s, a second at rest before each.
fn sysid_voltages() -> Vec<Vec<f64>> {
    let dt = SYSID_DT_S;
    let mut rows = vec![];
    let mut push = |len: f64, f: &dyn Fn(f64) -> f64| {
        let n = (len / dt).round() as usize;
        for k in 0..n {
            rows.push(vec![f(k as f64 * dt)]);
        }
    };
    push(1.0, &|_| 0.0);
    push(5.0, &|s| 1.2 * s);
    push(1.0, &|_| 0.0);
    push(5.0, &|s| -1.2 * s);
    push(1.0, &|_| 0.0);
    push(2.0, &|_| 12.0);
    push(1.0, &|_| 0.0);
    push(2.0, &|_| -12.0);
    rows
}

/// The outputs a kind's rig measures.
fn outputs_of(kind: Kind) -> &'static [&'static str] {
    match kind {
        Kind::AxisVoltage | Kind::AxisDemand => &["motor_speed_rad_s", "current_A"],
        Kind::PairDemand => &["left_motor_speed_rad_s", "right_motor_speed_rad_s"],
        Kind::VehicleVoltage => &[
            "x_m",
            "y_m",
            "heading_rad",
            "left_motor_speed_rad_s",
            "right_motor_speed_rad_s",
        ],
        Kind::BaseVelocity | Kind::BaseRig => &[
            "x_m",
            "y_m",
            "heading_rad",
            "left_wheel_speed_m_s",
            "right_wheel_speed_m_s",
            "yaw_rate_rad_s",
        ],
    }
}

fn rig_of(kind: Kind) -> RigKind {
    match kind {
        Kind::AxisVoltage | Kind::AxisDemand => RigKind::DriveAxis,
        Kind::PairDemand => RigKind::DrivePair,
        _ => RigKind::Vehicle,
    }
}

/// The machine's recording of the excitation: the inputs replayed on it, each output with
/// seeded white noise (a tracker's 2 mm and 5 mrad on the pose, 1 % of the output's spread
/// on the others: a sensor ranged to its signal).
pub fn record(case: &Case, machine: &Scene, seed: u64) -> Result<Recording, CalibrateError> {
    let (text, path) = record_text(case, machine, seed)?;
    Recording::parse(&text, &path).map_err(|e| CalibrateError::Data(e.to_string()))
}

/// [`record`]'s recording as text in the exchange format, and its name.
pub fn record_text(
    case: &Case,
    machine: &Scene,
    seed: u64,
) -> Result<(String, std::path::PathBuf), CalibrateError> {
    let mut rng = Pcg64::seed_from_u64(seed);
    let (inputs, dt, rows) = excitation_rows(case.kind, case.excitation, &mut rng);
    let outputs = outputs_of(case.kind);
    let mut columns = vec!["t_s"];
    columns.extend(&inputs);
    columns.extend(outputs);
    let mut text = crate::record::header(
        rig_of(case.kind),
        &[(
            "description",
            format!("calibration proof case {}", case.name),
        )],
        &columns,
    );
    for (k, u) in rows.iter().enumerate() {
        let mut cells = vec![format!("{}", k as f64 * dt)];
        cells.extend(u.iter().map(|v| format!("{v}")));
        cells.extend(outputs.iter().map(|_| "0".to_string()));
        let _ = writeln!(text, "{}", cells.join(","));
    }
    let path = Path::new(&case.name).with_extension("csv");
    let inputs_rec =
        Recording::parse(&text, &path).map_err(|e| CalibrateError::Data(e.to_string()))?;
    let r = replay(machine, &inputs_rec)?;
    let mut noisy = crate::record::header(
        rig_of(case.kind),
        &[(
            "description",
            format!("calibration proof case {}", case.name),
        )],
        &columns,
    );
    let sd: Vec<f64> = outputs
        .iter()
        .map(|n| match *n {
            "x_m" | "y_m" => 0.002,
            "heading_rad" => 0.005,
            n => {
                let y = &r.output(n).expect("a produced output").simulated;
                let m = y.iter().sum::<f64>() / y.len() as f64;
                0.01 * (y.iter().map(|v| (v - m).powi(2)).sum::<f64>() / y.len() as f64).sqrt()
            }
        })
        .collect();
    for (k, u) in rows.iter().enumerate() {
        let mut cells = vec![format!("{}", k as f64 * dt)];
        cells.extend(u.iter().map(|v| format!("{v}")));
        for (n, s) in outputs.iter().zip(&sd) {
            let e: f64 = StandardNormal.sample(&mut rng);
            let y = r.output(n).expect("a produced output").simulated[k];
            cells.push(format!("{}", y + s * e));
        }
        let _ = writeln!(noisy, "{}", cells.join(","));
    }
    Ok((noisy, path))
}

/// The scene a case is calibrated from: the clean machine with its fitted keys each off by
/// a seeded 5-20 % either way (the concealed effect stays off).
pub fn belief(clean: &Scene, free: &[ParamKey], seed: u64) -> Result<Scene, CalibrateError> {
    let mut rng = Pcg64::seed_from_u64(seed ^ 0x9e37_79b9_7f4a_7c15);
    let pairs: Vec<(String, f64)> = free
        .iter()
        .map(|k| {
            let v = keys::get(clean, k.key())?;
            let sign = if rng.random::<bool>() { 1.0 } else { -1.0 };
            Ok((
                k.to_string(),
                v * (1.0 + sign * rng.random_range(0.05..0.20)),
            ))
        })
        .collect::<Result<_, CalibrateError>>()?;
    keys::set(clean, &pairs)
}

/// A case's machine, its recording and the scene calibrated against it.
pub fn setup(case: &Case, seed: u64) -> Result<(Scene, Recording, Scene), CalibrateError> {
    let clean = clean_machine(case.kind)?;
    let known = Scene::from_toml(&clean.to_toml(), Path::new("clean.toml"), &case.common)
        .map_err(|e| CalibrateError::Key(e.to_string()))?;
    if case.kind == Kind::BaseRig {
        return setup_through_rig(case, &known, seed);
    }
    let machine = Scene::from_toml(&known.to_toml(), Path::new("machine.toml"), &case.machine)
        .map_err(|e| CalibrateError::Key(e.to_string()))?;
    let rec = record(case, &machine, seed)?;
    let free = super::default_free_of(&rec);
    let belief = belief(&known, free, seed)?;
    Ok((machine, rec, belief))
}

/// [`setup`] of a base known by its rig: the belief is the scene `diagnose --rig` makes of
/// the rig stating the free keys off; the machine is that scene with every value the rig
/// states at the truth, and the case's physics. What a rig cannot state (the castors, the
/// gear mesh: sized from the rig's mass) is the same in both, as in every case of the
/// proof: a wrong guess there is physics the vocabulary does not name.
fn setup_through_rig(
    case: &Case,
    known: &Scene,
    seed: u64,
) -> Result<(Scene, Recording, Scene), CalibrateError> {
    let believed = through_rig(&belief(known, &super::VELOCITY_BASE_FREE, seed)?)?;
    let mut sets = crate::rig::Rig::of_base_scene(known).scene_sets();
    sets.extend(case.machine.iter().cloned());
    let machine = Scene::from_toml(&believed.to_toml(), Path::new("machine.toml"), &sets)
        .map_err(|e| CalibrateError::Key(e.to_string()))?;
    let rec = record(case, &machine, seed)?;
    Ok((machine, rec, believed))
}

/// Runs one case with `seed`: records the machine, calibrates the belief with every effect
/// the recording can show, and judges the outcome.
pub fn run(case: &Case, seed: u64) -> Result<(Outcome, Calibration), CalibrateError> {
    let (machine, rec, belief) = setup(case, seed)?;
    let request = Request {
        free: vec![],
        effects: Choice::All,
        validate: None,
    };
    let c = calibrate_telling(&belief, &rec, &request, &|_| {})?;
    let accepted = c.accepted_in_order();
    let key_error = case.truth.and_then(|(key, truth)| {
        let k = c.keys.iter().find(|k| k.key == key)?;
        Some((k.after - truth) / truth)
    });
    let key_within = key_error.is_some_and(|x| x.abs() <= KEY_TOLERANCE);
    let passed = match case.effect {
        // A clean machine, or one whose only difference is a key's value (a payload).
        None => accepted.is_empty() && (case.truth.is_none() || key_within),
        Some(e) => accepted.first().map(|a| a.0) == Some(e) && key_within,
    };
    let keys = c
        .keys
        .iter()
        .filter(|k| k.calibrated())
        .filter_map(|k| {
            Some((
                k.key.clone(),
                keys::get(&machine, &k.key).ok()?,
                k.after,
                k.std,
            ))
        })
        .collect();
    let outcome = Outcome {
        case: case.clone(),
        accepted,
        key_error,
        keys,
        fit_pct: (
            super::write::mean_fit(&c.before, &c.outputs),
            super::write::mean_fit(&c.after, &c.outputs),
        ),
        passed,
    };
    Ok((outcome, c))
}

/// Share of the fitted keys whose 1-sigma interval holds the machine's value, and how many
/// keys were counted.
pub fn coverage(outcomes: &[Outcome]) -> (f64, usize) {
    let judged: Vec<bool> = outcomes
        .iter()
        .flat_map(|o| o.keys.iter())
        .filter_map(|(_, truth, value, std)| std.map(|s| (value - truth).abs() <= s))
        .collect();
    let n = judged.len();
    let covered = judged.iter().filter(|&&c| c).count();
    (covered as f64 / n.max(1) as f64, n)
}

/// Realised coverage of the printed intervals over round trips, for one key of one kind
/// (or `all keys` of it): how many fitted values had a standard deviation, and how many
/// of those held the machine's value within 1 and within 1.96 of it (the nominal 68.3 %
/// and 95 % intervals).
#[derive(Debug, Clone, PartialEq)]
pub struct CoverageRow {
    /// The kind's name.
    pub kind: &'static str,
    /// The scene key, or `all keys`.
    pub key: String,
    /// Fitted values with a standard deviation.
    pub n: usize,
    /// Of them, within one standard deviation of the truth.
    pub within_68: usize,
    /// Of them, within 1.96 standard deviations.
    pub within_95: usize,
}

impl CoverageRow {
    /// The realised share within `k` of `n`, and its Monte Carlo standard error
    /// `sqrt(p (1 - p) / n)` (a binomial share's).
    pub fn share(&self, k: usize) -> (f64, f64) {
        let n = self.n.max(1) as f64;
        let p = k as f64 / n;
        (p, (p * (1.0 - p) / n).sqrt())
    }
}

/// The coverage of every fitted key's interval in `outcomes`, by kind: one row per key,
/// then `all keys` of the kind.
pub fn coverage_table(outcomes: &[Outcome]) -> Vec<CoverageRow> {
    let mut rows: Vec<CoverageRow> = vec![];
    let mut add = |kind: &'static str, key: &str, z: f64| {
        let at = match rows.iter().position(|r| r.kind == kind && r.key == key) {
            Some(i) => i,
            None => {
                rows.push(CoverageRow {
                    kind,
                    key: key.to_string(),
                    n: 0,
                    within_68: 0,
                    within_95: 0,
                });
                rows.len() - 1
            }
        };
        let r = &mut rows[at];
        r.n += 1;
        r.within_68 += usize::from(z <= 1.0);
        r.within_95 += usize::from(z <= 1.96);
    };
    for o in outcomes {
        let kind = o.case.kind.name();
        for (key, truth, value, std) in &o.keys {
            if let Some(s) = std.filter(|s| *s > 0.0) {
                let z = (value - truth).abs() / s;
                add(kind, key, z);
                add(kind, ALL_KEYS, z);
            }
        }
    }
    // Each kind's keys, then its total.
    rows.sort_by(|a, b| (a.kind, a.key == ALL_KEYS).cmp(&(b.kind, b.key == ALL_KEYS)));
    rows
}

const ALL_KEYS: &str = "all keys";

/// [`coverage_table`] as text: nominal and realised coverage with the Monte Carlo error.
pub fn render_coverage(rows: &[CoverageRow]) -> String {
    let mut s = format!(
        "{:<16} {:<34} {:>5}  {:>22}  {:>22}\n",
        "kind", "key", "n", "68.3 % nominal: real", "95 % nominal: real"
    );
    for r in rows {
        let cell = |k: usize| {
            let (p, e) = r.share(k);
            format!("{:.1} ± {:.1} %", 100.0 * p, 100.0 * e)
        };
        let _ = writeln!(
            s,
            "{:<16} {:<34} {:>5}  {:>22}  {:>22}",
            r.kind,
            r.key,
            r.n,
            cell(r.within_68),
            cell(r.within_95)
        );
    }
    s
}

/// The table of outcomes: case, what was accepted, the key's error, the fits, pass or fail.
pub fn render(outcomes: &[Outcome]) -> String {
    let mut s = format!(
        "{:<44} {:<40} {:>8} {:>16}  result\n",
        "case", "accepted (in order)", "error", "fit %"
    );
    for o in outcomes {
        let accepted = if o.accepted.is_empty() {
            "(none)".to_string()
        } else {
            o.accepted
                .iter()
                .map(|(e, v)| format!("{} {}", e.name(), crate::numtext::sig(*v, 4)))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let _ = writeln!(
            s,
            "{:<44} {:<40} {:>8} {:>6.1} -> {:>6.1}  {}",
            o.case.name,
            accepted,
            o.key_error
                .map_or("-".into(), |e| format!("{:+.1}%", 100.0 * e)),
            o.fit_pct.0,
            o.fit_pct.1,
            if o.passed { "pass" } else { "FAIL" }
        );
    }
    let (share, n) = coverage(outcomes);
    let _ = writeln!(
        s,
        "1-sigma coverage: {:.0} % of {n} fitted keys hold the machine's value",
        100.0 * share
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn outcome(kind: Kind, keys: &[(&str, f64, f64, Option<f64>)]) -> Outcome {
        let case = Case {
            name: "x".into(),
            kind,
            excitation: Excitation::CmdVelSteps,
            effect: None,
            truth: None,
            machine: vec![],
            common: vec![],
        };
        Outcome {
            case,
            accepted: vec![],
            key_error: None,
            keys: keys
                .iter()
                .map(|(k, t, v, s)| (k.to_string(), *t, *v, *s))
                .collect(),
            fit_pct: (0.0, 0.0),
            passed: true,
        }
    }

    /// Each key's interval is judged at 1 and at 1.96 of its standard deviation, per kind,
    /// with the kind's total last; a key without a deviation is not counted; the Monte Carlo
    /// error is the binomial share's.
    #[test]
    fn coverage_counts_each_interval_by_kind_and_key() {
        let outcomes = [
            // z = 0.5 and z = 1.5
            outcome(
                Kind::BaseRig,
                &[("m", 10.0, 10.5, Some(1.0)), ("k", 1.0, 1.15, Some(0.1))],
            ),
            // z = 3, and a key the fit could not give a deviation
            outcome(
                Kind::BaseRig,
                &[("m", 10.0, 7.0, Some(1.0)), ("k", 1.0, 2.0, None)],
            ),
            outcome(Kind::AxisVoltage, &[("r", 1.0, 1.0, Some(0.1))]),
        ];
        let rows = coverage_table(&outcomes);
        let find = |kind: &str, key: &str| {
            rows.iter()
                .find(|r| r.kind == kind && r.key == key)
                .unwrap()
        };
        let m = find("base_rig", "m");
        assert_eq!((m.n, m.within_68, m.within_95), (2, 1, 1));
        let k = find("base_rig", "k");
        assert_eq!((k.n, k.within_68, k.within_95), (1, 0, 1));
        let all = find("base_rig", "all keys");
        assert_eq!((all.n, all.within_68, all.within_95), (3, 1, 2));
        assert_eq!(rows.last().unwrap().key, "all keys");
        let (p, e) = all.share(all.within_95);
        assert!((p - 2.0 / 3.0).abs() < 1e-12);
        assert!((e - (p * (1.0 - p) / 3.0).sqrt()).abs() < 1e-12);
        assert_eq!(find("axis_voltage", "all keys").within_68, 1);
    }
}
