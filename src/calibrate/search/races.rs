//! An effect against a stage: its key scanned with the stage's keys held, raced on the
//! recording's first part (and the keys raced alone, the null race), tried in full, and an
//! effect the scene has weighed against its absence.

use super::*;
use crate::record::channels as chan;

impl Problem<'_> {
    /// The values of the effect's key a scan tries: a tenth to ten times its start, nine
    /// values a factor 1.78 apart; for a key of either sign, nine values evenly across its
    /// range. The fit that follows finds the value within the basin the scan points to (a
    /// lifted wheel rattling in its play has basins narrower than a factor of 2).
    pub(super) fn scan_values(home: &effects::Home) -> Vec<f64> {
        (-4..=4)
            .map(|i| match home.signed_range {
                Some(range) => range * i as f64 / 4.0,
                None => home.start * 10f64.powf(i as f64 / 4.0),
            })
            .collect()
    }

    /// Each value of the scan on `scene` (the effect switched on), the other keys held:
    /// the value and the outputs, `None` where the simulation diverged.
    pub(super) fn scan(
        &self,
        scene: &Scene,
        home: &effects::Home,
    ) -> Result<Vec<(f64, Option<Outputs>)>, CalibrateError> {
        let model =
            SceneReplay::with_signed(scene, self.rec, &[home.key.to_string()], &self.signed)?
                .on(self.engine)
                .corrected(self.defect())
                .windowed(self.windows.clone());
        Ok(Self::scan_values(home)
            .par_iter()
            .map(|&v| (v, model.predict(&[v], &self.data).ok()))
            .collect())
    }

    /// The weighted residual sum of squares of `predicted` over the pose outputs alone.
    pub(super) fn pose_cost(&self, predicted: &[Vec<f64>]) -> f64 {
        let r = residuals(&self.data, predicted, &self.weighting.outputs);
        let mut k = 0;
        let mut cost = 0.0;
        for (j, col) in self.data.outputs.iter().enumerate() {
            let pose = [chan::X_M, chan::Y_M, chan::HEADING_RAD]
                .contains(&self.data.output_names[j].as_str());
            for cell in col.iter().flatten() {
                let _ = cell;
                if pose {
                    cost += r[k] * r[k];
                }
                k += 1;
            }
        }
        cost
    }

    /// The weighted residual sum of squares of `predicted`.
    pub(super) fn cost_of(&self, predicted: &[Vec<f64>]) -> f64 {
        residuals(&self.data, predicted, &self.weighting.outputs)
            .iter()
            .map(|r| r * r)
            .sum()
    }

    /// The lowest-cost value of a scan on `scene` (its start where nothing simulated), and
    /// its outputs. A play or a clipping limit moves the outputs in steps the gradient
    /// cannot see across, so a fit must start in the right basin.
    pub(super) fn scan_start(
        &self,
        scene: &Scene,
        home: &effects::Home,
    ) -> Result<(f64, Option<Outputs>, f64), CalibrateError> {
        let scanned = self.scan(scene, home)?;
        let best = scanned
            .into_iter()
            .filter(|(_, y)| y.is_some())
            .map(|(v, y)| {
                let cost = self.cost_of(y.as_ref().expect("filtered"));
                (v, y, cost)
            })
            .reduce(|a, b| if b.2 < a.2 { b } else { a });
        Ok(best.unwrap_or((home.start, None, f64::INFINITY)))
    }

    /// An effect's key raced on a stage: scanned (the other keys held) from the stage's
    /// values and from the beliefs (a missing effect can drag the free keys far from the
    /// machine, into a basin where the effect looks like no help), then fitted with the
    /// stage's keys for [`RACE_ITERATIONS`] from each scan's best; the better fit is
    /// the race's. What it gains over the
    /// stage after those few iterations ranks the effects for their full trials.
    pub fn race(&self, stage: &Stage, home: &effects::Home) -> Result<Stage, CalibrateError> {
        let mut free = stage.free.clone();
        free.extend(home.keys().iter().map(|k| k.to_string()));
        let on_stage = effects::switched_on(&stage.scene, home)?;
        let believed = effects::switched_on(&self.with_beliefs(&stage.scene)?, home)?;
        // From each base's best scan: the effect's key and the others interact (a speed
        // loop's set-point is the torque constant's), and the lower scan can be the wrong
        // basin.
        let from = |base: Scene| -> Result<Stage, CalibrateError> {
            let start = if home.scanned {
                let (value, _, _) = self.scan_start(&base, home)?;
                keys::set(&base, &[(home.key.to_string(), value)])?
            } else {
                base
            };
            self.fit_for(&start, &free, RACE_ITERATIONS)
        };
        let (a, b) = rayon::join(|| from(on_stage), || from(believed));
        Ok(better_fit(a?, b?))
    }

    /// A race without an effect: the stage's keys alone fitted for [`RACE_ITERATIONS`] from
    /// the stage and from the beliefs, the better kept, as [`Problem::race`] does with an
    /// effect's key. On the recording's first part the keys alone gain there whatever the
    /// effect; what an effect's race gains beyond this is what the effect did.
    pub fn null_race(&self, stage: &Stage) -> Result<Stage, CalibrateError> {
        let believed = self.with_beliefs(&stage.scene)?;
        let (a, b) = rayon::join(
            || self.fit_for(&stage.scene, &stage.free, RACE_ITERATIONS),
            || self.fit_for(&believed, &stage.free, RACE_ITERATIONS),
        );
        Ok(better_fit(a?, b?))
    }

    /// The fit moved on while the effect's key ends at the edge of its search window where
    /// the effect grows (a window is a factor of 10 around where the scan started it, not a
    /// physical limit): up to twice, the window is centred on that edge and the fit
    /// resumed, kept if it fits better. At the edge where the effect vanishes it stays: the
    /// recording does not support the effect.
    pub(super) fn beyond_the_window(
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

    /// The effect's key fitted with the stage's, going on from its race ([`Problem::race`]),
    /// and the evidence for it against the stage.
    pub fn try_effect(
        &self,
        stage: &Stage,
        home: &effects::Home,
        raced: &Stage,
    ) -> Result<(EffectTrial, Stage), CalibrateError> {
        let next = self.fit(&raced.reached, &raced.free)?;
        let next = self.beyond_the_window(next, home, &raced.free)?;
        let n_stage = stage.effective_n(&self.data);
        // The gain is the effect's only if the stage's own physics, refitted from where the
        // effect's fit ended, does not reach it: the rough play or limit may have led the
        // free keys out of a poor minimum, which is no evidence for the effect.
        // The null fit can only lower the reference's cost: an effect that fails against
        // the stage fails against it too, and needs no null fit.
        let null = if Gain::of(&self.data, &stage.fit, &n_stage, &next.fit).passes() {
            let fitted = values(&next.scene, &stage.free)?;
            let pairs: Vec<(String, f64)> = stage.free.iter().cloned().zip(fitted).collect();
            Some(self.fit_quick(&keys::set(&stage.scene, &pairs)?, &stage.free, vec![])?)
        } else {
            None
        };
        let reference = match &null {
            Some(null) if null.fit.cost < stage.fit.cost => null,
            _ => stage,
        };
        let n_ref = reference.effective_n(&self.data);
        let trial = self.trial(home, reference, &n_ref, &next)?;
        let trial = match (&null, self.simulator_judges() && trial.accepted) {
            (Some(null), true) => self.against_the_simulators_null(home, trial, null, &next)?,
            _ => trial,
        };
        Ok((trial, next))
    }

    /// Where the simulator judges, an effect's trial that passes against a null fitted on
    /// the reduced base weighed again against the null refitted through the simulator
    /// itself (the stage's keys from where the effect's fit ended, the effect off): the
    /// two engines' optima differ, and an effect whose extra keys only move the stage's
    /// keys to where the simulator would have them anyway has no evidence of its own.
    /// The weaker of the two gains is the effect's.
    pub(super) fn against_the_simulators_null(
        &self,
        home: &effects::Home,
        trial: EffectTrial,
        null: &Stage,
        next: &Stage,
    ) -> Result<EffectTrial, CalibrateError> {
        let refitted = self.through_simulator(&null.reached, &null.free)?;
        let n_ref = refitted.effective_n(&self.data);
        let again = self.trial(home, &refitted, &n_ref, next)?;
        Ok(if again.delta_aic < trial.delta_aic {
            again
        } else {
            trial
        })
    }

    /// An effect the model has, weighed against its absence: the stage's other keys fitted
    /// with the effect's key at its off value (from the stage and from the beliefs,
    /// raced), and the stage's gain over that (its key counted as fitted).
    pub fn weigh_present(
        &self,
        stage: &Stage,
        home: &effects::Home,
    ) -> Result<Presence, CalibrateError> {
        let without = home
            .off_values()
            .expect("only effects that can be taken out are weighed");
        let keys = home.keys();
        let free: Vec<String> = stage
            .free
            .iter()
            .filter(|k| !keys.contains(&k.as_str()))
            .cloned()
            .collect();
        let off_scene = keys::set(&stage.scene, &without)?;
        let believed = keys::set(&self.with_beliefs(&stage.scene)?, &without)?;
        let off = self.fit_quick(&off_scene, &free, vec![values(&believed, &free)?])?;
        let n_off = off.effective_n(&self.data);
        let gain = if free.len() < stage.free.len() || self.simulator_judges() {
            self.gain(&off, &n_off, stage)?
        } else {
            Gain::of_prediction(&self.data, &off.fit, &n_off, &stage.fit.predicted)
        };
        Ok(Presence { gain, off })
    }
}

/// The better of two fits of the same keys from two starts (the lower cost; the first on a
/// tie).
fn better_fit(a: Stage, b: Stage) -> Stage {
    if b.fit.cost < a.fit.cost {
        b
    } else {
        a
    }
}
