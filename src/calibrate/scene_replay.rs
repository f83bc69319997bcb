//! The simulator replaying a recording as a model the fitter can fit: its parameters are
//! scene keys, each evaluation a replay on the simulator or on the reduced base (which may
//! carry its defect), the pose compared over windows where the data has one.

use crate::ident::data::Dataset;
use crate::ident::model::{Diverged, ParamSpec, Predictor};
use crate::record::Recording;
use crate::replay::{replay_with, Engine, ReplayError};
use crate::scene::Scene;

use super::{defect, keys, pose_windows, CalibrateError};

/// The simulator replaying a recording, as a model the fitter can fit: its parameters are
/// scene keys.
pub struct SceneReplay<'a> {
    scene: Scene,
    rec: &'a Recording,
    specs: Vec<ParamSpec>,
    /// The pose compared over windows ([`pose_windows`]), where the data's pose is.
    windows: Option<pose_windows::PoseWindows>,
    /// What each evaluation replays on: the simulator, or the reduced base.
    engine: Engine,
    /// Added to the reduced base's predictions: the simulator's replay minus its own at
    /// one set of keys ([`defect::Defect`]); `None` on the simulator.
    defect: Option<defect::Defect>,
}

impl<'a> SceneReplay<'a> {
    /// Every key is a strictly positive quantity searched on a log scale within a factor
    /// of 10 of the scene's value. The simulator steps gear play and friction as events
    /// on its time grid, so its outputs are rough in the parameters below about 1e-4
    /// relative: the Jacobian is differenced over 0.1 %.
    pub fn new(scene: &Scene, rec: &'a Recording, free: &[String]) -> Result<Self, CalibrateError> {
        Self::with_signed(scene, rec, free, &[])
    }

    /// [`SceneReplay::new`] where the keys in `signed` (key, half-width) may take either
    /// sign: searched on a linear scale within the half-width around zero.
    pub fn with_signed(
        scene: &Scene,
        rec: &'a Recording,
        free: &[String],
        signed: &[(String, f64)],
    ) -> Result<Self, CalibrateError> {
        let specs = free
            .iter()
            .map(|k| {
                let v = keys::get(scene, k)?;
                if let Some((_, range)) = signed.iter().find(|(s, _)| s == k) {
                    return Ok(ParamSpec {
                        rough: true,
                        ..ParamSpec::new(k, v, -range, *range).with_fd_step(1e-2)
                    });
                }
                if !(v.is_finite() && v > 0.0) {
                    return Err(CalibrateError::Key(format!(
                        "--free {k}: the scene's value is {v}; a fitted key needs a positive starting value (set one with --set {k}=...)"
                    )));
                }
                Ok(ParamSpec {
                    rough: true,
                    ..ParamSpec::positive(k, v).with_fd_step(1e-2)
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(SceneReplay {
            scene: scene.clone(),
            rec,
            specs,
            windows: None,
            engine: Engine::Simulator,
            defect: None,
        })
    }

    /// The same model with `defect` added to each prediction where it replays on the
    /// reduced base.
    pub fn corrected(mut self, defect: Option<defect::Defect>) -> Self {
        self.defect = defect;
        self
    }

    /// The same model replayed on `engine`.
    pub fn on(mut self, engine: Engine) -> Self {
        self.engine = engine;
        self
    }

    /// The same model with its pose outputs as motions over `windows` (the dataset it is
    /// fitted to has its measured pose so: [`pose_windows::PoseWindows::measured`]).
    pub fn windowed(mut self, windows: Option<pose_windows::PoseWindows>) -> Self {
        self.windows = windows;
        self
    }

    /// The same model with the beliefs of `belief` (the user's scene) on the keys in
    /// `believed` (the user's free keys) that it states an uncertainty for
    /// (`[uncertainty_pct]`): each is believed at that scene's value, as uncertain as
    /// stated, its search range widened to hold [`crate::ident::BELIEF_SPAN_SD`] standard
    /// deviations of it (as [`crate::ident::state_beliefs`] does for a rig). Any other key
    /// (an effect's strength, a key whose uncertainty the scene does not state) has no
    /// belief: the recording alone decides it.
    pub fn believing(
        mut self,
        belief: &Scene,
        believed: &[String],
    ) -> Result<Self, CalibrateError> {
        for spec in &mut self.specs {
            spec.belief_sd_rel = None;
            let Some(pct) = belief.uncertainty_pct.get(&spec.name) else {
                continue;
            };
            if !believed.contains(&spec.name) {
                continue;
            }
            let b = keys::get(belief, &spec.name)?;
            if !(b.is_finite() && b > 0.0) {
                continue;
            }
            spec.nominal = b;
            *spec = spec.clone().stated_belief(pct / 100.0);
        }
        Ok(self)
    }

    /// The same model with the search window of each of `free` (the user's free keys)
    /// anchored at `belief`'s value, a factor of 10 either way, wherever the fit starts:
    /// a key a fit left at the edge stays at the edge of the same window, so that a bound
    /// reached is reported as one, not walked past by the next fit.
    pub fn anchored(mut self, belief: &Scene, free: &[String]) -> Result<Self, CalibrateError> {
        for spec in &mut self.specs {
            // A stated belief's window is its own ([`SceneReplay::believing`]).
            if !free.contains(&spec.name)
                || spec.lo <= 0.0
                || belief.uncertainty_pct.contains_key(&spec.name)
            {
                continue;
            }
            let b = keys::get(belief, &spec.name)?;
            if b.is_finite() && b > 0.0 {
                spec.lo = spec.lo.max(0.1 * b).min(spec.nominal);
                spec.hi = spec.hi.min(10.0 * b).max(spec.nominal);
            }
        }
        Ok(self)
    }

    /// The scene with parameters `p` in its free keys.
    pub fn scene_with(&self, p: &[f64]) -> Result<Scene, CalibrateError> {
        let pairs: Vec<(String, f64)> = self
            .specs
            .iter()
            .map(|s| s.name.clone())
            .zip(p.iter().copied())
            .collect();
        keys::set(&self.scene, &pairs)
    }
}

impl Predictor for SceneReplay<'_> {
    fn param_specs(&self) -> &[ParamSpec] {
        &self.specs
    }

    fn predict(&self, p: &[f64], data: &Dataset) -> Result<Vec<Vec<f64>>, Diverged> {
        let fail = || Diverged { t_s: data.t_s[0] };
        let scene = self.scene_with(p).map_err(|_| fail())?;
        let r = replay_with(&scene, self.rec, self.engine).map_err(|e| match e {
            ReplayError::Diverged { t_s, .. } => Diverged { t_s },
            _ => fail(),
        })?;
        let mut y = data
            .output_names
            .iter()
            .map(|n| r.output(n).map(|o| o.simulated.clone()).ok_or_else(fail))
            .collect::<Result<Vec<_>, _>>()?;
        if let Some(w) = &self.windows {
            w.simulated(&mut y);
        }
        if let (true, Some(d)) = (self.engine.is_reduced(), &self.defect) {
            d.correct(&mut y);
        }
        Ok(y)
    }
}
