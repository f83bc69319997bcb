//! Fitting one candidate effect on top of the current stage of a diagnosis, in two steps:
//!
//! 1. **Screen** (every candidate), on the record's first part ([`exploration_rows`]):
//!    the effect's parameter is placed by scans from the stage's fit and from the rig's
//!    beliefs, and the candidate is fitted from the best places with the nominal free
//!    parameters. Unless the full search follows, the whole record is then fitted from
//!    the screen's fits (a few iterations from there): a true fit of the whole record,
//!    whose gain is a lower bound on what the effect can earn.
//! 2. **Full search** (only a parameter too rough for derivatives, a backlash play, whose
//!    screen could still matter on the first part or on the whole record): a profile over
//!    the grid and an alternation of fits and line searches on the first part, then the
//!    whole record's fit from the best of them.
//!
//! Most candidates are absent and their screen shows it; the searching is done on a
//! fraction of the record, and the whole record is fitted once per candidate from where
//! the search ended.

use rayon::prelude::*;

use crate::ident::data::Dataset;
use crate::ident::effects::Effect;
use crate::ident::fit::{self, Fit, FitSettings};
use crate::ident::model::GreyBox;
use crate::ident::Structure;

use super::evidence::{effective_n, Gain};
use super::search::{effect_grid, golden, profile_scan, scan, start_with};
use super::{Candidate, Scales, MIN_RSS_REDUCTION};

/// Share of [`MIN_RSS_REDUCTION`] a screen must reach for the full search to be run: a
/// screened fit is a lower bound, and the full search of a present effect seldom gains
/// more than a few times its screen.
pub const SCREEN_SHARE: f64 = 1.0 / 3.0;

/// Share of the record the screens and the rough searches explore on, and the fewest rows
/// they take. The development records (4,000 to 20,000 rows) mostly explore on the
/// fewest; the bench's 30,000-row axis on 4,500.
pub const EXPLORE_SHARE: f64 = 0.15;
pub const MIN_EXPLORE_ROWS: usize = 2000;

/// Rows of the record's first part the searching is done on: [`EXPLORE_SHARE`] of them,
/// but at least [`MIN_EXPLORE_ROWS`] (enough engagements of a play to place it).
pub fn exploration_rows(rows: usize) -> usize {
    ((rows as f64 * EXPLORE_SHARE).ceil() as usize)
        .max(MIN_EXPLORE_ROWS)
        .min(rows)
}

/// Starts of a rough search that are alternated (the lowest-cost ones).
pub const ALTERNATED_STARTS: usize = 2;

/// What the candidate search needs of the diagnosis so far.
pub(super) struct Context<'a> {
    pub structure: &'a Structure,
    /// The stage's fit (the baseline, or the baseline with the effects accepted so far).
    pub fit: &'a Fit,
    /// Indices of the nominal model's free parameters.
    pub free_nominal: &'a [usize],
    /// The rig's beliefs of every nominal parameter.
    pub beliefs: &'a [f64],
    pub data: &'a Dataset,
    /// The record's first part ([`exploration_rows`]), where the scans, the screens and a
    /// rough parameter's search (profile and alternation) place the starts of the whole
    /// record's fit.
    pub explore: &'a Dataset,
    /// The stage's cost on [`Context::explore`].
    pub explore_stage_cost: f64,
    pub weights: &'a fit::Weighting,
    pub scales: &'a Scales,
    pub max_iterations: usize,
}

/// A candidate as fitted: the structure with the effect, the fit (if any start
/// simulated), and whether only its screen was run.
pub(super) struct Fitted {
    pub structure: Structure,
    pub fit: Option<Fit>,
    pub screened_only: bool,
}

/// The candidate's structure, the starts found by scanning, and the index sets its fits
/// need.
struct Setup {
    structure: Structure,
    grid: Vec<f64>,
    /// Best places of the effect's parameter, the others at the stage's fit.
    from_fit: Vec<f64>,
    /// The stage's fit with the nominal free parameters back at the rig's beliefs.
    believed: Vec<f64>,
    /// Index of the effect's own parameter.
    idx: usize,
    /// Free parameters besides the effect's own.
    others: Vec<usize>,
    /// Starts: first those from the stage's fit ([`Setup::fitted_starts`] of them), then
    /// the one from the rig's beliefs.
    starts: Vec<Vec<f64>>,
    fitted_starts: usize,
}

impl Context<'_> {
    /// Screens the candidate, and runs its full search when the screen could matter.
    pub fn fit(&self, e: Effect) -> Fitted {
        let setup = self.setup(e);
        let screened = self.screen(&setup);
        let rough = self.rough(&setup);
        let gain = |f: &Fit, stage_cost: f64| 1.0 - f.cost / stage_cost;
        let promising_on_part = screened
            .iter()
            .any(|f| gain(f, self.explore_stage_cost) >= SCREEN_SHARE * MIN_RSS_REDUCTION);
        let mut starts = setup.starts.clone();
        starts.extend(screened.iter().map(|f| f.params.clone()));
        if rough && promising_on_part {
            // The full search ends in fits of the whole record from its best starts, the
            // screen's among them: a whole-record fit of the screen first would be spent.
            return Fitted {
                fit: self.rough_search(&setup, starts),
                structure: setup.structure,
                screened_only: false,
            };
        }
        let screen = (!screened.is_empty())
            .then(|| {
                // The scans' start from the stage's fit is raced with the screen's: a
                // first part that cannot determine a parameter (a slow ramp, the mass)
                // leaves it anywhere, and the whole record's fit from there can settle in
                // a worse basin than from where the stage had it.
                let mut from: Vec<Vec<f64>> = screened.into_iter().map(|f| f.params).collect();
                from.extend(setup.starts.first().cloned());
                self.fit_from(&setup, from, self.data)
            })
            .flatten();
        // The first part can miss what the rest of the record shows: the whole record's fit
        // can still call for the full search.
        let promising = screen
            .as_ref()
            .is_some_and(|f| gain(f, self.fit.cost) >= SCREEN_SHARE * MIN_RSS_REDUCTION);
        if !promising || !rough {
            return Fitted {
                structure: setup.structure,
                fit: screen,
                screened_only: rough,
            };
        }
        if let Some(f) = &screen {
            starts.push(f.params.clone());
        }
        // The screen is a fit too: keep whichever is lower.
        let best = lower(self.rough_search(&setup, starts), screen);
        Fitted {
            structure: setup.structure,
            fit: best,
            screened_only: false,
        }
    }

    /// The screen's fits on the record's first part, from the scans' starts: where the
    /// whole record's fit starts from (raced). A fit of the first part costs a fraction of
    /// the whole record's, and lands close enough to its minimum that the whole record's
    /// fit from there takes a few iterations.
    fn screen(&self, setup: &Setup) -> Vec<Fit> {
        let fitted = if self.stage_has_effects() {
            // A later round: the stage's nominal parameters were themselves fitted with an
            // effect from the rig's beliefs, so the start from the beliefs is raced with
            // the others (on the development records it never won a later round, and
            // fitted on its own it was half of a vehicle's diagnosis time).
            vec![self.fit_from(setup, setup.starts.clone(), self.explore)]
        } else {
            // The starts from the stage's fit are raced; the start from the rig's beliefs
            // is far from converged after a few iterations (that is its point: a basin
            // the baseline has left by absorbing the effect into a nominal parameter,
            // a delay into the inductance), so it is fitted on its own, and both basins go
            // on to the whole record (the first part can rank them wrongly: a DCMC's speed
            // loop whose integral barely acts in the record's first seconds).
            let (from_fit, from_rig) = setup.starts.split_at(setup.fitted_starts);
            let (a, b) = rayon::join(
                || self.fit_from(setup, from_fit.to_vec(), self.explore),
                || self.fit_from(setup, from_rig.to_vec(), self.explore),
            );
            vec![a, b]
        };
        fitted.into_iter().flatten().collect()
    }

    /// Whether the stage already carries an accepted effect (a round after the first):
    /// every effect adds its parameters to the nominal ones.
    fn stage_has_effects(&self) -> bool {
        self.fit.params.len() > self.beliefs.len()
    }

    fn setup(&self, e: Effect) -> Setup {
        let stage = self.fit;
        let s = self.scales;
        let (grid, lo, hi) = effect_grid(e, s);
        let probe = self.structure.with_effect(e, grid[0], lo, hi, s.speed_max);
        // Scan from the stage's fit, and from the rig's beliefs: a baseline can absorb an
        // effect into a nominal parameter (a delay into an inflated inductance), which
        // hides the effect's true value from a scan there.
        let mut believed = stage.params.clone();
        for &i in self.free_nominal {
            believed[i] = self.beliefs[i];
        }
        let (from_fit, from_rig) = rayon::join(
            || scan(&probe, &stage.params, &grid, self.explore, self.weights),
            || scan(&probe, &believed, &grid, self.explore, self.weights),
        );
        let s1 = from_fit.first().copied().unwrap_or(grid[0]);
        let structure = self.structure.with_effect(e, s1, lo, hi, s.speed_max);
        let m = structure.model();
        let idx = m.params().len() - 1;
        let start_at = |base: &[f64], g: f64| start_with(m, base, idx, g);
        let starts: Vec<Vec<f64>> = from_fit
            .iter()
            .take(2)
            .map(|&g| start_at(&stage.params, g))
            .chain(from_rig.iter().take(1).map(|&g| start_at(&believed, g)))
            .collect();
        let fitted_starts = from_fit.len().min(2);
        // The block's nuisance parameters are fitted with the nominal ones, and so are
        // parameters the effect makes identifiable that the nominal model could not
        // separate (a play splits the inertia and damping between its two sides).
        let mut others = stage.free.clone();
        others.extend(stage.params.len()..idx);
        for i in structure.newly_identifiable(e, &self.data.output_names) {
            if !others.contains(&i) {
                others.push(i);
            }
        }
        Setup {
            structure,
            grid,
            from_fit,
            believed,
            idx,
            others,
            starts,
            fitted_starts,
        }
    }

    /// A parameter whose cost is too rough for derivatives on small scales.
    fn rough(&self, setup: &Setup) -> bool {
        setup.structure.model().params()[setup.idx].fd_step > 1e-6
    }

    fn settings(&self, free: Vec<usize>, starts: Vec<Vec<f64>>) -> FitSettings {
        FitSettings {
            free,
            weighting: self.weights.clone(),
            max_iterations: self.max_iterations,
            starts,
        }
    }

    /// The stage's own structure refitted from where a candidate's fit ended (its
    /// parameters without the effect's, which come last): a rough candidate's search can
    /// lead the shared parameters out of a poor minimum of the stage, a gain that is no
    /// evidence for the effect.
    pub fn stage_refit_from(&self, candidate_params: &[f64]) -> Option<Fit> {
        let m = self.structure.model();
        let start = candidate_params[..m.params().len()].to_vec();
        let settings = self.settings(self.fit.free.clone(), vec![start]);
        fit::fit_raced(m, self.data, &settings).ok()
    }

    /// The candidate fitted on `data`, every free parameter and the effect's, from `starts`.
    fn fit_from(&self, setup: &Setup, starts: Vec<Vec<f64>>, data: &Dataset) -> Option<Fit> {
        let mut free = setup.others.clone();
        free.push(setup.idx);
        fit::fit_raced(setup.structure.model(), data, &self.settings(free, starts)).ok()
    }

    /// The full search of a rough parameter: a profile over every fourth grid value from
    /// the rig's beliefs adds starts; from each, fits of the others with the parameter
    /// held alternate with line searches of the parameter with the others held; then the
    /// final fit from all of them.
    fn rough_search(&self, setup: &Setup, mut starts: Vec<Vec<f64>>) -> Option<Fit> {
        let m = setup.structure.model();
        let s1 = setup.from_fit.first().copied().unwrap_or(setup.grid[0]);
        let coarse: Vec<f64> = setup.grid.iter().step_by(4).copied().collect();
        let profile_start = start_with(m, &setup.believed, setup.idx, s1);
        starts.extend(profile_scan(
            &setup.structure,
            &profile_start,
            setup.idx,
            &setup.others,
            &coarse,
            self.explore,
            self.weights,
        ));
        // Alternation is the costly part: only from the starts that begin lowest.
        let mut ranked: Vec<(f64, Vec<f64>)> = starts
            .into_iter()
            .map(|p| (self.cost(m, &p, self.explore), p))
            .collect();
        ranked.sort_by(|a, b| a.0.total_cmp(&b.0));
        ranked.truncate(ALTERNATED_STARTS);
        let alternated: Vec<Vec<f64>> = ranked
            .into_par_iter()
            .map(|(_, p)| self.alternate(setup, p))
            .collect();
        // Each alternated start sits at the bottom of its basin on the first part, so a
        // few iterations on the whole record rank them as the end would.
        self.fit_from(setup, alternated, self.data)
    }

    /// Weighted residual sum of squares at `p` on `data`.
    fn cost(&self, m: &dyn GreyBox, p: &[f64], data: &Dataset) -> f64 {
        fit::cost_at(m, p, data, self.weights)
    }

    /// Three passes of: fit the others with the rough parameter held, then place it by a
    /// golden-section search within a factor 1.5 with the others held.
    fn alternate(&self, setup: &Setup, mut p: Vec<f64>) -> Vec<f64> {
        let m = setup.structure.model();
        let idx = setup.idx;
        for _ in 0..3 {
            let settings = self.settings(setup.others.clone(), vec![p.clone()]);
            let Ok(f) = fit::minimise(m, self.explore, &settings) else {
                break;
            };
            p = f.params;
            let at = |g: f64| {
                let mut q = p.clone();
                q[idx] = g;
                self.cost(m, &q, self.explore)
            };
            p[idx] = golden(&at, p[idx] / 1.5, p[idx] * 1.5, 16).unwrap_or(p[idx]);
        }
        p
    }
}

/// The fit of lower cost, or whichever exists.
fn lower(a: Option<Fit>, b: Option<Fit>) -> Option<Fit> {
    match (a, b) {
        (Some(a), Some(b)) => Some(if b.cost < a.cost { b } else { a }),
        (a, b) => a.or(b),
    }
}

/// The most significant candidate whose gain is its effect's: it must also beat the stage's
/// own structure refitted from where the candidate's fit ended
/// ([`Context::stage_refit_from`]) by the same rule (AIC gain, share of the
/// residual). A candidate that does not is marked not significant in `round`.
pub(super) fn earned_beyond_the_stage(
    context: &Context,
    data: &Dataset,
    significants: &mut Vec<(f64, Effect, Structure, Fit)>,
    round: &mut [Candidate],
) -> Option<(f64, Effect, Structure, Fit)> {
    significants.sort_by(|a, b| b.0.total_cmp(&a.0));
    for (delta_aic, e, cand, f) in significants.drain(..) {
        let earned = match context.stage_refit_from(&f.params) {
            Some(null) if null.cost < context.fit.cost => {
                Gain::of(data, &null, &effective_n(data, &null.predicted), &f).passes()
            }
            _ => true,
        };
        if earned {
            return Some((delta_aic, e, cand, f));
        }
        if let Some(c) = round.iter_mut().find(|c| c.name == e.name()) {
            c.significant = false;
            c.reached_without_it = true;
        }
    }
    None
}
