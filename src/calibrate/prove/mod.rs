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

mod cases;
mod coverage;
mod noise;
mod recording;
use cases::through_rig;
pub use cases::{cases, clean_machine};
pub use coverage::{
    coverage, coverage_csv, coverage_figures, coverage_table, render_coverage, CoverageRow,
};
pub use noise::SensorNoise;
pub use recording::{record, record_text};

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
    /// The measurement noise its recording carries.
    pub noise: SensorNoise,
    /// Whether the concealed effect is left out of what calibrate may try (`prove
    /// --calibrate --left-out`): the model is wrong on purpose.
    pub left_out: bool,
}

/// One fitted key of a round trip against the machine's value.
#[derive(Debug, Clone, PartialEq)]
pub struct FittedKey {
    /// The scene key.
    pub key: String,
    /// The machine's value.
    pub truth: f64,
    /// The calibrated value.
    pub calibrated: f64,
    /// Its standard deviation, if the fit gave one.
    pub std: Option<f64>,
    /// Said to hold only given a key the recording could not tell apart
    /// ([`crate::calibrate::KeyFit::conditional`]): its interval is not counted.
    pub conditional: bool,
}

impl FittedKey {
    /// The error in standard deviations, `(calibrated - truth) / std`; `None` without a
    /// positive deviation.
    pub fn z(&self) -> Option<f64> {
        self.std
            .filter(|s| *s > 0.0)
            .map(|s| (self.calibrated - self.truth) / s)
    }
}

/// A case's outcome.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// The case.
    pub case: Case,
    /// The seed it ran with.
    pub seed: u64,
    /// The effects accepted, in the order of acceptance, with their keys' values.
    pub accepted: Vec<(Effect, f64)>,
    /// The concealed effect's key as calibrated, relative error to the truth.
    pub key_error: Option<f64>,
    /// Each fitted key against the machine's value.
    pub keys: Vec<FittedKey>,
    /// Mean replay fit before and after, %.
    pub fit_pct: (f64, f64),
    /// The strongest link between an output's residual and a signal, over the strength
    /// that says the model is wrong ([`crate::calibrate::adequacy::ResidualLink::strength`]);
    /// `None`: no output long enough to judge.
    pub residual_link: Option<f64>,
    /// Whether the case passed: the concealed effect accepted first with its key within
    /// [`KEY_TOLERANCE`], or nothing accepted on a clean case (and on a payload case, the
    /// mass within it). With the effect left out ([`Case::left_out`]): the model check
    /// said the model is wrong, or every fitted key's 95 % interval still held the
    /// machine's value.
    pub passed: bool,
}

impl Outcome {
    /// Whether the calibration's model check said the model is wrong (its strongest link
    /// past the check's limit).
    pub fn model_flagged(&self) -> bool {
        self.residual_link.is_some_and(|s| s > 1.0)
    }
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
    let effects = match case.effect {
        Some(e) if case.left_out => Choice::Named(
            cases::effects_of(case.kind)
                .into_iter()
                .filter(|&o| o != e)
                .collect(),
        ),
        _ => Choice::All,
    };
    let request = Request {
        free: vec![],
        effects,
        validate: None,
    };
    let c = calibrate_telling(&belief, &rec, &request, &|_| {})?;
    let accepted = c.accepted_in_order();
    let key_error = case.truth.and_then(|(key, truth)| {
        let k = c.keys.iter().find(|k| k.key == key)?;
        Some((k.after - truth) / truth)
    });
    let key_within = key_error.is_some_and(|x| x.abs() <= KEY_TOLERANCE);
    let keys: Vec<FittedKey> = c
        .keys
        .iter()
        .filter(|k| k.calibrated())
        .filter_map(|k| {
            Some(FittedKey {
                key: k.key.clone(),
                truth: keys::get(&machine, &k.key).ok()?,
                calibrated: k.after,
                std: k.std,
                conditional: k.conditional(),
            })
        })
        .collect();
    let model_flagged = c.model_check_fails();
    let passed = match case.effect {
        // Honest when wrong: said so, or its intervals held anyway.
        Some(_) if case.left_out => {
            model_flagged
                || keys
                    .iter()
                    .filter_map(FittedKey::z)
                    .all(|z| z.abs() <= 1.96)
        }
        // A clean machine, or one whose only difference is a key's value (a payload).
        None => accepted.is_empty() && (case.truth.is_none() || key_within),
        Some(e) => accepted.first().map(|a| a.0) == Some(e) && key_within,
    };
    let outcome = Outcome {
        case: case.clone(),
        seed,
        accepted,
        key_error,
        keys,
        fit_pct: (
            super::write::mean_fit(&c.before, &c.outputs),
            super::write::mean_fit(&c.after, &c.outputs),
        ),
        residual_link: c.residual_links.first().map(|l| l.strength()),
        passed,
    };
    Ok((outcome, c))
}

/// The model check of a round trip: the strongest residual link over the strength at
/// which the check fails, `WRONG` where it did.
fn model_check_cell(o: &Outcome) -> String {
    match o.residual_link {
        Some(m) if o.model_flagged() => format!("WRONG {m:.1}x"),
        Some(m) => format!("ok {m:.1}x"),
        None => "-".into(),
    }
}

/// The table of outcomes: case, what was accepted, the key's error, the fits, pass or fail.
pub fn render(outcomes: &[Outcome]) -> String {
    let mut s = format!(
        "{:<44} {:<40} {:>8} {:>16} {:>12}  result\n",
        "case", "accepted (in order)", "error", "fit %", "model check"
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
            "{:<44} {:<40} {:>8} {:>6.1} -> {:>6.1} {:>12}  {}",
            o.case.name,
            accepted,
            o.key_error
                .map_or("-".into(), |e| format!("{:+.1}%", 100.0 * e)),
            o.fit_pct.0,
            o.fit_pct.1,
            model_check_cell(o),
            if o.passed { "pass" } else { "FAIL" }
        );
    }
    let (share, n) = coverage(outcomes);
    let _ = writeln!(
        s,
        "1-sigma coverage: {:.0} % of {n} fitted keys hold the machine's value",
        100.0 * share
    );
    let flagged = outcomes.iter().filter(|o| o.model_flagged()).count();
    if flagged > 0 {
        let trusted: Vec<Outcome> = outcomes
            .iter()
            .filter(|o| !o.model_flagged())
            .cloned()
            .collect();
        let (share, n) = coverage(&trusted);
        let _ = writeln!(
            s,
            "model check failed (intervals said not to be trusted) on {flagged} of {} round trips; of the others, {:.0} % of {n} fitted keys hold the machine's value",
            outcomes.len(),
            100.0 * share
        );
    }
    let conditional = outcomes
        .iter()
        .flat_map(|o| &o.keys)
        .filter(|k| k.conditional)
        .count();
    if conditional > 0 {
        let _ = writeln!(
            s,
            "not counted: {conditional} estimates said to hold only given a key the recording could not tell apart (held at the scene's value)"
        );
    }
    s
}
