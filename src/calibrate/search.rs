//! The staged search of a calibration: the free keys fitted through the simulator (a
//! stage), each effect tried on a stage from a scan over its key's range, and the evidence
//! that decides whether the recording supports it.

use rayon::prelude::*;

use super::{effects, keys, CalibrateError, EffectTrial, SceneReplay};
use crate::diagnose::evidence::{effective_n, Gain};
use crate::ident::data::Dataset;
use crate::ident::fit::{fit_predictor, residuals, Fit, FitError, FitSettings, Weighting};
use crate::ident::model::{ParamSpec, Predictor};
use crate::record::Recording;
use crate::scene::Scene;

/// One fit of the scene's keys: the scene as fitted (a key at a bound keeps its start).
#[derive(Clone)]
pub(super) struct Stage {
    pub scene: Scene,
    pub free: Vec<String>,
    pub fit: Fit,
    pub specs: Vec<ParamSpec>,
}

impl Stage {
    pub fn at_bound(&self, i: usize) -> Option<f64> {
        crate::ident::bound_reached(self.fit.params[i], self.specs[i].lo, self.specs[i].hi)
    }
}

/// What every fit of one calibration shares.
pub(super) struct Problem<'a> {
    pub rec: &'a Recording,
    /// The scene as the user wrote it, and the keys fitted with every effect.
    pub belief: &'a Scene,
    pub free: Vec<String>,
    /// Effect keys of either sign, with their search half-widths.
    pub signed: Vec<(String, f64)>,
    pub data: Dataset,
    /// How every fit after the first stage weighs outputs and beliefs (the first stage's).
    pub weighting: Weighting,
}

/// Restarts of the first stage's fit at most ([`Problem::first_stage`]).
const MAX_RESTARTS: usize = 3;

/// Share of its cost a restart must remove for another to follow.
const RESTART_GAIN: f64 = 0.01;

/// Iteration limit of each fit through the simulator.
const MAX_ITERATIONS: usize = 30;

impl Problem<'_> {
    /// The first stage: the `free` keys of `scene` fitted from its values in the two
    /// passes of [`crate::ident::fit_weighted`] (outputs weighted by their residual
    /// floored at their noise; a key whose belief the user's scene states,
    /// `[uncertainty_pct]`, held near it where the recording cannot determine it). Its
    /// weighting is the one every later fit of the calibration uses, as a diagnosis's
    /// candidates use its baseline's: evidence compares fits weighed alike.
    pub fn first_stage(&mut self, scene: &Scene, free: &[String]) -> Result<Stage, CalibrateError> {
        let stage = self.stage(scene, free, |model, slots, start| {
            crate::ident::fit_weighted(model, &self.data, slots, MAX_ITERATIONS, vec![start])
        })?;
        self.weighting = stage.fit.weighting.clone();
        // The simulator's play and friction make the cost rough: a fit stops in a dent
        // that a restart (its damping reset) leaves. Restarted while that gains.
        let mut stage = stage;
        for _ in 0..MAX_RESTARTS {
            let again = self.fit(&stage.scene, free)?;
            let gained = 1.0 - again.fit.cost / stage.fit.cost;
            if gained > 0.0 {
                stage = again;
            }
            if gained < RESTART_GAIN {
                break;
            }
        }
        Ok(stage)
    }

    /// Fits the `free` keys of `scene` from its values with the calibration's weighting.
    pub fn fit(&self, scene: &Scene, free: &[String]) -> Result<Stage, CalibrateError> {
        self.stage(scene, free, |model, slots, start| {
            let settings = FitSettings {
                free: slots.to_vec(),
                weighting: self.weighting.clone(),
                max_iterations: MAX_ITERATIONS,
                starts: vec![start],
            };
            fit_predictor(model, &self.data, &settings)
        })
    }

    /// The stage `fit` reaches from `scene`'s values of the `free` keys. A key that ends at
    /// a bound, or that neither the recording nor a belief determines, keeps its start.
    fn stage(
        &self,
        scene: &Scene,
        free: &[String],
        fit: impl Fn(&SceneReplay, &[usize], Vec<f64>) -> Result<Fit, FitError>,
    ) -> Result<Stage, CalibrateError> {
        let model = SceneReplay::with_signed(scene, self.rec, free, &self.signed)?
            .believing(self.belief, &self.free)?;
        let start: Vec<f64> = free
            .iter()
            .map(|k| keys::get(scene, k))
            .collect::<Result<_, _>>()?;
        let fit =
            fit(&model, &(0..free.len()).collect::<Vec<_>>(), start.clone()).map_err(|e| {
                CalibrateError::Fit {
                    file: self.rec.path.clone(),
                    message: e.to_string(),
                }
            })?;
        let specs = model.param_specs().to_vec();
        let kept: Vec<f64> = (0..free.len())
            .map(|i| {
                let b = crate::ident::bound_reached(fit.params[i], specs[i].lo, specs[i].hi);
                if b.is_some() || fit.std[i].is_none() {
                    start[i]
                } else {
                    fit.params[i]
                }
            })
            .collect();
        Ok(Stage {
            scene: model.scene_with(&kept)?,
            free: free.to_vec(),
            fit,
            specs,
        })
    }

    /// The scene with the free keys back at the user's values (accepted effects' keys kept).
    fn with_beliefs(&self, scene: &Scene) -> Result<Scene, CalibrateError> {
        let beliefs: Vec<(String, f64)> = self
            .free
            .iter()
            .map(|k| Ok((k.clone(), keys::get(self.belief, k)?)))
            .collect::<Result<_, CalibrateError>>()?;
        keys::set(scene, &beliefs)
    }

    /// The stage refitted from the beliefs with its effects at their fitted strengths,
    /// if that fits better: an effect fitted from a distorted start can leave the free
    /// keys in a poorer minimum, and the next round's effects must not be credited with
    /// the gain of leaving it.
    pub fn polished(&self, stage: Stage) -> Result<Stage, CalibrateError> {
        let again = self.fit(&self.with_beliefs(&stage.scene)?, &stage.free)?;
        Ok(if again.fit.cost < stage.fit.cost {
            again
        } else {
            stage
        })
    }

    /// Where the effect's key starts its fit: the lowest cost of a scan over its search
    /// range (a tenth to ten times its start, nine values a factor 1.78 apart; for a key of
    /// either sign, nine values evenly across its range), the other
    /// keys held. A play or a clipping limit moves the outputs in steps the gradient
    /// cannot see across, so the fit must start in the right basin.
    fn scan_start(&self, scene: &Scene, home: &effects::Home) -> Result<f64, CalibrateError> {
        let model =
            SceneReplay::with_signed(scene, self.rec, &[home.key.to_string()], &self.signed)?;
        let values: Vec<f64> = (-4..=4)
            .map(|i| match home.signed_range {
                Some(range) => range * i as f64 / 4.0,
                None => home.start * 10f64.powf(i as f64 / 4.0),
            })
            .collect();
        let costs: Vec<f64> = values
            .par_iter()
            .map(|&v| {
                model.predict(&[v], &self.data).map_or(f64::INFINITY, |y| {
                    residuals(&self.data, &y, &self.weighting.outputs)
                        .iter()
                        .map(|r| r * r)
                        .sum()
                })
            })
            .collect();
        let best = (0..values.len()).fold(0, |b, i| if costs[i] < costs[b] { i } else { b });
        Ok(values[best])
    }

    /// The fit moved on while the effect's key ends at the edge of its search window where
    /// the effect grows (a window is a factor of 10 around where the scan started it, not a
    /// physical limit): up to twice, the window is centred on that edge and the fit
    /// resumed, kept if it fits better. At the edge where the effect vanishes it stays: the
    /// recording does not support the effect.
    fn beyond_the_window(
        &self,
        mut stage: Stage,
        home: &effects::Home,
        free: &[String],
    ) -> Result<Stage, CalibrateError> {
        let i = free.len() - 1;
        for _ in 0..2 {
            let Some(edge) = stage.at_bound(i) else { break };
            // A key of either sign searches a fixed range: no window to move.
            let grows = edge == stage.specs[i].hi && home.signed_range.is_none();
            if !grows {
                break;
            }
            let resumed = self.fit(
                &keys::set(&stage.scene, &[(home.key.to_string(), edge)])?,
                free,
            )?;
            if resumed.fit.cost >= stage.fit.cost {
                break;
            }
            stage = resumed;
        }
        Ok(stage)
    }

    /// The effect's key fitted with the stage's, and the evidence for it.
    pub fn try_effect(
        &self,
        stage: &Stage,
        home: &effects::Home,
    ) -> Result<(EffectTrial, Stage), CalibrateError> {
        let mut free = stage.free.clone();
        free.push(home.key.to_string());
        // From the stage's values, and from the beliefs: a missing effect can drag the
        // free keys far from the machine, into a basin the effect's fit does not leave.
        let bases = [stage.scene.clone(), self.with_beliefs(&stage.scene)?];
        let mut best: Option<Stage> = None;
        for base in bases {
            let scan = effects::Home {
                start: self.scan_start(&effects::switched_on(&base, home)?, home)?,
                ..home.clone()
            };
            let next = self.fit(&effects::switched_on(&base, &scan)?, &free)?;
            if best.as_ref().is_none_or(|b| next.fit.cost < b.fit.cost) {
                best = Some(next);
            }
        }
        let next = best.expect("a start was fitted");
        let n_stage = effective_n(&self.data, &stage.fit.predicted);
        let next = self.beyond_the_window(next, home, &free)?;
        // The gain is the effect's only if the stage's own physics, refitted from where the
        // effect's fit ended, does not reach it: the rough play or limit may have led the
        // free keys out of a poor minimum, which is no evidence for the effect.
        let fitted: Vec<(String, f64)> = stage
            .free
            .iter()
            .map(|k| Ok((k.clone(), keys::get(&next.scene, k)?)))
            .collect::<Result<_, CalibrateError>>()?;
        // The null fit can only lower the reference's cost: an effect that fails against
        // the stage fails against it too, and needs no null fit.
        let null = if Gain::of(&self.data, &stage.fit, &n_stage, &next.fit).passes() {
            Some(self.fit(&keys::set(&stage.scene, &fitted)?, &stage.free)?)
        } else {
            None
        };
        let reference = match &null {
            Some(null) if null.fit.cost < stage.fit.cost => null,
            _ => stage,
        };
        let n_ref = effective_n(&self.data, &reference.fit.predicted);
        Ok((self.trial(home, reference, &n_ref, &next, &free), next))
    }

    /// The evidence for the effect fitted in `next` against `reference`, whose effective
    /// residual counts are `n_ref`.
    fn trial(
        &self,
        home: &effects::Home,
        reference: &Stage,
        n_ref: &[f64],
        next: &Stage,
        free: &[String],
    ) -> EffectTrial {
        let gain = Gain::of(&self.data, &reference.fit, n_ref, &next.fit);
        let i = free.len() - 1;
        let at_bound = next.at_bound(i);
        EffectTrial {
            effect: home.effect,
            key: home.key.to_string(),
            value: next.fit.params[i],
            std: next.fit.std[i],
            at_bound,
            delta_aic: gain.delta_aic,
            rss_reduction_pct: 100.0 * gain.reduction,
            // A key the recording does not determine (a limit above every command) is
            // not what earned a gain.
            accepted: gain.passes() && at_bound.is_none() && next.fit.std[i].is_some(),
            scene_value: home.in_scene.then_some(home.start),
        }
    }
}
