//! Measured outputs under the models' simulations, as one Rerun layout that every fitting
//! command saves (`replay`, `identify`, `diagnose`, `calibrate`): a column per output with
//! the measurement (wide, pale) under each model's simulation, titled with the fits, and
//! below it each model's difference from the measurement; a first column shows the
//! recording's inputs (the commands that drove it). The recording is named after the
//! command and the recording file, and the file takes its name only when complete.

use rerun::blueprint::components::{ContainerKind, PlayState};
use rerun::external::re_sdk_types::blueprint::archetypes::TimePanelBlueprint;
use rerun::{RecordingStream, RecordingStreamBuilder};

use super::layout::{container, hide_legend, send_layout, view};

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
    /// What the terms outside the vocabulary found depend on (the wheel speed, a phase,
    /// the heat...), measured, on the recording's time base: shown under the inputs, so a
    /// residual that follows one reads beside it.
    pub quantities: Vec<Input<'a>>,
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

/// The fit view's title: each model's fit, in the legend's order, then the output (the fits
/// first: a narrow column cuts a title's end, and the output's name is in the difference
/// view's title below too: `fit 94.6 % -> 100.0 %, motor_speed_rad_s`).
fn title(o: &Output) -> String {
    let fits: Vec<String> = o
        .models
        .iter()
        .filter_map(|m| m.fit_pct.map(|f| format!("{f:.1} %")))
        .collect();
    if fits.is_empty() {
        format!("{}: measured and simulated", o.name)
    } else {
        format!("fit {}, {}", fits.join(" -> "), o.name)
    }
}

/// Where the first model (the original scene, the baseline) is furthest from the
/// measurement, each output's difference over its measured spread: the time window around
/// it, s (a tenth of the recording, at least a second, inside it). The overlay opens
/// playing in this window, so the eye starts where the models differ most.
pub fn largest_difference_window(o: &Overlay) -> Option<(f64, f64)> {
    let mut worst: Option<(f64, f64)> = None;
    let (mut t_lo, mut t_hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for out in &o.outputs {
        let Some(m) = out.models.first() else {
            continue;
        };
        let measured: Vec<f64> = out.measured.iter().flatten().copied().collect();
        let spread = measured.iter().copied().fold(f64::NEG_INFINITY, f64::max)
            - measured.iter().copied().fold(f64::INFINITY, f64::min);
        if !(spread > 0.0) {
            continue;
        }
        for ((t, y), s) in out.t_s.iter().zip(out.measured).zip(m.values) {
            t_lo = t_lo.min(*t);
            t_hi = t_hi.max(*t);
            if let Some(y) = y {
                let d = (y - s).abs() / spread;
                if d.is_finite() && worst.is_none_or(|w| d > w.1) {
                    worst = Some((*t, d));
                }
            }
        }
    }
    let (t, _) = worst?;
    let half = (0.05 * (t_hi - t_lo)).max(0.5);
    Some(((t - half).max(t_lo), (t + half).min(t_hi)))
}

/// Seconds as the time line's integer nanoseconds.
fn nanos(t_s: f64) -> rerun::time::TimeInt {
    rerun::time::TimeInt::new_temporal((t_s * 1e9).round() as i64)
}

/// Columns of outputs side by side at most; more wrap into a grid of this many columns
/// (six in a row cut every title and squeezed every plot).
const MAX_COLUMNS: usize = 3;

/// The colours in words, for the key above the plots (the plots' own legends are hidden:
/// in a narrow column they sat on the data).
fn colour_key(o: &Overlay, window: Option<(f64, f64)>) -> String {
    const MODEL_NAMES: [&str; 3] = ["orange", "blue", "green"];
    // The lines' colours in order, each named before its series.
    fn coloured<'a>(names: impl Iterator<Item = &'a str>) -> String {
        const INPUT_NAMES: [&str; 4] = ["red", "blue", "yellow", "purple"];
        names
            .enumerate()
            .map(|(k, n)| format!("{} {n}", INPUT_NAMES[k % INPUT_NAMES.len()]))
            .collect::<Vec<_>>()
            .join(", ")
    }
    let models: Vec<String> = o
        .outputs
        .first()
        .map(|out| {
            out.models
                .iter()
                .enumerate()
                .map(|(k, m)| format!("**{}**: {}", MODEL_NAMES[k % MODEL_NAMES.len()], m.label))
                .collect()
        })
        .unwrap_or_default();
    let mut key = format!(
        "**Grey, wide**: measured. {}; below, measured minus each.",
        models.join(". ")
    );
    if !o.inputs.is_empty() {
        key.push_str(&format!(
            " Inputs: {}.",
            coloured(o.inputs.iter().map(|i| i.name))
        ));
    }
    if !o.quantities.is_empty() {
        key.push_str(&format!(
            " What the terms found depend on, measured: {}.",
            coloured(o.quantities.iter().map(|i| i.name))
        ));
    }
    if let Some((a, b)) = window {
        key.push_str(&format!(
            " Highlighted: {a:.1}-{b:.1} s, where the first model is furthest off."
        ));
    }
    key
}

/// The layout: the colour key and the inputs across the top, then per output its fit
/// above its differences, in columns (a grid beyond [`MAX_COLUMNS`]). Fixed ids: the same
/// overlay writes the same layout.
fn layout(bp: &RecordingStream, o: &Overlay, window: Option<(f64, f64)>) -> Result<u8, VizError> {
    let mut n: u8 = 0;
    let mut next = || {
        n = n.wrapping_add(1);
        n
    };
    let mut columns = Vec::new();
    for out in &o.outputs {
        let p = part(&out.name);
        let fit = view(
            bp,
            next(),
            "TimeSeries",
            &title(out),
            &format!("/{p}/fit"),
            &["$origin/**"],
        )?;
        hide_legend(bp, &fit)?;
        let diff = view(
            bp,
            next(),
            "TimeSeries",
            &format!("{}: measured - simulated", out.name),
            &format!("/{p}/difference"),
            &["$origin/**"],
        )?;
        hide_legend(bp, &diff)?;
        columns.push(container(
            bp,
            next(),
            ContainerKind::Vertical,
            None,
            &[fit, diff],
            Some(&[0.65, 0.35]),
        )?);
    }
    let outputs = if columns.len() <= MAX_COLUMNS {
        container(bp, next(), ContainerKind::Horizontal, None, &columns, None)?
    } else {
        container(
            bp,
            next(),
            ContainerKind::Grid,
            None,
            &columns,
            Some(&[MAX_COLUMNS as f32]),
        )?
    };
    let key = view(bp, next(), "TextDocument", "Colours", "/key", &["$origin"])?;
    let mut rows = vec![key];
    let mut shares = vec![0.12];
    if !o.inputs.is_empty() {
        let names: Vec<&str> = o.inputs.iter().map(|i| i.name).collect();
        let inputs = view(
            bp,
            next(),
            "TimeSeries",
            &format!("inputs of {}: {}", o.recording, names.join(", ")),
            "/inputs",
            &["$origin/**"],
        )?;
        hide_legend(bp, &inputs)?;
        rows.push(inputs);
        shares.push(0.22);
    }
    if !o.quantities.is_empty() {
        let names: Vec<&str> = o.quantities.iter().map(|i| i.name).collect();
        let quantities = view(
            bp,
            next(),
            "TimeSeries",
            &format!("what the terms found depend on: {}", names.join(", ")),
            "/terms",
            &["$origin/**"],
        )?;
        hide_legend(bp, &quantities)?;
        rows.push(quantities);
        shares.push(0.15);
    }
    rows.push(outputs);
    shares.push(1.0 - shares.iter().sum::<f32>());
    let root = next();
    container(
        bp,
        root,
        ContainerKind::Vertical,
        None,
        &rows,
        Some(&shares),
    )?;
    time_panel(bp, window)?;
    Ok(root)
}

/// The time panel: paused on the timeline `t`, with the window where the first model is
/// furthest off selected.
fn time_panel(bp: &RecordingStream, window: Option<(f64, f64)>) -> Result<(), VizError> {
    let mut panel = TimePanelBlueprint::new()
        .with_timeline("t")
        .with_play_state(PlayState::Paused);
    if let Some((a, b)) = window {
        panel = panel.with_time_selection(
            rerun::external::re_sdk_types::datatypes::AbsoluteTimeRange {
                min: nanos(a).into(),
                max: nanos(b).into(),
            },
        );
    }
    bp.log("time_panel", &panel).map_err(err)
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
        .save(&partial)
        .map_err(err)?;
    let window = largest_difference_window(o);
    send_layout(&rec, |bp| layout(bp, o, window))?;
    rec.log_static(
        "key",
        &rerun::TextDocument::new(colour_key(o, window))
            .with_media_type(rerun::MediaType::markdown()),
    )
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
    for (k, q) in o.quantities.iter().enumerate() {
        let p = format!("terms/{}", part(q.name));
        style(&rec, &p, q.name, INPUTS[k % INPUTS.len()], 1.5)?;
        series(
            &rec,
            &p,
            q.t_s
                .iter()
                .copied()
                .zip(q.values.iter().copied())
                .filter(|(_, v)| v.is_finite()),
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_window_opens_where_the_first_model_is_furthest_off_and_titles_lead_with_the_fits() {
        let t: Vec<f64> = (0..1000).map(|k| k as f64 * 0.01).collect();
        let measured: Vec<Option<f64>> = t.iter().map(|t| Some(t.sin())).collect();
        // Off by 0.5 around 7 s only.
        let first: Vec<f64> = t
            .iter()
            .map(|t| t.sin() + if (*t - 7.0).abs() < 0.05 { 0.5 } else { 0.0 })
            .collect();
        let second: Vec<f64> = t.iter().map(|t| t.sin()).collect();
        let out = Output {
            name: "motor_speed_rad_s".into(),
            t_s: &t,
            measured: &measured,
            models: vec![
                Simulation {
                    label: "original".into(),
                    values: &first,
                    fit_pct: Some(80.0),
                },
                Simulation {
                    label: "calibrated".into(),
                    values: &second,
                    fit_pct: Some(99.0),
                },
            ],
        };
        assert_eq!(title(&out), "fit 80.0 % -> 99.0 %, motor_speed_rad_s");
        let o = Overlay {
            quantities: vec![Input {
                name: "wheel speed (rad/s)",
                t_s: &t,
                values: &second,
            }],
            what: "calibration",
            recording: "r.csv",
            inputs: vec![],
            outputs: vec![out],
        };
        let (a, b) = largest_difference_window(&o).unwrap();
        // A tenth of the 10 s recording around 7 s.
        assert!(a < 7.0 && b > 7.0 && (b - a - 1.0).abs() < 0.02, "{a} {b}");
        let key = colour_key(&o, Some((a, b)));
        assert!(key.contains("Highlighted: 6.5-7.5 s"), "{key}");
        assert!(
            key.contains("depend on, measured: red wheel speed (rad/s)"),
            "{key}"
        );
    }
}
