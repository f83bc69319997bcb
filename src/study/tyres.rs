//! Tyre compounds: hard polyurethane against soft rubber, on painted and bare concrete,
//! with payloads of 0, 100 and 200 kg, over the proportional gain: where the drive tyres
//! start to slide and where slip-driven limit cycles start (the thesis's recommendation of
//! a softer compound, quantified).

use crate::firmware::ControllerParams;
use crate::model::chassis::PayloadParams;
use crate::model::tyre::TyreChoice;
use crate::world::FloorParams;
use std::collections::BTreeMap;
use std::path::PathBuf;

use super::{md_table, opt, study_sweep, value_of, write_summary, StudyOptions, StudyOutput};
use crate::plot::{Plot, Series, Style, COLOURS};
use crate::sweep::{RunResult, SweepError, SweepOptions};

/// The scene the study sweeps.
pub const SCENE: &str = include_str!("../../scenes/studies/tyre_compounds.toml");
/// Its name in messages and manifests.
pub const SCENE_LABEL: &str = "scenes/studies/tyre_compounds.toml";

/// A run "slips" when a drive tyre is on its friction limit for at least this share of its
/// slip window (the second half of its time on the wire). Backlash-only limit cycles on good grip slide for 0-4 % of the
/// time (tooth knocks at each engagement); cycles that the tyres cannot follow slide for a
/// fifth of it and more.
pub const SLIDING_SHARE: f64 = 0.05;

/// One compound, floor and payload over the gains.
#[derive(Debug, Clone)]
pub struct TyreGroup {
    /// The compound.
    pub compound: String,
    /// The floor.
    pub surface: String,
    /// The payload, kg (as the sweep wrote it).
    pub payload_kg: String,
    /// (gain, sliding fraction, limit-cycle amplitude m (0: none), lost the wire).
    pub runs: Vec<(f64, f64, f64, bool)>,
    /// Lowest gain at which the tyres slide for [`SLIDING_SHARE`] of the time.
    pub slip_onset_gain: Option<f64>,
    /// Lowest gain with a limit cycle during which the tyres slide that much.
    pub slip_cycle_onset_gain: Option<f64>,
    /// Gains at which the sensors lost the wire (too little steering at the lowest gains,
    /// a cycle that outgrows the coils' range at the highest).
    pub wire_lost_gains: Vec<f64>,
}

impl TyreGroup {
    /// Mean sliding fraction over the given gains (those where every group held the wire).
    pub fn mean_sliding_over(&self, gains: &[f64]) -> f64 {
        let v: Vec<f64> = self
            .runs
            .iter()
            .filter(|r| gains.iter().any(|g| (g - r.0).abs() < 1e-9))
            .map(|r| r.1)
            .collect();
        v.iter().sum::<f64>() / v.len().max(1) as f64
    }
}

/// Runs the study; returns the groups and the summary.
pub fn run(
    opts: &StudyOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<(Vec<TyreGroup>, StudyOutput), SweepError> {
    let varies = grid(opts.quick);
    let (o, results) = study_sweep(
        opts,
        "sweep",
        SCENE_LABEL,
        SCENE,
        &[],
        &varies,
        false,
        progress,
    )?;
    let groups = groups_of(&o, &results);
    let held = gains_every_group_held(&groups);
    let mut summary = summary_table(&o, &results, &groups, &held);
    let (plot, plot_says) = onset_plot(opts, &groups)?;
    let mut files = vec![plot];
    summary.push_str(&format!("\nPlots: `slip_cycle_onset.svg` ({plot_says}); `sweep/plots/` (every metric against gain, one line per compound, floor and payload; a cross marks a gain where a run lost the wire).\n"));
    files.push(write_summary(&opts.out_dir, &summary)?);
    Ok((groups, StudyOutput { summary, files }))
}

/// The sweep's grid: gain, compound, floor and payload (fewer of each when quick).
fn grid(quick: bool) -> Vec<String> {
    if quick {
        // The gain first: the sweep's plots put the first numeric key along x.
        vec![
            "controller.gain_scale=1..3:9".into(),
            "tyre.compound=hard_polyurethane,soft_rubber".into(),
            "floor.surface=painted_concrete".into(),
            "payload.mass_kg=0".into(),
        ]
    } else {
        vec![
            "controller.gain_scale=0.5..4:15".into(),
            "tyre.compound=hard_polyurethane,soft_rubber".into(),
            "floor.surface=painted_concrete,bare_concrete".into(),
            "payload.mass_kg=0,100,200".into(),
        ]
    }
}

/// The runs grouped by compound, floor and payload, each with its onsets.
fn groups_of(o: &SweepOptions, results: &[RunResult]) -> Vec<TyreGroup> {
    let mut groups: BTreeMap<(String, String, String), TyreGroup> = BTreeMap::new();
    for r in results {
        let Ok(s) = &r.outcome else { continue };
        let key = (
            value_of(o, r, TyreChoice::compound.key()).to_string(),
            value_of(o, r, FloorParams::surface.key()).to_string(),
            value_of(o, r, PayloadParams::mass_kg.key()).to_string(),
        );
        let gain: f64 = value_of(o, r, ControllerParams::gain_scale.key())
            .parse()
            .unwrap_or(f64::NAN);
        let g = groups.entry(key.clone()).or_insert_with(|| TyreGroup {
            compound: key.0,
            surface: key.1,
            payload_kg: key.2,
            runs: vec![],
            slip_onset_gain: None,
            slip_cycle_onset_gain: None,
            wire_lost_gains: vec![],
        });
        g.runs.push((
            gain,
            s.sliding_fraction,
            s.limit_cycle.map_or(0.0, |c| c.amplitude_m),
            s.lost_wire,
        ));
    }
    let mut groups: Vec<TyreGroup> = groups.into_values().collect();
    for g in &mut groups {
        g.runs.sort_by(|a, b| a.0.total_cmp(&b.0));
        g.slip_onset_gain = g.runs.iter().find(|r| r.1 >= SLIDING_SHARE).map(|r| r.0);
        g.slip_cycle_onset_gain = g
            .runs
            .iter()
            .find(|r| !r.3 && r.2 > 0.0 && r.1 >= SLIDING_SHARE)
            .map(|r| r.0);
        g.wire_lost_gains = g.runs.iter().filter(|r| r.3).map(|r| r.0).collect();
    }
    groups
}

/// Gains at which every group kept the wire: slip compared like for like.
fn gains_every_group_held(groups: &[TyreGroup]) -> Vec<f64> {
    groups
        .first()
        .map(|g| g.runs.iter().map(|r| r.0).collect::<Vec<_>>())
        .unwrap_or_default()
        .into_iter()
        .filter(|gain| {
            groups
                .iter()
                .all(|g| g.runs.iter().any(|r| (r.0 - gain).abs() < 1e-9 && !r.3))
        })
        .collect()
}

/// The summary's text and its table of groups.
fn summary_table(
    o: &SweepOptions,
    results: &[RunResult],
    groups: &[TyreGroup],
    held: &[f64],
) -> String {
    let rows: Vec<Vec<String>> = groups
        .iter()
        .map(|g| {
            vec![
                g.compound.clone(),
                g.surface.clone(),
                g.payload_kg.clone(),
                opt(g.slip_onset_gain, 2),
                opt(g.slip_cycle_onset_gain, 2),
                if g.wire_lost_gains.is_empty() {
                    "-".into()
                } else {
                    g.wire_lost_gains
                        .iter()
                        .map(|x| format!("{x}"))
                        .collect::<Vec<_>>()
                        .join(", ")
                },
                format!("{:.1}", 100.0 * g.mean_sliding_over(held)),
            ]
        })
        .collect();
    let mut summary = format!(
        "# Tyre-compound study\n\nScene `{SCENE_LABEL}` (full level: rapier chassis, tyres, castors), \
         {} runs of {} s. A run slips when a drive tyre is on its friction limit for at least \
         {:.0} % of the second half of its time on the wire; a slip-driven limit cycle is a sustained oscillation of \
         at least {:.0} mm during which it slips. Gains are `controller.gain_scale` (1 = the \
         firmware's Kp = -1/20).\n\nSliding is the mean share of the time over the gains at \
         which every combination kept the wire ({}).\n\n",
        results.len(),
        o.scene_text
            .lines()
            .find_map(|l| l.strip_prefix("duration_s = "))
            .unwrap_or("?"),
        100.0 * SLIDING_SHARE,
        1000.0 * crate::sim::metrics::LIMIT_CYCLE_MIN_AMPLITUDE_M,
        held.iter().map(|g| format!("{g}")).collect::<Vec<_>>().join(", ")
    );
    summary.push_str(&md_table(
        &[
            "compound",
            "floor",
            "payload kg",
            "slip from gain",
            "slip cycles from gain",
            "wire lost at gains",
            "sliding %",
        ],
        &rows,
    ));
    summary
}

/// The onset of slip-driven cycles against payload, one line per compound and floor (bars
/// for one payload), written; the file and what it shows.
fn onset_plot(
    opts: &StudyOptions,
    groups: &[TyreGroup],
) -> Result<(PathBuf, &'static str), SweepError> {
    // Onset of slip-driven cycles against payload, one line per compound and floor.
    let mut lines: BTreeMap<(String, String), (Vec<f64>, Vec<f64>)> = BTreeMap::new();
    for g in groups {
        let e = lines
            .entry((g.compound.clone(), g.surface.clone()))
            .or_default();
        e.0.push(g.payload_kg.parse().unwrap_or(f64::NAN));
        e.1.push(g.slip_cycle_onset_gain.unwrap_or(f64::NAN));
    }
    let labels: Vec<String> = lines.keys().map(|(c, s)| format!("{c} on {s}")).collect();
    let payloads: std::collections::BTreeSet<&str> =
        groups.iter().map(|g| g.payload_kg.as_str()).collect();
    let plot: PathBuf = opts.out_dir.join("slip_cycle_onset.svg");
    std::fs::create_dir_all(&opts.out_dir).map_err(crate::sweep::io_err(&opts.out_dir))?;
    let (svg, plot_says) = if payloads.len() == 1 {
        // One payload (the quick study): a line against payload would be a dot each on
        // an axis of nothing; the onsets side by side say it.
        let payload = payloads.iter().next().copied().unwrap_or("0");
        let bars: Vec<crate::plot::bars::BarGroup> = lines
            .values()
            .zip(&labels)
            .map(|((_, y), label)| crate::plot::bars::BarGroup {
                label: label.clone(),
                values: vec![y.first().copied().unwrap_or(f64::NAN)],
            })
            .collect();
        (
            crate::plot::bars::bar_chart(
                &format!("onset of slip-driven limit cycles, payload {payload} kg"),
                "the lowest controller.gain_scale swept at which the tyres slide in a limit cycle; none: not at the gains swept",
                &[("onset gain_scale", COLOURS[0])],
                &bars,
                "",
            ),
            "onset gain by compound and floor, one payload",
        )
    } else {
        // Where no onset was found up to the top gain swept, the onset is censored: an
        // open triangle at the top gain ("above this"), never a point as if measured.
        let top = groups
            .iter()
            .flat_map(|g| g.runs.iter().map(|r| r.0))
            .fold(f64::NEG_INFINITY, f64::max);
        let censored: Vec<(String, Vec<f64>, Vec<f64>)> = lines
            .values()
            .zip(&labels)
            .map(|((x, y), label)| {
                let xs: Vec<f64> = x
                    .iter()
                    .zip(y)
                    .filter(|(_, y)| y.is_nan())
                    .map(|(x, _)| *x)
                    .collect();
                let n = xs.len();
                (
                    format!("{label}: none up to gain {}", crate::numtext::sig(top, 3)),
                    xs,
                    vec![top; n],
                )
            })
            .collect();
        let mut series: Vec<Series> = lines
            .values()
            .zip(&labels)
            .enumerate()
            .map(|(i, ((x, y), label))| Series::line(label, x, y, COLOURS[i % COLOURS.len()]))
            .collect();
        series.extend(
            censored
                .iter()
                .enumerate()
                .filter(|(_, c)| !c.1.is_empty())
                .map(|(i, (label, x, y))| {
                    Series::line(label, x, y, COLOURS[i % COLOURS.len()]).with_style(Style::Above)
                }),
        );
        (
            Plot {
                title: "onset of slip-driven limit cycles (open triangle: none up to the top gain swept)",
                x_label: "payload, kg",
                y_label: "gain_scale",
                series: &series,
                band: None,
                flags: None,
                empty_note: "no run reached a slip-driven limit cycle at the gains swept",
            }
            .render(),
            "onset gain against payload; an open triangle where none was found up to the top gain swept",
        )
    };
    crate::output::write_atomically(&plot, svg).map_err(crate::sweep::io_err(&plot))?;
    Ok((plot, plot_says))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn group(payload: &str, onset: Option<f64>) -> TyreGroup {
        TyreGroup {
            compound: "soft_rubber".into(),
            surface: "painted_concrete".into(),
            payload_kg: payload.into(),
            runs: vec![(1.0, 0.0, 0.0, false), (4.0, 0.2, 0.01, false)],
            slip_onset_gain: onset,
            slip_cycle_onset_gain: onset,
            wire_lost_gains: vec![],
        }
    }

    /// An onset not found up to the top gain swept is drawn censored (an open triangle at
    /// the top gain), never as a measured point; a found onset stays a point.
    #[test]
    fn an_onset_not_reached_is_drawn_censored_at_the_top_gain() {
        let dir = std::env::temp_dir().join(format!("agvsim_onset_{}", std::process::id()));
        let opts = StudyOptions {
            out_dir: dir.clone(),
            jobs: 1,
            quick: false,
        };
        let groups = [
            group("0", Some(2.5)),
            group("100", None),
            group("200", None),
        ];
        let (file, says) = onset_plot(&opts, &groups).unwrap();
        let svg = std::fs::read_to_string(file).unwrap();
        let _ = std::fs::remove_dir_all(&dir);
        assert!(says.contains("open triangle"), "{says}");
        assert!(
            svg.contains("none up to gain 4"),
            "no censored legend entry"
        );
        // Two censored payloads: two open triangles in the data, one in the legend.
        let triangles = svg.matches(r##"fill="white" stroke="#1f5fbf""##).count();
        assert_eq!(triangles, 3, "{svg}");
    }
}
