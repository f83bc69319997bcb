//! What a diagnosis gives: each candidate as fitted, the effects found with their
//! alternatives, the terms, where the residual was before and after, and the contract's
//! JSON.

use crate::model::motor::MotorParams;

use std::collections::BTreeMap;

use serde::Serialize;

use super::regimes::RegimeShare;
use super::{terms, MIN_RSS_REDUCTION};
use crate::ident::effects::Effect;
use crate::ident::Evaluation;

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
    pub feedforward: Option<crate::ident::sysid_regression::Report>,
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
