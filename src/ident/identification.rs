//! What `identify` reports: each parameter with its deviation and bound, the thesis-style
//! state space of the DCMC structures, and the whole identification.

use nalgebra::DMatrix;
use serde::Serialize;

use super::data::LeftOut;
use super::evaluate::Evaluation;
use super::fit::bound_reached;
use super::fit::Fit;
use super::model::GreyBox;
use super::models::dcmc_pair::DcmcPair;
use super::structure::Structure;
use super::sysid_regression as feedforward;

/// One parameter as reported.
#[derive(Debug, Clone, Serialize)]
pub struct ParamReport {
    /// The parameter's name.
    pub name: String,
    /// The rig's belief.
    pub nominal: f64,
    /// The fitted (or, if fixed, the believed) value.
    pub value: f64,
    /// Standard deviation (free parameters); `null` when the data do not determine it,
    /// and when the search ended at a bound.
    pub std: Option<f64>,
    /// Whether it was fitted.
    pub free: bool,
    /// The bound of the search the value ended on, if it did: then the value is no
    /// estimate but a sign that the belief (the rig's nominal) or the model's structure is
    /// wrong.
    pub at_bound: Option<f64>,
    /// What the record alone determines of it (its standard deviation without the
    /// belief); `null` where it does not determine it at all, or it was not fitted.
    pub data_std: Option<f64>,
    /// One standard deviation of the rig's belief, % of it; `null`: no belief holds it.
    pub belief_sd_pct: Option<f64>,
    /// Held by its belief: fitted, but the record determines it less well than the rig's
    /// belief does ([`fit::Fit::held_by_belief`]), so its value is more belief than data.
    pub held: bool,
}

/// Each reported parameter of `model` as `f` fitted it.
pub fn param_reports(model: &dyn GreyBox, f: &Fit) -> Vec<ParamReport> {
    model
        .params()
        .iter()
        .enumerate()
        .filter(|(i, _)| model.reports(*i))
        .map(|(i, s)| {
            let slot = f.free.iter().position(|&j| j == i);
            let at_bound = slot.and_then(|_| bound_reached(f.params[i], s.lo, s.hi));
            ParamReport {
                name: s.name.clone(),
                nominal: s.nominal,
                value: f.params[i],
                std: if at_bound.is_some() {
                    None
                } else {
                    slot.and_then(|k| f.std[k])
                },
                free: slot.is_some(),
                at_bound,
                data_std: slot.and_then(|k| f.data_std[k]),
                belief_sd_pct: s.belief_sd_rel.map(|r| 100.0 * r),
                held: slot.is_some_and(|k| f.held_by_belief(k)),
            }
        })
        .collect()
}

/// A continuous-time state-space model with standard deviations (thesis-style tables).
#[derive(Debug, Clone, Serialize)]
pub struct StateSpaceReport {
    /// A, row by row.
    pub a: Vec<Vec<f64>>,
    /// A's standard deviations (`None`: fixed, or not determined).
    pub a_std: Vec<Vec<Option<f64>>>,
    /// B, row by row.
    pub b: Vec<Vec<f64>>,
    /// B's standard deviations.
    pub b_std: Vec<Vec<Option<f64>>>,
}

/// The result of `identify`.
#[derive(Debug, Clone, Serialize)]
pub struct Identification {
    /// The model's name.
    pub model: String,
    /// Contract input columns of the recording the model has no use for.
    pub ignored_inputs: Vec<String>,
    /// Outputs the recording measures but does not excite, left out of the fit.
    pub left_out: Vec<LeftOut>,
    /// The rig file.
    pub rig: String,
    /// Every parameter.
    pub params: Vec<ParamReport>,
    /// Free parameters.
    pub n_free: usize,
    /// Residuals (measured output cells).
    pub n_residuals: usize,
    /// Akaike's final prediction error: V (1 + d/N) / (1 - d/N).
    pub fpe: f64,
    /// N ln V + 2 d (constants of the Gaussian likelihood dropped).
    pub aic: f64,
    /// Solver iterations.
    pub iterations: usize,
    /// Model simulations.
    pub evaluations: usize,
    /// Whether the solver converged.
    pub converged: bool,
    /// Starts tried.
    pub starts: usize,
    /// The fit on the estimation record.
    pub estimation: Evaluation,
    /// The fit on the validation record.
    pub validation: Option<Evaluation>,
    /// The thesis-style A and B (the DCMC structures).
    pub state_space: Option<StateSpaceReport>,
    /// SysId's kS, kV, kA of the same record, for comparison (voltage-driven records).
    pub feedforward: Option<feedforward::Report>,
    /// All parameters' values (not serialised).
    #[serde(skip)]
    pub fitted: Vec<f64>,
}

impl Identification {
    /// A fitted parameter value by name.
    pub fn value(&self, name: &str) -> Option<f64> {
        self.params.iter().find(|p| p.name == name).map(|p| p.value)
    }

    /// A parameter's standard deviation by name.
    pub fn std(&self, name: &str) -> Option<f64> {
        self.params
            .iter()
            .find(|p| p.name == name)
            .and_then(|p| p.std)
    }
}

pub(super) fn assemble(
    structure: &Structure,
    f: &Fit,
    estimation: Evaluation,
    validation: Option<Evaluation>,
    starts: usize,
) -> Identification {
    let model = structure.model();
    let params = param_reports(model, f);
    let d = f.free.len() as f64;
    let n = estimation.n_samples as f64;
    let v = estimation.loss;
    let state_space = match structure {
        Structure::Pair(pair) => Some(state_space_report(pair, f)),
        _ => None,
    };
    Identification {
        model: model.name(),
        ignored_inputs: Vec::new(),
        left_out: Vec::new(),
        rig: String::new(),
        params,
        n_free: f.free.len(),
        n_residuals: f.n_residuals,
        fpe: v * (1.0 + d / n) / (1.0 - d / n),
        aic: n * v.ln() + 2.0 * d,
        iterations: f.iterations,
        evaluations: f.evaluations,
        converged: f.converged,
        starts,
        estimation,
        validation,
        state_space,
        feedforward: None,
        fitted: f.params.clone(),
    }
}

/// A and B of a DCMC pair with standard deviations by the delta method (A and B are
/// functions of the parameters; their covariance is G Cov G').
fn state_space_report(pair: &DcmcPair, f: &Fit) -> StateSpaceReport {
    let flatten = |p: &[f64]| {
        let (a, b) = pair.state_space(p);
        a.iter().chain(b.iter()).copied().collect::<Vec<f64>>()
    };
    let base = flatten(&f.params);
    let d = f.free.len();
    let undetermined = f.std.iter().any(|s| s.is_none());
    let mut g = DMatrix::zeros(base.len(), d);
    for (c, &i) in f.free.iter().enumerate() {
        let h = 1e-7 * f.params[i].abs().max(1e-9);
        let mut p = f.params.clone();
        p[i] += h;
        for (r, v) in flatten(&p).iter().enumerate() {
            g[(r, c)] = (v - base[r]) / h;
        }
    }
    let cov = &g * &f.covariance * g.transpose();
    let (a, b) = pair.state_space(&f.params);
    let nx = a.nrows();
    let std_of = |flat: usize| {
        // An entry that depends on an undetermined parameter is itself undetermined.
        let depends_on_undetermined = f
            .std
            .iter()
            .enumerate()
            .any(|(c, s)| s.is_none() && g[(flat, c)].abs() > 0.0);
        (!(undetermined && depends_on_undetermined)).then(|| cov[(flat, flat)].max(0.0).sqrt())
    };
    // nalgebra stores column-major: entry (r, c) of A is flat index c * nx + r.
    StateSpaceReport {
        a: (0..nx)
            .map(|r| (0..nx).map(|c| a[(r, c)]).collect())
            .collect(),
        a_std: (0..nx)
            .map(|r| (0..nx).map(|c| std_of(c * nx + r)).collect())
            .collect(),
        b: (0..nx)
            .map(|r| (0..2).map(|c| b[(r, c)]).collect())
            .collect(),
        b_std: (0..nx)
            .map(|r| (0..2).map(|c| std_of(nx * nx + c * nx + r)).collect())
            .collect(),
    }
}
