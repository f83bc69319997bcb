//! Terms outside the vocabulary in a calibration: after the effect rounds, on a lifted
//! drive the simulator replays, the contract's families ([`crate::model::term`]) are
//! searched through the simulator itself, as `diagnose --rig` searches them through its
//! fitting model, and a term the recording supports goes into the scene (`[term]`).
//!
//! 1. **Screen**: the stage's residual is linearised in its free keys (one replay each)
//!    and in each form's coefficients (one replay each, the coefficient 3 % of its
//!    physical ceiling, its order or exponent set in the scene), and each form is
//!    fitted on the even tenths of the recording and judged on the odd ones
//!    ([`crate::diagnose::terms::screen::judge_columns`]).
//! 2. **Fit**: the best-screened form (removing at least
//!    [`crate::diagnose::terms::MIN_HELD_OUT_REDUCTION`] of the held-out residual, and
//!    half of what the round's best effect removed: a term wins a round only with twice
//!    its AIC gain) has its
//!    coefficients (and a thermal time constant) fitted through the simulator with the
//!    stage's keys, with its family's
//!    next orders where they screened nearly as well (the best fit of those passing the
//!    rules is taken); where none passes, the best of another family.
//! 3. **Judge**: the effects' rules (the AIC gain with the effective residual count, the
//!    share of the residual removed, against the stage and against the stage's keys
//!    refitted from where the term's fit left them), the coefficients inside their
//!    bounds, determined, of the sign the physics has and two standard deviations clear
//!    of zero.
//!
//! The simulator's term reads its own angle: a periodic term's phase drifts with the
//! replay's angle error over a long record, where `diagnose --rig` fits it on the
//! measured angle.

use rayon::prelude::*;

use super::search::{Problem, Stage};
use super::{keys, CalibrateError};
use crate::diagnose::terms::screen::{difference, fitting_rows, judge_columns};
use crate::diagnose::terms::{
    contract_params, forms, main_std, Ceilings, TermRow, CONFIRMED, MIN_HELD_OUT_REDUCTION,
    ORDER_RIVALS, RIVAL_SHARE,
};
use crate::ident::data::Dataset;
use crate::ident::fit::residuals;
use crate::ident::models::rotary_axis::{AxisInput, TermCoefficient, TermForm};
use crate::model::term::Family;
use crate::record::channels as chan;
use crate::record::Recording;
use crate::rig::RigKind;
use crate::scene::Scene;

/// Relative step of a free key's difference in the screen's linearisation: the
/// simulator's outputs are rough below about 1e-4 relative (its events on its time grid).
const KEY_STEP: f64 = 1e-2;

/// A coefficient's screen perturbation through the simulator, as a share of its physical
/// ceiling: thirty times the fitting model's (`diagnose`'s 1e-3), as the simulator's
/// roughness asks (a torque constant falling by 1e-4 at the record's currents is lost in
/// it).
const SCREEN_STEP: f64 = 3e-2;

/// A form tried through the simulator: its row (the contract's parameters and the
/// verdict), its form, its keys and whether the calibration took it.
#[derive(Debug, Clone)]
pub struct TermTrial {
    /// The fitted form as judged, in the contract's terms.
    pub row: TermRow,
    /// The form.
    pub form: TermForm,
    /// The scene key its order, exponent or time constant is set in, and the value.
    pub setting: Option<(String, f64)>,
    /// Its coefficients' scene keys with their fitted values and standard deviations.
    pub coefficients: Vec<(String, f64, Option<f64>)>,
    /// A coefficient ended with the sign its physics cannot have (a drag that drives).
    pub wrong_sign: bool,
    /// Whether the calibration took it into the scene.
    pub accepted: bool,
    /// A vocabulary effect that explained the residual nearly as well (the term passed the
    /// rules but had less than [`crate::diagnose::round::VOCABULARY_PREFERENCE`] times its
    /// AIC gain): the effect keeps its name.
    pub outranked_by: Option<&'static str>,
}

/// The term search of a calibration: how many forms were screened and each form fitted.
#[derive(Debug, Clone, Default)]
pub struct TermSearch {
    /// Forms screened.
    pub screened: usize,
    /// The forms fitted, in the order fitted (the accepted one last).
    pub trials: Vec<TermTrial>,
}

impl TermSearch {
    /// The term the calibration took into the scene, if any.
    pub fn accepted(&self) -> Option<&TermTrial> {
        self.trials.iter().find(|t| t.accepted)
    }

    /// The accepted term at the calibration's final values (`keys`, the last stage's
    /// `fit`): the rounds after it refit its coefficients with the others, as an accepted
    /// effect's key is reported at its final value.
    pub(super) fn settle(
        &mut self,
        keys: &[super::KeyFit],
        data: &Dataset,
        fit: &crate::ident::fit::Fit,
        ceilings: &Ceilings,
    ) {
        let Some(t) = self.trials.iter_mut().find(|t| t.accepted) else {
            return;
        };
        for (key, value, std) in &mut t.coefficients {
            if let Some(k) = keys.iter().find(|k| k.key == *key) {
                (*value, *std) = (k.after, k.std);
            }
        }
        if let Some((key, order)) = &mut t.setting {
            if let Some(k) = keys.iter().find(|k| k.key == *key) {
                *order = k.after;
                t.form.order = k.after;
            }
        }
        let values: Vec<f64> = t.coefficients.iter().map(|c| c.1).collect();
        let stds: Vec<Option<f64>> = t.coefficients.iter().map(|c| c.2).collect();
        t.row.params = contract_params(t.form, &values, data, fit, ceilings);
        t.row.std = main_std(t.form, &stds, data, fit, ceilings);
    }
}

/// Whether a calibration searches terms on this recording: a lifted drive (the families
/// are drivetrain physics, seen apart from a chassis's there) replayed by the simulator,
/// of a scene without a term.
pub(super) fn searched(rec: &Recording, scene: &Scene, engine: crate::replay::Engine) -> bool {
    matches!(rec.rig, RigKind::DriveAxis | RigKind::DrivePair)
        && engine == crate::replay::Engine::Simulator
        && !scene.term.any()
}

/// The drive's physical ceilings on a term's coefficients: the stall torque at the
/// largest voltage `peak_v` the recording asks of the motors, through the scene's motor;
/// the recording's largest current and mean square current (the stall current and its
/// square without a current) and its largest motor speed through the gear.
pub(super) fn ceilings(scene: &Scene, data: &Dataset, peak_v: f64) -> Ceilings {
    let m = &scene.motor;
    let stall_a = peak_v / m.resistance_ohm;
    // The torque constant's fall is bounded at the largest current the record shows (a
    // lifted axis never nears its stall current, and a ceiling there would leave the
    // screen's step lost in the simulator's roughness).
    let current_a = data
        .output_index(chan::CURRENT_A)
        .map(|j| {
            data.outputs[j]
                .iter()
                .flatten()
                .fold(0.0f64, |x, i| x.max(i.abs()))
        })
        .filter(|i| *i > 0.0)
        .unwrap_or(stall_a);
    Ceilings::of_record(
        data,
        m.torque_constant_nm_a * stall_a,
        current_a,
        scene.gearbox.ratio,
    )
}

/// Every term coefficient's scene key with its search half-width (its ceiling): the
/// calibration fits them on a linear scale through zero.
pub(super) fn signed_keys(ceilings: &Ceilings) -> Vec<(String, f64)> {
    let mut out: Vec<(String, f64)> = Vec::new();
    for form in forms(AxisInput::Voltage) {
        for c in form.coefficients(&ceilings.of_form(form)) {
            match out.iter_mut().find(|(k, _)| k == c.key) {
                Some((_, w)) => *w = w.max(c.hi),
                None => out.push((c.key.to_string(), c.hi)),
            }
        }
    }
    out
}

/// The scene with a form's order set and its coefficients at `values`.
fn with_form(
    scene: &Scene,
    form: TermForm,
    coefficients: &[TermCoefficient],
    values: &[f64],
) -> Result<Scene, CalibrateError> {
    let mut pairs: Vec<(String, f64)> = form
        .fixed()
        .map(|(_, key, v)| (key.to_string(), v))
        .into_iter()
        .collect();
    pairs.extend(
        coefficients
            .iter()
            .zip(values)
            .map(|(c, v)| (c.key.to_string(), *v)),
    );
    keys::set(scene, &pairs)
}

/// One form's screen: its held-out share removed, and its coefficients fitted on the
/// whole record (clamped into their search).
struct Screened {
    form: TermForm,
    coefficients: Vec<TermCoefficient>,
    held_out_reduction: f64,
    start: Vec<f64>,
}

/// The stage's residual on the simulator and its derivatives in the stage's free keys.
struct Linearised {
    residual: Vec<f64>,
    jacobian: Vec<Vec<f64>>,
    fitting: Vec<bool>,
}

impl Linearised {
    fn at(problem: &Problem, stage: &Stage) -> Result<Option<Linearised>, CalibrateError> {
        let w = &problem.weighting.outputs;
        let Some(base) = problem.simulator_prediction(&stage.reached)? else {
            return Ok(None);
        };
        let residual = residuals(&problem.data, &base, w);
        let columns: Vec<Option<Vec<f64>>> = stage
            .free
            .par_iter()
            .map(|k| {
                let v = keys::get(&stage.reached, k)?;
                let h = KEY_STEP * if v != 0.0 { v.abs() } else { 1.0 };
                let moved = keys::set(&stage.reached, &[(k.clone(), v + h)])?;
                Ok(problem
                    .simulator_prediction(&moved)?
                    .map(|y| difference(&residuals(&problem.data, &y, w), &residual, h)))
            })
            .collect::<Result<_, CalibrateError>>()?;
        let Some(jacobian) = columns.into_iter().collect::<Option<Vec<_>>>() else {
            return Ok(None);
        };
        Ok(Some(Linearised {
            residual,
            jacobian,
            fitting: fitting_rows(&problem.data),
        }))
    }

    /// A form's columns through the simulator, judged beside the stage's keys.
    fn screen(
        &self,
        problem: &Problem,
        stage: &Stage,
        form: TermForm,
        ceilings: &Ceilings,
    ) -> Result<Option<Screened>, CalibrateError> {
        let w = &problem.weighting.outputs;
        let coefficients = form.coefficients(&ceilings.of_form(form));
        let mut columns = Vec::with_capacity(coefficients.len());
        for (i, c) in coefficients.iter().enumerate() {
            let h = SCREEN_STEP * c.hi;
            let mut values = vec![0.0; coefficients.len()];
            values[i] = h;
            let scene = with_form(&stage.reached, form, &coefficients, &values)?;
            let Some(y) = problem.simulator_prediction(&scene)? else {
                return Ok(None);
            };
            columns.push(difference(
                &residuals(&problem.data, &y, w),
                &self.residual,
                h,
            ));
        }
        let Some(judged) = judge_columns(&self.jacobian, &columns, &self.residual, &self.fitting)
        else {
            return Ok(None);
        };
        let start = judged.starts(&coefficients);
        Ok(Some(Screened {
            form,
            coefficients,
            held_out_reduction: judged.held_out_reduction,
            start,
        }))
    }
}

/// The round's best effect, against which a term is weighed.
#[derive(Debug, Clone, Copy)]
pub(super) struct Rival {
    /// Its name.
    pub effect: &'static str,
    /// Its AIC gain.
    pub delta_aic: f64,
    /// The share of the stage's residual it removed.
    pub reduction: f64,
}

/// Share of the round's best effect's residual reduction a term's screen must reach for
/// its fits to be run: to win the round a term needs more than twice the effect's AIC
/// gain, so more than its reduction; the linearised screen on half the record may
/// underestimate a term's, hence the half.
const RIVAL_SCREEN_SHARE: f64 = 0.5;

/// Searches the families on the calibration's `stage` through the simulator, against the
/// round's best effect `rival` (none: no effect passed): the search, and the stage with
/// the accepted term's coefficients among its free keys.
pub(super) fn search(
    problem: &Problem,
    stage: &Stage,
    ceilings: &Ceilings,
    rival: Option<&Rival>,
    progress: &dyn Fn(&str),
) -> Result<(TermSearch, Option<Stage>), CalibrateError> {
    let all = forms(AxisInput::Voltage);
    progress(&format!(
        "terms outside the vocabulary: screening {} forms of {} families through the simulator",
        all.len(),
        Family::ALL.len()
    ));
    let mut out = TermSearch::default();
    let Some(lin) = Linearised::at(problem, stage)? else {
        return Ok((out, None));
    };
    let mut screened: Vec<Screened> = all
        .into_par_iter()
        .map(|form| lin.screen(problem, stage, form, ceilings))
        .collect::<Result<Vec<_>, _>>()?
        .into_iter()
        .flatten()
        .collect();
    out.screened = screened.len();
    screened.sort_by(|a, b| b.held_out_reduction.total_cmp(&a.held_out_reduction));
    progress(&format!(
        "terms: the best screens removed {} of the held-out residual",
        screened
            .iter()
            .take(3)
            .map(|s| format!(
                "{:.1} % ({} {})",
                100.0 * s.held_out_reduction,
                s.form.family.name(),
                s.form.order
            ))
            .collect::<Vec<_>>()
            .join(", ")
    ));
    // A term that cannot outdo the round's best effect is not fitted.
    let needed = rival.map_or(0.0, |r| RIVAL_SCREEN_SHARE * r.reduction);
    if let (Some(best), Some(r)) = (screened.first(), rival) {
        if best.held_out_reduction < needed && best.held_out_reduction >= MIN_HELD_OUT_REDUCTION {
            progress(&format!(
                "terms: not fitted: the best screen removed less than half of what {} removed ({:.1} %)",
                r.effect,
                100.0 * r.reduction
            ));
        }
    }
    let mut families: Vec<Family> = Vec::new();
    for s in screened.iter().filter(|s| s.held_out_reduction >= needed) {
        if families.len() >= CONFIRMED || s.held_out_reduction < MIN_HELD_OUT_REDUCTION {
            break;
        }
        if families.contains(&s.form.family) {
            continue;
        }
        families.push(s.form.family);
        // The family's next orders where they screened nearly as well (speed powers of 1.5
        // and 2 screen within a few percent of each other on a short record): each fitted,
        // and the whole record's fit chooses.
        let rivals: Vec<&Screened> = screened
            .iter()
            .filter(|r| r.form.family == s.form.family)
            .take(ORDER_RIVALS + 1)
            .filter(|r| r.held_out_reduction >= RIVAL_SHARE * s.held_out_reduction)
            .collect();
        progress(&format!(
            "fitting {} (order {}) through the simulator: its screen removed {:.1} % of the held-out residual",
            s.form.family.name(),
            rivals
                .iter()
                .map(|r| r.form.order.to_string())
                .collect::<Vec<_>>()
                .join(", "),
            100.0 * s.held_out_reduction
        ));
        let fits = rivals
            .par_iter()
            .map(|r| fitted(problem, stage, r, ceilings))
            .collect::<Result<Vec<_>, _>>()?;
        let best = fits
            .iter()
            .enumerate()
            .filter(|(_, (t, _))| t.accepted)
            .max_by(|(_, a), (_, b)| a.0.row.delta_aic.total_cmp(&b.0.row.delta_aic))
            .map(|(i, _)| i);
        let mut with = None;
        for (i, (mut trial, stage)) in fits.into_iter().enumerate() {
            // Only the best order of the family is taken.
            trial.accepted = Some(i) == best;
            if trial.accepted {
                with = Some(stage);
            }
            out.trials.push(trial);
        }
        if with.is_some() {
            // The accepted one last.
            out.trials.sort_by_key(|t| t.accepted);
            return Ok((out, with));
        }
    }
    Ok((out, None))
}

/// A screened form's coefficients fitted through the simulator with the stage's keys,
/// and judged.
fn fitted(
    problem: &Problem,
    stage: &Stage,
    s: &Screened,
    ceilings: &Ceilings,
) -> Result<(TermTrial, Stage), CalibrateError> {
    let scene = with_form(&stage.scene, s.form, &s.coefficients, &s.start)?;
    let mut free = stage.free.clone();
    // A thermal time constant is refined by the fit (a positive key, on a log scale
    // within a factor of 10 of the screen's); orders and exponents stay where the
    // screen put them.
    let refined = match (s.form.family, s.form.fixed()) {
        (Family::ThermalDrift, Some((_, key, _))) => Some(key.to_string()),
        _ => None,
    };
    free.extend(refined.iter().cloned());
    free.extend(s.coefficients.iter().map(|c| c.key.to_string()));
    let next = problem.fit(&scene, &free)?;
    let n_stage = stage.effective_n(&problem.data);
    let gain = problem.gain(stage, &n_stage, &next)?;
    // As for an effect: the gain is the term's only if the stage's keys, refitted from
    // where the term's fit left them without it, do not reach it.
    let gain = if gain.passes() {
        let fitted: Vec<(String, f64)> = stage
            .free
            .iter()
            .map(|k| Ok((k.clone(), keys::get(&next.reached, k)?)))
            .collect::<Result<_, CalibrateError>>()?;
        let null = problem.fit_quick(&keys::set(&stage.scene, &fitted)?, &stage.free, vec![])?;
        if null.fit.cost < stage.fit.cost {
            problem.gain(&null, &null.effective_n(&problem.data), &next)?
        } else {
            gain
        }
    } else {
        gain
    };
    let first = stage.free.len() + refined.iter().len();
    let slots: Vec<usize> = (first..next.free.len()).collect();
    // The refined time constant: the form's order as fitted, and a bound reached there is
    // a heating the recording cannot place in time.
    let form = match &refined {
        Some(key) => TermForm {
            order: keys::get(&next.reached, key)?,
            ..s.form
        },
        None => s.form,
    };
    let tau_at_bound = refined.is_some() && next.at_bound(first - 1).is_some();
    let values: Vec<f64> = slots.iter().map(|&i| next.fit.params[i]).collect();
    let stds: Vec<Option<f64>> = slots.iter().map(|&i| next.fit.std[i]).collect();
    let at_bound = tau_at_bound || slots.iter().any(|&i| next.at_bound(i).is_some());
    let wrong_sign = s
        .coefficients
        .iter()
        .zip(&values)
        .any(|(c, v)| c.lo >= 0.0 && *v < 0.0);
    let undetermined = stds.iter().any(|sd| sd.is_none());
    let z_sq: f64 = values
        .iter()
        .zip(&stds)
        .map(|(v, sd)| sd.map_or(0.0, |sd| (v / sd).powi(2)))
        .sum();
    let significant = gain.passes()
        && s.held_out_reduction >= MIN_HELD_OUT_REDUCTION
        && !at_bound
        && !wrong_sign
        && !undetermined
        && z_sq > 4.0;
    let row = TermRow {
        name: form.family.name().into(),
        params: contract_params(form, &values, &problem.data, &next.fit, ceilings),
        std: main_std(form, &stds, &problem.data, &next.fit, ceilings),
        fit_pct: crate::ident::fit_pct_mean(&problem.data, &next.fit.predicted),
        rss_reduction_pct: 100.0 * gain.reduction,
        held_out_reduction_pct: 100.0 * s.held_out_reduction,
        delta_aic: gain.delta_aic,
        significant,
        at_bound,
        undetermined,
    };
    let trial = TermTrial {
        row,
        form,
        setting: form.fixed().map(|(_, key, v)| (key.to_string(), v)),
        coefficients: s
            .coefficients
            .iter()
            .zip(values.iter().zip(&stds))
            .map(|(c, (v, sd))| (c.key.to_string(), *v, *sd))
            .collect(),
        wrong_sign,
        accepted: significant,
        outranked_by: None,
    };
    Ok((trial, next))
}
