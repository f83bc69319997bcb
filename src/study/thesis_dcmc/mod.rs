//! The thesis's DCMC as identified, and the default machine fitted to it.
//!
//! The thesis identified the lifted-wheel system (DCMC, motor, gear train and wheel) from
//! random demands sampled at 25 ms with MATLAB's PEM (section 5.2.1, case 1, "PEM on 2/22
//! 1997 at 17:17"): continuous time, states and outputs the two motor speeds,
//! `A = diag(-1.5447 +- 0.0533, -1.7278 +- 0.0315)`,
//! `B = [[-4.3438 +- 0.1248, -3.1130 +- 0.1074], [-3.9616 +- 0.0641, 2.8626 +- 0.0498]]`,
//! loss 4.45e5, FPE 4.54e5. This module
//!
//! 1. makes a reference recording from that model ([`reference_recording`]): the
//!    thesis's model driven by pulse demands like the microcontroller's, sampled at 25 ms,
//!    with white output noise at the thesis's loss;
//! 2. fits the scene's DCMC keys to it by replaying its demands through the simulator's
//!    lifted-wheel machine ([`LiftedDcmcReplay`], the simulator itself, not a copy of its
//!    laws);
//! 3. identifies the default machine's own lifted-wheel experiment with the thesis's
//!    case-1 structure, for comparison with the thesis's A and B.
//!
//! **Units of the thesis's model** (worked out from the seed, section 2.4.1 and Figs
//! 5.5-5.6): the inputs are the forward and turn demands in percent (the pulse program
//! sent "+-100% demand signals"; the figures' input axes run to +-100); the outputs are
//! motor shaft speeds in rad/s: the speeds were "inferred from attached position encoders"
//! on the motors (1024 counts per revolution, read every 25 ms: 0.25 rad/s per count),
//! the figures' output axes run to +-300, and the steady gains `-B/A` give 2.8 and 2.3
//! rad/s per percent, so full demand is 230-280 rad/s: below the motor's 380 rad/s
//! no-load speed at 24 V (Kv = 0.063 V s/rad) and impossible as a wheel speed (21 m/s).
//! The loss is the determinant of the residual covariance, so equal noise on both outputs
//! has the RMS `loss^(1/4)` = 25.8 rad/s.
//!
//! **Signs.** The thesis's forward column is negative on both sides and its turn column
//! positive on the right: the encoder's and the turn demand's sign conventions. agvsim
//! counts forward demand and forward motor speed positive and turns left with positive
//! turn demand (right side faster), so the reference negates both speeds and the turn
//! demand: `B_agvsim = [[4.3438, -3.1130], [3.9616, 2.8626]]`. Magnitudes, time constants
//! and column ratios, which are what is compared, are unchanged.

mod matching;
mod reference;
mod replay;
mod summary;

pub use matching::{
    identify_lifted, identify_lifted_mean, match_case1, Case1Match, PairModel, MATCHED_KEYS,
    MATCH_SEEDS,
};
pub use reference::{
    column_ratios, reference_recording, ReferenceSpec, ThesisCase1, CASE1, THESIS_LIKE_HOLD,
    THESIS_LIKE_PEAK_PCT,
};
pub use replay::{fit_dcmc_keys, LiftedDcmcReplay, ResponseForm};

use crate::scene::keys::set_number;

use crate::ident::data::Dataset;
use crate::scene::Scene;

/// Why the thesis-DCMC study could not be done.
#[derive(Debug, thiserror::Error)]
pub enum ThesisDcmcError {
    /// A lifted-wheel experiment stopped.
    #[error(transparent)]
    Experiment(#[from] crate::experiment::ExperimentError),
    /// Its rig did not load.
    #[error(transparent)]
    Rig(#[from] crate::rig::RigError),
    /// A recording did not load.
    #[error(transparent)]
    Recording(#[from] crate::record::RecordingError),
    /// An identification could not be done.
    #[error(transparent)]
    Ident(#[from] crate::ident::IdentError),
    /// A fit through the simulator could not be done.
    #[error(transparent)]
    Fit(#[from] crate::ident::fit::FitError),
    /// A floor run stopped.
    #[error(transparent)]
    Sim(#[from] crate::sim::SimError),
    /// The case-1 identification gave no state-space model.
    #[error("the case-1 fit has no state-space report")]
    NoStateSpace,
}
/// One response form fitted to the reference, and what the machine then does.
#[derive(Debug, Clone)]
pub struct FormResult {
    /// The form.
    pub form: ResponseForm,
    /// Fitted keys (the form's order) with standard deviations.
    pub fitted: Vec<(String, f64, Option<f64>)>,
    /// The simulator's normalised fit to the reference, per output (left, right), %.
    pub replay_fit_pct: [f64; 2],
    /// The machine with these keys, its thesis-like lifted-wheel runs identified (case 1,
    /// mean over [`MATCH_SEEDS`]).
    pub identified: PairModel,
    /// The lab floor run at the firmware's gain with these keys, complex level.
    pub floor: crate::sim::metrics::RunSummary,
    /// Rightmost closed-loop pole of the firmware's P-D loop at gain 1, 1/s.
    pub rightmost_pole_1_s: Option<f64>,
}

/// The matched machine with a lag on the turn demand too: what the floor allows.
#[derive(Debug, Clone)]
pub struct TurnLagProbe {
    /// The turn demand's lag, s.
    pub turn_response_time_s: f64,
    /// Its thesis-like lifted runs identified with case 1 (mean over [`MATCH_SEEDS`]).
    pub identified: PairModel,
    /// The lab floor run at the firmware's gain, complex level.
    pub floor: crate::sim::metrics::RunSummary,
}

/// What the study found.
#[derive(Debug, Clone)]
pub struct ThesisDcmcResult {
    /// Each form fitted directly to the reference.
    pub forms: Vec<FormResult>,
    /// The keys matched so that the machine identifies as the thesis's (the shipped ones).
    pub matched: Case1Match,
    /// The matched machine with lags on its turn demand.
    pub turn_lag_probe: Vec<TurnLagProbe>,
    /// The reference identified with the case-1 structure (checks the generator).
    pub reference_model: PairModel,
    /// The scene's machine as shipped, its thesis-like lifted-wheel runs identified with
    /// case 1 (mean over [`MATCH_SEEDS`]).
    pub machine_model: PairModel,
}

/// Fits one form to the reference and tries the result on the floor.
fn try_form(
    scene: &Scene,
    data: &Dataset,
    form: ResponseForm,
    dir: &std::path::Path,
) -> Result<FormResult, ThesisDcmcError> {
    let (fit, model) = fit_dcmc_keys(scene, data, form)?;
    let fitted = form
        .keys()
        .iter()
        .enumerate()
        .map(|(i, k)| (k.to_string(), fit.params[i], fit.std[i]))
        .collect();
    let eval = crate::ident::evaluate(data, fit.predicted.clone(), 10);
    let replay_fit_pct =
        LiftedDcmcReplay::OUTPUTS.map(|o| eval.fit_pct.get(o).copied().unwrap_or(f64::NAN));
    let mut machine = model.scene_with(&fit.params);
    machine.sim.wheels_lifted = scene.sim.wheels_lifted;
    let identified = identify_lifted_mean(&machine, dir)?;
    let mut floor_scene = machine.clone();
    floor_scene.sim.fidelity = crate::scene::Fidelity::Complex;
    let floor = crate::sweep::run::summarise(&floor_scene)?;
    let rightmost_pole_1_s = crate::sim::linearize::linearise(&machine)
        .ok()
        .and_then(|l| crate::sim::linearize::close_loop(&l))
        .map(|c| c.rightmost_re());
    Ok(FormResult {
        form,
        fitted,
        replay_fit_pct,
        identified,
        floor,
        rightmost_pole_1_s,
    })
}

/// The scene with the matched keys (the lag on both sides).
pub fn matched_scene(scene: &Scene, m: &Case1Match) -> Scene {
    let mut s = scene.clone();
    ResponseForm::ForwardLag.isolate(&mut s);
    for (k, v) in MATCHED_KEYS.iter().zip(m.values) {
        set_number(&mut s, k, v);
    }
    s.dcmc.response_time_right_s = s.dcmc.response_time_left_s;
    s
}

/// Turn lags tried on the matched machine.
pub const PROBED_TURN_LAGS_S: [f64; 5] = [0.0, 0.1, 0.2, 0.3, 0.5];

/// The matched machine with each of [`PROBED_TURN_LAGS_S`] on its turn demand: how it then
/// identifies, and whether the firmware still holds the wire.
fn probe_turn_lag(
    scene: &Scene,
    m: &Case1Match,
    dir: &std::path::Path,
) -> Result<Vec<TurnLagProbe>, ThesisDcmcError> {
    PROBED_TURN_LAGS_S
        .iter()
        .map(|&t| {
            let mut s = matched_scene(scene, m);
            s.dcmc.turn_response_time_s = t;
            let identified = identify_lifted_mean(&s, dir)?;
            s.sim.fidelity = crate::scene::Fidelity::Complex;
            let floor = crate::sweep::run::summarise(&s)?;
            Ok(TurnLagProbe {
                turn_response_time_s: t,
                identified,
                floor,
            })
        })
        .collect()
}

/// The study: the reference, each response form fitted to it and tried on the floor, the
/// keys matched so the machine identifies as the thesis's, the turn lag the floor allows,
/// and the shipped machine identified.
pub fn run(
    opts: &crate::study::StudyOptions,
) -> Result<(ThesisDcmcResult, crate::study::StudyOutput), crate::sweep::SweepError> {
    use crate::record::Recording;
    use crate::sweep::SweepError;
    let err = |e: ThesisDcmcError| SweepError::Format {
        path: opts.out_dir.clone(),
        message: e.to_string(),
    };
    let scene = Scene::from_toml(
        crate::study::thesis::SCENE,
        std::path::Path::new(crate::study::thesis::SCENE_LABEL),
        &[],
    )?;
    std::fs::create_dir_all(&opts.out_dir).map_err(crate::sweep::io_err(&opts.out_dir))?;
    let ref_path = opts.out_dir.join("case1_reference.csv");
    let text = reference_recording(&ReferenceSpec::default());
    crate::output::write_atomically(&ref_path, &text).map_err(crate::sweep::io_err(&ref_path))?;
    let rec = Recording::parse(&text, &ref_path).map_err(|e| err(e.into()))?;
    let data = Dataset::from_recording(
        &rec,
        &LiftedDcmcReplay::INPUTS.map(String::from),
        &LiftedDcmcReplay::OUTPUTS.map(String::from),
    )
    .map_err(|e| err(e.into()))?;
    let forms = ResponseForm::ALL
        .iter()
        .map(|f| try_form(&scene, &data, *f, &opts.out_dir.join("forms")))
        .collect::<Result<Vec<_>, _>>()
        .map_err(err)?;
    let matched = match_case1(&scene, &opts.out_dir.join("match")).map_err(err)?;
    let turn_lag_probe =
        probe_turn_lag(&scene, &matched, &opts.out_dir.join("probe")).map_err(err)?;
    let (_, reference_model) =
        identify_lifted(&scene, &opts.out_dir.join("machine"), 1, Some(&ref_path)).map_err(err)?;
    let machine_model = identify_lifted_mean(&scene, &opts.out_dir.join("machine")).map_err(err)?;
    let result = ThesisDcmcResult {
        forms,
        matched,
        turn_lag_probe,
        reference_model: reference_model.expect("asked for"),
        machine_model,
    };
    let summary = summary::summary(&result, &scene);
    let path = crate::study::write_summary(&opts.out_dir, &summary)?;
    Ok((
        result,
        crate::study::StudyOutput {
            summary,
            files: vec![path, ref_path],
        },
    ))
}
