//! Other runs of the machine as a check on each finding: an effect a calibration adds must
//! also improve the replay of a recording it was not fitted on. A finding the other runs do
//! not confirm is the fitted run's noise or circumstance (a floor, a payload, one odd
//! manoeuvre), not the machine's physics.

use super::pose_windows::PoseWindows;
use super::{CalibrateError, SceneReplay};
use crate::ident::data::Dataset;
use crate::ident::fit::residuals;
use crate::ident::model::Predictor;
use crate::ident::weighting::spread_weights;
use crate::record::Recording;
use crate::replay::{Drive, Engine};
use crate::scene::Scene;

/// A validation recording as the fits see it: its outputs in common with the fitted ones,
/// its pose over windows, each output weighed by its own spread.
pub struct Validation {
    rec: Recording,
    data: Dataset,
    windows: Option<PoseWindows>,
    weights: Vec<f64>,
}

impl Validation {
    /// The validation of `rec` on the fitted `outputs` it measures, driven as `drive`;
    /// `None` where it measures none of them.
    pub fn of(
        rec: &Recording,
        outputs: &[String],
        drive: Drive,
    ) -> Result<Option<Validation>, CalibrateError> {
        let common: Vec<String> = outputs
            .iter()
            .filter(|o| {
                rec.column(o)
                    .is_some_and(|c| c.iter().flatten().count() >= 2)
            })
            .cloned()
            .collect();
        if common.is_empty() {
            return Ok(None);
        }
        let inputs: Vec<String> = drive.columns().iter().map(|s| s.to_string()).collect();
        let data = Dataset::from_recording(rec, &inputs, &common)
            .map_err(|e| CalibrateError::Data(e.to_string()))?;
        let windows = PoseWindows::of(&data);
        let data = match &windows {
            Some(w) => w.measured(&data),
            None => data,
        };
        let weights = spread_weights(&data);
        Ok(Some(Validation {
            rec: rec.clone(),
            data,
            windows,
            weights,
        }))
    }

    /// The recording's name, for the report.
    pub fn name(&self) -> String {
        self.rec.path.display().to_string()
    }

    /// The weighted residual sum of squares of `scene` replayed on it (infinite where the
    /// replay diverges).
    pub fn rss(&self, scene: &Scene, engine: Engine) -> Result<f64, CalibrateError> {
        let model = SceneReplay::with_signed(scene, &self.rec, &[], &[])?
            .on(engine)
            .windowed(self.windows.clone());
        Ok(match model.predict(&[], &self.data) {
            Ok(y) => residuals(&self.data, &y, &self.weights)
                .iter()
                .map(|r| r * r)
                .sum(),
            Err(_) => f64::INFINITY,
        })
    }

    /// Whether `after` replays it better than `before` (both replays run together).
    pub fn improved(
        &self,
        before: &Scene,
        after: &Scene,
        engine: Engine,
    ) -> Result<bool, CalibrateError> {
        let (b, a) = rayon::join(|| self.rss(before, engine), || self.rss(after, engine));
        Ok(a? < b?)
    }
}
