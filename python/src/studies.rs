//! The thesis's lab experiments and the shipped studies (`agvsim experiment`, `agvsim
//! study`) as the library runs them, each argument checked as the CLI's parser checks its
//! flag and named as Python passes it.

use std::path::PathBuf;

use pyo3::prelude::*;

use agvsim::commands::{self, flags};

use crate::{bad_argument, job};

/// A value checked by the CLI's own parser of its flag, refused under its Python name.
fn parsed<T>(
    name: &str,
    value: impl std::fmt::Display,
    parse: fn(&str) -> Result<T, String>,
) -> PyResult<T> {
    let text = value.to_string();
    parse(&text).map_err(|why| bad_argument(name, &text, &why))
}

/// `agvsim experiment KIND SCENE --set ... --out OUT ...`: what it printed (the files
/// written, one per line).
#[pyfunction]
#[pyo3(signature = (kind, scene, set, out, name=None, seed=None, interval_s=None,
    duration_s=15.0, pattern="pulses".to_string(), peak_demand_pct=40.0, hold_samples=(4, 16),
    speed_noise_rad_s=0.5, rig_error=0.0))]
#[allow(clippy::too_many_arguments)]
pub fn experiment(
    py: Python<'_>,
    kind: String,
    scene: PathBuf,
    set: Vec<String>,
    out: PathBuf,
    name: Option<String>,
    seed: Option<u64>,
    interval_s: Option<f64>,
    duration_s: f64,
    pattern: String,
    peak_demand_pct: f64,
    hold_samples: (usize, usize),
    speed_noise_rad_s: f64,
    rig_error: f64,
) -> PyResult<String> {
    let request = commands::experiment::ExperimentRequest {
        kind: kind
            .parse()
            .map_err(|why: String| bad_argument("kind", &kind, &why))?,
        scene,
        set: set.into(),
        out,
        name,
        seed,
        interval_s: interval_s
            .map(|v| parsed("interval_s", v, flags::positive_seconds))
            .transpose()?,
        duration_s: parsed("duration_s", duration_s, flags::positive_seconds)?,
        pattern: pattern
            .parse()
            .map_err(|why: String| bad_argument("pattern", &pattern, &why))?,
        peak_demand_pct: parsed("peak_demand_pct", peak_demand_pct, flags::demand_pct)?,
        hold_samples: parsed(
            "hold_samples",
            format!("{}..{}", hold_samples.0, hold_samples.1),
            flags::hold_range,
        )?,
        speed_noise_rad_s: parsed("speed_noise_rad_s", speed_noise_rad_s, flags::non_negative)?,
        rig_error: parsed("rig_error", rig_error, flags::non_negative)?,
    };
    job(py, false, move |say| {
        commands::experiment::run(&request, say)
    })
}

/// Tells nobody of a study's progress (Python callers read the summary).
fn quietly(_: usize, _: usize) {}

/// `agvsim study NAME --out OUT [--quick] [--jobs N]`: the summary and the files written.
#[pyfunction]
#[pyo3(signature = (name, out, jobs=0, quick=false))]
pub fn study(
    py: Python<'_>,
    name: String,
    out: PathBuf,
    jobs: usize,
    quick: bool,
) -> PyResult<String> {
    let request = commands::study::StudyRequest {
        kind: name
            .parse()
            .map_err(|why: String| bad_argument("name", &name, &why))?,
        out: Some(out),
        jobs: flags::Jobs::of(jobs),
        quick,
        progress: quietly,
    };
    job(py, false, move |say| commands::study::run(&request, say))
}
