//! Measured outputs under the models' simulations, as one Rerun layout that every fitting
//! command saves (`replay`, `identify`, `diagnose`, `calibrate`): a column per output with
//! the measurement (wide, pale) under each model's simulation, titled with the fits, and
//! below it each model's difference from the measurement; a first column shows the
//! recording's inputs (the commands that drove it). The recording is named after the
//! command and the recording file, and the file takes its name only when complete.

use rerun::blueprint::{Blueprint, Horizontal, TimeSeriesView, Vertical};
use rerun::RecordingStreamBuilder;

use super::{err, VizError};

/// One model's simulation of an output.
pub struct Simulation<'a> {
    /// What the model is (`baseline`, `diagnosed`, `calibrated scene`).
    pub label: String,
    /// Its value on each row of the output's time base.
    pub values: &'a [f64],
    /// Its fit to the measurement, %, where known.
    pub fit_pct: Option<f64>,
}

/// One output: its measurement and the models' simulations on one time base.
pub struct Output<'a> {
    /// The output's column name (its unit in the name); a prefix such as `validation: `
    /// tells outputs of another recording apart.
    pub name: String,
    /// Times, s, of the recording's rows.
    pub t_s: &'a [f64],
    /// The measurement on each row (`None`: not measured there).
    pub measured: &'a [Option<f64>],
    /// Each model's simulation.
    pub models: Vec<Simulation<'a>>,
}

/// An input column: name, times (s) and values.
pub struct Input<'a> {
    /// Its column name.
    pub name: &'a str,
    /// Times, s.
    pub t_s: &'a [f64],
    /// Values (held from each row to the next).
    pub values: &'a [f64],
}

/// What one saved file shows.
pub struct Overlay<'a> {
    /// The command that made it (`diagnosis`, `identification`), for the recording's name.
    pub what: &'a str,
    /// The recording file's name.
    pub recording: &'a str,
    /// The recording's inputs.
    pub inputs: Vec<Input<'a>>,
    /// The outputs compared.
    pub outputs: Vec<Output<'a>>,
}

const MEASURED: [u8; 4] = [170, 170, 170, 255];
/// One colour per model, in order: the first (original, baseline) orange, the second
/// (calibrated, diagnosed) blue.
const MODELS: [[u8; 4]; 3] = [[208, 128, 0, 255], [31, 95, 191, 255], [40, 160, 80, 255]];
const INPUTS: [[u8; 4]; 4] = [
    [230, 90, 90, 255],
    [90, 140, 230, 255],
    [200, 160, 40, 255],
    [150, 90, 200, 255],
];

/// A name usable as one entity path part.
fn part(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// The fit view's title: the output and each model's fit, in the legend's order (short, so
/// that it stays readable in a narrow column: `motor_speed_rad_s: fit 94.6 % -> 100.0 %`).
fn title(o: &Output) -> String {
    let fits: Vec<String> = o
        .models
        .iter()
        .filter_map(|m| m.fit_pct.map(|f| format!("{f:.1} %")))
        .collect();
    if fits.is_empty() {
        format!("{}: measured and simulated", o.name)
    } else {
        format!("{}: fit {}", o.name, fits.join(" -> "))
    }
}

/// The inputs across the top, then a column per output: its fit above its differences.
fn blueprint(o: &Overlay) -> Blueprint {
    let columns: Vec<rerun::blueprint::ContainerLike> = o
        .outputs
        .iter()
        .map(|out| {
            let p = part(&out.name);
            Vertical::new([
                TimeSeriesView::new(title(out))
                    .with_origin(format!("/{p}/fit"))
                    .into(),
                TimeSeriesView::new(format!("{}: measured - simulated", out.name))
                    .with_origin(format!("/{p}/difference"))
                    .into(),
            ])
            .with_row_shares([0.65, 0.35])
            .into()
        })
        .collect();
    let outputs = Horizontal::new(columns);
    if o.inputs.is_empty() {
        return Blueprint::new(outputs);
    }
    let names: Vec<&str> = o.inputs.iter().map(|i| i.name).collect();
    let inputs = TimeSeriesView::new(format!("inputs of {}: {}", o.recording, names.join(", ")))
        .with_origin("/inputs");
    Blueprint::new(Vertical::new([inputs.into(), outputs.into()]).with_row_shares([0.28, 0.72]))
}

/// Sends one series as a column chunk: far cheaper than a log call per sample.
fn series(
    rec: &rerun::RecordingStream,
    path: &str,
    points: impl Iterator<Item = (f64, f64)>,
) -> Result<(), VizError> {
    let (t, v): (Vec<f64>, Vec<f64>) = points.filter(|(_, v)| v.is_finite()).unzip();
    if t.is_empty() {
        return Ok(());
    }
    let n = t.len();
    let time = [rerun::TimeColumn::new_duration_secs("t", t)];
    let columns = rerun::Scalars::new(v)
        .columns(std::iter::repeat_n(1, n))
        .map_err(err)?;
    rec.send_columns(path, time, columns).map_err(err)
}

fn style(
    rec: &rerun::RecordingStream,
    path: &str,
    name: &str,
    colour: [u8; 4],
    width: f32,
) -> Result<(), VizError> {
    rec.log_static(
        path,
        &rerun::SeriesLines::new()
            .with_names([name])
            .with_colors([colour])
            .with_widths([width]),
    )
    .map_err(err)
}

/// Saves the overlay to `path` (written beside it and renamed when complete).
pub fn save(path: &std::path::Path, o: &Overlay) -> Result<(), VizError> {
    let partial = crate::output::partial_name(path);
    let rec = RecordingStreamBuilder::new("agvsim")
        .recording_id(format!("agvsim-{}-{}", part(o.what), o.recording))
        .with_blueprint(blueprint(o))
        .save(&partial)
        .map_err(err)?;
    rec.send_recording_name(format!("{} of {}", o.what, o.recording))
        .map_err(err)?;
    for (k, i) in o.inputs.iter().enumerate() {
        let p = format!("inputs/{}", part(i.name));
        style(&rec, &p, i.name, INPUTS[k % INPUTS.len()], 1.5)?;
        series(
            &rec,
            &p,
            i.t_s.iter().copied().zip(i.values.iter().copied()),
        )?;
    }
    for out in &o.outputs {
        let p = part(&out.name);
        // Numbered paths draw the measurement first, under the models.
        let measured = || {
            out.t_s
                .iter()
                .zip(out.measured)
                .filter_map(|(t, y)| y.map(|y| (*t, y)))
        };
        style(
            &rec,
            &format!("{p}/fit/0_measured"),
            "measured",
            MEASURED,
            5.0,
        )?;
        series(&rec, &format!("{p}/fit/0_measured"), measured())?;
        for (k, m) in out.models.iter().enumerate() {
            let colour = MODELS[k % MODELS.len()];
            let fit = format!("{p}/fit/{}_{}", k + 1, part(&m.label));
            let diff = format!("{p}/difference/{}_{}", k + 1, part(&m.label));
            style(&rec, &fit, &m.label, colour, 1.5)?;
            style(&rec, &diff, &format!("measured - {}", m.label), colour, 1.5)?;
            series(
                &rec,
                &fit,
                out.t_s.iter().copied().zip(m.values.iter().copied()),
            )?;
            let differences = out
                .t_s
                .iter()
                .zip(out.measured)
                .zip(m.values)
                .filter_map(|((t, y), s)| y.map(|y| (*t, y - s)));
            series(&rec, &diff, differences)?;
        }
    }
    rec.flush_blocking().map_err(err)?;
    drop(rec);
    std::fs::rename(&partial, path).map_err(|e| err(format!("{}: {e}", path.display())))?;
    Ok(())
}
