//! Identification and diagnosis results as Rerun recordings: measured outputs beside the
//! models' simulations and the residuals, as time series.

use rerun::RecordingStreamBuilder;

use super::{err, VizError};

/// Saves a diagnosis: measured outputs with the baseline's and the diagnosed model's
/// simulations and residuals, as time series in a `.rrd` file.
pub fn save_diagnosis(
    path: &std::path::Path,
    d: &crate::diagnose::Diagnosis,
) -> Result<(), VizError> {
    let rec = RecordingStreamBuilder::new("agvsim")
        .recording_id(format!("agvsim-diagnose-{}", d.recording))
        .save(path)
        .map_err(err)?;
    let Some(data) = d.baseline.data.as_ref() else {
        return Ok(());
    };
    for (j, name) in data.output_names.iter().enumerate() {
        for (k, t) in data.t_s.iter().enumerate() {
            rec.set_duration_secs("t", *t);
            rec.log(
                format!("{name}/baseline"),
                &rerun::Scalars::new([d.baseline.predicted[j][k]]),
            )
            .map_err(err)?;
            rec.log(
                format!("{name}/diagnosed"),
                &rerun::Scalars::new([d.diagnosed.predicted[j][k]]),
            )
            .map_err(err)?;
            if let Some(y) = data.outputs[j][k] {
                rec.log(format!("{name}/measured"), &rerun::Scalars::new([y]))
                    .map_err(err)?;
                rec.log(
                    format!("{name}/residual/baseline"),
                    &rerun::Scalars::new([y - d.baseline.predicted[j][k]]),
                )
                .map_err(err)?;
                rec.log(
                    format!("{name}/residual/diagnosed"),
                    &rerun::Scalars::new([y - d.diagnosed.predicted[j][k]]),
                )
                .map_err(err)?;
            }
        }
    }
    rec.flush_blocking().map_err(err)?;
    Ok(())
}

/// Saves an identification's measured and simulated outputs (estimation and validation) as
/// time series, and its residuals, to a `.rrd` file.
pub fn save_identification(
    path: &std::path::Path,
    id: &crate::ident::Identification,
) -> Result<(), VizError> {
    let rec = RecordingStreamBuilder::new("agvsim")
        .recording_id(format!("agvsim-identify-{}", id.estimation.recording))
        .save(path)
        .map_err(err)?;
    let mut evals = vec![("estimation", &id.estimation)];
    if let Some(v) = &id.validation {
        evals.push(("validation", v));
    }
    for (label, e) in evals {
        let Some(data) = e.data.as_ref() else {
            continue;
        };
        for (j, name) in data.output_names.iter().enumerate() {
            for (k, t) in data.t_s.iter().enumerate() {
                rec.set_duration_secs("t", *t);
                rec.log(
                    format!("{label}/{name}/simulated"),
                    &rerun::Scalars::new([e.predicted[j][k]]),
                )
                .map_err(err)?;
                if let Some(y) = data.outputs[j][k] {
                    rec.log(
                        format!("{label}/{name}/measured"),
                        &rerun::Scalars::new([y]),
                    )
                    .map_err(err)?;
                    rec.log(
                        format!("{label}/{name}/residual"),
                        &rerun::Scalars::new([y - e.predicted[j][k]]),
                    )
                    .map_err(err)?;
                }
            }
        }
    }
    rec.flush_blocking().map_err(err)?;
    Ok(())
}
