//! One round of the diagnosis: every candidate effect not yet found is fitted from the
//! stage in parallel, each is judged (its gain, whether its own parameter ends on a bound
//! of its search or where the effect vanishes, whether the record determines it), and the
//! best significant one that earned its gain beyond the stage becomes the round's finding,
//! with the regime its evidence lies in and the rivals it barely beat.

use rayon::prelude::*;

use super::evidence::{self, describe, effective_n, Gain};
use super::scales::Scales;
use super::{
    candidate, regimes, terms, Alternative, Candidate, DiagnoseOptions, Finding, Stage,
    MIN_DELTA_AIC,
};
use crate::ident::data::Dataset;
use crate::ident::effects::Choice;
use crate::ident::effects::{Effect, NullBound};
use crate::ident::fit::Fit;
use crate::ident::Structure;

/// A significant candidate: its AIC gain, the effect, and the structure and fit with it.
pub(super) type Significant = (f64, Effect, Structure, Fit);

/// How many times a round's best effect's AIC gain a term's must exceed to be named in
/// its place (see [`Rounds::run`]).
pub const VOCABULARY_PREFERENCE: f64 = 2.0;

/// What the rounds found: every round's table of effects and of terms,
/// the effects and the terms accepted (each with its round).
#[derive(Default)]
pub(super) struct Outcome {
    pub rounds: Vec<Vec<Candidate>>,
    pub term_rounds: Vec<Option<terms::Search>>,
    pub findings: Vec<Finding>,
    pub terms: Vec<terms::TermFinding>,
}

/// What every round of one diagnosis shares: the record, the baseline's residual energy
/// by regime, and how progress is told.
pub(super) struct Rounds<'a> {
    pub data: &'a Dataset,
    pub regimes: &'a [regimes::Regime],
    /// The baseline's residual energy per sample.
    pub base_energy: &'a [f64],
    /// Whether the model is a linear axis (its parameters are named in N, not N m).
    pub linear: bool,
    pub tell: &'a (dyn Fn(String) + Sync),
}

impl Rounds<'_> {
    /// Up to [`super::ROUNDS`] rounds from the baseline `stage`: each fits the candidates
    /// not yet found, and the best that earned its gain is the next stage. The last stage,
    /// every round's table, and the findings in the order accepted.
    pub fn run(
        &self,
        mut stage: Stage,
        free: &[usize],
        scales: &Scales,
        opts: &DiagnoseOptions,
    ) -> (Stage, Outcome) {
        let data = self.data;
        let explore = data.prefix(candidate::exploration_rows(data.len()));
        let beliefs = stage.structure.model().nominal();
        let weights = stage.fit.weighting.clone();
        let applicable = stage.structure.applicable();
        let mut out = Outcome::default();
        // The regimes the findings' evidence named, with their effects: the next names
        // another.
        let mut named: Vec<(String, &str)> = Vec::new();
        for round_no in 1..=super::ROUNDS {
            let stage_n = effective_n(data, &stage.fit.predicted);
            let candidates: Vec<Effect> = applicable
                .iter()
                .copied()
                .filter(|e| !out.findings.iter().any(|f| f.effect == *e))
                .filter(|e| opts.effects.admits(*e))
                .collect();
            let context = candidate::Context {
                structure: &stage.structure,
                fit: &stage.fit,
                free_nominal: free,
                beliefs: &beliefs,
                data,
                explore: &explore,
                explore_stage_cost: crate::ident::fit::cost_at(
                    stage.structure.model(),
                    &stage.fit.params,
                    &explore,
                    &weights,
                ),
                weights: &weights,
                scales,
                max_iterations: opts.ident.max_iterations,
            };
            let mut round = Vec::new();
            let mut significants: Vec<Significant> = Vec::new();
            for (e, fitted) in self.fit_all(&context, round_no, &candidates) {
                if let Some((row, significant)) = self.judge(&stage, &stage_n, e, fitted) {
                    round.push(row);
                    significants.extend(significant);
                }
            }
            let best =
                candidate::earned_beyond_the_stage(&context, data, &mut significants, &mut round);
            round.sort_by(|a, b| b.delta_aic.total_cmp(&a.delta_aic));
            let search = (opts.effects == Choice::All)
                .then(|| {
                    let tell = |m: String| (self.tell)(format!("round {round_no}: terms: {m}"));
                    terms::search(data, &stage, &stage_n, opts.ident.max_iterations, &tell)
                })
                .flatten();
            let term = search.as_ref().and_then(|s| s.best.clone());
            out.term_rounds.push(search);
            // A vocabulary effect that explains the residual keeps its name: a term wins
            // a round only with more than twice the best effect's evidence (and the
            // rule's margin). A speed power of 0.5 mimics Coulomb friction: on the
            // development recordings with Coulomb friction it reaches 94 % of the
            // friction's gain; on those with a term the best effect reaches 7 % of its.
            let term_wins = match (&term, &best) {
                (Some(t), Some(b)) => {
                    t.gain.delta_aic > VOCABULARY_PREFERENCE * b.0 + MIN_DELTA_AIC
                }
                (Some(_), None) => true,
                (None, _) => false,
            };
            if let (true, Some(t)) = (term_wins, term) {
                out.terms.push(self.term_finding(
                    &stage,
                    &t,
                    round_no,
                    &weights.outputs,
                    &mut named,
                ));
                out.rounds.push(round);
                stage = Stage {
                    structure: t.structure,
                    fit: t.fit,
                };
                continue;
            }
            let Some(best) = best else {
                out.rounds.push(round);
                break;
            };
            let mut finding = self.finding(&stage, &best, &round, &weights.outputs, &mut named);
            finding.round = round_no;
            out.findings.push(finding);
            out.rounds.push(round);
            let (_, _, cand, f) = best;
            stage = Stage {
                structure: cand,
                fit: f,
            };
        }
        (stage, out)
    }

    /// Where the residual an accepted fit removes from the stage's lay, as a sentence; the
    /// regime it names is added to `named` under `name` (the next finding names another).
    fn evidence_of(
        &self,
        stage: &Stage,
        fit: &Fit,
        weights_outputs: &[f64],
        named: &mut Vec<(String, &'static str)>,
        name: &'static str,
    ) -> String {
        let after = regimes::energy_per_sample(self.data, &fit.predicted, weights_outputs);
        let removed: Vec<f64> = self
            .base_energy
            .iter()
            .zip(&after)
            .map(|(a, b)| (a - b).max(0.0))
            .collect();
        let (evidence, regime) = evidence::evidence(
            &regimes::shares(self.regimes, &removed, removed.iter().sum()),
            100.0 * (1.0 - fit.rss() / stage.fit.rss()),
            named,
        );
        named.extend(regime.map(|r| (r, name)));
        evidence
    }

    /// An accepted term as a finding: where the residual it removes lay.
    fn term_finding(
        &self,
        stage: &Stage,
        t: &terms::Fitted,
        round: usize,
        weights_outputs: &[f64],
        named: &mut Vec<(String, &'static str)>,
    ) -> terms::TermFinding {
        let evidence =
            self.evidence_of(stage, &t.fit, weights_outputs, named, t.form.family.name());
        terms::TermFinding {
            evidence: format!(
                "{evidence}; on the held-out half of the record's time blocks it removed {:.0}% of the residual",
                t.row.held_out_reduction_pct
            ),
            description: terms::describe(&t.row),
            quantity: match &t.structure {
                crate::ident::Structure::Rotary(m) => {
                    terms::quantity_series(t.form, self.data, m.ratio)
                }
                _ => None,
            },
            row: t.row.clone(),
            round,
        }
    }

    /// Fits every candidate in parallel from the stage `context` holds, telling each as it
    /// finishes; in the candidates' order.
    pub fn fit_all(
        &self,
        context: &candidate::Context,
        round_no: usize,
        candidates: &[Effect],
    ) -> Vec<(Effect, candidate::Fitted)> {
        (self.tell)(format!(
            "round {round_no}: {} candidate effects, fitted in parallel",
            candidates.len()
        ));
        let finished = std::sync::atomic::AtomicUsize::new(0);
        candidates
            .par_iter()
            .map(|&e| {
                let fitted = context.fit(e);
                let k = finished.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
                let how = if fitted.screened_only {
                    " (screened: too little gain for the full search)"
                } else {
                    ""
                };
                (self.tell)(format!(
                    "round {round_no}: {} fitted ({k} of {}){how}",
                    e.name(),
                    candidates.len()
                ));
                (e, fitted)
            })
            .collect()
    }

    /// A fitted candidate's row of the round's table, and the candidate itself if it is
    /// significant; `None` where no start of it simulated.
    pub fn judge(
        &self,
        stage: &Stage,
        stage_n: &[f64],
        e: Effect,
        fitted: candidate::Fitted,
    ) -> Option<(Candidate, Option<Significant>)> {
        let candidate::Fitted {
            structure: cand,
            fit: f,
            screened_only,
        } = fitted;
        let f = f?;
        let gain = Gain::of(self.data, &stage.fit, stage_n, &f);
        // An effect whose own parameter sits at the bound where the effect vanishes
        // (a play of 0.1 mrad) did not earn the gain: its block's other physics did.
        let idx = f.params.len() - 1;
        let lo = cand.model().params()[idx].lo;
        let hi = cand.model().params()[idx].hi;
        let value = f.params[idx];
        let at_null_bound = match e.def().null_bound {
            NullBound::Neither => false,
            NullBound::Upper => value > hi / 1.5,
            NullBound::Lower => lo > 0.0 && value < 1.5 * lo,
        };
        let slot = f.free.len() - 1;
        // An effect whose parameter ends on either bound of its search (a peak friction
        // coefficient of 0.05, a 500 ms delay) or that the record does not determine
        // is no finding, whatever its gain: the gain is the search's, not the physics'.
        let at_bound = crate::ident::bound_reached(value, lo, hi);
        let undetermined = f.std[slot].is_none();
        let significant = gain.passes() && !at_null_bound && at_bound.is_none() && !undetermined;
        let row = Candidate {
            name: e.name().into(),
            param: e.param_name(self.linear).into(),
            value,
            std: f.std[slot],
            fit_pct: crate::ident::fit_pct_mean(self.data, &f.predicted),
            rss_reduction_pct: 100.0 * gain.reduction,
            delta_aic: gain.delta_aic,
            significant,
            screened_only,
            reached_without_it: false,
            at_bound,
            undetermined,
        };
        Some((row, significant.then_some((gain.delta_aic, e, cand, f))))
    }

    /// The round's best candidate as a finding: its value, the regime its evidence lies in
    /// (`named` holds the regimes earlier findings named; this one's is added) and the
    /// significant rivals within [`MIN_DELTA_AIC`] of it in `round`.
    pub fn finding(
        &self,
        stage: &Stage,
        best: &Significant,
        round: &[Candidate],
        weights_outputs: &[f64],
        named: &mut Vec<(String, &'static str)>,
    ) -> Finding {
        let (best_aic, e, _, f) = best;
        let alternatives: Vec<Alternative> = round
            .iter()
            .filter(|c| c.name != e.name() && c.significant)
            .filter(|c| best_aic - c.delta_aic < MIN_DELTA_AIC)
            .filter_map(|c| {
                let other = Effect::from_name(&c.name)?;
                Some(Alternative {
                    name: c.name.clone(),
                    param: c.param.clone(),
                    value: c.value,
                    delta_aic_behind: best_aic - c.delta_aic,
                    separated_by: evidence::what_separates(*e, other),
                })
            })
            .collect();
        let evidence = self.evidence_of(stage, f, weights_outputs, named, e.name());
        let idx = f.params.len() - 1;
        Finding {
            effect: *e,
            param: e.param_name(self.linear).into(),
            value: f.params[idx],
            std: f.std[f.free.len() - 1],
            fit_pct: crate::ident::fit_pct_mean(self.data, &f.predicted),
            evidence,
            description: describe(*e, f.params[idx], self.linear),
            alternatives,
            round: 0,
        }
    }
}
