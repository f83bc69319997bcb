//! Backlash tolerance: limit-cycle amplitude against gear play and proportional gain, on
//! the lab run at the full level; which play keeps the cycle inside the settled band.

use super::{md_table, opt, study_sweep, value_of, write_summary, StudyOptions, StudyOutput};
use crate::firmware::ControllerParams;
use crate::model::gearbox::GearboxParams;
use crate::sim::metrics::SETTLED_BAND_M;
use crate::sweep::SweepError;

/// The scene the study sweeps.
pub const SCENE: &str = include_str!("../../scenes/lab_offset_120mm.toml");
/// Its name in messages and manifests.
pub const SCENE_LABEL: &str = "scenes/lab_offset_120mm.toml";

/// One run of the study.
#[derive(Debug, Clone, Copy)]
pub struct BacklashRun {
    /// Gear play, rad.
    pub play_rad: f64,
    /// Firmware gain scale.
    pub gain: f64,
    /// Limit-cycle amplitude, m (0: none).
    pub limit_cycle_m: f64,
    /// The error came to stay within the settled band.
    pub settled: bool,
    /// The sensors lost the wire.
    pub lost_wire: bool,
}

/// Runs the study into `opts.out_dir`; `progress` follows its sweep.
pub fn run(
    opts: &StudyOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<(Vec<BacklashRun>, StudyOutput), SweepError> {
    let varies: Vec<String> = if opts.quick {
        vec![
            "gearbox.backlash_rad=0,0.0873,0.1745".into(),
            "controller.gain_scale=1,2".into(),
        ]
    } else {
        // 0-15 degrees in 2.5 degree steps.
        vec![
            "gearbox.backlash_rad=0..0.261799388:7".into(),
            "controller.gain_scale=0.5,1,1.5,2".into(),
        ]
    };
    let (o, results) = study_sweep(
        opts,
        "sweep",
        SCENE_LABEL,
        SCENE,
        &["sim.duration_s=20"],
        &varies,
        false,
        progress,
    )?;
    let mut runs: Vec<BacklashRun> = vec![];
    for r in &results {
        let Ok(s) = &r.outcome else { continue };
        runs.push(BacklashRun {
            play_rad: value_of(&o, r, GearboxParams::backlash_rad.key())
                .parse()
                .unwrap_or(f64::NAN),
            gain: value_of(&o, r, ControllerParams::gain_scale.key())
                .parse()
                .unwrap_or(f64::NAN),
            limit_cycle_m: s.limit_cycle.map_or(0.0, |c| c.amplitude_m),
            settled: s.settling_distance_m.is_some(),
            lost_wire: s.lost_wire,
        });
    }
    let gains = &o.grid.varies[1].values;
    let plays = &o.grid.varies[0].values;
    let mut header = vec!["play deg".to_string()];
    header.extend(gains.iter().map(|g| format!("gain {g}: cycle mm")));
    let rows: Vec<Vec<String>> = plays
        .iter()
        .map(|p| {
            let pv: f64 = p.parse().unwrap_or(f64::NAN);
            let mut row = vec![format!("{:.1}", pv.to_degrees())];
            for g in gains {
                let gv: f64 = g.parse().unwrap_or(f64::NAN);
                let cell = runs
                    .iter()
                    .find(|r| r.play_rad == pv && r.gain == gv)
                    .map(|r| {
                        let settled = if r.settled { "" } else { ", unsettled" };
                        if r.lost_wire {
                            "lost wire".to_string()
                        } else if r.limit_cycle_m > 0.0 {
                            format!("{:.1}{settled}", 1000.0 * r.limit_cycle_m)
                        } else {
                            format!("none{settled}")
                        }
                    })
                    .unwrap_or_else(|| "failed".into());
                row.push(cell);
            }
            row
        })
        .collect();
    let header_refs: Vec<&str> = header.iter().map(String::as_str).collect();
    let mut summary = format!(
        "# Backlash tolerance\n\nScene `{SCENE_LABEL}` at the full level, 20 s runs: the \
         limit-cycle amplitude (half peak-to-peak lateral error) for each gear play and gain.\n\n"
    );
    summary.push_str(&md_table(&header_refs, &rows));
    summary.push_str(&format!(
        "\nLargest play with which the run settles (lateral error within {:.0} mm from some \
         point on; a cycle larger than that never settles):\n\n",
        1000.0 * SETTLED_BAND_M
    ));
    for g in gains {
        let gv: f64 = g.parse().unwrap_or(f64::NAN);
        let ok = runs
            .iter()
            .filter(|r| r.gain == gv && !r.lost_wire && r.settled)
            .map(|r| r.play_rad.to_degrees())
            .fold(None, |a: Option<f64>, x| Some(a.map_or(x, |a| a.max(x))));
        summary.push_str(&format!("- gain {g}: {} deg\n", opt(ok, 1)));
    }
    summary.push_str("\nPlots: `sweep/plots/limit_cycle_amplitude_m.svg` (amplitude against play, a line per gain).\n");
    let files = vec![write_summary(&opts.out_dir, &summary)?];
    Ok((runs, StudyOutput { summary, files }))
}
