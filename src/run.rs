//! Running a scene with its observers: the recording CSV, the metrics, and a watcher
//! that sees the run as it goes (the Rerun recorder of `agvsim run --save`).

use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use crate::record::{vehicle_columns, RecordingWriter};
use crate::scene::Scene;
use crate::sim::metrics::{MetricsObserver, RunSummary};
use crate::sim::{Sim, SimError, SimParams, Snapshot};

/// Errors of a run.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The simulation could not be set up, or stopped.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// The watcher could not take a snapshot (its message names its file or viewer).
    #[error("{0}")]
    Watcher(WatchError),
    /// An output could not be written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
}

/// What to write.
#[derive(Debug, Clone)]
pub struct RunOptions {
    /// Folder for the recording and the scene as run.
    pub out_dir: PathBuf,
    /// Name used for files (and by the watcher).
    pub name: String,
    /// What a velocity-commanded base drives (`controller.kind = "velocity"`): the
    /// scene's square or circle where `None`, or commands the caller read from the
    /// scene's commands CSV.
    pub manoeuvre: Option<crate::model::manoeuvre::Manoeuvre>,
}

/// Something that watches a run as it goes: asked at every physics step whether it wants
/// the snapshot, and given it when it does.
pub trait Watcher {
    /// Whether this step's snapshot is wanted (called once per physics step).
    fn due(&mut self) -> bool;
    /// Takes a snapshot; an error (naming the file or viewer) stops the run.
    fn observe(&mut self, s: &Snapshot, params: &SimParams) -> Result<(), WatchError>;
}

/// Why a watcher could not take a snapshot: its own error (the Rerun recorder's names the
/// file or viewer), kept whole.
pub type WatchError = Box<dyn std::error::Error + Send + Sync>;

/// What a run produced.
#[derive(Debug, Clone)]
pub struct RunOutput {
    /// The run's measures.
    pub summary: RunSummary,
    /// The recording written.
    pub recording: PathBuf,
    /// The scene as run, overrides included.
    pub scene_used: PathBuf,
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> RunError + '_ {
    move |source| RunError::Io {
        path: path.to_owned(),
        source,
    }
}

/// Runs a scene for its duration, writing `NAME.csv` and `NAME.scene.toml` (the scene as
/// run, overrides included) into the output folder, and showing the run to `watcher`.
pub fn run_scene(
    scene: &Scene,
    opts: &RunOptions,
    mut watcher: Option<&mut dyn Watcher>,
) -> Result<RunOutput, RunError> {
    let params = SimParams::from_scene(scene)?;
    std::fs::create_dir_all(&opts.out_dir).map_err(io(&opts.out_dir))?;
    let recording = opts.out_dir.join(format!("{}.csv", opts.name));
    let scene_used = opts.out_dir.join(format!("{}.scene.toml", opts.name));
    // A rerun replaces both files: the old pair goes first, and the new scene takes its
    // name only after the new recording, so that an interrupted rerun never leaves a
    // new scene beside the old recording (nor the old scene beside a new one).
    remove_earlier(&[&recording, &scene_used])?;
    let scene_partial = crate::output::partial_name(&scene_used);
    std::fs::write(&scene_partial, scene.to_toml()).map_err(io(&scene_partial))?;
    // The recording streams into `NAME.csv.partial` and takes its name only when the run
    // has finished: a run killed or stopped by an error leaves no file that looks like a
    // finished, shorter run.
    let partial = crate::output::partial_name(&recording);
    let file = File::create(&partial).map_err(io(&partial))?;
    let meta = recording_meta(scene, opts, &params);
    let mut writer = RecordingWriter::new(
        BufWriter::new(file),
        crate::rig::RigKind::Vehicle,
        &meta,
        vehicle_columns(),
    )
    .map_err(io(&recording))?;
    let record_every = ((scene.sim.record_interval_s / params.sim.dt_s).round() as u64).max(1);
    let duration = params.sim.duration_s;
    let velocity = scene.controller.kind == crate::firmware::ControllerKind::Velocity;
    let mut sim = Sim::from_params(params)?;
    let mut metrics = MetricsObserver::default();
    if velocity {
        // No wire to follow: its coils are not read, and losing it is no event.
        sim = sim.without_coils();
        metrics = MetricsObserver::wireless();
    }
    let first = sim.snapshot();
    writer.row(&first).map_err(io(&recording))?;
    metrics.observe(&first);
    let steps = (duration / sim.params().sim.dt_s).round() as u64;
    let dt = sim.params().sim.dt_s;
    // A velocity-commanded base drives its manoeuvre: the command is held a step.
    let manoeuvre = velocity.then(|| {
        opts.manoeuvre
            .clone()
            .unwrap_or_else(|| crate::model::manoeuvre::Manoeuvre::Shape(scene.manoeuvre.clone()))
    });
    let mut viz_err = None;
    for k in 1..=steps {
        if let Some(m) = &manoeuvre {
            let (linear_m_s, angular_rad_s) = m.command_at((k - 1) as f64 * dt);
            sim.set_actuation(crate::sim::Actuation::Velocity {
                linear_m_s,
                angular_rad_s,
            });
        }
        if let Err(e) = sim.step() {
            // A diverged run leaves no recording behind, not even the partial one.
            let _ = std::fs::remove_file(&partial);
            let _ = std::fs::remove_file(&scene_partial);
            return Err(e.naming_suspects(scene).into());
        }
        // The run's last step is always recorded and shown: the recording's last row and
        // the viewer's last frame are the run's end, whatever the intervals.
        let last = k == steps;
        let want_row = k % record_every == 0 || last;
        let want_viz = watcher.as_mut().is_some_and(|v| v.due() || last);
        if want_row || want_viz || k % 10 == 0 {
            let s = sim.snapshot();
            if want_row {
                writer.row(&s).map_err(io(&recording))?;
            }
            if k % 10 == 0 || want_row {
                metrics.observe(&s);
            }
            if let (true, Some(v)) = (want_viz, watcher.as_mut()) {
                if let Err(e) = v.observe(&s, sim.params()) {
                    viz_err = Some(e);
                    break;
                }
            }
        }
    }
    writer.finish().map_err(io(&recording))?;
    if let Some(e) = viz_err {
        let _ = std::fs::remove_file(&partial);
        let _ = std::fs::remove_file(&scene_partial);
        return Err(RunError::Watcher(e));
    }
    std::fs::rename(&partial, &recording).map_err(io(&recording))?;
    std::fs::rename(&scene_partial, &scene_used).map_err(io(&scene_used))?;
    Ok(RunOutput {
        summary: metrics.summary(),
        recording,
        scene_used,
    })
}

/// Removes an earlier run's files (none there is no error).
fn remove_earlier(files: &[&PathBuf]) -> Result<(), RunError> {
    for old in files {
        match std::fs::remove_file(old) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => return Err(io(old)(e)),
            _ => {}
        }
    }
    Ok(())
}

/// The recording's metadata: what it is, its interval, what made it, its seed.
fn recording_meta(
    scene: &Scene,
    opts: &RunOptions,
    params: &SimParams,
) -> [(&'static str, String); 5] {
    [
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
                params.sim.fidelity.name()
            ),
        ),
        ("seed", format!("{}", params.sim.seed)),
        (
            "heading",
            "rad, counter-clockwise from world x, unwrapped".to_string(),
        ),
    ]
}

/// What the summary says of a window with no limit cycle: its swing, and why it is not a
/// cycle (too small, dying away, or too short a window to call one).
fn no_cycle_text(n: Option<crate::sim::metrics::NoCycle>, tail_pct: f64, over: &str) -> String {
    use crate::sim::metrics::NoCycleReason;
    let min_mm = 1000.0 * crate::sim::metrics::LIMIT_CYCLE_MIN_AMPLITUDE_M;
    let Some(n) = n else {
        return format!(
            "none (no sustained swing of {min_mm:.0} mm or more in the last {tail_pct:.0} % {over})"
        );
    };
    let swing = format!(
        "+/-{:.1} mm in the last {tail_pct:.0} % {over} ({:.1} s)",
        1000.0 * n.swing_m,
        n.window_s
    );
    match n.reason {
        NoCycleReason::Small => format!(
            "none (the lateral error swings {swing}, under the {min_mm:.0} mm a limit cycle needs)"
        ),
        NoCycleReason::Decaying => format!(
            "none: the swing is dying away ({swing}; its later half swings less than half as far)"
        ),
        NoCycleReason::TooShort => format!(
            "too short to call: the lateral error swings {swing}, fewer than two full periods between its upward crossings; a longer run tells whether it is a limit cycle"
        ),
        NoCycleReason::NoWindow => {
            format!("none (too few samples in the last {tail_pct:.0} % {over} to look for one)")
        }
    }
}

/// Where the tyres slid and why a peak slip ratio is large, as the run shows it: the
/// sliding split by what the wheels were doing, and what they did at the peak where that
/// is not driving along (a slip ratio divides by the contact's speed over the ground,
/// small when the wheels start from rest or counter-rotate before the body turns).
fn slip_explained(s: &RunSummary) -> String {
    use crate::sim::metrics::WheelMotion;
    let mut out = String::new();
    let b = s.sliding_by_motion;
    // Sliding only while driving along needs no split (a wire follower's cornering).
    if b.turning_on_spot + b.near_rest > 0.0 {
        let parts: Vec<String> = [
            (b.turning_on_spot, WheelMotion::TurningOnTheSpot),
            (b.near_rest, WheelMotion::NearRest),
            (b.moving, WheelMotion::Driving),
        ]
        .iter()
        .filter(|(v, _)| *v > 0.0)
        .map(|(v, m)| format!("{:.1} % {}", 100.0 * v, m.words()))
        .collect();
        out.push_str(&format!("\n           where it slid: {}", parts.join(", ")));
    }
    if s.peak_abs_slip_ratio > 0.5 && s.peak_slip_motion != WheelMotion::Driving {
        out.push_str(&format!(
            "\n           the peak slip ratio came while {}: a slip ratio divides by the contact's speed over the ground, which is small there (the body has not yet followed the wheels)",
            s.peak_slip_motion.words()
        ));
    }
    out
}

/// The summary `agvsim run` prints: one labelled line per measure, with units. Every
/// error figure says what stretch of the run it covers.
pub fn render_summary(scene_path: &Path, scene: &Scene, s: &RunSummary) -> String {
    use std::fmt::Write;
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
    if s.wheels_lifted {
        let _ = writeln!(
            out,
            "tracking   none: the wheels are lifted and the chassis stays put"
        );
    } else if scene.controller.kind == crate::firmware::ControllerKind::Velocity {
        out.push_str(&path_lines(scene, s));
    } else {
        out.push_str(&tracking_lines(s));
    }
    let _ = writeln!(
        out,
        "slip       peak {:.3}, mean {:.3} (slip ratio), sliding {:.1} % of the time ({}){}",
        s.peak_abs_slip_ratio,
        s.mean_abs_slip_ratio,
        100.0 * s.sliding_fraction,
        s.slip_window.describe(),
        slip_explained(s)
    );
    let _ = writeln!(
        out,
        "energy     {:.0} J from the battery",
        s.battery_energy_j
    );
    let terms = scene.term.families_on();
    if !terms.is_empty() {
        let names: Vec<&str> = terms.iter().map(|f| f.name()).collect();
        let _ = writeln!(
            out,
            "terms      {} in both drivetrains (the scene's [term]: physics outside the effect vocabulary)",
            names.join(", ")
        );
    }
    if !s.faults.is_empty() {
        let _ = writeln!(out, "DCMC fault {}", s.faults.join(", "));
    }
    if let Some(e) = s.bumper_at {
        let _ = writeln!(
            out,
            "bumper     stopped on contact with an obstacle at {}",
            event_words(&e)
        );
    }
    out
}

/// "12.30 s, 4.10 m travelled, axle at (4.10, 0.02) m".
fn event_words(e: &crate::sim::metrics::RunEvent) -> String {
    format!(
        "{:.2} s, {:.2} m travelled, axle at ({:.2}, {:.2}) m",
        e.t_s, e.distance_m, e.at_m[0], e.at_m[1]
    )
}

/// A velocity-commanded base's lines: where its manoeuvre left it against where it
/// started (a square or a circle followed exactly closes on its start), and its speeds.
fn path_lines(scene: &Scene, s: &RunSummary) -> String {
    use std::fmt::Write;
    let m = &s.motion;
    let mut out = String::new();
    let (dx, dy) = (m.end.x_m - m.start.x_m, m.end.y_m - m.start.y_m);
    let turned = m.end.heading_rad - m.start.heading_rad;
    let manoeuvre = &scene.manoeuvre;
    let shape_s = manoeuvre.duration_s();
    // A shape the run's length cuts short ends wherever it was: no closing to judge.
    let cut_short = manoeuvre.kind != "commands" && s.duration_s + 1e-9 < shape_s;
    let shape = if manoeuvre.kind == "square" {
        format!(
            "of {} m sides",
            crate::param::plain_number(manoeuvre.side_m)
        )
    } else {
        format!(
            "of {} m radius",
            crate::param::plain_number(manoeuvre.radius_m)
        )
    };
    let _ = if cut_short {
        writeln!(
            out,
            "path       {} {shape}, {} laps: cut short at {:.2} s by sim.duration_s (the laps take {} s); ended ({:.3}, {:.3}) m from its start, turned {:+.1} deg",
            manoeuvre.kind,
            manoeuvre.laps,
            s.duration_s,
            crate::numtext::sig(shape_s, 4),
            dx,
            dy,
            turned.to_degrees()
        )
    } else if manoeuvre.kind != "commands" {
        let laps = manoeuvre.laps.max(1) as f64;
        let sign = if manoeuvre.clockwise { -1.0 } else { 1.0 };
        // The shape turns a whole turn a lap; what is left over is the heading error.
        let heading_error = turned - sign * laps * std::f64::consts::TAU;
        writeln!(
            out,
            "path       {} {shape}: ended {:.3} m from its start, heading {:+.2} deg off (a base following its commands exactly closes on its start)",
            manoeuvre.kind,
            dx.hypot(dy),
            heading_error.to_degrees()
        )
    } else {
        writeln!(
            out,
            "path       commands from {}: ended ({:.3}, {:.3}) m from its start, turned {:+.1} deg",
            manoeuvre.commands,
            dx,
            dy,
            turned.to_degrees()
        )
    };
    let _ = writeln!(
        out,
        "speeds     mean {:.3} m/s while moving ({:.1} s), peak {:.3} m/s, peak yaw rate {:.3} rad/s",
        m.mean_speed_m_s(),
        m.moving_s,
        m.peak_speed_m_s,
        m.peak_yaw_rate_rad_s
    );
    out
}

/// The wire-following lines: settling, the error and what it covers, the limit cycle,
/// and the wire lost or ended.
fn tracking_lines(s: &RunSummary) -> String {
    use crate::sim::metrics::{ErrorWindow, LIMIT_CYCLE_TAIL_FRACTION, SETTLED_BAND_M};
    use std::fmt::Write;
    let band_mm = 1000.0 * SETTLED_BAND_M;
    let mut out = String::new();
    let _ = match s.settling_distance_m {
        Some(d) => writeln!(
            out,
            "settled    after {d:.2} m (lateral error within {band_mm:.0} mm from then on)"
        ),
        None if s.error_window != ErrorWindow::WholeRun => {
            writeln!(out, "settled    no (the wire was lost or ended first)")
        }
        None => writeln!(
            out,
            "settled    no (lateral error never stayed within {band_mm:.0} mm)"
        ),
    };
    let _ = writeln!(
        out,
        "error      RMS {:.1} mm, peak {:.1} mm lateral ({})",
        1000.0 * s.rms_lateral_error_m,
        1000.0 * s.peak_lateral_error_m,
        s.error_window.describe()
    );
    let cycle_over = match s.error_window {
        ErrorWindow::UntilWireLost | ErrorWindow::UntilWireEnd => "on the wire",
        _ => "of the run",
    };
    let tail_pct = 100.0 * LIMIT_CYCLE_TAIL_FRACTION;
    let _ = match s.limit_cycle {
        Some(c) => writeln!(
            out,
            "cycle      limit cycle +/-{:.1} mm, period {:.2} s (last {tail_pct:.0} % {cycle_over})",
            1000.0 * c.amplitude_m,
            c.period_s
        ),
        None => writeln!(out, "cycle      {}", no_cycle_text(s.no_cycle, tail_pct, cycle_over)),
    };
    if let Some(e) = s.wire_lost {
        let after = if s.off_wire_at_end {
            "still lost at the end"
        } else {
            "found again by the end"
        };
        let times = match s.wire_losses {
            0 | 1 => String::new(),
            n => format!(" {n} times, first"),
        };
        let _ = writeln!(
            out,
            "wire       lost{times} at {}; {after}",
            event_words(&e)
        );
    }
    if let Some(e) = s.wire_end {
        let _ = writeln!(
            out,
            "wire end   passed the far end of the wire at {}",
            event_words(&e)
        );
    }
    out
}

/// The scene's `[expect]` claims against the run, one line each; nothing when the table
/// is empty. With overrides the run is not the scene as written, so nothing is checked.
pub fn render_expectations(scene: &Scene, s: &RunSummary, overridden: bool) -> String {
    use std::fmt::Write;
    if scene.expect.is_empty() {
        return String::new();
    }
    if overridden {
        return "expected   not checked: --set/--duration/--seed changed the scene its [expect] describes\n"
            .into();
    }
    let mut out = String::new();
    for c in crate::sim::expectation::check(&scene.expect, s) {
        let _ = writeln!(
            out,
            "expected   {:<40} {} (run: {})",
            c.claim,
            if c.met { "met" } else { "NOT MET" },
            c.observed
        );
    }
    out
}
