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

/// Saves a replay: per output, measured and simulated overlaid in one plot on one
/// timeline (`t`, the recording's time) with their difference below, to a `.rrd` file.
pub fn save_replay(
    path: &std::path::Path,
    name: &str,
    r: &crate::replay::Replay,
) -> Result<(), VizError> {
    use rerun::blueprint::{Blueprint, Grid, TimeSeriesView, Vertical};
    let columns = r.outputs.iter().map(|o| {
        Vertical::new([
            TimeSeriesView::new(format!("{}: measured and simulated", o.name))
                .with_origin(format!("/{}/fit", o.name))
                .into(),
            TimeSeriesView::new(format!("{}: measured - simulated", o.name))
                .with_origin(format!("/{}/difference", o.name))
                .into(),
        ])
        .with_row_shares([0.65, 0.35])
        .into()
    });
    let rec = RecordingStreamBuilder::new("agvsim")
        .recording_id(format!("agvsim-replay-{name}"))
        .with_blueprint(Blueprint::new(Grid::new(columns)))
        .save(path)
        .map_err(err)?;
    rec.send_recording_name(format!("replay of {name}"))
        .map_err(err)?;
    for o in &r.outputs {
        let style =
            |n: &str, c: [u8; 4]| rerun::SeriesLines::new().with_names([n]).with_colors([c]);
        rec.log_static(
            format!("{}/fit/measured", o.name),
            &style("measured", [150, 150, 150, 255]),
        )
        .map_err(err)?;
        rec.log_static(
            format!("{}/fit/simulated", o.name),
            &style("simulated", [31, 95, 191, 255]),
        )
        .map_err(err)?;
        rec.log_static(
            format!("{}/difference", o.name),
            &style("difference", [208, 128, 0, 255]),
        )
        .map_err(err)?;
        for (k, t) in r.t_s.iter().enumerate() {
            rec.set_duration_secs("t", *t);
            rec.log(
                format!("{}/fit/simulated", o.name),
                &rerun::Scalars::new([o.simulated[k]]),
            )
            .map_err(err)?;
            if let Some(y) = o.measured[k] {
                rec.log(
                    format!("{}/fit/measured", o.name),
                    &rerun::Scalars::new([y]),
                )
                .map_err(err)?;
                rec.log(
                    format!("{}/difference", o.name),
                    &rerun::Scalars::new([y - o.simulated[k]]),
                )
                .map_err(err)?;
            }
        }
    }
    rec.flush_blocking().map_err(err)?;
    Ok(())
}

/// Saves a calibration: per fitted output, the measured output under the original and the
/// calibrated scene's replays in one plot on one timeline (`t`, the recording's time), and
/// below it each scene's difference from the measurement, to a `.rrd` file. The file is
/// written beside its name and takes it only when complete.
pub fn save_calibration(
    path: &std::path::Path,
    name: &str,
    c: &crate::calibrate::Calibration,
) -> Result<(), VizError> {
    use rerun::blueprint::{Blueprint, Grid, TimeSeriesView, Vertical};
    let outputs: Vec<(
        &crate::replay::ReplayedOutput,
        &crate::replay::ReplayedOutput,
    )> = c
        .outputs
        .iter()
        .filter_map(|n| Some((c.before.output(n)?, c.after.output(n)?)))
        .collect();
    let columns = outputs.iter().map(|(b, a)| {
        Vertical::new([
            TimeSeriesView::new(format!(
                "{}: fit {:.1} % -> {:.1} %",
                b.name, b.fit_pct, a.fit_pct
            ))
            .with_origin(format!("/{}/fit", b.name))
            .into(),
            TimeSeriesView::new(format!("{}: measured - simulated", b.name))
                .with_origin(format!("/{}/difference", b.name))
                .into(),
        ])
        .with_row_shares([0.65, 0.35])
        .into()
    });
    let partial = crate::output::partial_name(path);
    let rec = RecordingStreamBuilder::new("agvsim")
        .recording_id(format!("agvsim-calibrate-{name}"))
        .with_blueprint(Blueprint::new(Grid::new(columns)))
        .save(&partial)
        .map_err(err)?;
    rec.send_recording_name(format!("calibration against {name}"))
        .map_err(err)?;
    let grey = [170, 170, 170, 255];
    let (orange, blue) = ([208, 128, 0, 255], [31, 95, 191, 255]);
    for (b, a) in &outputs {
        // The measurement wide and pale, so that a replay on top of it stays visible; the
        // numbered paths draw the measurement first and the calibrated scene last.
        let style = |n: &str, c: [u8; 4], w: f32| {
            rerun::SeriesLines::new()
                .with_names([n])
                .with_colors([c])
                .with_widths([w])
        };
        let series = [
            ("fit/1_measured", style("measured", grey, 5.0)),
            ("fit/2_original", style("original scene", orange, 1.5)),
            ("fit/3_calibrated", style("calibrated scene", blue, 1.5)),
            (
                "difference/1_original",
                style("measured - original", orange, 1.5),
            ),
            (
                "difference/2_calibrated",
                style("measured - calibrated", blue, 1.5),
            ),
        ];
        for (path, s) in &series {
            rec.log_static(format!("{}/{path}", b.name), s)
                .map_err(err)?;
        }
        for (k, t) in c.before.t_s.iter().enumerate() {
            rec.set_duration_secs("t", *t);
            let log = |path: &str, v: f64| {
                rec.log(format!("{}/{path}", b.name), &rerun::Scalars::new([v]))
                    .map_err(err)
            };
            log("fit/2_original", b.simulated[k])?;
            log("fit/3_calibrated", a.simulated[k])?;
            if let Some(y) = b.measured[k] {
                log("fit/1_measured", y)?;
                log("difference/1_original", y - b.simulated[k])?;
                log("difference/2_calibrated", y - a.simulated[k])?;
            }
        }
    }
    rec.flush_blocking().map_err(err)?;
    drop(rec);
    std::fs::rename(&partial, path).map_err(err)?;
    Ok(())
}
