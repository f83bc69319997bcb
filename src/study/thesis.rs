//! The thesis's simulation figures (Figs 6.1-6.5): the lab run (sensor pair 120 mm off a
//! straight wire) over proportional gain at each fidelity level, paths drawn as lateral
//! error against distance, and the `full` level beside them showing what slip adds.

use super::{md_table, study_sweep, value_of, write_summary, StudyOptions, StudyOutput};
use crate::firmware::ControllerParams;
use crate::model::gearbox::GearboxParams;
use crate::model::tyre::TyreChoice;
use crate::plot::{svg, Series, COLOURS};
use crate::sim::metrics::RunSummary;
use crate::sweep::SweepError;

/// The lab scene every level runs.
pub const SCENE: &str = include_str!("../../scenes/lab_offset_120mm.toml");
/// Its name in messages and manifests.
pub const SCENE_LABEL: &str = "scenes/lab_offset_120mm.toml";

/// Simulated time of each run, s: long enough for the 0.7-2 s limit cycles to show in the
/// last 40 % of the run.
pub const DURATION_S: f64 = 20.0;

/// One run of the study.
#[derive(Debug, Clone)]
pub struct ThesisRun {
    /// Firmware gain scale.
    pub gain: f64,
    /// RMS lateral error over the whole run (the thesis compares whole paths), m.
    pub whole_run_rms_m: f64,
    /// Limit-cycle amplitude (0: none), m.
    pub limit_cycle_m: f64,
    /// Share of the slip window (second half of the time on the wire) with a drive tyre sliding.
    pub sliding_fraction: f64,
    /// The sensors lost the wire.
    pub lost_wire: bool,
}

/// A fidelity level's gain sweep.
#[derive(Debug, Clone)]
pub struct ThesisLevel {
    /// The fidelity level.
    pub level: String,
    /// Its runs by gain.
    pub runs: Vec<ThesisRun>,
}

fn gains(level: &str, quick: bool) -> &'static str {
    match (level, quick) {
        // Figs 6.1-6.2: 0.1-1.0 and 1.5-4.0.
        ("linear", false) => "0.1,0.2,0.3,0.5,0.7,1.0,1.5,2.0,3.0,4.0",
        ("linear", true) => "0.2,0.5,1.0,2.0,4.0",
        // The full level from where its tyres begin to slide, finely up to where, with the
        // thesis's hard tyres on painted concrete, it stops holding the wire (near gain 2).
        ("full", false) => "1.0,1.25,1.5,1.75,2.0,3.0,4.0,5.0,6.0",
        ("full", true) => "1.0,1.5,1.75,2.0,4.0",
        // Figs 6.3-6.5: 2.0-6.0.
        (_, false) => "2.0,3.0,4.0,5.0,6.0",
        (_, true) => "2.0,4.0,6.0",
    }
}

/// The fidelity levels, simplest first.
pub const LEVELS: [&str; 4] = ["linear", "nonlinear", "complex", "full"];

/// Runs the study into `opts.out_dir`; `progress` follows its sweeps.
pub fn run(
    opts: &StudyOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<(Vec<ThesisLevel>, StudyOutput), SweepError> {
    let mut levels = vec![];
    let mut files = vec![];
    let mut rows = vec![];
    let duration = format!("sim.duration_s={DURATION_S}");
    for level in LEVELS {
        let fidelity = format!("sim.fidelity={level}");
        let varies = vec![format!(
            "controller.gain_scale={}",
            gains(level, opts.quick)
        )];
        let (o, results) = study_sweep(
            opts,
            level,
            SCENE_LABEL,
            SCENE,
            &[&fidelity, &duration],
            &varies,
            true,
            progress,
        )?;
        let mut runs = vec![];
        let mut paths = vec![];
        for r in &results {
            let gain: f64 = value_of(&o, r, ControllerParams::gain_scale.key())
                .parse()
                .unwrap_or(f64::NAN);
            let (Ok(s), Some(t)) = (&r.outcome, &r.trace) else {
                continue;
            };
            let n = t.lateral_error_m.len().max(1) as f64;
            let whole = (t.lateral_error_m.iter().map(|e| e * e).sum::<f64>() / n).sqrt();
            runs.push(ThesisRun {
                gain,
                whole_run_rms_m: whole,
                limit_cycle_m: s.limit_cycle.map_or(0.0, |c| c.amplitude_m),
                sliding_fraction: s.sliding_fraction,
                lost_wire: s.lost_wire,
            });
            let y_mm: Vec<f64> = t.lateral_error_m.iter().map(|e| 1000.0 * e).collect();
            let label = if s.lost_wire {
                format!("gain {gain} (lost the wire; out of scale)")
            } else {
                format!("gain {gain}")
            };
            paths.push((label, t.distance_m.clone(), y_mm, s.lost_wire));
            rows.push(table_row(level, gain, whole, s));
        }
        let fig = paths_figure(opts, level, &paths)?;
        files.push(fig);
        levels.push(ThesisLevel {
            level: level.to_string(),
            runs,
        });
    }
    let mut summary = format!(
        "# The thesis's figures\n\nScene `{SCENE_LABEL}`: straight wire, the sensor pair starts \
         120 mm off it, {DURATION_S} s runs. Levels: `linear` (Figs 6.1-6.2), `nonlinear` \
         (sensors, sample and hold, delay: Figs 6.3-6.4), `complex` (plus ADC quantisation and \
         backlash: Fig 6.5), and agvsim's `full` level (rapier chassis, tyres that slip, \
         castors) with the thesis's hard tyres on painted concrete.\n\n"
    );
    summary.push_str(&md_table(
        &[
            "level",
            "gain",
            "RMS error mm (whole run)",
            "limit cycle mm",
            "sliding %",
            "lost wire",
        ],
        &rows,
    ));
    summary.push_str("\n## Trends\n\n");
    for l in &levels {
        summary.push_str(&format!("- {}\n", trend(l)));
    }
    summary.push_str(&what_slip_adds(opts, progress)?);
    summary.push_str(
        "\nPaths: `paths_LEVEL.svg`; each level's sweep, traces and metric plots in `LEVEL/`; \
         the probe's sweep in `full_mechanism/`.\n",
    );
    files.push(write_summary(&opts.out_dir, &summary)?);
    Ok((levels, StudyOutput { summary, files }))
}

/// A level's runs as a figure, `paths_LEVEL.svg`: the sensor pair's offset from the wire
/// along each run (label, distance m, offset mm, lost the wire).
fn paths_figure(
    opts: &StudyOptions,
    level: &str,
    paths: &[(String, Vec<f64>, Vec<f64>, bool)],
) -> Result<std::path::PathBuf, SweepError> {
    let series: Vec<Series> = paths
        .iter()
        .enumerate()
        .map(|(i, (label, x, y, lost))| {
            let line = Series::line(label, x, y, COLOURS[i % COLOURS.len()]);
            // A lost run's error runs off to metres and would flatten every cycle.
            if *lost {
                line.out_of_scale()
            } else {
                line
            }
        })
        .collect();
    let fig = opts.out_dir.join(format!("paths_{level}.svg"));
    crate::output::write_atomically(
        &fig,
        svg(
            &format!("{level} level: sensor-pair offset from the wire along the run"),
            "distance travelled, m",
            "lateral error, mm",
            &series,
            None,
        ),
    )
    .map_err(crate::sweep::io_err(&fig))?;
    Ok(fig)
}

/// A run's row of the summary's table.
fn table_row(level: &str, gain: f64, whole_run_rms_m: f64, s: &RunSummary) -> Vec<String> {
    let whole = whole_run_rms_m;
    vec![
        level.to_string(),
        format!("{gain}"),
        format!("{:.1}", 1000.0 * whole),
        if s.limit_cycle.is_some() {
            format!(
                "{:.1}",
                1000.0 * s.limit_cycle.map_or(0.0, |c| c.amplitude_m)
            )
        } else {
            "-".into()
        },
        format!("{:.1}", 100.0 * s.sliding_fraction),
        if s.lost_wire { "yes" } else { "no" }.into(),
    ]
}

/// One cell of the high-gain probe: the `full` level at a gain with or without the tyre's
/// friction drop on sliding and the gear play.
struct ProbeRun {
    gain: f64,
    friction_drop: bool,
    play: bool,
    lost_wire: bool,
}

/// The `full` level at the high gains with the two ingredients of the thesis's account of
/// Run #3 switched off in turn: the friction lost when a tyre slides (the compound's
/// sliding ratio against none) and the gear play (against none). Returns the summary
/// section.
fn what_slip_adds(
    opts: &StudyOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<String, SweepError> {
    let scene = crate::scene::Scene::from_toml(SCENE, std::path::Path::new(SCENE_LABEL), &[])?;
    let params = crate::sim::SimParams::from_scene(&scene)?;
    let tyre = params.drive_tyre(params.floor.default);
    let sliding = tyre.sliding_mu / tyre.peak_mu;
    let play = scene.gearbox.backlash_rad;
    let gains = if opts.quick { "2,4" } else { "2,3,4,6" };
    let varies = vec![
        format!("tyre.sliding_ratio={sliding},1"),
        format!("gearbox.backlash_rad={play},0"),
        format!("controller.gain_scale={gains}"),
    ];
    let duration = format!("sim.duration_s={DURATION_S}");
    let (o, results) = study_sweep(
        opts,
        "full_mechanism",
        SCENE_LABEL,
        SCENE,
        &["sim.fidelity=full", &duration],
        &varies,
        false,
        progress,
    )?;
    let mut runs = vec![];
    let mut rows = vec![];
    for r in &results {
        let Ok(m) = &r.outcome else { continue };
        let num = |k: &str| value_of(&o, r, k).parse::<f64>().unwrap_or(f64::NAN);
        let drop = num(TyreChoice::sliding_ratio.key()) < 1.0;
        let has_play = num(GearboxParams::backlash_rad.key()) > 0.0;
        let gain = num(ControllerParams::gain_scale.key());
        rows.push(vec![
            if drop { "yes" } else { "no" }.into(),
            if has_play { "yes" } else { "no" }.into(),
            format!("{gain}"),
            m.limit_cycle
                .map_or("-".into(), |c| format!("{:.1}", 1000.0 * c.amplitude_m)),
            format!("{:.1}", 100.0 * m.sliding_fraction),
            format!("{:.3}", m.mean_abs_slip_ratio),
            if m.lost_wire { "yes" } else { "no" }.into(),
        ]);
        runs.push(ProbeRun {
            gain,
            friction_drop: drop,
            play: has_play,
            lost_wire: m.lost_wire,
        });
    }
    let held = |drop: bool, play: bool| -> Vec<String> {
        runs.iter()
            .filter(|p| p.friction_drop == drop && p.play == play && !p.lost_wire)
            .map(|p| format!("{}", p.gain))
            .collect()
    };
    let describe = |v: Vec<String>| {
        if v.is_empty() {
            "none".to_string()
        } else {
            v.join(", ")
        }
    };
    let mut md = format!(
        "\n## What slip adds at high gain\n\nThe thesis explains Run #3 by two things together: \
         gear teeth engaging after the motor freewheels through the play spin the wheels, and \
         spinning wheels grip less. The `full` level at gains {gains}, with the `{}` \
         compound's sliding friction ({sliding} of the peak) or none lost on sliding, and with \
         the gear play ({:.1} degrees) or none:\n\n",
        scene.tyre.compound,
        play.to_degrees()
    );
    md.push_str(&md_table(
        &[
            "friction drop",
            "gear play",
            "gain",
            "limit cycle mm",
            "sliding %",
            "mean slip ratio",
            "lost wire",
        ],
        &rows,
    ));
    md.push_str(&format!(
        "\nGains at which the wire is held: with the drop and the play {}; with the drop only \
         {}; with the play only {}; with neither {}. Where the sensors lose the wire, the \
         slipping vehicle has overshot it at a heading the saturated tyres cannot turn back \
         before both coils fall below the lost-wire threshold; the thesis's vehicle instead kept \
         cycling across the wire.\n",
        describe(held(true, true)),
        describe(held(true, false)),
        describe(held(false, true)),
        describe(held(false, false)),
    ));
    Ok(md)
}

/// A sentence on what a level's sweep shows, from its numbers.
pub fn trend(l: &ThesisLevel) -> String {
    let r = &l.runs;
    if r.len() < 2 {
        return format!("{}: too few runs for a trend", l.level);
    }
    let cycles: Vec<&ThesisRun> = r.iter().filter(|x| x.limit_cycle_m > 0.0).collect();
    let growing = cycles.len() >= 2
        && cycles
            .windows(2)
            .all(|w| w[1].limit_cycle_m >= w[0].limit_cycle_m);
    let first = &r[0];
    let last = &r[r.len() - 1];
    let mut s = format!(
        "{}: whole-run RMS error {:.1} mm at gain {} and {:.1} mm at gain {}",
        l.level,
        1000.0 * first.whole_run_rms_m,
        first.gain,
        1000.0 * last.whole_run_rms_m,
        last.gain
    );
    if l.level == "linear" && r.len() >= 3 {
        let early = r[0].whole_run_rms_m - r[1].whole_run_rms_m;
        let late = r[r.len() - 2].whole_run_rms_m - r[r.len() - 1].whole_run_rms_m;
        s.push_str(&format!(
            "; the last gain step gains {:.1} mm against {:.1} mm for the first (an asymptote)",
            1000.0 * late,
            1000.0 * early
        ));
    }
    if !cycles.is_empty() {
        s.push_str(&format!(
            "; limit cycles at {} of {} gains, {:.1}-{:.1} mm{}",
            cycles.len(),
            r.len(),
            1000.0
                * cycles
                    .iter()
                    .map(|c| c.limit_cycle_m)
                    .fold(f64::INFINITY, f64::min),
            1000.0 * cycles.iter().map(|c| c.limit_cycle_m).fold(0.0, f64::max),
            if growing { ", growing with gain" } else { "" }
        ));
    }
    let slip_cycles: Vec<String> = r
        .iter()
        .filter(|x| x.limit_cycle_m > 0.0 && x.sliding_fraction >= super::tyres::SLIDING_SHARE)
        .map(|x| format!("{} ({:.0} % sliding)", x.gain, 100.0 * x.sliding_fraction))
        .collect();
    if !slip_cycles.is_empty() {
        s.push_str(&format!(
            "; slip-driven limit cycles at gain {}",
            slip_cycles.join(", ")
        ));
    }
    let lost: Vec<String> = r
        .iter()
        .filter(|x| x.lost_wire)
        .map(|x| format!("{}", x.gain))
        .collect();
    if !lost.is_empty() {
        s.push_str(&format!(
            "; the sensors lose the wire at gain {}",
            lost.join(", ")
        ));
    }
    s
}
