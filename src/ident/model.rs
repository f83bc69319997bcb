//! Grey-box models: continuous-time state equations with named, bounded parameters, and
//! their simulation over a recording's time base (inputs zero-order held, outputs compared
//! where measured).

use super::data::Dataset;
pub use super::parameters::{Binding, ParamSpec, DEFAULT_BELIEF_SD_REL};

/// How a model output relates to its states.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum OutputKind {
    /// The value at the sample instant.
    Instant,
    /// The mean rate of a state over the interval ending at the sample (an encoder speed:
    /// count difference over the sample interval). The state's index.
    IntervalRate(usize),
}

/// What the output-error fitter needs of a model: its parameters and its prediction of
/// a record's outputs, `[output][row]` in the dataset's output order. Every [`GreyBox`] is
/// one (integrated by [`simulate`]); the simulator replaying a record is another.
pub trait Predictor: Sync {
    /// The parameters, free or fixed.
    fn param_specs(&self) -> &[ParamSpec];
    /// The outputs at the parameter values `p`.
    fn predict(&self, p: &[f64], data: &Dataset) -> Result<Vec<Vec<f64>>, Diverged>;
}

impl<T: GreyBox + ?Sized> Predictor for T {
    fn param_specs(&self) -> &[ParamSpec] {
        self.params()
    }
    fn predict(&self, p: &[f64], data: &Dataset) -> Result<Vec<Vec<f64>>, Diverged> {
        self.simulate_record(p, data)
    }
}

/// A model's dynamics: continuous-time state equations on its blocks, which are built
/// from a parameter vector once per simulation and immutable during it (the system half
/// of Drake's system/context split); everything that evolves is in the state vector or
/// the held vector.
pub trait Dynamics: Sync {
    /// The model's blocks at one parameter vector's values.
    type Blocks;
    /// The blocks at the parameter values `p` (each written through its key,
    /// [`Binding`]).
    fn blocks(&self, p: &[f64]) -> Self::Blocks;
    /// Number of states.
    fn n_states(&self) -> usize;
    /// Number of values computed at each sample instant and held until the next (a
    /// digital controller's command, a delay line's output...).
    fn n_held(&self) -> usize {
        0
    }
    /// The state at a record's start.
    fn initial_state(&self, b: &Self::Blocks, data: &Dataset) -> Vec<f64>;
    /// Longest integration step the dynamics allow at these parameters, s.
    fn max_step_s(&self, b: &Self::Blocks) -> f64;
    /// Longest integration step over a sample interval starting in state `x`, s, when a
    /// stiffness that depends on the state allows more than the worst case
    /// ([`Dynamics::max_step_s`]); `None` (the default): the worst case holds throughout.
    fn max_step_at(&self, _b: &Self::Blocks, _x: &[f64]) -> Option<f64> {
        None
    }
    /// Dead time between the recorded input and its action, s (inputs are then looked up,
    /// zero-order held, at t - delay at every integration stage).
    fn input_delay_s(&self, _b: &Self::Blocks) -> f64 {
        0.0
    }
    /// Called at each sample instant before integrating over the next interval.
    fn hold(&self, _b: &Self::Blocks, _t_s: f64, _x: &[f64], _u: &[f64], _held: &mut [f64]) {}
    /// The state's rate of change.
    fn derivatives(&self, b: &Self::Blocks, x: &[f64], u: &[f64], held: &[f64], dx: &mut [f64]);
    /// Where inside an integration step of `h` seconds from `before` to `after` a
    /// piecewise law first changes piece (a gear's teeth meeting or parting), as a
    /// fraction of the step; `None` when no law changes piece. A kink inside a step costs
    /// RK4 its order, and with it the event's timing, so the integrator retakes such a
    /// step split there ([`EVENT_SPLITS`]). No piecewise law by default.
    fn event_fraction(
        &self,
        _b: &Self::Blocks,
        _before: &[f64],
        _after: &[f64],
        _h: f64,
    ) -> Option<f64> {
        None
    }
    /// After each integration step: set-valued laws (stiction) act here.
    fn after_step(&self, _b: &Self::Blocks, _x_before: &[f64], _x: &mut [f64]) {}
    /// An output of the model, resolved from its column name once before the per-sample
    /// loop ([`Dynamics::output_of`]).
    type Output: Copy;
    /// The output a recording's column `name` is (the model's own "none" for a column it
    /// does not produce, whose value is then NaN).
    fn output_of(&self, name: &str) -> Self::Output;
    /// How an output is formed.
    fn output_kind(&self, o: Self::Output) -> OutputKind;
    /// Instantaneous value of an output.
    fn output(&self, b: &Self::Blocks, o: Self::Output, x: &[f64], u: &[f64], held: &[f64]) -> f64;
    /// Adjusts a finished simulation to the recording's frame before it is compared (a
    /// pose tracker's unknown start pose): called once per simulation.
    fn align_outputs(&self, _data: &Dataset, _y: &mut [Vec<f64>]) {}
}

/// A record simulated by a model's dynamics at a parameter vector ([`simulate`]): what
/// the fitter calls through a [`GreyBox`] whatever the model's blocks.
pub trait SimulateRecord {
    /// Predicted outputs, `[output][row]`, in the dataset's output order.
    fn simulate_record(&self, p: &[f64], data: &Dataset) -> Result<Vec<Vec<f64>>, Diverged>;
}

impl<T: Dynamics> SimulateRecord for T {
    fn simulate_record(&self, p: &[f64], data: &Dataset) -> Result<Vec<Vec<f64>>, Diverged> {
        simulate(self, p, data)
    }
}

/// A grey-box model: its parameters (each a key of its blocks, with bounds), what it
/// frees by default, its inputs and outputs, and its simulation.
pub trait GreyBox: Predictor + SimulateRecord {
    /// Model name for reports.
    fn name(&self) -> String;
    /// All parameters, free or fixed.
    fn params(&self) -> &[ParamSpec];
    /// The parameters, to state beliefs' uncertainty ([`crate::ident::state_beliefs`]).
    fn params_mut(&mut self) -> &mut [ParamSpec];
    /// Parameters freed by default (indices into `params`), given the outputs measured.
    fn default_free(&self, outputs: &[String]) -> Vec<usize>;
    /// Parameters a record cannot move, however its outputs are measured (no turn was
    /// commanded, so the track and yaw inertia act on nothing): left out of the default
    /// free set, where the search would only drift them.
    fn unexcited(&self, _data: &Dataset) -> Vec<usize> {
        Vec::new()
    }
    /// SysId's terms (kS, kV, kA) the parameters `p` imply, per `speed_unit` (`m/s`: a
    /// wheel's rim speed, `rad/s`: the motor's), where the model is a voltage-driven DC
    /// drive ([`crate::ident::sysid_law`]); `None` by default.
    fn sysid_terms(&self, _p: &[f64], _speed_unit: &str) -> Option<crate::ident::sysid_law::Terms> {
        None
    }
    /// Outputs of a record that its inputs do not excite, each with why (a gyro on a
    /// straight run: the record's yaw is its sensor's noise, and the model's a response to
    /// the noise in the commands): left out of the fit, where a model mismatch on nothing
    /// would steer the parameters, and reported. None by default.
    fn unexcited_outputs(&self, _data: &Dataset) -> Vec<(String, String)> {
        Vec::new()
    }
    /// The default free set for a record: [`GreyBox::default_free`] without what it
    /// cannot excite.
    fn default_free_for(&self, data: &Dataset) -> Vec<usize> {
        let idle = self.unexcited(data);
        self.default_free(&data.output_names)
            .into_iter()
            .filter(|i| !idle.contains(i))
            .collect()
    }
    /// Input columns (all required).
    fn input_names(&self) -> Vec<String>;
    /// Output columns the model can predict (those present in a recording are used).
    fn output_names(&self) -> Vec<String>;
    /// Whether parameter `i` acts in this model's structure and belongs in its report (a
    /// torque-driven axis carries the armature's slots unused).
    fn reports(&self, _i: usize) -> bool {
        true
    }
    /// Index of a parameter by name.
    fn param_index(&self, name: &str) -> Option<usize> {
        self.params().iter().position(|s| s.name == name)
    }
    /// Indices of the named parameters the model has, in the order named.
    fn indices_of(&self, names: &[&str]) -> Vec<usize> {
        names.iter().filter_map(|n| self.param_index(n)).collect()
    }
    /// Every parameter at its nominal value.
    fn nominal(&self) -> Vec<f64> {
        self.params().iter().map(|s| s.nominal).collect()
    }
}

/// A simulation that left the physical range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("the model diverged at t = {t_s} s (state not finite)")]
pub struct Diverged {
    /// When, s.
    pub t_s: f64,
}

/// Most integration steps a model may take between two samples.
pub const MAX_SUBSTEPS: usize = 2000;

/// Predicted outputs, `[output][row]`, in the dataset's output order.
/// A record joined from several tests is simulated test by test, each from its own
/// initial state (every test starts from rest) and aligned on its own.
pub fn simulate<M: Dynamics + ?Sized>(
    model: &M,
    p: &[f64],
    data: &Dataset,
) -> Result<Vec<Vec<f64>>, Diverged> {
    // The parameters are immutable during the simulation: the blocks are built once.
    let b = model.blocks(p);
    let segments = data.segments();
    if segments.len() <= 1 {
        return simulate_one(model, &b, data);
    }
    let mut y: Vec<Vec<f64>> = vec![Vec::with_capacity(data.len()); data.output_names.len()];
    for range in segments {
        let part = simulate_one(model, &b, &data.rows(range))?;
        for (all, piece) in y.iter_mut().zip(part) {
            all.extend(piece);
        }
    }
    Ok(y)
}

/// One record from its initial state.
fn simulate_one<M: Dynamics + ?Sized>(
    model: &M,
    p: &M::Blocks,
    data: &Dataset,
) -> Result<Vec<Vec<f64>>, Diverged> {
    let n = data.len();
    let nx = model.n_states();
    let outputs: Vec<M::Output> = data
        .output_names
        .iter()
        .map(|name| model.output_of(name))
        .collect();
    let kinds: Vec<OutputKind> = outputs.iter().map(|&o| model.output_kind(o)).collect();
    let mut x = model.initial_state(p, data);
    let mut held = vec![0.0; model.n_held()];
    let mut u = vec![0.0; data.inputs.len()];
    let mut y = vec![vec![0.0; n]; data.output_names.len()];

    let delay = model.input_delay_s(p);
    let worst_step = model.max_step_s(p);
    let mut rk4 = Rk4::new(nx);
    let mut start = vec![0.0; nx];
    let mut switches = DelayedSwitches::new(delay);
    for k in 0..n {
        data.input_row(k, &mut u);
        let t = data.t_s[k];
        if k == 0 {
            model.hold(p, t, &x, &u, &mut held);
        }
        // Outputs at t_k (the held values are those computed at t_k).
        for (j, &o) in outputs.iter().enumerate() {
            y[j][k] = match kinds[j] {
                OutputKind::Instant => model.output(p, o, &x, &u, &held),
                // No interval before the first sample: its instantaneous rate.
                OutputKind::IntervalRate(_) if k == 0 => model.output(p, o, &x, &u, &held),
                OutputKind::IntervalRate(_) => y[j][k], // set at the end of the interval
            };
        }
        if k + 1 == n {
            break;
        }
        let t_next = data.t_s[k + 1];
        let max_h = model.max_step_at(p, &x).unwrap_or(worst_step).max(1e-7);
        start.copy_from_slice(&x);
        // Without a delay the input is held over the whole interval. A delayed input
        // changes where a delayed sample instant `t_j + delay` falls inside it: the
        // interval is split there, so that every step sees one input and the switch is
        // placed exactly (and the cost varies smoothly with the delay).
        let mut from = t;
        for to in switches
            .within(&data.t_s, t, t_next)
            .chain(std::iter::once(t_next))
        {
            if delay > 0.0 {
                data.input_at(0.5 * (from + to) - delay, &mut u);
            }
            let steps = ((to - from) / max_h).ceil().max(1.0) as usize;
            if steps > MAX_SUBSTEPS {
                // Parameters this stiff are outside any physical reading of the record.
                return Err(Diverged { t_s: t });
            }
            let h = (to - from) / steps as f64;
            for _ in 0..steps {
                rk4.step(model, p, &mut x, &u, &held, h);
            }
            from = to;
        }
        if x.iter().any(|v| !v.is_finite() || v.abs() > 1e12) {
            return Err(Diverged {
                t_s: data.t_s[k + 1],
            });
        }
        let interval = t_next - t;
        for (j, kind) in kinds.iter().enumerate() {
            if let OutputKind::IntervalRate(s) = kind {
                y[j][k + 1] = (x[*s] - start[*s]) / interval;
            }
        }
        data.input_row(k + 1, &mut u);
        model.hold(p, data.t_s[k + 1], &x, &u, &mut held);
    }
    model.align_outputs(data, &mut y);
    Ok(y)
}

/// The record's sample instants shifted by an input delay, walked in time order: where a
/// delayed input changes inside a sample interval.
struct DelayedSwitches {
    /// Input delay, s.
    delay_s: f64,
    /// First sample whose delayed instant is later than the last interval's start (the
    /// intervals are visited in order, so the walk never goes back).
    cursor: usize,
}

impl DelayedSwitches {
    fn new(delay_s: f64) -> DelayedSwitches {
        DelayedSwitches { delay_s, cursor: 0 }
    }

    /// Instants strictly inside `(t, t_next)` where the delayed input changes (none
    /// without a delay, since the interval runs between two sample instants).
    fn within<'a>(
        &mut self,
        t_s: &'a [f64],
        t: f64,
        t_next: f64,
    ) -> impl Iterator<Item = f64> + 'a {
        let delay = self.delay_s;
        if delay > 0.0 {
            while self.cursor < t_s.len() && t_s[self.cursor] + delay <= t {
                self.cursor += 1;
            }
        } else {
            self.cursor = t_s.len();
        }
        t_s[self.cursor..]
            .iter()
            .map(move |&s| s + delay)
            .take_while(move |&s| s < t_next)
    }
}

/// Most times a step is split at an event ([`Dynamics::event_fraction`]): the first
/// estimate of the event's instant comes from the state at the step's start, and a
/// second split catches an estimate that fell short.
pub const EVENT_SPLITS: usize = 2;

/// Classic fourth-order Runge-Kutta with its stage buffers, the input held over a step.
struct Rk4 {
    k: [Vec<f64>; 4],
    tmp: Vec<f64>,
    before: Vec<f64>,
    /// Where the part of a step still to be taken starts.
    part_start: Vec<f64>,
}

impl Rk4 {
    fn new(nx: usize) -> Rk4 {
        Rk4 {
            k: std::array::from_fn(|_| vec![0.0; nx]),
            tmp: vec![0.0; nx],
            before: vec![0.0; nx],
            part_start: vec![0.0; nx],
        }
    }

    /// Advances `x` by `h` seconds (split at the events of piecewise laws,
    /// [`Dynamics::event_fraction`]), then lets the model's set-valued laws act.
    fn step<M: Dynamics + ?Sized>(
        &mut self,
        model: &M,
        p: &M::Blocks,
        x: &mut [f64],
        u: &[f64],
        held: &[f64],
        h: f64,
    ) {
        self.before.copy_from_slice(x);
        self.part_start.copy_from_slice(x);
        let mut left = h;
        self.advance(model, p, x, u, held, left);
        for _ in 0..EVENT_SPLITS {
            // An event within a thousandth of either end of the step is where a split
            // would put it already (the part before was split there): splitting again
            // would only add rounding.
            let Some(at) = model
                .event_fraction(p, &self.part_start, x, left)
                .filter(|at| (1e-3..1.0 - 1e-3).contains(at))
            else {
                break;
            };
            x.copy_from_slice(&self.part_start);
            self.advance(model, p, x, u, held, at * left);
            left *= 1.0 - at;
            self.part_start.copy_from_slice(x);
            self.advance(model, p, x, u, held, left);
        }
        model.after_step(p, &self.before, x);
    }

    /// One classic RK4 step of `h` seconds.
    fn advance<M: Dynamics + ?Sized>(
        &mut self,
        model: &M,
        p: &M::Blocks,
        x: &mut [f64],
        u: &[f64],
        held: &[f64],
        h: f64,
    ) {
        let [k1, k2, k3, k4] = &mut self.k;
        let tmp = &mut self.tmp;
        model.derivatives(p, x, u, held, k1);
        for i in 0..x.len() {
            tmp[i] = x[i] + 0.5 * h * k1[i];
        }
        model.derivatives(p, tmp, u, held, k2);
        for i in 0..x.len() {
            tmp[i] = x[i] + 0.5 * h * k2[i];
        }
        model.derivatives(p, tmp, u, held, k3);
        for i in 0..x.len() {
            tmp[i] = x[i] + h * k3[i];
        }
        model.derivatives(p, tmp, u, held, k4);
        for i in 0..x.len() {
            x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One state `x` from 0, one input `u`, measured as `x`, under one of two laws.
    struct OneState {
        law: Law,
        specs: Vec<ParamSpec>,
    }

    enum Law {
        /// `dx/dt = u` delayed by the parameter: the integral of the delayed input.
        DelayedIntegral,
        /// `dx/dt = 1` up to `x = 0.3`, `1 + 2 (x - 0.3)` above: a kink in the law (as a
        /// gear's teeth meeting), met inside a step; the integrator told of it or not.
        Kinked { told: bool },
    }

    impl GreyBox for OneState {
        fn name(&self) -> String {
            "one state".into()
        }
        fn params(&self) -> &[ParamSpec] {
            &self.specs
        }

        fn params_mut(&mut self) -> &mut [ParamSpec] {
            &mut self.specs
        }
        fn default_free(&self, _outputs: &[String]) -> Vec<usize> {
            (0..self.specs.len()).collect()
        }
        fn input_names(&self) -> Vec<String> {
            vec!["u".into()]
        }
        fn output_names(&self) -> Vec<String> {
            vec!["x".into()]
        }
    }

    impl Dynamics for OneState {
        /// The delay, s (the only parameter).
        type Blocks = f64;
        fn blocks(&self, p: &[f64]) -> f64 {
            p.first().copied().unwrap_or(0.0)
        }
        fn n_states(&self) -> usize {
            1
        }
        fn initial_state(&self, _b: &f64, _data: &Dataset) -> Vec<f64> {
            vec![0.0]
        }
        fn max_step_s(&self, _b: &f64) -> f64 {
            1.0
        }
        fn input_delay_s(&self, delay: &f64) -> f64 {
            match self.law {
                Law::DelayedIntegral => *delay,
                Law::Kinked { .. } => 0.0,
            }
        }
        fn event_fraction(&self, _b: &f64, before: &[f64], after: &[f64], h: f64) -> Option<f64> {
            // The rate at the start (1) reaches the kink at (0.3 - x) / 1.
            let told = matches!(self.law, Law::Kinked { told: true });
            (told && before[0] <= 0.3 && after[0] > 0.3).then(|| (0.3 - before[0]) / h)
        }
        fn derivatives(&self, _b: &f64, x: &[f64], u: &[f64], _h: &[f64], dx: &mut [f64]) {
            dx[0] = match self.law {
                Law::DelayedIntegral => u[0],
                Law::Kinked { .. } => 1.0 + 2.0 * (x[0] - 0.3).max(0.0),
            };
        }
        type Output = ();
        fn output_of(&self, _name: &str) {}
        fn output_kind(&self, _o: ()) -> OutputKind {
            OutputKind::Instant
        }
        fn output(&self, _b: &f64, _o: (), x: &[f64], _u: &[f64], _h: &[f64]) -> f64 {
            x[0]
        }
    }

    /// A record of [`OneState`]: input `u` at the instants `t_s`, `x` measured as 0.
    fn one_state_data(t_s: Vec<f64>, u: Vec<f64>) -> Dataset {
        let n = t_s.len();
        Dataset {
            name: "one state".into(),
            t_s,
            input_names: vec!["u".into()],
            inputs: vec![u],
            output_names: vec!["x".into()],
            outputs: vec![vec![Some(0.0); n]],
            segment_starts: vec![0],
        }
    }

    #[test]
    fn a_step_across_a_kink_is_split_where_the_law_changes() {
        // One step of 0.5 s: x reaches 0.3 at t = 0.3 s, then grows as
        // 0.3 + (e^(2 (t - 0.3)) - 1) / 2. Split at the kink, each piece is smooth and RK4
        // is accurate to its order (5e-5 here); across it, RK4 averages the two laws.
        let data = one_state_data(vec![0.0, 0.5], vec![0.0, 0.0]);
        let end = |told: bool| {
            let m = OneState {
                law: Law::Kinked { told },
                specs: vec![],
            };
            simulate(&m, &[], &data).unwrap()[0][1]
        };
        let exact = 0.3 + (0.4f64.exp() - 1.0) / 2.0;
        assert!((end(true) - exact).abs() < 1e-4, "{}", end(true));
        assert!((end(false) - exact).abs() > 1e-2, "{}", end(false));
    }

    #[test]
    fn a_delayed_input_switches_exactly_at_the_delayed_sample_instant() {
        // A unit step at t = 0.01 s, sampled every 10 ms, delayed by 3.7 ms: the integral
        // at t is (t - 0.0137) once the step has acted, to rounding, whatever the delay's
        // place inside the interval (a step-size grid would round it to a stage time).
        let n = 6;
        let data = one_state_data(
            (0..n).map(|k| k as f64 * 0.01).collect(),
            (0..n).map(|k| if k >= 1 { 1.0 } else { 0.0 }).collect(),
        );
        let model = OneState {
            law: Law::DelayedIntegral,
            specs: vec![ParamSpec::new("delay_s", 0.0037, 0.0, 0.1)],
        };
        for delay in [0.0037, 0.0123, 0.0] {
            let y = simulate(&model, &[delay], &data).unwrap();
            for (k, x) in y[0].iter().enumerate() {
                let expected = (data.t_s[k] - 0.01 - delay).max(0.0);
                assert!(
                    (x - expected).abs() < 1e-12,
                    "delay {delay}: x({}) = {x}, expected {expected}",
                    data.t_s[k]
                );
            }
        }
    }
}
