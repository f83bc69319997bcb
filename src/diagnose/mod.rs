//! Diagnosis: when the nominal model, its parameters fitted, still disagrees with a
//! recording, locate where, name the missing physics from the contract's vocabulary, fit
//! it, and show the improvement.
//!
//! 1. **Baseline**: identify the rig's nominal model (its default free parameters).
//! 2. **Locate**: the baseline residual's energy by operating regime (`regimes`).
//! 3. **Hypothesise**: every vocabulary effect that applies to the structure, as an
//!    optional block of the same model.
//! 4. **Fit and select**: each candidate is fitted with the nominal free parameters, from
//!    two starting values of its own parameter, with the baseline's output weights. A
//!    candidate is significant when its AIC gain, computed with the *effective* number of
//!    independent residuals (the baseline residual is coloured, so N overstates the
//!    evidence), exceeds [`MIN_DELTA_AIC`] and it removes at least [`MIN_RSS_REDUCTION`] of
//!    the residual. The most significant is accepted and the search repeats once for a
//!    second effect.

mod candidate;
pub(crate) mod evidence;
pub mod plots;
pub mod prove;
pub mod regimes;
pub mod report;
pub(crate) mod round;
mod scales;
mod search;
pub mod terms;

use crate::model::motor::MotorParams;
pub use evidence::relative_errors;

use std::collections::BTreeMap;
use std::path::Path;

use serde::Serialize;

use crate::ident::data::Dataset;
use crate::ident::effects::{Choice, Effect};
use crate::ident::fit::Fit;
use crate::ident::{
    build_structure, evaluate, fit_structure, Evaluation, IdentError, IdentifyOptions, Structure,
};
use crate::record::Recording;
use crate::rig::Rig;
use evidence::effective_n;
use regimes::RegimeShare;
use scales::{scales, Scales};

/// Smallest gain in AIC (with the effective sample count) that counts as evidence.
pub const MIN_DELTA_AIC: f64 = 10.0;
/// Smallest share of the baseline's residual sum of squares an effect must remove.
pub const MIN_RSS_REDUCTION: f64 = 0.03;
/// Fewest samples a diagnosis will decide on.
pub const MIN_SAMPLES: usize = 100;
/// Rounds of the search: each adds at most one effect, so a diagnosis names at most
/// this many. Two keep a diagnosis of many records affordable; `calibrate` goes on.
pub const ROUNDS: usize = 2;

/// One candidate effect as fitted.
#[derive(Debug, Clone, Serialize)]
pub struct Candidate {
    /// The effect's vocabulary name.
    pub name: String,
    /// Its parameter's vocabulary name.
    pub param: String,
    /// The parameter's fitted value (its unit is in its name).
    pub value: f64,
    /// Its standard deviation; `None` where the record does not determine it.
    pub std: Option<f64>,
    /// The normalised fit with the effect, %, mean over outputs.
    pub fit_pct: f64,
    /// Share of the residual sum of squares removed, %.
    pub rss_reduction_pct: f64,
    /// AIC gain with the effective number of residuals.
    pub delta_aic: f64,
    /// Whether it passed the selection rule.
    pub significant: bool,
    /// Only the candidate's screen was fitted: it removed too little of the residual for
    /// the full search of a rough parameter to be worth its cost (its gain is a lower
    /// bound).
    pub screened_only: bool,
    /// Its gain passed the rule, but the stage's own structure refitted from where the
    /// candidate's fit ended reaches it too: not the effect's.
    pub reached_without_it: bool,
    /// The bound of its search its parameter ended on, if it did: then it is no estimate,
    /// and the effect is not found whatever its gain.
    pub at_bound: Option<f64>,
    /// Its parameter's standard deviation could not be had: the record does not
    /// determine it, and the effect is not found whatever its gain.
    pub undetermined: bool,
}

/// An accepted effect.
#[derive(Debug, Clone)]
pub struct Finding {
    /// The effect.
    pub effect: Effect,
    /// Its parameter's vocabulary name.
    pub param: String,
    /// The parameter's value (its unit is in its name).
    pub value: f64,
    /// Its standard deviation; `None` where the record does not determine it.
    pub std: Option<f64>,
    /// The normalised fit with the effect, %, mean over outputs.
    pub fit_pct: f64,
    /// Why: where its residual lived and what it removed.
    pub evidence: String,
    /// The physics in words.
    pub description: String,
    /// Other effects this record cannot tell from it: they passed the same rule, and the
    /// evidence for this one is not [`MIN_DELTA_AIC`] stronger.
    pub alternatives: Vec<Alternative>,
    /// The round (from 1) that accepted it.
    pub round: usize,
}

/// An effect a record cannot tell from the one found.
#[derive(Debug, Clone, Serialize)]
pub struct Alternative {
    /// The effect's vocabulary name.
    pub name: String,
    /// Its parameter's vocabulary name.
    pub param: String,
    /// Its fitted value.
    pub value: f64,
    /// How much less AIC it gains than the effect found.
    pub delta_aic_behind: f64,
    /// Why the record cannot tell them apart, and what record would.
    pub separated_by: String,
}

/// The result of a diagnosis.
#[derive(Debug, Clone)]
pub struct Diagnosis {
    /// The recording's file name.
    pub recording: String,
    /// The model's name.
    pub model: String,
    /// The baseline's normalised fit, %, mean over outputs.
    pub baseline_fit_pct: f64,
    /// The baseline's fitted parameters by name.
    pub baseline_params: BTreeMap<String, f64>,
    /// Contract input columns of the recording the model has no use for.
    pub ignored_inputs: Vec<String>,
    /// Outputs the recording measures but does not excite, left out of the fit.
    pub left_out: Vec<crate::ident::LeftOut>,
    /// Free baseline parameters whose search ended at a bound (name, bound): no
    /// estimates, but signs that the rig's belief or the model's structure is wrong.
    pub baseline_at_bound: BTreeMap<String, f64>,
    /// Baseline residual energy by regime.
    pub where_before: Vec<RegimeShare>,
    /// Residual energy by regime after the accepted effects.
    pub where_after: Vec<RegimeShare>,
    /// Every candidate of each round.
    pub rounds: Vec<Vec<Candidate>>,
    /// The accepted effects, in the order accepted.
    pub findings: Vec<Finding>,
    /// Terms outside the vocabulary accepted (each with its round).
    pub terms: Vec<terms::TermFinding>,
    /// Each round's search of the terms (`None` where none was run).
    pub term_rounds: Vec<Option<terms::Search>>,
    /// Structure the residual keeps that no effect and no term explains, if any.
    pub unexplained: Option<Unexplained>,
    /// The diagnosed model's normalised fit, %, mean over outputs.
    pub final_fit_pct: f64,
    /// The diagnosed model's parameters by name.
    pub final_params: BTreeMap<String, f64>,
    /// Effective number of independent residuals used in the AIC comparison.
    pub effective_n: f64,
    /// The baseline's evaluation (fits, loss, residual checks).
    pub baseline: Evaluation,
    /// The diagnosed model's evaluation.
    pub diagnosed: Evaluation,
    /// Relative simulation errors `|y - yhat| / |y|`, %, per output (and the speed by
    /// differencing a position), of the baseline and the diagnosed model.
    pub relative_error_before_pct: BTreeMap<String, f64>,
    /// The same for the diagnosed model, %.
    pub relative_error_after_pct: BTreeMap<String, f64>,
    /// The baseline's and the diagnosed model's evaluations on the validation recording.
    pub validation: Option<(Evaluation, Evaluation)>,
    /// SysId's kS, kV, kA of the same record, beside what diagnosis finds (voltage-driven
    /// records; kS as a motor torque with the baseline's torque constant and resistance).
    pub feedforward: Option<crate::import::wpilib::feedforward::Report>,
    /// SysId's terms the diagnosed model implies, with their standard deviations, in the
    /// regression's unit of speed (voltage-driven DC drives).
    pub sysid_terms: Option<crate::ident::sysid_terms::FittedTerms>,
    /// The baseline's parameters as fitted: values, standard deviations, what the record
    /// alone determines, and which its beliefs held.
    pub baseline_estimates: Vec<crate::ident::ParamReport>,
    /// The diagnosed model's parameters as fitted.
    pub final_estimates: Vec<crate::ident::ParamReport>,
    /// How long the diagnosed model's residual stays correlated, s: the blocks its
    /// standard deviations treat as independent (one sample interval: white).
    pub correlation_s: f64,
    /// The same in samples (1: a white residual).
    pub correlation_rows: usize,
}

impl Diagnosis {
    /// The names of what was found, effects and terms, in the order accepted.
    pub fn found_names(&self) -> Vec<String> {
        let mut named: Vec<(usize, String)> = self
            .findings
            .iter()
            .map(|f| (f.round, f.effect.name().to_string()))
            .chain(self.terms.iter().map(|t| (t.round, t.row.name.clone())))
            .collect();
        named.sort_by_key(|(round, _)| *round);
        named.into_iter().map(|(_, n)| n).collect()
    }

    /// The Coulomb friction diagnosis found, in SysId's terms: the voltage that just
    /// overcomes it, `kS = Tc R / K`, V (with the diagnosed model's K and R).
    pub fn coulomb_as_ks_v(&self) -> Option<f64> {
        let tc = self
            .findings
            .iter()
            .find(|f| f.effect == Effect::CoulombFriction)?
            .value;
        let k = self
            .final_params
            .get(MotorParams::torque_constant_nm_a.key())?;
        let r = self.final_params.get(MotorParams::resistance_ohm.key())?;
        (*k > 0.0).then(|| tc * r / k)
    }

    /// The contract's JSON object.
    pub fn contract_json(&self) -> serde_json::Value {
        let mut effects: Vec<(usize, serde_json::Value)> = self
            .findings
            .iter()
            .map(|f| {
                (
                    f.round,
                    serde_json::json!({
                        "name": f.effect.name(),
                        "params": { f.param.clone(): f.value },
                        "std": { f.param.clone(): f.std },
                        "fit_pct": f.fit_pct,
                        "evidence": f.evidence,
                        "description": f.description,
                        "cannot_be_told_from": f.alternatives,
                    }),
                )
            })
            .collect();
        effects.extend(self.terms.iter().map(|t| {
            let params: serde_json::Map<String, serde_json::Value> =
                t.row.params.iter().cloned().collect();
            let main = t
                .row
                .params
                .first()
                .map_or(String::new(), |(n, _)| n.clone());
            (
                t.round,
                serde_json::json!({
                    "name": t.row.name,
                    "outside_vocabulary": true,
                    "params": params,
                    "std": { main: t.row.std },
                    "fit_pct": t.row.fit_pct,
                    "evidence": t.evidence,
                    "description": t.description,
                    "delta_aic": t.row.delta_aic,
                    "held_out_reduction_pct": t.row.held_out_reduction_pct,
                }),
            )
        }));
        effects.sort_by_key(|(round, _)| *round);
        let effects: Vec<serde_json::Value> = effects.into_iter().map(|(_, e)| e).collect();
        let mut v = serde_json::json!({
            "recording": self.recording,
            "model": self.model,
            "ignored_inputs": self.ignored_inputs,
            "left_out": self.left_out,
            "baseline": {
                "fit_pct": self.baseline_fit_pct,
                "fit_pct_per_output": self.baseline.fit_pct,
                "params": self.baseline_params,
                "at_bound": self.baseline_at_bound,
                "estimates": self.baseline_estimates,
            },
            "effects": effects,
            "final": {
                "fit_pct": self.final_fit_pct,
                "fit_pct_per_output": self.diagnosed.fit_pct,
                "params": self.final_params,
                "estimates": self.final_estimates,
                "residual_correlation_s": self.correlation_s,
            },
            "where_before": self.where_before,
            "where_after": self.where_after,
            "candidates": self.rounds,
            "term_candidates": self.term_rounds.iter().map(|r| r.as_ref().map(|s| serde_json::json!({
                "screened": s.screened,
                "fitted": s.fitted,
            }))).collect::<Vec<_>>(),
            "effective_n": self.effective_n,
            "relative_error_pct": {"baseline": self.relative_error_before_pct, "final": self.relative_error_after_pct},
        });
        if let Some(u) = &self.unexplained {
            v["unexplained"] = serde_json::json!(u);
        }
        if let Some(ff) = &self.feedforward {
            v["sysid_feedforward"] = serde_json::json!(ff);
            if let Some(ks) = self.coulomb_as_ks_v() {
                v["sysid_feedforward"]["diagnosed_ks_v"] = ks.into();
            }
            if let Some(t) = &self.sysid_terms {
                v["sysid_feedforward"]["diagnosed_terms"] = serde_json::json!(t);
            }
        }
        if let Some((b, d)) = &self.validation {
            v["validation"] = serde_json::json!({
                "recording": b.recording,
                "baseline_fit_pct": b.fit_pct_mean,
                "final_fit_pct": d.fit_pct_mean,
            });
        }
        v
    }
}

impl Structure {
    fn applicable(&self) -> Vec<Effect> {
        match self {
            Structure::Rotary(m) => m.applicable(),
            Structure::Linear(m) => m.applicable(),
            Structure::Vehicle(m) => m.applicable(),
            _ => vec![],
        }
    }

    /// Nominal parameters an effect's block makes identifiable, beyond the nominal free set.
    fn newly_identifiable(&self, e: Effect, outputs: &[String]) -> Vec<usize> {
        match self {
            Structure::Rotary(m) => m.newly_identifiable(e, outputs),
            _ => vec![],
        }
    }

    fn with_effect(&self, e: Effect, start: f64, lo: f64, hi: f64, speed_max: f64) -> Structure {
        match self {
            Structure::Rotary(m) => Structure::Rotary(m.with_effect(e, start, lo, hi, speed_max)),
            Structure::Linear(m) => Structure::Linear(m.with_effect(e, start, lo, hi, speed_max)),
            Structure::Vehicle(m) => Structure::Vehicle(m.with_effect(e, start, lo, hi, speed_max)),
            other => other.clone(),
        }
    }
}

/// Options of a diagnosis.
#[derive(Debug, Clone, Default)]
pub struct DiagnoseOptions {
    /// The identification's settings (iterations, starts, residual lags).
    pub ident: IdentifyOptions,
    /// Which candidate effects to try (by default every one that applies to the
    /// structure).
    pub effects: Choice,
    /// Told each stage as it happens (the baseline, each round's candidates as they
    /// finish), from worker threads too: the command prints it, a test leaves it `None`.
    pub progress: Option<fn(&str)>,
}

struct Stage {
    structure: Structure,
    fit: Fit,
}

/// Diagnoses a recording against its rig: the baseline fitted, then up to [`ROUNDS`]
/// rounds of candidate effects ([`round`]), then the diagnosis reported.
pub fn diagnose(
    rig: &Rig,
    rig_path: &Path,
    rec: &Recording,
    validation: Option<&Recording>,
    opts: &DiagnoseOptions,
) -> Result<Diagnosis, IdentError> {
    let structure = diagnosable_structure(rig, rig_path, rec, opts)?;
    let model = structure.model();
    let (data, left_out) = crate::ident::dataset_for(model, rec)?;
    check_decidable(&data, rec)?;
    // A rotary axis carries the measured angle's line beside its input, for a periodic
    // term (fitted on the angle the encoder measured); the other models read their own
    // inputs first and leave it.
    let data = match &structure {
        Structure::Rotary(_) => data.with_measured_angle().unwrap_or(data),
        _ => data,
    };
    let free = model.default_free_for(&data);
    crate::ident::enough_data(rec, &data, free.len())?;
    let base_fit = fit_structure(model, &data, &free, &opts.ident, &model.nominal())
        .map_err(|e| crate::ident::diverging_start(rec, &data, e))?;
    let weights = base_fit.weighting.clone();
    let speed = regimes::measured_speed(&data);
    let regs = regimes::regimes(&data, &speed);
    let base_energy = regimes::energy_per_sample(&data, &base_fit.predicted, &weights.outputs);
    let scales = scales(&structure, &base_fit.params, &data, &speed);
    let baseline_eval = evaluate(&data, base_fit.predicted.clone(), opts.ident.max_lag);
    crate::ident::finite_loss(rec, &data, &baseline_eval)?;
    let tell = |msg: String| {
        if let Some(p) = opts.progress {
            p(&msg);
        }
    };
    tell(format!(
        "baseline fitted ({} iterations); trying the candidate effects",
        base_fit.iterations
    ));
    let rounds_of = round::Rounds {
        data: &data,
        regimes: &regs,
        base_energy: &base_energy,
        linear: matches!(structure, Structure::Linear(_)),
        tell: &tell,
    };
    let (stage, outcome) = rounds_of.run(
        Stage {
            structure: structure.clone(),
            fit: base_fit.clone(),
        },
        &free,
        &scales,
        opts,
    );
    let validation = validation
        .map(|v| validate(&structure, &base_fit, &stage, v, opts.ident.max_lag))
        .transpose()?;
    Ok(report_of(
        rec,
        &data,
        Baseline {
            structure: &structure,
            fit: &base_fit,
            eval: baseline_eval,
            energy: &base_energy,
        },
        stage,
        Found {
            regimes: &regs,
            rounds: outcome.rounds,
            findings: outcome.findings,
            terms: outcome.terms,
            term_rounds: outcome.term_rounds,
            left_out,
            validation,
            max_lag: opts.ident.max_lag,
        },
    ))
}

/// The rig's structure for this recording, if a diagnosis can take it and every effect
/// named applies to it.
fn diagnosable_structure(
    rig: &Rig,
    rig_path: &Path,
    rec: &Recording,
    opts: &DiagnoseOptions,
) -> Result<Structure, IdentError> {
    let structure = build_structure(rig, rig_path, rec, opts.ident.model)?;
    if !matches!(
        structure,
        Structure::Rotary(_) | Structure::Linear(_) | Structure::Vehicle(_)
    ) {
        return Err(IdentError::NotDiagnosable {
            file: rec.path.clone(),
            rig: rig_path.to_path_buf(),
            model: structure.model().name(),
        });
    }
    let applicable = structure.applicable();
    if let Choice::Named(asked) = &opts.effects {
        if let Some(e) = asked.iter().find(|e| !applicable.contains(e)) {
            return Err(IdentError::EffectNotApplicable {
                effect: e.name().into(),
                model: structure.model().name(),
                applicable: applicable
                    .iter()
                    .map(|e| e.name())
                    .collect::<Vec<_>>()
                    .join(", "),
            });
        }
    }
    Ok(structure)
}

/// The baseline's and the diagnosed model's evaluations on a validation recording.
fn validate(
    structure: &Structure,
    base_fit: &Fit,
    stage: &Stage,
    v: &Recording,
    max_lag: usize,
) -> Result<(Evaluation, Evaluation), IdentError> {
    let (vd, _) = crate::ident::dataset_for(structure.model(), v)?;
    let sim = |s: &Structure, p: &[f64]| {
        s.model()
            .simulate_record(p, &vd)
            .map_err(|d| IdentError::Mismatch {
                file: v.path.clone(),
                message: format!("the model {d} on the validation recording"),
            })
    };
    let b = evaluate(&vd, sim(structure, &base_fit.params)?, max_lag);
    let d = evaluate(&vd, sim(&stage.structure, &stage.fit.params)?, max_lag);
    Ok((b, d))
}

/// The nominal model as first fitted.
struct Baseline<'a> {
    structure: &'a Structure,
    fit: &'a Fit,
    eval: Evaluation,
    /// Its residual energy per sample.
    energy: &'a [f64],
}

/// What the rounds found, and what the report needs beside it.
struct Found<'a> {
    regimes: &'a [regimes::Regime],
    rounds: Vec<Vec<Candidate>>,
    findings: Vec<Finding>,
    terms: Vec<terms::TermFinding>,
    term_rounds: Vec<Option<terms::Search>>,
    left_out: Vec<crate::ident::LeftOut>,
    validation: Option<(Evaluation, Evaluation)>,
    max_lag: usize,
}

/// The diagnosis as reported: the baseline beside the diagnosed model (`stage`), where
/// their residuals lie, SysId's view of the same record.
fn report_of(
    rec: &Recording,
    data: &Dataset,
    base: Baseline,
    stage: Stage,
    found: Found,
) -> Diagnosis {
    let (structure, base_fit) = (base.structure, base.fit);
    let final_energy =
        regimes::energy_per_sample(data, &stage.fit.predicted, &base_fit.weighting.outputs);
    let base_total_energy: f64 = base.energy.iter().sum();
    let diagnosed_eval = evaluate(data, stage.fit.predicted.clone(), found.max_lag);
    let unexplained = unexplained(
        &found,
        &regimes::shares(found.regimes, &final_energy, final_energy.iter().sum()),
    );
    let params_of = |s: &Structure, p: &[f64]| -> BTreeMap<String, f64> {
        let m = s.model();
        m.params()
            .iter()
            .zip(p)
            .enumerate()
            .filter(|(i, _)| m.reports(*i))
            .map(|(_, (s, v))| (s.name.clone(), *v))
            .collect()
    };
    let baseline_params = params_of(structure, &base_fit.params);
    let final_params = params_of(&stage.structure, &stage.fit.params);
    // SysId's kS beside the diagnosed model: both as a torque at the motor shaft, with
    // the diagnosed model's own torque constant and resistance (the baseline's absorbed
    // the missing friction).
    let feedforward = crate::import::wpilib::feedforward::of_recording(
        rec,
        final_params
            .get(MotorParams::torque_constant_nm_a.key())
            .copied(),
        final_params.get(MotorParams::resistance_ohm.key()).copied(),
    );
    let sysid_terms = feedforward.as_ref().and_then(|ff| {
        let unit = match ff.speed_unit.as_str() {
            "m/s" => "m/s",
            "rad/s" => "rad/s",
            _ => return None,
        };
        crate::ident::sysid_terms::of_fit(stage.structure.model(), &stage.fit, unit)
    });
    let dt = {
        let mut dts: Vec<f64> = data.t_s.windows(2).map(|w| w[1] - w[0]).collect();
        dts.sort_by(f64::total_cmp);
        dts.get(dts.len() / 2).copied().unwrap_or(0.0)
    };
    Diagnosis {
        sysid_terms,
        baseline_estimates: crate::ident::param_reports(structure.model(), base_fit),
        final_estimates: crate::ident::param_reports(stage.structure.model(), &stage.fit),
        correlation_s: stage.fit.correlation_rows as f64 * dt,
        correlation_rows: stage.fit.correlation_rows,
        feedforward,
        relative_error_before_pct: relative_errors(data, &base_fit.predicted),
        relative_error_after_pct: relative_errors(data, &stage.fit.predicted),
        recording: data.name.clone(),
        model: structure.model().name(),
        baseline_fit_pct: base.eval.fit_pct_mean,
        baseline_params,
        baseline_at_bound: at_bound_of(structure, base_fit),
        left_out: found.left_out,
        ignored_inputs: crate::ident::ignored_inputs(
            rec,
            &crate::ident::model_columns(structure.model()),
        ),
        where_before: regimes::shares(found.regimes, base.energy, base_total_energy),
        where_after: regimes::shares(found.regimes, &final_energy, base_total_energy),
        unexplained,
        terms: found.terms,
        term_rounds: found.term_rounds,
        rounds: found.rounds,
        final_fit_pct: diagnosed_eval.fit_pct_mean,
        final_params,
        findings: found.findings,
        effective_n: effective_n(data, &base_fit.predicted).iter().sum(),
        baseline: base.eval,
        diagnosed: diagnosed_eval,
        validation: found.validation,
    }
}

/// Structure the residual keeps that no effect and no term explains.
#[derive(Debug, Clone, Serialize)]
pub struct Unexplained {
    /// Share of the diagnosed model's residual that the best fitted term, though it
    /// failed the rules, removed, %: what a model could still gain.
    pub fit_gap_pct: f64,
    /// Where: the regime the residual concentrates in and the quantity it correlates with.
    #[serde(rename = "where")]
    pub where_: String,
}

/// Share of the residual a fitted term must remove, though it failed the rules, for the
/// diagnosis to say structure remains unexplained.
pub const UNEXPLAINED_REDUCTION: f64 = 2.0 * MIN_RSS_REDUCTION;

/// Structure left unexplained: the last round accepted nothing, and a term fitted there
/// removed at least [`UNEXPLAINED_REDUCTION`] of the residual yet failed the rules (its
/// coefficient on a bound, undetermined, or not clear of zero; or too little evidence
/// counted with the effective residual count). A screen alone claims nothing: its
/// linearisation fails where the model is rough (a gear play).
fn unexplained(found: &Found, final_shares: &[RegimeShare]) -> Option<Unexplained> {
    let accepted = found.findings.len() + found.terms.len();
    if accepted >= found.rounds.len() {
        return None;
    }
    let search = found.term_rounds.last()?.as_ref()?;
    let top = search
        .fitted
        .iter()
        .filter(|t| !t.significant)
        .max_by(|a, b| a.rss_reduction_pct.total_cmp(&b.rss_reduction_pct))?;
    if top.rss_reduction_pct < 100.0 * UNEXPLAINED_REDUCTION {
        return None;
    }
    let regime = final_shares
        .iter()
        .filter(|s| s.concentration() > 1.5)
        .max_by(|a, b| a.concentration().total_cmp(&b.concentration()))
        .map_or("spread over the record".to_string(), |s| {
            format!(
                "{:.0}% of it in the {:.0}% of samples {}",
                s.energy_pct, s.samples_pct, s.regime
            )
        });
    let quantity = crate::model::term::Family::from_name(&top.name).map_or("", |f| f.quantity());
    Some(Unexplained {
        fit_gap_pct: top.rss_reduction_pct,
        where_: format!(
            "the residual lies {regime}; it follows the {quantity} most ({} removes {:.1} % of it but fails the rules)",
            top.name, top.rss_reduction_pct
        ),
    })
}

/// Refuses records that cannot support a decision. An input is excited when it takes at
/// least two levels and changes: within a test, or, for a test that starts from rest, by
/// the step from rest to its first value (a dynamic test's step is applied as the record
/// starts).
fn check_decidable(data: &Dataset, rec: &Recording) -> Result<(), IdentError> {
    let refuse = |why: String| IdentError::Mismatch {
        file: rec.path.clone(),
        message: why,
    };
    if data.len() < MIN_SAMPLES {
        return Err(refuse(format!(
            "{} samples is too short to decide whether physics is missing (at least {MIN_SAMPLES} needed)",
            data.len()
        )));
    }
    let speed = regimes::measured_speed(data);
    let segments: Vec<(std::ops::Range<usize>, bool)> = data
        .segments()
        .into_iter()
        .map(|r| (r.clone(), starts_at_rest(&speed, r)))
        .collect();
    for (i, u) in data.inputs.iter().enumerate() {
        let mut levels: Vec<f64> = u.clone();
        let mut changes = 0;
        for (segment, at_rest) in &segments {
            let u = &u[segment.clone()];
            changes += u.windows(2).filter(|w| w[0] != w[1]).count();
            if *at_rest && u[0] != 0.0 {
                levels.push(0.0);
                changes += 1;
            }
        }
        let (lo, hi) = levels
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(*v), b.max(*v))
            });
        if hi - lo <= 0.0 || changes < MIN_INPUT_CHANGES {
            return Err(refuse(format!(
                "input `{}` is not excited (range {lo}..{hi}, {changes} changes, counting a step from rest at a test's start): the record cannot tell the model's parameters from missing physics",
                data.input_names[i]
            )));
        }
    }
    Ok(())
}

/// Fewest input changes (a step from rest counts as one) a diagnosis decides on: one step
/// already shows the gain and the lag of the response.
pub const MIN_INPUT_CHANGES: usize = 1;

/// Whether a test starts at rest: its measured speed (the forward speed of a vehicle,
/// the shaft's of an axis) on its first row within 2 % of the test's largest (sensor noise
/// at standstill).
fn starts_at_rest(speed: &[f64], rows: std::ops::Range<usize>) -> bool {
    let speed = &speed[rows];
    let largest = speed.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    largest > 0.0 && speed[0].abs() <= 0.02 * largest
}

/// The free parameters of a fit that ended on a bound of their search, with the bound.
fn at_bound_of(s: &Structure, f: &crate::ident::fit::Fit) -> BTreeMap<String, f64> {
    let specs = s.model().params();
    f.free
        .iter()
        .filter_map(|&i| {
            let p = &specs[i];
            crate::ident::bound_reached(f.params[i], p.lo, p.hi).map(|b| (p.name.clone(), b))
        })
        .collect()
}
