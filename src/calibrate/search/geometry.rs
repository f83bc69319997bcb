//! The wheel geometry on the wheels' odometry: the effective radii and track fitted to the
//! tracked pose over windows restarted from it, and the evidence for them against the
//! configured geometry.

use super::*;
use crate::record::channels as chan;

/// A tracker's position noise, m, and heading noise, rad, where nothing says otherwise:
/// what the wheels' odometry is weighed by ([`Problem::geometry_by_odometry`]).
const TRACKER_POSITION_NOISE_M: f64 = 0.002;
/// See [`TRACKER_POSITION_NOISE_M`].
const TRACKER_HEADING_NOISE_RAD: f64 = 0.005;

impl Problem<'_> {
    /// The wheel geometry searched on the wheels' odometry (their measured turns through
    /// the rolling law against the tracked pose, over the pose's windows: no dynamics) and
    /// confirmed through the simulator: the stage replayed with the geometry must fit the
    /// recording better than without it. Its evidence is the odometry's: the geometry
    /// against the configured one on the pose. `None` where the recording has no wheel
    /// turns to read (the geometry is then fitted through the simulator, as other
    /// effects are).
    pub fn geometry_by_odometry(
        &self,
        stage: &Stage,
        home: &effects::Home,
    ) -> Result<Option<(EffectTrial, Stage, Vec<crate::calibrate::KeyFit>)>, CalibrateError> {
        use crate::calibrate::odometry::{Odometry, KEYS};
        let Some(turns) = self.wheel_turns.clone() else {
            return Ok(None);
        };
        let others: Vec<String> = self
            .data
            .output_names
            .iter()
            .filter(|n| ![chan::X_M, chan::Y_M, chan::HEADING_RAD].contains(&n.as_str()))
            .cloned()
            .collect();
        let pose = self.data.without_outputs(&others);
        if pose.output_names.len() < 3 {
            return Ok(None);
        }
        let offs = home.off_values().expect("the geometry can be taken out");
        let off_of = |key: &str| {
            offs.iter()
                .find(|(k, _)| k == key)
                .map(|(_, v)| *v)
                .expect("the geometry's keys")
        };
        let configured = [off_of(KEYS[0]), off_of(KEYS[1]), off_of(KEYS[2])];
        let windows = self.windows.as_ref().and_then(|w| w.for_dataset(&pose));
        let model = WindowedOdometry {
            odometry: Odometry::new(turns, configured),
            windows,
        };
        let weights = tracker_weights(&pose);
        let settings = |free: Vec<usize>| FitSettings {
            free,
            weighting: Weighting::outputs_only(weights.clone()),
            max_iterations: MAX_ITERATIONS,
            starts: vec![configured.to_vec()],
        };
        let fail = |e: FitError| CalibrateError::Fit {
            file: self.rec.path.clone(),
            message: format!("the wheels' odometry: {e}"),
        };
        let on = fit_predictor(&model, &pose, &settings(vec![0, 1, 2])).map_err(fail)?;
        // The configured geometry: nothing free, its cost and outputs.
        let off = fit_predictor_quick(&model, &pose, &settings(vec![]), false).map_err(fail)?;
        let n_off = effective_n(&pose, &off.predicted);
        let gain = Gain::of(&pose, &off, &n_off, &on);
        // Through the simulator: the stage with the geometry, its free keys refitted.
        let pairs: Vec<(String, f64)> = KEYS
            .iter()
            .map(|k| k.to_string())
            .zip(on.params.iter().copied())
            .collect();
        let with = self.fit_quick(&keys::set(&stage.scene, &pairs)?, &stage.free, vec![])?;
        // Confirmed where the model's pose fits better with it: the wheels' speeds, read
        // through the configured geometry, do not see it.
        let confirmed = self.pose_cost(&with.fit.predicted) < self.pose_cost(&stage.fit.predicted);
        let distinct =
            (0..3).any(|i| on.std[i].is_some_and(|s| (on.params[i] - configured[i]).abs() > s));
        let gain = Gain {
            delta_aic: wald_delta_aic(&on, &configured),
            reduction: gain.reduction,
        };
        let specs = model.odometry.param_specs();
        let at_bound = (0..3)
            .find_map(|i| crate::ident::bound_reached(on.params[i], specs[i].lo, specs[i].hi));
        let trial = EffectTrial {
            accepted: gain.passes() && confirmed && distinct && at_bound.is_none(),
            ..EffectTrial::of(home, on.params[2], on.std[2], at_bound, &gain)
        };
        let fits = KEYS
            .iter()
            .enumerate()
            .map(|(i, k)| crate::calibrate::KeyFit {
                key: k.to_string(),
                before: keys::get(self.belief, k).unwrap_or(configured[i]),
                after: on.params[i],
                fitted: on.params[i],
                std: on.std[i],
                at_bound: None,
                held: false,
                confounded: false,
                trades_with: vec![],
                moves_with_held: vec![],
            })
            .collect();
        Ok(Some((trial, with, fits)))
    }

    /// The evidence for the effect fitted in `next` against `reference`, whose effective
    /// residual counts are `n_ref`. Accepted only where the gain passes the rule and the
    /// key is an estimate: not at a bound, determined by the recording, and further from
    /// its off value than its standard deviation (a strength the recording cannot tell
    /// from none is no finding).
    pub(in crate::calibrate) fn trial(
        &self,
        home: &effects::Home,
        reference: &Stage,
        n_ref: &[f64],
        next: &Stage,
    ) -> Result<EffectTrial, CalibrateError> {
        let gain = self.gain(reference, n_ref, next)?;
        let i = next.free.len() - 1;
        let value = next.fit.params[i];
        let std = next.fit.std[i];
        // Each of the effect's keys (the strength key last): an estimate where none is at
        // a bound, and the effect told from none where one of them lies further from its
        // off value than its standard deviation.
        let n = home.also.len() + 1;
        let offs: Vec<f64> = home
            .also
            .iter()
            .map(|c| c.off)
            .chain([home.off.unwrap_or(0.0)])
            .collect();
        let slots = next.free.len() - n..next.free.len();
        let at_bound = next
            .at_bound(i)
            .or_else(|| slots.clone().find_map(|j| next.at_bound(j)));
        let distinct = slots
            .zip(&offs)
            .any(|(j, off)| next.fit.std[j].is_some_and(|s| (next.fit.params[j] - off).abs() > s))
            && std.is_some();
        Ok(EffectTrial {
            accepted: gain.passes() && at_bound.is_none() && distinct,
            ..EffectTrial::of(home, value, std, at_bound, &gain)
        })
    }
}

/// The odometry model with its pose compared over the calibration's windows.
struct WindowedOdometry {
    odometry: crate::calibrate::odometry::Odometry,
    windows: Option<crate::calibrate::pose_windows::PoseWindows>,
}

impl Predictor for WindowedOdometry {
    fn param_specs(&self) -> &[ParamSpec] {
        self.odometry.param_specs()
    }

    fn predict(
        &self,
        p: &[f64],
        data: &Dataset,
    ) -> Result<Vec<Vec<f64>>, crate::ident::model::Diverged> {
        let mut y = self.odometry.predict(p, data)?;
        if let Some(w) = &self.windows {
            w.simulated(&mut y);
        }
        Ok(y)
    }
}

/// The evidence for a fitted geometry: its distance from the configured one in its own
/// covariance (the Wald statistic, the likelihood ratio's measure where the odometry's
/// residual is as correlated as a pose over a window is), less what the rule asks of
/// three keys, as an AIC gain. The effective-sample likelihood gain counts a window's
/// drift as one sample and asks far more.
fn wald_delta_aic(on: &Fit, configured: &[f64; 3]) -> f64 {
    let deviation =
        nalgebra::DVector::from_iterator(3, (0..3).map(|i| on.params[i] - configured[i]));
    let wald = on
        .covariance
        .clone()
        .pseudo_inverse(1e-30)
        .map(|inv| (deviation.transpose() * inv * &deviation)[(0, 0)])
        .unwrap_or(0.0);
    wald - 2.0 * 3.0
}

/// Each pose output's weight: one over a tracker's noise (a motion-capture or map pose:
/// 2 mm, 5 mrad, as the fitting vehicle assumes where a rig does not say). The odometry's
/// residual is that noise and the encoders' counts, not the outputs' spread, which
/// turning on the spot gives the heading alone.
fn tracker_weights(pose: &Dataset) -> Vec<f64> {
    pose.output_names
        .iter()
        .map(|n| match n.as_str() {
            chan::HEADING_RAD => 1.0 / TRACKER_HEADING_NOISE_RAD,
            _ => 1.0 / TRACKER_POSITION_NOISE_M,
        })
        .collect()
}
