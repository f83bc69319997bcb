//! Placing an effect's parameter before the local fit: a scan grid per effect, a grid
//! scan with golden-section refinement, and the golden-section search itself.

use rayon::prelude::*;

use crate::ident::data::Dataset;
use crate::ident::effects::{Effect, Scale, Scaled, Spacing};
use crate::ident::fit;
use crate::ident::model::GreyBox;
use crate::ident::Structure;

use super::Scales;

/// A scan grid and the bounds of an effect's parameter: its declaration's grid
/// ([`crate::ident::effects::Grid`]) placed by the record's scales. Effects like backlash
/// have narrow basins (a wrong play shifts every engagement), so a local solver needs a
/// start found by scanning the parameter with the baseline's other values.
pub(super) fn effect_grid(e: Effect, s: &Scales) -> (Vec<f64>, f64, f64) {
    let g = e.def().grid;
    let at = |v: Scaled| v.times * scale(v.of, s);
    let (a, b, n) = (at(g.from), at(g.to), g.n);
    let grid = match g.spacing {
        Spacing::Log => (0..n)
            .map(|i| a * (b / a).powf(i as f64 / (n - 1) as f64))
            .collect(),
        Spacing::Linear => (0..n)
            .map(|i| a + (b - a) * i as f64 / (n - 1) as f64)
            .collect(),
    };
    (grid, at(g.lo), at(g.hi))
}

/// A record's scale ([`Scale`]) as the diagnosis measured it.
fn scale(of: Scale, s: &Scales) -> f64 {
    match of {
        Scale::One => 1.0,
        Scale::Effort => s.effort,
        Scale::SupplyV => s.v_max,
        Scale::SampleS => s.dt,
        Scale::SampleAtLeastMsS => s.dt.max(1e-3),
        Scale::SpeedLoopGain => s.v_max / s.speed_max.max(1e-9) / s.tau.max(1e-6),
        Scale::WeightN => s.weight_n.max(1e-6),
    }
}

/// The best values of an effect's parameter, the others held at `params` (a block's
/// nuisance parameters at their starts): a grid scan, then a golden-section search between
/// the neighbours of each of the (up to three, non-adjacent) best grid points. Parameters
/// that switch at events (backlash) leave a cost too rough for derivatives on small
/// scales, so this search, not the local solver, places them.
pub(super) fn scan(
    cand: &Structure,
    params: &[f64],
    grid: &[f64],
    data: &Dataset,
    weights: &fit::Weighting,
) -> Vec<f64> {
    let m = cand.model();
    let idx = m.params().len() - 1;
    let cost = |g: f64| fit::cost_at(m, &start_with(m, params, idx, g), data, weights);
    let scored: Vec<f64> = grid.par_iter().map(|&g| cost(g)).collect();
    let mut order: Vec<usize> = (0..grid.len()).filter(|&i| scored[i].is_finite()).collect();
    order.sort_by(|&a, &b| scored[a].total_cmp(&scored[b]));
    let mut picked: Vec<usize> = Vec::new();
    for i in order {
        if picked.iter().all(|&j| i.abs_diff(j) > 1) {
            picked.push(i);
        }
        if picked.len() == 3 {
            break;
        }
    }
    picked
        .par_iter()
        .map(|&i| {
            let lo = grid[i.saturating_sub(1)];
            let hi = grid[(i + 1).min(grid.len() - 1)];
            golden(&cost, lo, hi, 8).unwrap_or(grid[i])
        })
        .collect()
}

/// Golden-section minimum of `f` on [a, b] (on a log scale when both are positive).
pub(super) fn golden(f: &dyn Fn(f64) -> f64, a: f64, b: f64, iterations: usize) -> Option<f64> {
    let log = a > 0.0 && b > 0.0;
    let (to, from) = (
        move |x: f64| if log { x.ln() } else { x },
        move |x: f64| if log { x.exp() } else { x },
    );
    let (mut lo, mut hi) = (to(a.min(b)), to(a.max(b)));
    if hi <= lo {
        return None;
    }
    let r = 0.5 * (5f64.sqrt() - 1.0);
    let mut x1 = hi - r * (hi - lo);
    let mut x2 = lo + r * (hi - lo);
    let (mut f1, mut f2) = (f(from(x1)), f(from(x2)));
    for _ in 0..iterations {
        if f1 < f2 {
            hi = x2;
            x2 = x1;
            f2 = f1;
            x1 = hi - r * (hi - lo);
            f1 = f(from(x1));
        } else {
            lo = x1;
            x1 = x2;
            f1 = f2;
            x2 = lo + r * (hi - lo);
            f2 = f(from(x2));
        }
    }
    Some(from(if f1 < f2 { x1 } else { x2 }))
}

/// Profile scan of a rough parameter: at each grid value, held, a few iterations of the
/// other free parameters from `start` (a parameter like a backlash play shifts every
/// engagement, and the nominal parameters fitted without it lean away from it, so a scan
/// with them held can miss the true play's basin entirely). Returns up to two non-adjacent
/// best grid points, each with the parameters fitted there.
pub(super) fn profile_scan(
    cand: &Structure,
    start: &[f64],
    idx: usize,
    others: &[usize],
    grid: &[f64],
    data: &Dataset,
    weights: &fit::Weighting,
) -> Vec<Vec<f64>> {
    let m = cand.model();
    let fitted: Vec<Option<(f64, Vec<f64>)>> = grid
        .par_iter()
        .map(|&g| {
            let mut p = start.to_vec();
            p[idx] = g;
            let settings = fit::FitSettings {
                free: others.to_vec(),
                weighting: weights.clone(),
                max_iterations: 8,
                starts: vec![p],
            };
            fit::minimise(m, data, &settings)
                .ok()
                .map(|f| (f.cost, f.params))
        })
        .collect();
    let mut order: Vec<usize> = (0..grid.len()).filter(|&i| fitted[i].is_some()).collect();
    order.sort_by(|&a, &b| {
        let c = |i: usize| fitted[i].as_ref().map_or(f64::INFINITY, |f| f.0);
        c(a).total_cmp(&c(b))
    });
    let mut picked: Vec<usize> = Vec::new();
    for i in order {
        if picked.iter().all(|&j| i.abs_diff(j) > 1) {
            picked.push(i);
        }
        if picked.len() == 2 {
            break;
        }
    }
    picked
        .into_iter()
        .filter_map(|i| fitted[i].as_ref().map(|f| f.1.clone()))
        .collect()
}

/// A start for a candidate: `base` (the stage's parameters), the block's nuisance
/// parameters at their nominal values, and the effect's own (index `idx`) at `g`.
pub(super) fn start_with(m: &dyn GreyBox, base: &[f64], idx: usize, g: f64) -> Vec<f64> {
    let mut p = base.to_vec();
    p.extend(m.params()[base.len()..].iter().map(|s| s.nominal));
    p[idx] = g;
    p
}
