//! A linear drive axis behind a current amplifier (force = gain x command), a rigid mass
//! with viscous friction, open loop or in the closed loop the rig's `[feedback]` describes.
//! In closed loop the command is computed at each sample instant from the simulated state
//! and held, as the real digital controller does, and the recorded command becomes an
//! output to compare with.

use crate::model::Bounded;
use crate::record::channels as chan;
use crate::rig::blocks::CurrentAmplifier;
use crate::rig::blocks::PositionLoop;
use std::path::Path;

use std::sync::OnceLock;

use crate::ident::data::Dataset;
use crate::ident::effects::{self, Effect};
use crate::ident::model::{Binding, Dynamics, GreyBox, OutputKind, ParamSpec};
use crate::param::KeyTable;
use crate::rig::blocks::LinearLoad;
use crate::rig::{Rig, RigError};

/// The moving mass.
pub const MASS: &str = LinearLoad::mass_kg.key();
/// The axis's viscous friction.
pub const VISCOUS: &str = LinearLoad::viscous_n_s_m.key();

crate::declare_params! {
    /// The linear axis's effects (section `effect`): the vocabulary's physics a linear
    /// axis can show, each off at its default.
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct LinearEffects in "effect" {
        /// Coulomb friction force.
        coulomb_force_n as "coulomb_force_N": f64 = 0.0, "N", NonNegative;
        /// Positive-direction over negative-direction viscous coefficient.
        viscous_ratio: f64 = 1.0, "", Positive;
        /// Constant bias force (gravity component, cable, sensor bias).
        offset_n as "offset_N": f64 = 0.0, "N", Finite;
        /// Dead time between the command and the force.
        delay_s: f64 = 0.0, "s", NonNegative;
    }
}

/// What the linear axis's parameters set, by key.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LinearParams {
    /// The load (mass, viscous friction).
    pub load: LinearLoad,
    /// The effects' strengths.
    pub effect: LinearEffects,
}

fn linear_keys() -> &'static KeyTable<LinearParams> {
    static TABLE: OnceLock<KeyTable<LinearParams>> = OnceLock::new();
    TABLE.get_or_init(|| {
        KeyTable::<LinearParams>::new()
            .block(|a| &a.load, |a| &mut a.load)
            .block(|a| &a.effect, |a| &mut a.effect)
    })
}

/// The loop that produced the command.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Loop {
    /// `command_V` is given.
    Open,
    /// command = kv (kp (reference - position) - speed), clipped to the drive limit.
    PositionVelocityCascade {
        /// Position gain, 1/s.
        kp_1_s: f64,
        /// Velocity gain, V per m/s.
        kv_v_s_m: f64,
    },
}

/// A linear axis with any effects switched on.
#[derive(Debug, Clone)]
pub struct LinearAxis {
    specs: Vec<ParamSpec>,
    binding: Binding<LinearParams>,
    /// Force per volt of command, N/V.
    pub force_per_volt: f64,
    /// Command limit, V (infinite when the rig gives none).
    pub limit_v: f64,
    /// The loop that produced the command, if any.
    pub feedback: Loop,
    /// Effects switched on, with the index of each one's parameter.
    pub effects: effects::EffectSlots,
    /// Smoothing speed of Coulomb friction, m/s.
    pub coulomb_eps_m_s: f64,
    /// The recording gives the known external force on the load (`disturbance_force_N`,
    /// a contract input): it enters the force balance as the last input.
    pub disturbance_input: bool,
    /// The recording gives the commanded force (`force_N`) instead of `command_V`.
    pub force_input: bool,
}

impl LinearAxis {
    /// The axis a rig describes. With `force_input` the recording commands the force itself
    /// (`force_N`), so the amplifier's gain and limit do not enter.
    pub fn from_rig(rig: &Rig, path: &Path, force_input: bool) -> Result<LinearAxis, RigError> {
        let need = |k: &str, why: &str| rig.require(k, path, why);
        if rig.get(LinearLoad::viscous_n_s_m.key()) == Some(0.0) {
            return Err(crate::rig::zero_refused(
                path,
                LinearLoad::viscous_n_s_m.key(),
                "the linear-axis model searches its friction on a log scale around the belief, and a moving load always has some: give a rough positive value (for example the mass over a time constant of a few seconds)",
            ));
        }
        let specs = vec![
            ParamSpec::positive(MASS, need(MASS, "the linear axis's moving mass")?),
            ParamSpec::positive(
                VISCOUS,
                need(VISCOUS, "the linear axis's viscous friction")?,
            ),
        ];
        let feedback = match rig.text(PositionLoop::kind.key()) {
            None => Loop::Open,
            Some("position_velocity_cascade") => Loop::PositionVelocityCascade {
                kp_1_s: need(PositionLoop::kp_1_s.key(), "the position loop gain")?,
                kv_v_s_m: need(PositionLoop::kv_v_s_m.key(), "the velocity loop gain")?,
            },
            Some(other) => {
                return Err(RigError::Invalid {
                    file: path.to_owned(),
                    message: format!(
                        "feedback.kind = \"{other}\": expected \"position_velocity_cascade\""
                    ),
                })
            }
        };
        let (force_per_volt, limit_v) = if force_input && feedback == Loop::Open {
            (1.0, f64::INFINITY)
        } else {
            (
                need(
                    CurrentAmplifier::force_per_volt_n_v.key(),
                    "force = gain x command_V",
                )?,
                rig.get(CurrentAmplifier::limit_v.key())
                    .unwrap_or(f64::INFINITY),
            )
        };
        Ok(LinearAxis {
            binding: Binding::new(linear_keys(), &specs),
            specs,
            force_per_volt,
            limit_v,
            force_input: force_input && feedback == Loop::Open,
            feedback,
            effects: effects::EffectSlots::default(),
            coulomb_eps_m_s: 1e-3,
            disturbance_input: false,
        })
    }

    /// Effects that can act on a linear axis behind a current amplifier.
    pub fn applicable(&self) -> Vec<Effect> {
        let mut e = vec![
            Effect::CoulombFriction,
            Effect::Offset,
            Effect::FrictionAsymmetry,
        ];
        // In closed loop the input is the reference, not the actuation: a dead time of the
        // amplifier would have to sit inside the loop, which this model does not place.
        if self.feedback == Loop::Open {
            e.push(Effect::TransportDelay);
        }
        e
    }

    /// This model with one more effect (see `RotaryAxis::with_effect`).
    pub fn with_effect(
        &self,
        effect: Effect,
        start: f64,
        lo: f64,
        hi: f64,
        max_speed: f64,
    ) -> LinearAxis {
        let mut m = self.clone();
        let first = m.specs.len();
        m.specs.push(effect.param(true, start, lo, hi));
        m.effects.add(effect, first..m.specs.len());
        m.binding = Binding::new(linear_keys(), &m.specs);
        m.coulomb_eps_m_s = (effects::COULOMB_SMOOTHING_FRACTION * max_speed).max(1e-6);
        m
    }

    fn effect(&self, e: Effect) -> Option<usize> {
        self.effects.get(e)
    }

    /// The parameters at the values `p`, written by key into the axis's blocks.
    pub fn declared(&self, p: &[f64]) -> LinearParams {
        self.binding.apply(&LinearParams::default(), p)
    }

    /// Parameters whose key the axis's blocks do not have (none; a test checks).
    pub fn unbound(&self) -> Vec<&str> {
        self.binding.unbound(&self.specs)
    }

    /// The controller's command at a state, V.
    pub fn command_v(&self, x: &[f64], reference_m: f64) -> f64 {
        match self.feedback {
            Loop::Open => f64::NAN,
            Loop::PositionVelocityCascade { kp_1_s, kv_v_s_m } => (kv_v_s_m
                * (kp_1_s * (reference_m - x[0]) - x[1]))
                .bounded(-self.limit_v, self.limit_v),
        }
    }
}

impl GreyBox for LinearAxis {
    fn name(&self) -> String {
        match self.feedback {
            Loop::Open => "linear drive axis, current amplifier, open loop".into(),
            Loop::PositionVelocityCascade { .. } => {
                "linear drive axis, current amplifier, position-velocity cascade".into()
            }
        }
    }

    fn params(&self) -> &[ParamSpec] {
        &self.specs
    }

    fn params_mut(&mut self) -> &mut [ParamSpec] {
        &mut self.specs
    }

    fn default_free(&self, _outputs: &[String]) -> Vec<usize> {
        self.indices_of(&[MASS, VISCOUS])
    }

    fn input_names(&self) -> Vec<String> {
        let mut i = match self.feedback {
            Loop::Open if self.force_input => vec![chan::FORCE_N.to_string()],
            Loop::Open => vec![chan::COMMAND_V.to_string()],
            Loop::PositionVelocityCascade { .. } => vec![chan::REFERENCE_M.to_string()],
        };
        if self.disturbance_input {
            i.push(chan::DISTURBANCE_FORCE_N.into());
        }
        i
    }

    fn output_names(&self) -> Vec<String> {
        let mut o = vec![chan::POSITION_M.to_string(), chan::SPEED_M_S.to_string()];
        if self.feedback != Loop::Open {
            o.push(chan::COMMAND_V.into());
        }
        o
    }
}

impl Dynamics for LinearAxis {
    type Blocks = LinearParams;
    type Output = LinearOutput;

    fn blocks(&self, p: &[f64]) -> LinearParams {
        self.declared(p)
    }

    fn n_states(&self) -> usize {
        2
    }

    fn n_held(&self) -> usize {
        1
    }

    fn initial_state(&self, _a: &LinearParams, data: &Dataset) -> Vec<f64> {
        vec![data.first_measured(chan::POSITION_M).unwrap_or(0.0), 0.0]
    }

    fn max_step_s(&self, a: &LinearParams) -> f64 {
        0.2 * a.load.mass_kg / a.load.viscous_n_s_m
    }

    fn hold(&self, _a: &LinearParams, _t_s: f64, x: &[f64], u: &[f64], held: &mut [f64]) {
        held[0] = match self.feedback {
            Loop::Open => u[0].bounded(-self.limit_v, self.limit_v),
            Loop::PositionVelocityCascade { .. } => self.command_v(x, u[0]),
        };
    }

    fn input_delay_s(&self, a: &LinearParams) -> f64 {
        a.effect.delay_s
    }

    fn derivatives(&self, a: &LinearParams, x: &[f64], u: &[f64], held: &[f64], dx: &mut [f64]) {
        let mut force = self.force_per_volt * held[0];
        if self.disturbance_input {
            // The known external force on the load, as recorded.
            force += u[u.len() - 1];
        }
        let v = x[1];
        let (load, effect) = (&a.load, &a.effect);
        let viscous = match self.effect(Effect::FrictionAsymmetry) {
            Some(_) => effects::asymmetric_viscous(load.viscous_n_s_m, effect.viscous_ratio, v),
            None => load.viscous_n_s_m * v,
        };
        force -= viscous;
        if self.effect(Effect::CoulombFriction).is_some() {
            force -= effects::smooth_coulomb(effect.coulomb_force_n, v, self.coulomb_eps_m_s);
        }
        if self.effect(Effect::Offset).is_some() {
            force += effect.offset_n;
        }
        dx[0] = x[1];
        dx[1] = force / load.mass_kg;
    }

    fn output_of(&self, name: &str) -> LinearOutput {
        match name {
            chan::POSITION_M => LinearOutput::Position,
            chan::SPEED_M_S => LinearOutput::Speed,
            chan::COMMAND_V => LinearOutput::Command,
            _ => LinearOutput::Other,
        }
    }

    fn output_kind(&self, _o: LinearOutput) -> OutputKind {
        OutputKind::Instant
    }

    fn output(
        &self,
        _a: &LinearParams,
        o: LinearOutput,
        x: &[f64],
        _u: &[f64],
        held: &[f64],
    ) -> f64 {
        match o {
            LinearOutput::Position => x[0],
            LinearOutput::Speed => x[1],
            LinearOutput::Command => held[0],
            LinearOutput::Other => f64::NAN,
        }
    }
}

/// What a linear axis's output column is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LinearOutput {
    /// `position_m`.
    Position,
    /// `speed_m_s`.
    Speed,
    /// `command_V`, as the loop held it.
    Command,
    /// A column the model does not produce.
    Other,
}
