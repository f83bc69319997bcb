//! The simulator as judge: where the reduced base and the simulator disagree, the
//! evidence for an effect and the keys at the end come from the simulator's replays; an
//! effect accepted on the reduced base is confirmed through the simulator.

use super::*;

impl Problem<'_> {
    /// Whether the simulator confirms a step found on the reduced base, `added` keys
    /// more: the recording replayed on `after` and on `before` (both replays run
    /// together), the gain passing the evidence rule ([`Gain::passes`]) there too. The
    /// reduced base leaves physics out (the castors' swing, the teeth's ringing): a step
    /// that only bends a key to make up for that gains nothing in the simulator.
    pub fn confirmed(
        &self,
        before: &Scene,
        after: &Scene,
        added: Added,
    ) -> Result<bool, CalibrateError> {
        let (b, a) = rayon::join(
            || self.simulator_prediction(before),
            || self.simulator_prediction(after),
        );
        Ok(match (b?, a?) {
            (_, None) => false,
            (None, Some(_)) => true,
            (Some(b), Some(a)) => match added {
                Added::Keys(n) => {
                    Gain::of_predictions(&self.data, &b, &a, n, &self.weighting.outputs).passes()
                }
                Added::Pose => self.pose_cost(&a) < self.pose_cost(&b),
            },
        })
    }

    /// What does not confirm the step from `before` to `after` (an effect found, `added`
    /// keys more): on the reduced base, the simulator's replay of the recording; then the
    /// validation recordings' replays. `None`: confirmed.
    pub fn unconfirmed(
        &self,
        before: &Scene,
        after: &Scene,
        added: Added,
    ) -> Result<Option<crate::calibrate::Unconfirmed>, CalibrateError> {
        // Judged by the simulator already, or confirmed by it here.
        if self.engine.is_reduced()
            && !self.simulator_judges()
            && !self.confirmed(before, after, added)?
        {
            return Ok(Some(crate::calibrate::Unconfirmed::Simulator));
        }
        if let Some(v) = &self.validation {
            if !v.improved(before, after, self.engine)? {
                return Ok(Some(crate::calibrate::Unconfirmed::Validation));
            }
        }
        Ok(None)
    }

    /// Whether the simulator judges ([`Problem::simulator_judges`]).
    pub fn simulator_judges(&self) -> bool {
        self.simulator_judges
            .load(std::sync::atomic::Ordering::Relaxed)
    }

    /// Weighs again who judges the evidence from `stage` on: where the fits run on the
    /// reduced base, the simulator replays the stage, and the reduced base's disagreement
    /// with it (weighted as the residual) is set against the stage's residual; beyond
    /// [`JUDGE_SHARE`] of it, the simulator judges from then on (as the model grows and its
    /// residual shrinks to the noise, the reduced base's omissions weigh more). Returns
    /// whether the simulator has just taken over.
    pub fn rejudge(&self, stage: &Stage) -> Result<bool, CalibrateError> {
        if self.engine == crate::replay::Engine::Simulator || self.simulator_judges() {
            return Ok(false);
        }
        let takes_over = self.disagrees(stage)?;
        if takes_over {
            self.simulator_judges
                .store(true, std::sync::atomic::Ordering::Relaxed);
        }
        Ok(takes_over)
    }

    /// Whether the simulator sees at least `share` of the improvement the fits' engine
    /// claims for `stage` over `scene` as written (each replayed where its fit ended,
    /// weighted as the residual; [`FAITHFUL_SHARE`] for the reduced base as it is, any
    /// gain at all for one carrying its defect, whose claim is the corrected one). Where
    /// it does not, the reduced base bent the keys to make up for physics it leaves out,
    /// and is no model of this recording.
    pub fn simulator_sees_gain(
        &self,
        scene: &Scene,
        stage: &Stage,
        share: f64,
    ) -> Result<bool, CalibrateError> {
        let w = &self.weighting.outputs;
        let cost =
            |p: &[Vec<f64>]| -> f64 { residuals(&self.data, p, w).iter().map(|r| r * r).sum() };
        let before = self.fit_quick(scene, &[], vec![])?;
        let claimed = cost(&before.fit.predicted) - cost(&stage.fit.predicted);
        if !(claimed > 0.0) {
            return Ok(true);
        }
        let (b, a) = rayon::join(
            || self.simulator_prediction(scene),
            || self.simulator_prediction(&stage.reached),
        );
        Ok(match (b?, a?) {
            (Some(b), Some(a)) => cost(&b) - cost(&a) >= share * claimed,
            _ => false,
        })
    }

    /// Whether the reduced base disagrees with the simulator on `stage` by more than
    /// [`JUDGE_SHARE`] of its residual.
    pub(super) fn disagrees(&self, stage: &Stage) -> Result<bool, CalibrateError> {
        let Some(sim) = self.simulator_prediction(&stage.reached)? else {
            return Ok(true);
        };
        let w = &self.weighting.outputs;
        let reduced = residuals(&self.data, &stage.fit.predicted, w);
        let simulated = residuals(&self.data, &sim, w);
        let disagreement: f64 = reduced
            .iter()
            .zip(&simulated)
            .map(|(a, b)| (a - b) * (a - b))
            .sum();
        let residual: f64 = reduced.iter().map(|r| r * r).sum();
        Ok(disagreement > JUDGE_SHARE * residual)
    }

    /// What `richer` gains over `reference` (whose effective residual counts are
    /// `n_ref`): on the fits' own predictions, or, where the simulator judges
    /// ([`Problem::simulator_judges`]), on its replays of where each fit ended.
    pub(in crate::calibrate) fn gain(
        &self,
        reference: &Stage,
        n_ref: &[f64],
        richer: &Stage,
    ) -> Result<Gain, CalibrateError> {
        if !self.simulator_judges() {
            return Ok(Gain::of(&self.data, &reference.fit, n_ref, &richer.fit));
        }
        let (a, b) = rayon::join(
            || self.simulator_prediction(&reference.reached),
            || self.simulator_prediction(&richer.reached),
        );
        let added = richer.free.len().saturating_sub(reference.free.len());
        Ok(match (a?, b?) {
            (Some(a), Some(b)) => {
                Gain::of_predictions(&self.data, &a, &b, added, &self.weighting.outputs)
            }
            (_, None) => Gain {
                delta_aic: f64::NEG_INFINITY,
                reduction: f64::NEG_INFINITY,
            },
            (None, Some(_)) => Gain {
                delta_aic: f64::INFINITY,
                reduction: 1.0,
            },
        })
    }
}
