//! An identification run: the free parameters, the starts, the weighted fit, the checks
//! that the record can carry the fit, and the predictions of a fitted model.

use crate::model::motor::MotorParams;

use std::path::Path;

use rand::{Rng, SeedableRng};

use super::data::Dataset;
use super::data::{ignored_inputs, LeftOut};
use super::evaluate::{evaluate, Evaluation};
use super::fit::{self, Fit, FitSettings};
use super::identification::{assemble, Identification};
use super::model::{GreyBox, Predictor};
use super::structure::{build_structure, Structure};
use super::sysid_regression as feedforward;
use super::weighting;
use super::{IdentError, IdentifyOptions};
use crate::record::Recording;
use crate::rig::Rig;

/// Resolves `--free` names against the model's parameters.
fn free_indices(
    model: &dyn GreyBox,
    names: &Option<Vec<String>>,
    data: &Dataset,
) -> Result<Vec<usize>, IdentError> {
    match names {
        None => Ok(model.default_free_for(data)),
        Some(names) => {
            if let Some((_, n)) = names
                .iter()
                .enumerate()
                .find(|(i, n)| names[..*i].contains(n))
            {
                return Err(IdentError::DuplicateParameter { name: n.clone() });
            }
            names
                .iter()
                .map(|n| {
                    model
                        .param_index(n)
                        .ok_or_else(|| IdentError::UnknownParameter {
                            name: n.clone(),
                            model: model.name(),
                            known: model
                                .params()
                                .iter()
                                .map(|p| p.name.as_str())
                                .collect::<Vec<_>>()
                                .join(", "),
                        })
                })
                .collect()
        }
    }
}

/// Starting points: the nominal values, then perturbations of the free parameters by
/// log-uniform factors in [1/2, 2] (seeded, so runs repeat).
pub fn starts(nominal: &[f64], free: &[usize], count: usize) -> Vec<Vec<f64>> {
    let mut rng = rand_pcg::Pcg64::seed_from_u64(0x5eed);
    let mut out = vec![nominal.to_vec()];
    for _ in 1..count.max(1) {
        let mut p = nominal.to_vec();
        for &i in free {
            let f: f64 = rng.random_range(-1.0..1.0);
            p[i] *= 2f64.powf(f);
        }
        out.push(p);
    }
    out
}

/// Fits a structure's parameters to a dataset, in two passes:
///
/// 1. each output weighted by its spread (outputs in different units count alike), every
///    believed free parameter's belief weighed against what the residual at the start is
///    worth ([`fit::Weighting::prior_for`]);
/// 2. (several outputs, or believed free parameters) each output re-weighted by its
///    residual RMS, floored at its noise level ([`weighting::output_weights`]), and the
///    beliefs kept only for the parameters the first pass found the record determines
///    less well than the belief ([`Fit::held_by_belief`]), weighed against what the first
///    pass's residual is worth; refitted from there. A parameter the record determines is
///    then the record's estimate alone; one it cannot (a mass on a quasi-static ramp) is
///    held near its belief instead of wandering to a bound.
pub fn fit_structure(
    model: &dyn GreyBox,
    data: &Dataset,
    free: &[usize],
    opts: &IdentifyOptions,
    start_from: &[f64],
) -> Result<Fit, IdentError> {
    let starts = starts(start_from, free, opts.starts);
    Ok(fit_weighted(
        model,
        data,
        free,
        opts.max_iterations,
        starts,
    )?)
}

/// The two passes of [`fit_structure`] for any [`Predictor`] (a grey box, or the simulator
/// replaying a record), from `starts` (the first one sets the first pass's prior weight).
pub fn fit_weighted(
    model: &dyn Predictor,
    data: &Dataset,
    free: &[usize],
    max_iterations: usize,
    starts: Vec<Vec<f64>>,
) -> Result<Fit, fit::FitError> {
    let weights = weighting::spread_weights(data);
    let believed = free
        .iter()
        .any(|&i| model.param_specs()[i].belief_sd_rel.is_some());
    let prior = |predicted: &[Vec<f64>], outputs: &[f64]| {
        if believed {
            fit::Weighting::prior_for(data, predicted, outputs)
        } else {
            0.0
        }
    };
    let prior0 = starts
        .first()
        .and_then(|p| model.predict(p, data).ok())
        .map_or(0.0, |y| prior(&y, &weights));
    let settings = FitSettings {
        free: free.to_vec(),
        weighting: fit::Weighting {
            outputs: weights,
            prior: prior0,
            holding: None,
        },
        max_iterations,
        starts,
    };
    let mut f = fit::fit_predictor(model, data, &settings)?;
    if data.outputs.len() > 1 || believed {
        let holding: Vec<usize> = (0..f.free.len())
            .filter(|&slot| f.held_by_belief(slot))
            .map(|slot| f.free[slot])
            .collect();
        let outputs = weighting::output_weights(data, &f.predicted);
        let weighting = fit::Weighting {
            prior: if holding.is_empty() {
                0.0
            } else {
                prior(&f.predicted, &outputs)
            },
            outputs,
            holding: Some(holding),
        };
        let second = fit::fit_predictor(
            model,
            data,
            &FitSettings {
                free: free.to_vec(),
                weighting,
                max_iterations,
                starts: vec![f.params.clone()],
            },
        )?;
        let (iterations, evaluations) = (f.iterations, f.evaluations);
        f = second;
        f.iterations += iterations;
        f.evaluations += evaluations;
    }
    Ok(f)
}

/// Identifies the rig's model from a recording (and checks it on a validation recording).
pub fn identify(
    rig: &Rig,
    rig_path: &Path,
    rec: &Recording,
    validation: Option<&Recording>,
    opts: &IdentifyOptions,
) -> Result<Identification, IdentError> {
    if let Some(v) = validation {
        if v.rig != rec.rig {
            return Err(IdentError::Mismatch {
                file: v.path.clone(),
                message: format!(
                    "the validation recording is a `{}` recording, the one identified `{}`: validate on a recording of the same rig",
                    v.rig, rec.rig
                ),
            });
        }
    }
    let structure = build_structure(rig, rig_path, rec, opts.model)?;
    let model = structure.model();
    let (data, left_out) = dataset_for(model, rec)?;
    let free = free_indices(model, &opts.free, &data)?;
    enough_data(rec, &data, free.len())?;
    let f = fit_structure(model, &data, &free, opts, &model.nominal())
        .map_err(|e| diverging_start(rec, &data, e))?;
    let estimation = evaluate(&data, f.predicted.clone(), opts.max_lag);
    finite_loss(rec, &data, &estimation)?;
    let validation = match validation {
        Some(v) => {
            let (vdata, _) = dataset_for(model, v)?;
            let y = model
                .simulate_record(&f.params, &vdata)
                .map_err(|d| IdentError::Mismatch {
                    file: v.path.clone(),
                    message: format!("the identified model {d} on the validation recording"),
                })?;
            Some(evaluate(&vdata, y, opts.max_lag))
        }
        None => None,
    };
    let mut id = assemble(&structure, &f, estimation, validation, opts.starts);
    id.ignored_inputs = ignored_inputs(rec, &model_columns(model));
    id.left_out = left_out;
    id.feedforward = feedforward::of_recording(
        rec,
        id.value(MotorParams::torque_constant_nm_a.key()),
        id.value(MotorParams::resistance_ohm.key()),
    );
    Ok(id)
}

/// The dataset a model is fitted on: its inputs and the outputs the recording measures,
/// less those the recording does not excite ([`GreyBox::unexcited_outputs`]), which are
/// returned with why.
pub fn dataset_for(
    model: &dyn GreyBox,
    rec: &Recording,
) -> Result<(Dataset, Vec<LeftOut>), IdentError> {
    let data = Dataset::from_recording(rec, &model.input_names(), &model.output_names())?;
    let left = LeftOut::of(&data, model.unexcited_outputs(&data));
    if left.len() == data.output_names.len() {
        return Err(IdentError::Mismatch {
            file: rec.path.clone(),
            message: format!(
                "no output the record excites: {}",
                left.iter()
                    .map(|l| format!("{} ({})", l.output, l.why))
                    .collect::<Vec<_>>()
                    .join("; ")
            ),
        });
    }
    let names: Vec<String> = left.iter().map(|l| l.output.clone()).collect();
    Ok((data.without_outputs(&names), left))
}

/// Measured output values needed per free parameter: below this the loss, FPE and the
/// standard deviations (which divide by `N - d`) say more about the count than the
/// machine.
pub const MIN_VALUES_PER_PARAMETER: usize = 5;

/// Refuses a record too short to fit `free` parameters.
pub(crate) fn enough_data(rec: &Recording, data: &Dataset, free: usize) -> Result<(), IdentError> {
    let n = data.measured_cells();
    let need = MIN_VALUES_PER_PARAMETER * free.max(1);
    if n < need {
        return Err(IdentError::Mismatch {
            file: rec.path.clone(),
            message: format!(
                "too few samples to fit: {n} measured output values ({} rows) for {free} free parameters; at least {need} are needed ({MIN_VALUES_PER_PARAMETER} per parameter)",
                data.len()
            ),
        });
    }
    Ok(())
}

/// A model that diverges at its starting parameters: say where in the recording, and what
/// in it could be at fault (a huge input cell, a long gap in time), not only the rig.
pub(crate) fn diverging_start(rec: &Recording, data: &Dataset, e: IdentError) -> IdentError {
    let IdentError::Fit(fit::FitError::DivergesAtStart { t_s }) = e else {
        return e;
    };
    let largest = data
        .inputs
        .iter()
        .flatten()
        .fold(0.0f64, |m, v| m.max(v.abs()));
    let gap = data
        .t_s
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(0.0f64, f64::max);
    IdentError::Mismatch {
        file: rec.path.clone(),
        message: format!(
            "the model diverges from the rig's values at t = {t_s} s of this recording: check its inputs there (largest |input| in the record {largest:e}; longest gap between samples {gap:.3} s) and the rig's values"
        ),
    }
}

/// Refuses a fit whose loss is not a finite positive number: a cell too large to square,
/// or a record the model reproduces exactly (no noise left to estimate anything from).
pub(crate) fn finite_loss(
    rec: &Recording,
    data: &Dataset,
    e: &Evaluation,
) -> Result<(), IdentError> {
    if e.loss.is_finite() && e.loss > 0.0 && e.fit_pct.values().all(|f| f.is_finite()) {
        return Ok(());
    }
    let largest = data
        .inputs
        .iter()
        .flatten()
        .copied()
        .chain(data.outputs.iter().flatten().flatten().copied())
        .fold(0.0f64, |m, v| m.max(v.abs()));
    // A determinant of residual covariances can come out a rounding error below zero.
    let why = if e.loss.is_finite() && e.loss.abs() < 1e-12 {
        "the model reproduces the record exactly, so there is no residual to estimate the noise, the standard deviations or the FPE from".to_string()
    } else {
        format!("a cell is too large for the fit's arithmetic (largest |value| {largest:e}); check the recording's inputs and outputs")
    };
    Err(IdentError::Mismatch {
        file: rec.path.clone(),
        message: format!("the fit's loss is {}: {why}", e.loss),
    })
}

/// Simulates a structure at given parameters on a recording (for diagnosis and checks).
pub fn predict(
    structure: &Structure,
    params: &[f64],
    rec: &Recording,
) -> Result<(Dataset, Vec<Vec<f64>>), IdentError> {
    let model = structure.model();
    let data = Dataset::from_recording(rec, &model.input_names(), &model.output_names())?;
    let y = model
        .simulate_record(params, &data)
        .map_err(|d| IdentError::Mismatch {
            file: rec.path.clone(),
            message: format!("the model {d}"),
        })?;
    Ok((data, y))
}

/// A model's input and output columns: what a recording's columns are checked against.
pub fn model_columns(model: &dyn GreyBox) -> Vec<String> {
    model
        .input_names()
        .into_iter()
        .chain(model.output_names())
        .collect()
}
