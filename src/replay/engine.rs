//! What a replay runs on: the simulator at the scene's fidelity, or the reduced base (a
//! velocity-commanded base's cheaper model), behind one stepping interface.

use super::ReplayError;
use crate::record::Recording;
use crate::scene::Scene;
use crate::sim::reduced::{ReducedBase, Stepping};
use crate::sim::{Actuation, Sim, SimError, Snapshot};

/// What a replay runs: the simulator, or the reduced base a fit of a velocity-commanded
/// recording evaluates ([`crate::sim::reduced`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Engine {
    /// The simulator at the scene's fidelity.
    #[default]
    Simulator,
    /// The reduced velocity-commanded base: only for a vehicle on the floor driven by
    /// velocity commands, stepped as its scene asks.
    ReducedBase,
    /// The reduced base stepped as a fit's start asked ([`ReducedBase::held`]), so that its
    /// replays move smoothly with the keys the fit moves.
    ReducedBaseHeld(Stepping),
}

impl Engine {
    /// Whether it is the reduced base, however stepped.
    pub fn is_reduced(self) -> bool {
        !matches!(self, Engine::Simulator)
    }

    /// The reduced base stepped as `scene` asks, held from then on.
    pub fn reduced_held_at(scene: &Scene) -> Result<Engine, crate::sim::reduced::ReducedError> {
        Ok(Engine::ReducedBaseHeld(Stepping::of(scene)?))
    }
}

/// The machine a replay steps.
pub(super) enum Machine {
    Full(Box<Sim>),
    Reduced(Box<ReducedBase>),
}

impl Machine {
    pub(super) fn new(
        scene: &Scene,
        rec: &Recording,
        engine: Engine,
        coils: bool,
    ) -> Result<Machine, ReplayError> {
        Ok(match engine {
            Engine::Simulator => {
                let sim = Sim::new(scene)?;
                // A replay's recorded inputs drive the motors: the wire matters only to coil
                // readings compared with the recording's.
                Machine::Full(Box::new(if coils { sim } else { sim.without_coils() }))
            }
            Engine::ReducedBase | Engine::ReducedBaseHeld(_) => {
                let reduced = match engine {
                    Engine::ReducedBaseHeld(held) => ReducedBase::held(scene, held),
                    _ => ReducedBase::new(scene),
                };
                Machine::Reduced(Box::new(reduced.map_err(|source| {
                    ReplayError::Reduced {
                        file: rec.path.clone(),
                        source,
                    }
                })?))
            }
        })
    }

    pub(super) fn dt_s(&self) -> f64 {
        match self {
            Machine::Full(s) => s.params().sim.dt_s,
            Machine::Reduced(r) => r.dt_s(),
        }
    }

    pub(super) fn step(&mut self) -> Result<(), SimError> {
        match self {
            Machine::Full(s) => s.step(),
            Machine::Reduced(r) => r.step(),
        }
    }

    pub(super) fn snapshot(&self) -> Snapshot {
        match self {
            Machine::Full(s) => s.snapshot(),
            Machine::Reduced(r) => r.snapshot(),
        }
    }

    pub(super) fn set_actuation(&mut self, a: Actuation) {
        match self {
            Machine::Full(s) => s.set_actuation(a),
            Machine::Reduced(r) => r.set_actuation(a),
        }
    }

    /// A periodic term's phase read at the encoders' angles (the reduced base has no
    /// terms).
    pub(super) fn read_term_phase_at(&mut self, measured_rad: [f64; 2]) {
        if let Machine::Full(s) = self {
            s.read_term_phase_at(measured_rad);
        }
    }
}

/// The motor angles a periodic term is read at over `rows`, per side (left, right): the
/// recording's encoder angle (`motor_angle_rad`, or each side's `left_`/`right_`), or its
/// speed integrated from zero at the first row (an encoder's speed is its count
/// difference over the interval ending at its row, so the integral is exact to a count).
/// `None` where the scene has no periodic term, the recording neither column, or the
/// column never changes (an encoder that never turned, or a placeholder for the outputs
/// a replay is to simulate: the simulated angle is the phase then).
pub(super) fn term_phases(
    scene: &Scene,
    rec: &Recording,
    rows: &std::ops::Range<usize>,
) -> Option<[Vec<f64>; 2]> {
    use crate::model::term::Family;
    let periodic = scene
        .term
        .families_on()
        .iter()
        .any(|f| matches!(f, Family::PeriodicMotorAngle | Family::PeriodicWheelAngle));
    if !periodic {
        return None;
    }
    let side = |prefix: &str| -> Option<Vec<f64>> {
        let t = &rec.t_s[rows.clone()];
        let angle: Option<Vec<f64>> = rec
            .column(&format!("{prefix}angle_rad"))
            .and_then(|c| c[rows.clone()].iter().copied().collect());
        let speed = rec
            .column(&format!("{prefix}speed_rad_s"))
            .map(|c| &c[rows.clone()]);
        let theta = crate::ident::data::measured_angle(t, angle.as_deref(), speed)?;
        let turned = theta.iter().any(|x| *x != theta[0]);
        turned.then_some(theta)
    };
    match (side("motor_"), side("left_motor_"), side("right_motor_")) {
        (Some(m), _, _) => Some([m.clone(), m]),
        (None, Some(l), Some(r)) => Some([l, r]),
        _ => None,
    }
}
