//! Fitting commands' results as Rerun recordings, each in the one overlay layout
//! ([`super::overlay`]): the recording's inputs, then per output the measurement under the
//! models' simulations and their differences from it.

use super::overlay::{save, Input, Output, Overlay, Simulation};
use super::VizError;
use crate::ident::data::Dataset;

/// Input columns as the overlay shows them: names with their values on one time base.
fn inputs<'a>(
    names: impl IntoIterator<Item = &'a str>,
    t_s: &'a [f64],
    columns: &'a [Vec<f64>],
) -> Vec<Input<'a>> {
    names
        .into_iter()
        .zip(columns)
        .map(|(name, values)| Input { name, t_s, values })
        .collect()
}

/// The inputs of a dataset: its commands, not what a fit derives from its outputs (the
/// measured angle's line a periodic term reads, a ramp of hundreds of radians that would
/// flatten the commands beside it).
fn dataset_inputs(data: &Dataset) -> Vec<Input<'_>> {
    inputs(
        data.input_names.iter().map(String::as_str),
        &data.t_s,
        &data.inputs,
    )
    .into_iter()
    .filter(|i| !crate::ident::data::is_derived_input(i.name))
    .collect()
}

/// Saves a diagnosis: per output, the measurement under the baseline's and the diagnosed
/// model's simulations, with the recording's inputs.
pub fn save_diagnosis(
    path: &std::path::Path,
    d: &crate::diagnose::Diagnosis,
) -> Result<(), VizError> {
    let Some(data) = d.baseline.data.as_ref() else {
        return Err(VizError("the diagnosis kept no data to show".into()));
    };
    let outputs = data
        .output_names
        .iter()
        .enumerate()
        .map(|(j, name)| Output {
            name: name.clone(),
            t_s: &data.t_s,
            measured: &data.outputs[j],
            models: vec![
                Simulation {
                    label: "baseline".into(),
                    values: &d.baseline.predicted[j],
                    fit_pct: d.baseline.fit_pct.get(name).copied(),
                },
                Simulation {
                    label: "diagnosed".into(),
                    values: &d.diagnosed.predicted[j],
                    fit_pct: d.diagnosed.fit_pct.get(name).copied(),
                },
            ],
        })
        .collect();
    save(
        path,
        &Overlay {
            what: "diagnosis",
            recording: &d.recording,
            inputs: dataset_inputs(data),
            outputs,
            quantities: d
                .terms
                .iter()
                .filter_map(|t| t.quantity.as_ref())
                .map(|(name, values)| Input {
                    name,
                    t_s: &data.t_s,
                    values,
                })
                .collect(),
        },
    )
}

/// Saves an identification: per output, the measurement under the identified model's
/// simulation, for the estimation record and (prefixed `validation: `) the validation one.
pub fn save_identification(
    path: &std::path::Path,
    id: &crate::ident::Identification,
) -> Result<(), VizError> {
    let mut evals = vec![("", &id.estimation)];
    if let Some(v) = &id.validation {
        evals.push(("validation: ", v));
    }
    let mut outputs = Vec::new();
    for (prefix, e) in &evals {
        let Some(data) = e.data.as_ref() else {
            continue;
        };
        for (j, name) in data.output_names.iter().enumerate() {
            outputs.push(Output {
                name: format!("{prefix}{name}"),
                t_s: &data.t_s,
                measured: &data.outputs[j],
                models: vec![Simulation {
                    label: "identified model".into(),
                    values: &e.predicted[j],
                    fit_pct: e.fit_pct.get(name).copied(),
                }],
            });
        }
    }
    let inputs = id
        .estimation
        .data
        .as_ref()
        .map(dataset_inputs)
        .unwrap_or_default();
    save(
        path,
        &Overlay {
            quantities: vec![],
            what: "identification",
            recording: &id.estimation.recording,
            inputs,
            outputs,
        },
    )
}

/// The inputs a replay drove the simulator with.
fn replay_inputs(r: &crate::replay::Replay) -> Vec<Input<'_>> {
    inputs(r.drive.columns().iter().copied(), &r.t_s, &r.inputs)
}

/// Saves a replay: per output, the measurement under the simulation.
pub fn save_replay(
    path: &std::path::Path,
    name: &str,
    r: &crate::replay::Replay,
) -> Result<(), VizError> {
    let outputs = r
        .outputs
        .iter()
        .map(|o| Output {
            name: o.name.clone(),
            t_s: &r.t_s,
            measured: &o.measured,
            models: vec![Simulation {
                label: "simulated".into(),
                values: &o.simulated,
                fit_pct: o.fit_pct.is_finite().then_some(o.fit_pct),
            }],
        })
        .collect();
    save(
        path,
        &Overlay {
            quantities: vec![],
            what: "replay",
            recording: name,
            inputs: replay_inputs(r),
            outputs,
        },
    )
}

/// Saves a calibration: per fitted output, the measurement under the original and the
/// calibrated scene's replays.
pub fn save_calibration(
    path: &std::path::Path,
    name: &str,
    c: &crate::calibrate::Calibration,
) -> Result<(), VizError> {
    let outputs = c
        .outputs
        .iter()
        .filter_map(|n| Some((c.before.output(n)?, c.after.output(n)?)))
        .map(|(b, a)| Output {
            name: b.name.clone(),
            t_s: &c.before.t_s,
            measured: &b.measured,
            models: vec![
                Simulation {
                    label: "original scene".into(),
                    values: &b.simulated,
                    fit_pct: Some(b.fit_pct),
                },
                Simulation {
                    label: "calibrated scene".into(),
                    values: &a.simulated,
                    fit_pct: Some(a.fit_pct),
                },
            ],
        })
        .collect();
    save(
        path,
        &Overlay {
            quantities: vec![],
            what: "calibration",
            recording: name,
            inputs: replay_inputs(&c.before),
            outputs,
        },
    )
}
