//! Running a scene with its observers: the recording CSV, the Rerun recorder and the
//! metrics, as `agvsim run` does.

use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use crate::record::{vehicle_columns, RecordingWriter};
use crate::scene::Scene;
use crate::sim::metrics::{MetricsObserver, RunSummary};
use crate::sim::{Sim, SimError, SimParams};
use crate::viz::{RerunRecorder, RerunTarget, VizError};

/// Errors of a run.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error(transparent)]
    Sim(#[from] SimError),
    #[error(transparent)]
    Viz(#[from] VizError),
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
}

/// What to write.
#[derive(Debug, Clone)]
pub struct RunOptions {
    /// Folder for the recording and the scene as run.
    pub out_dir: PathBuf,
    /// Name used for files and the Rerun recording id.
    pub name: String,
    pub rerun: Option<RerunTarget>,
    /// Interval between Rerun frames, s.
    pub rerun_interval_s: f64,
}

/// What a run produced.
#[derive(Debug, Clone)]
pub struct RunOutput {
    pub summary: RunSummary,
    pub recording: PathBuf,
    pub scene_used: PathBuf,
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> RunError + '_ {
    move |source| RunError::Io {
        path: path.to_owned(),
        source,
    }
}

/// Runs a scene for its duration, writing `NAME.csv` and `NAME.scene.toml` (the scene as
/// run, overrides included) into the output folder.
pub fn run_scene(scene: &Scene, opts: &RunOptions) -> Result<RunOutput, RunError> {
    let params = SimParams::from_scene(scene)?;
    // The Rerun target first: a file that cannot be written (or a viewer that cannot be
    // reached) stops the run before any output is left behind.
    let mut viz = match &opts.rerun {
        Some(t) => Some(RerunRecorder::new(
            t,
            &opts.name,
            &params,
            opts.rerun_interval_s,
        )?),
        None => None,
    };
    std::fs::create_dir_all(&opts.out_dir).map_err(io(&opts.out_dir))?;
    let recording = opts.out_dir.join(format!("{}.csv", opts.name));
    let scene_used = opts.out_dir.join(format!("{}.scene.toml", opts.name));
    std::fs::write(&scene_used, scene.to_toml()).map_err(io(&scene_used))?;
    let file = File::create(&recording).map_err(io(&recording))?;
    let meta = [
        (
            "description",
            if scene.description.is_empty() {
                opts.name.clone()
            } else {
                scene.description.clone()
            },
        ),
        ("sample_time_s", format!("{}", scene.sim.record_interval_s)),
        (
            "source",
            format!(
                "agvsim {} simulation, fidelity {}",
                env!("CARGO_PKG_VERSION"),
                params.fidelity.name()
            ),
        ),
        ("seed", format!("{}", params.seed)),
        (
            "heading",
            "rad, counter-clockwise from world x, unwrapped".to_string(),
        ),
    ];
    let mut writer =
        RecordingWriter::new(BufWriter::new(file), "vehicle", &meta, vehicle_columns())
            .map_err(io(&recording))?;
    let record_every = ((scene.sim.record_interval_s / params.dt_s).round() as u64).max(1);
    let duration = params.duration_s;
    let mut sim = Sim::from_params(params)?;
    let mut metrics = MetricsObserver::default();
    let first = sim.snapshot();
    writer.row(&first).map_err(io(&recording))?;
    metrics.observe(&first);
    let steps = (duration / sim.params().dt_s).round() as u64;
    let mut viz_err = None;
    for k in 1..=steps {
        sim.step()?;
        let want_row = k % record_every == 0;
        let want_viz = viz.as_mut().is_some_and(|v| v.due());
        if want_row || want_viz || k % 10 == 0 {
            let s = sim.snapshot();
            if want_row {
                writer.row(&s).map_err(io(&recording))?;
            }
            if k % 10 == 0 || want_row {
                metrics.observe(&s);
            }
            if let (true, Some(v)) = (want_viz, viz.as_mut()) {
                if let Err(e) = v.observe(&s, sim.params()) {
                    viz_err = Some(e);
                    break;
                }
            }
        }
    }
    writer.finish().map_err(io(&recording))?;
    if let Some(e) = viz_err {
        return Err(e.into());
    }
    if let Some(v) = viz {
        v.finish()?;
    }
    Ok(RunOutput {
        summary: metrics.summary(),
        recording,
        scene_used,
    })
}

/// The summary `agvsim run` prints: one labelled line per measure, with units.
pub fn render_summary(scene_path: &Path, scene: &Scene, s: &RunSummary) -> String {
    use std::fmt::Write;
    let band_mm = 1000.0 * crate::sim::metrics::SETTLED_BAND_M;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "scene      {} ({}, fidelity {})",
        scene_path.display(),
        scene.description,
        scene.sim.fidelity.name()
    );
    let _ = writeln!(
        out,
        "simulated  {:.2} s, {:.2} m travelled",
        s.duration_s, s.distance_m
    );
    let _ = match s.settling_distance_m {
        Some(d) => writeln!(
            out,
            "settled    after {d:.2} m (lateral error within {band_mm:.0} mm from then on)"
        ),
        None => writeln!(
            out,
            "settled    no (lateral error never stayed within {band_mm:.0} mm)"
        ),
    };
    let _ = writeln!(
        out,
        "RMS error  {:.1} mm lateral (after settling), peak {:.1} mm",
        1000.0 * s.rms_lateral_error_m,
        1000.0 * s.peak_lateral_error_after_settling_m
    );
    let _ = writeln!(
        out,
        "peak slip  {:.3} (slip ratio, second half of the run), sliding {:.1} % of that time",
        s.peak_abs_slip_ratio,
        100.0 * s.sliding_fraction
    );
    let _ = writeln!(
        out,
        "energy     {:.0} J from the battery",
        s.battery_energy_j
    );
    if !s.faults.is_empty() {
        let _ = writeln!(out, "DCMC fault {}", s.faults.join(", "));
    }
    if s.bumper_stop {
        let _ = writeln!(out, "bumper     stopped on contact with an obstacle");
    }
    out
}
