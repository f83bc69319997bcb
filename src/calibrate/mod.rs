//! Calibration: the simulator itself fitted to a recording. The scene's values are the
//! beliefs; the free scene keys are fitted by output error through [`crate::replay`] (the
//! simulator at the scene's fidelity, driven by the recording's inputs), with the same
//! Levenberg-Marquardt fitter and statistics as `identify`. The result is a scene: what
//! was fitted goes back into the file the user runs, and the fit is shown before and after
//! in the simulation itself.

pub mod keys;
pub mod write;

use std::path::PathBuf;

use crate::ident::data::Dataset;
use crate::ident::fit::{fit_predictor, FitSettings};
use crate::ident::model::{Diverged, ParamSpec, Predictor};
use crate::record::Recording;
use crate::replay::{replay, Replay, ReplayError};
use crate::scene::Scene;

/// Why a calibration cannot be done.
#[derive(Debug, thiserror::Error)]
pub enum CalibrateError {
    #[error(transparent)]
    Replay(#[from] ReplayError),
    #[error("{0}")]
    Key(String),
    #[error("{file}: {message}")]
    Recording { file: PathBuf, message: String },
    #[error("{file}: the fit failed: {message}")]
    Fit { file: PathBuf, message: String },
}

/// The contract's outputs per rig: what a real rig measures, and what a calibration fits.
pub fn contract_outputs(rig: &str) -> &'static [&'static str] {
    match rig {
        "drive_axis" => &[
            "motor_speed_rad_s",
            "motor_angle_rad",
            "wheel_angle_rad",
            "current_A",
        ],
        _ => &[
            "x_m",
            "y_m",
            "heading_rad",
            "left_motor_speed_rad_s",
            "right_motor_speed_rad_s",
            "sensor_left_adc",
            "sensor_right_adc",
            "left_wheel_speed_m_s",
            "right_wheel_speed_m_s",
            "yaw_rate_rad_s",
        ],
    }
}

/// The scene keys a calibration fits by default, per recording kind: those the record
/// determines and a scene is most often wrong about.
///
/// - a lifted drive (`drive_axis`, `drive_pair`): the armature resistance, the torque
///   constant, the rotor inertia and the viscous friction, which set the motor's gain,
///   its time constant and its current;
/// - a `vehicle`: the torque constant and resistance (the drive's gain) and the chassis
///   mass and yaw inertia (how fast it answers in speed and in turn).
pub fn default_free(rig: &str) -> &'static [&'static str] {
    match rig {
        "vehicle" => &[
            "motor.torque_constant_Nm_A",
            "motor.resistance_ohm",
            "chassis.mass_kg",
            "chassis.yaw_inertia_kg_m2",
        ],
        _ => &[
            "motor.resistance_ohm",
            "motor.torque_constant_Nm_A",
            "motor.rotor_inertia_kg_m2",
            "motor.viscous_Nm_s_rad",
        ],
    }
}

/// The simulator replaying a recording, as a model the fitter can fit: its parameters are
/// scene keys.
pub struct SceneReplay<'a> {
    scene: Scene,
    rec: &'a Recording,
    specs: Vec<ParamSpec>,
}

impl<'a> SceneReplay<'a> {
    /// Every key is a strictly positive quantity searched on a log scale within a factor
    /// of 10 of the scene's value. The simulator steps gear play and friction as events
    /// on its time grid, so its outputs are rough in the parameters below about 1e-4
    /// relative: the Jacobian is differenced over 0.1 %.
    pub fn new(scene: &Scene, rec: &'a Recording, free: &[String]) -> Result<Self, CalibrateError> {
        let specs = free
            .iter()
            .map(|k| {
                let v = keys::get(scene, k)?;
                if !(v.is_finite() && v > 0.0) {
                    return Err(CalibrateError::Key(format!(
                        "--free {k}: the scene's value is {v}; a fitted key needs a positive starting value (set one with --set {k}=...)"
                    )));
                }
                Ok(ParamSpec::positive(k, v).with_fd_step(1e-2))
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(SceneReplay {
            scene: scene.clone(),
            rec,
            specs,
        })
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
        let r = replay(&scene, self.rec).map_err(|e| match e {
            ReplayError::Diverged { t_s, .. } => Diverged { t_s },
            _ => fail(),
        })?;
        data.output_names
            .iter()
            .map(|n| r.output(n).map(|o| o.simulated.clone()).ok_or_else(fail))
            .collect()
    }
}

/// One fitted key.
#[derive(Debug, Clone, PartialEq)]
pub struct KeyFit {
    pub key: String,
    /// The scene's value.
    pub before: f64,
    /// The fitted value (the scene's when the fit ended at a bound).
    pub after: f64,
    /// Standard deviation of the fitted value; `None` where the record does not determine it.
    pub std: Option<f64>,
    /// The bound the search ended on, if it did: then `after` is no estimate, and the
    /// scene keeps its value (the belief or the model's structure is wrong).
    pub at_bound: Option<f64>,
}

/// A calibration's result.
#[derive(Debug, Clone)]
pub struct Calibration {
    pub keys: Vec<KeyFit>,
    /// The outputs fitted (the contract's outputs the recording has).
    pub outputs: Vec<String>,
    /// The recording replayed on the original and on the calibrated scene.
    pub before: Replay,
    pub after: Replay,
    /// The calibrated scene (the original with the fitted keys changed).
    pub scene: Scene,
    pub iterations: usize,
}

/// Fits `free` scene keys (the recording kind's default set when empty) to the recording.
pub fn calibrate(
    scene: &Scene,
    rec: &Recording,
    free: &[String],
) -> Result<Calibration, CalibrateError> {
    calibrate_telling(scene, rec, free, &|_| {})
}

/// [`calibrate`], telling `progress` each stage as it starts (the command prints them on
/// standard error; each fit iteration replays the recording once per key and once more).
pub fn calibrate_telling(
    scene: &Scene,
    rec: &Recording,
    free: &[String],
    progress: &dyn Fn(&str),
) -> Result<Calibration, CalibrateError> {
    let free: Vec<String> = if free.is_empty() {
        default_free(&rec.rig)
            .iter()
            .map(|s| s.to_string())
            .collect()
    } else {
        free.to_vec()
    };
    progress("replaying the recording on the scene as written");
    let before = replay(scene, rec)?;
    let outputs: Vec<String> = contract_outputs(&rec.rig)
        .iter()
        .filter(|n| before.output(n).is_some())
        .map(|n| n.to_string())
        .collect();
    if outputs.is_empty() {
        return Err(CalibrateError::Recording {
            file: rec.path.clone(),
            message: format!(
                "none of the rig's outputs to fit ({})",
                contract_outputs(&rec.rig).join(", ")
            ),
        });
    }
    let inputs: Vec<String> = before
        .drive
        .columns()
        .iter()
        .map(|s| s.to_string())
        .collect();
    let data =
        Dataset::from_recording(rec, &inputs, &outputs).map_err(|e| CalibrateError::Recording {
            file: rec.path.clone(),
            message: e.to_string(),
        })?;
    let model = SceneReplay::new(scene, rec, &free)?;
    // Each output weighted by its spread, so outputs in different units count alike.
    let weights = data
        .outputs
        .iter()
        .map(|col| {
            let v: Vec<f64> = col.iter().flatten().copied().collect();
            let mean = v.iter().sum::<f64>() / v.len().max(1) as f64;
            let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / v.len().max(1) as f64;
            1.0 / var.sqrt().max(1e-12)
        })
        .collect();
    let nominal: Vec<f64> = model.param_specs().iter().map(|s| s.nominal).collect();
    let settings = FitSettings {
        free: (0..free.len()).collect(),
        weights,
        max_iterations: 30,
        starts: vec![nominal],
    };
    progress(&format!(
        "fitting {} keys through the simulator ({} or more replays an iteration, at most {} iterations)",
        free.len(),
        free.len() + 1,
        settings.max_iterations
    ));
    let fit = fit_predictor(&model, &data, &settings).map_err(|e| CalibrateError::Fit {
        file: rec.path.clone(),
        message: e.to_string(),
    })?;
    let keys: Vec<KeyFit> = model
        .param_specs()
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let v = fit.params[i];
            let at_bound = crate::ident::bound_reached(v, s.lo, s.hi);
            KeyFit {
                key: s.name.clone(),
                before: s.nominal,
                after: if at_bound.is_some() { s.nominal } else { v },
                std: if at_bound.is_some() { None } else { fit.std[i] },
                at_bound,
            }
        })
        .collect();
    let pairs: Vec<(String, f64)> = keys.iter().map(|k| (k.key.clone(), k.after)).collect();
    let calibrated = keys::set(scene, &pairs)?;
    progress(&format!(
        "fitted in {} iterations; replaying the recording on the calibrated scene",
        fit.iterations
    ));
    let after = replay(&calibrated, rec)?;
    Ok(Calibration {
        keys,
        outputs,
        before,
        after,
        scene: calibrated,
        iterations: fit.iterations,
    })
}
