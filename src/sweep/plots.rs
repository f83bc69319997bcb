//! Plots of each metric against a varied value (SVG), one line per combination of the
//! other varied values, means over repeats.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// A series' points binned by x (scaled to an integer): the sums of x and y, and the count.
type Bins = BTreeMap<i64, (f64, f64, usize)>;

/// A metric's lines by the other keys' value places: each its label and its bins.
type Lines = BTreeMap<Vec<usize>, (String, Bins)>;

use super::grid::Grid;
use super::results::{Table, METRICS};
use super::{io_err, SweepError};
use crate::plot::{Flags, Plot, Series, COLOURS};

/// Result columns that hold words, not numbers: not plotted.
const TEXT_METRICS: [&str; 3] = ["faults", "error_window", "slip_window"];

/// Metrics of how the wire was followed: meaningless for a run that lost the wire (its
/// "error" then measures distance from the wire), so such runs are left out of these
/// plots' lines and scale and marked with a cross instead.
const TRACKING_METRICS: [&str; 6] = [
    "rms_lateral_error_m",
    "peak_lateral_error_m",
    "settling_distance_m",
    "limit_cycle_amplitude_m",
    "limit_cycle_period_s",
    "final_lateral_error_m",
];

/// Most lines on one plot; more are split over several files (`METRIC.svg`,
/// `METRIC_part2.svg`, ...), each saying which lines it holds.
const MAX_SERIES: usize = 10;

/// The varied key plotted along x: the first with two or more numeric values, else the
/// first (its values then stand at 0, 1, 2...).
pub fn x_key(grid: &Grid) -> usize {
    grid.varies
        .iter()
        .position(|v| v.values.len() > 1 && v.values.iter().all(|x| x.parse::<f64>().is_ok()))
        .unwrap_or(0)
}

/// Writes `plots/METRIC.svg` for every numeric metric; returns the files.
pub fn write(dir: &Path, grid: &Grid, table: &Table) -> Result<Vec<PathBuf>, SweepError> {
    let pdir = dir.join("plots");
    std::fs::create_dir_all(&pdir).map_err(io_err(&pdir))?;
    let axis = Axis::of(grid, table);
    let mut files = vec![];
    for (metric, meaning) in METRICS.iter().filter(|(m, _)| !TEXT_METRICS.contains(m)) {
        let Some(mc) = table.column(metric) else {
            continue;
        };
        let tracking = TRACKING_METRICS.contains(metric);
        let (lines, flagged) = axis.lines(table, mc, tracking);
        if lines.is_empty() && flagged.is_empty() {
            continue;
        }
        let data: Vec<(String, Vec<f64>, Vec<f64>)> = lines
            .into_values()
            .map(|(label, pts)| {
                let (xs, ys) = pts.values().map(|(x, s, n)| (*x, s / *n as f64)).unzip();
                (
                    if label.is_empty() {
                        "mean over repeats".into()
                    } else {
                        label
                    },
                    xs,
                    ys,
                )
            })
            .collect();
        let flags = (!flagged.is_empty()).then_some(Flags {
            label: if tracking {
                "a run here lost the wire or failed (left out)"
            } else {
                "a run here lost the wire (kept) or failed (left out)"
            },
            x: &flagged,
            colour: "#c00000",
        });
        files.extend(write_parts(
            &pdir,
            metric,
            meaning,
            &data,
            &axis.label(),
            flags,
        )?);
    }
    Ok(files)
}

/// The plots' x axis: the first numeric key of the grid (else its first key, its values
/// as places), and the column each key is in.
struct Axis<'g> {
    grid: &'g Grid,
    /// The key along x.
    xi: usize,
    numeric: bool,
    key_cols: Vec<Option<usize>>,
    outcome: Option<usize>,
    lost: Option<usize>,
}

impl<'g> Axis<'g> {
    fn of(grid: &'g Grid, table: &Table) -> Self {
        let xi = x_key(grid);
        Axis {
            grid,
            xi,
            numeric: grid.varies[xi]
                .values
                .iter()
                .all(|x| x.parse::<f64>().is_ok()),
            key_cols: grid.varies.iter().map(|v| table.column(&v.key)).collect(),
            outcome: table.column("outcome"),
            lost: table.column("lost_wire"),
        }
    }

    /// A value of the x key as a place on the axis.
    fn x_of(&self, s: &str) -> f64 {
        let xv = &self.grid.varies[self.xi];
        if self.numeric {
            s.parse().unwrap_or(f64::NAN)
        } else {
            xv.values
                .iter()
                .position(|v| v == s)
                .map(|i| i as f64)
                .unwrap_or(f64::NAN)
        }
    }

    /// The axis's label (a text key's values listed in their places).
    fn label(&self) -> String {
        let xv = &self.grid.varies[self.xi];
        if self.numeric {
            xv.key.clone()
        } else {
            format!("{} ({})", xv.key, xv.values.join(", "))
        }
    }

    /// A metric's lines (one per combination of the other keys, in grid order, each the
    /// mean at each x) and the x of runs that failed or lost the wire. A failed run has no
    /// value; a lost run's tracking figures measure distance from the wire, so both are
    /// left out of the lines; its other figures (slip until the wire was lost, energy,
    /// distance) stay in.
    fn lines(&self, table: &Table, mc: usize, tracking: bool) -> (Lines, Vec<f64>) {
        // series label -> x -> (sum, count)
        let mut lines: Lines = BTreeMap::new();
        let mut flagged: Vec<f64> = vec![];
        for (_, _, cells) in &table.rows {
            let failed = self.outcome.map(|c| cells[c] != "ok").unwrap_or(false);
            let was_lost = self.lost.is_some_and(|c| cells[c] == "1");
            if failed || was_lost {
                if let Some(Some(col)) = self.key_cols.get(self.xi) {
                    let x = self.x_of(&cells[*col]);
                    if x.is_finite() && !flagged.contains(&x) {
                        flagged.push(x);
                    }
                }
            }
            if failed || (tracking && was_lost) {
                continue;
            }
            let Ok(y) = cells[mc].parse::<f64>() else {
                continue;
            };
            let mut order = vec![];
            let mut label = vec![];
            let mut x = f64::NAN;
            for (k, (v, col)) in self.grid.varies.iter().zip(&self.key_cols).enumerate() {
                let Some(col) = col else { continue };
                let val = &cells[*col];
                if k == self.xi {
                    x = self.x_of(val);
                } else {
                    order.push(v.values.iter().position(|w| w == val).unwrap_or(usize::MAX));
                    label.push(format!("{}={val}", short_key(&v.key)));
                }
            }
            if !x.is_finite() {
                continue;
            }
            let entry = lines
                .entry(order)
                .or_insert_with(|| (label.join(" "), BTreeMap::new()));
            // Keyed by x in fixed point so the map orders the points along x.
            let p = entry
                .1
                .entry((x * 1e9).round() as i64)
                .or_insert((x, 0.0, 0));
            p.1 += y;
            p.2 += 1;
        }
        (lines, flagged)
    }
}

/// A metric's plot, its lines split over several files when there are more than one plot
/// can show (each saying which lines it holds: no combination is left out); the files.
fn write_parts(
    pdir: &Path,
    metric: &str,
    meaning: &str,
    data: &[(String, Vec<f64>, Vec<f64>)],
    x_label: &str,
    flags: Option<Flags>,
) -> Result<Vec<PathBuf>, SweepError> {
    let mut files = vec![];
    let parts = data.len().div_ceil(MAX_SERIES).max(1);
    for part in 0..parts {
        let lo = part * MAX_SERIES;
        let chunk = &data[lo.min(data.len())..(lo + MAX_SERIES).min(data.len())];
        let series: Vec<Series> = chunk
            .iter()
            .enumerate()
            .map(|(i, (label, xs, ys))| Series::line(label, xs, ys, COLOURS[i % COLOURS.len()]))
            .collect();
        // The parts are files side by side (METRIC.svg, METRIC_part2.svg, ...).
        let title = if parts > 1 {
            format!(
                "{meaning}: part {}/{parts}, lines {}-{} of {}",
                part + 1,
                lo + 1,
                lo + chunk.len(),
                data.len()
            )
        } else {
            meaning.to_string()
        };
        let text = Plot {
            title: &title,
            x_label,
            y_label: metric,
            series: &series,
            band: None,
            flags,
            empty_note: "no run gave a value",
        }
        .render();
        let path = pdir.join(part_file(metric, part));
        crate::output::write_atomically(&path, text).map_err(io_err(&path))?;
        files.push(path);
    }
    Ok(files)
}

/// The file of part `part` (from 0) of a metric's plot.
fn part_file(metric: &str, part: usize) -> String {
    if part == 0 {
        format!("{metric}.svg")
    } else {
        format!("{metric}_part{}.svg", part + 1)
    }
}

/// `tyre.compound` -> `compound`: legends stay short.
fn short_key(key: &str) -> &str {
    key.rsplit('.').next().unwrap_or(key)
}
