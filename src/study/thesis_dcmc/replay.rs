//! The simulator's lifted-wheel machine replaying a recording's demands, as a model the
//! output-error fitter can fit: its parameters are scene keys of the DCMC.

use super::ThesisDcmcError;
use crate::ident::data::Dataset;
use crate::ident::fit::{fit_predictor, Fit, FitSettings};
use crate::ident::model::{Diverged, ParamSpec, Predictor};
use crate::model::dcmc::DcmcParams;
use crate::param::ParamKey;
use crate::record::channels as chan;
use crate::scene::Scene;
use crate::sim::{Actuation, Sim};

/// Which form of the DCMC's slow response a fit uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ResponseForm {
    /// A first-order lag per side on the forward demand; the turn demand at once.
    ForwardLag,
    /// The same, and a lag of its own on the turn demand.
    ForwardAndTurnLag,
    /// A rate limit per side (the unit's acceleration setting), no lag.
    Ramp,
    /// A lag per side on the forward demand and a rate limit on the turn demand (the
    /// unit's turn acceleration setting).
    ForwardLagTurnRamp,
}

impl ResponseForm {
    /// Every form.
    pub const ALL: [ResponseForm; 4] = [
        ResponseForm::ForwardLag,
        ResponseForm::ForwardAndTurnLag,
        ResponseForm::Ramp,
        ResponseForm::ForwardLagTurnRamp,
    ];

    /// The scene keys a fit of this form sets, in parameter order.
    pub fn keys(self) -> &'static [ParamKey] {
        match self {
            ResponseForm::ForwardLag => &[
                DcmcParams::forward_gain_v_pct,
                DcmcParams::turn_gain_v_pct,
                DcmcParams::response_time_left_s,
                DcmcParams::response_time_right_s,
            ],
            ResponseForm::ForwardAndTurnLag => &[
                DcmcParams::forward_gain_v_pct,
                DcmcParams::turn_gain_v_pct,
                DcmcParams::response_time_left_s,
                DcmcParams::response_time_right_s,
                DcmcParams::turn_response_time_s,
            ],
            ResponseForm::Ramp => &[
                DcmcParams::forward_gain_v_pct,
                DcmcParams::turn_gain_v_pct,
                DcmcParams::ramp_left_pct_s,
                DcmcParams::ramp_right_pct_s,
            ],
            ResponseForm::ForwardLagTurnRamp => &[
                DcmcParams::forward_gain_v_pct,
                DcmcParams::turn_gain_v_pct,
                DcmcParams::response_time_left_s,
                DcmcParams::response_time_right_s,
                DcmcParams::turn_ramp_pct_s,
            ],
        }
    }

    /// The form in words.
    pub fn name(self) -> &'static str {
        match self {
            ResponseForm::ForwardLag => "lag on the forward demand",
            ResponseForm::ForwardAndTurnLag => "lags on the forward and the turn demand",
            ResponseForm::Ramp => "rate limit (ramp) per side",
            ResponseForm::ForwardLagTurnRamp => "lag on the forward demand, ramp on the turn",
        }
    }

    /// The scene with only this form's response: the others' keys at zero.
    pub(super) fn isolate(self, scene: &mut Scene) {
        for key in RESPONSE_KEYS.iter().filter(|k| !self.keys().contains(k)) {
            crate::scene::keys::set_number(scene, key.key(), 0.0);
        }
    }
}

/// Every key of the DCMC's slow response (a lag or a rate limit), whichever form uses it.
const RESPONSE_KEYS: [ParamKey; 6] = [
    DcmcParams::response_time_left_s,
    DcmcParams::response_time_right_s,
    DcmcParams::turn_response_time_s,
    DcmcParams::ramp_left_pct_s,
    DcmcParams::ramp_right_pct_s,
    DcmcParams::turn_ramp_pct_s,
];

/// A key's value in a scene, where a fit starts: the scene's, or for a response that is
/// off (zero) a neutral start by the key's unit: a lag of 0.3 s, a rate of 100 %/s.
pub(super) fn starting_value(scene: &Scene, key: &str) -> f64 {
    let Some(k) = crate::scene::keys::table().find(key) else {
        return f64::NAN;
    };
    let v = k.get(scene).unwrap_or(0.0);
    let neutral = match k.unit {
        "s" => 0.3,
        "pct/s" => 100.0,
        _ => return v,
    };
    if v > 0.0 {
        v
    } else {
        neutral
    }
}

/// The simulator's lifted-wheel machine replaying a recording's demands: a [`Predictor`]
/// whose parameters are scene keys of the DCMC ([`ResponseForm::keys`]) and whose outputs
/// are the motor speeds as encoders give them: the mean over the interval before each
/// sample (row 0: the speed at the start).
pub struct LiftedDcmcReplay {
    scene: Scene,
    specs: Vec<ParamSpec>,
}

impl LiftedDcmcReplay {
    /// The scene's machine with its wheels lifted and only the form's response; the
    /// scene's values of the keys are the starting values (`starting_value`).
    pub fn new(scene: &Scene, form: ResponseForm) -> LiftedDcmcReplay {
        let mut scene = scene.clone();
        scene.sim.wheels_lifted = true;
        let start = scene.clone();
        form.isolate(&mut scene);
        // The simulator steps the gear play and Coulomb friction as events on its time
        // grid, so its outputs are not smooth in the parameters below about 1e-4
        // relative: difference the Jacobian over 0.1 %.
        let specs = form
            .keys()
            .iter()
            .map(|k| {
                let v = starting_value(&start, k.key());
                ParamSpec::new(k.key(), v, 1e-3 * v.abs(), 1e3 * v.abs()).with_fd_step(1e-3)
            })
            .collect();
        LiftedDcmcReplay { scene, specs }
    }

    /// The scene with parameters `p` in the form's keys.
    pub fn scene_with(&self, p: &[f64]) -> Scene {
        let mut s = self.scene.clone();
        for (spec, v) in self.specs.iter().zip(p) {
            crate::scene::keys::set_number(&mut s, &spec.key, *v);
        }
        s
    }

    /// The recording's inputs.
    pub const INPUTS: [&'static str; 2] = [chan::DEMAND_FWD_PCT, chan::DEMAND_TURN_PCT];
    /// The recording's outputs.
    pub const OUTPUTS: [&'static str; 2] =
        [chan::LEFT_MOTOR_SPEED_RAD_S, chan::RIGHT_MOTOR_SPEED_RAD_S];
}

impl Predictor for LiftedDcmcReplay {
    fn param_specs(&self) -> &[ParamSpec] {
        &self.specs
    }

    fn predict(&self, p: &[f64], data: &Dataset) -> Result<Vec<Vec<f64>>, Diverged> {
        let scene = self.scene_with(p);
        let mut sim = Sim::new(&scene).map_err(|_| Diverged { t_s: data.t_s[0] })?;
        let dt = sim.params().sim.dt_s;
        let out_index: Vec<usize> = data
            .output_names
            .iter()
            .map(|n| if n == Self::OUTPUTS[0] { 0 } else { 1 })
            .collect();
        let mut y = vec![vec![0.0; data.len()]; data.output_names.len()];
        let mut u = vec![0.0; data.inputs.len()];
        for (j, &side) in out_index.iter().enumerate() {
            y[j][0] = sim.drivetrains()[side].motor.speed_rad_s;
        }
        for k in 0..data.len() - 1 {
            let before = sim.drivetrains().map(|d| d.motor.angle_rad);
            data.input_row(k, &mut u);
            sim.set_actuation(Actuation::Demand {
                forward_pct: u[0],
                turn_pct: u[1],
            });
            let steps = ((data.t_s[k + 1] - data.t_s[k]) / dt).round().max(1.0) as usize;
            for _ in 0..steps {
                sim.step().map_err(|_| Diverged { t_s: data.t_s[k] })?;
            }
            let interval = data.t_s[k + 1] - data.t_s[k];
            for (j, &side) in out_index.iter().enumerate() {
                y[j][k + 1] = (sim.drivetrains()[side].motor.angle_rad - before[side]) / interval;
            }
        }
        Ok(y)
    }
}

/// Fits the scene's DCMC keys to a lifted-wheel recording (demands in, motor speeds out)
/// by output error through the simulator, in one response form. Returns the fit
/// (parameters in the form's key order) and the replay model.
pub fn fit_dcmc_keys(
    scene: &Scene,
    data: &Dataset,
    form: ResponseForm,
) -> Result<(Fit, LiftedDcmcReplay), ThesisDcmcError> {
    let model = LiftedDcmcReplay::new(scene, form);
    let nominal: Vec<f64> = model.specs.iter().map(|s| s.nominal).collect();
    let settings = FitSettings {
        free: (0..form.keys().len()).collect(),
        weighting: crate::ident::fit::Weighting::outputs_only(vec![1.0; data.output_names.len()]),
        max_iterations: 40,
        starts: vec![nominal],
    };
    let f = fit_predictor(&model, data, &settings)?;
    Ok((f, model))
}
