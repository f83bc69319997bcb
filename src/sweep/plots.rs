//! Plots of each metric against a varied value (SVG), one line per combination of the
//! other varied values, means over repeats.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// A series' points binned by x (scaled to an integer): the sums of x and y, and the count.
type Bins = BTreeMap<i64, (f64, f64, usize)>;

/// One line of a metric's plot (one combination of the other varied keys).
#[derive(Default)]
struct Line {
    /// Legend text: the other keys' values.
    label: String,
    /// Its points, binned by x.
    bins: Bins,
    /// The x of its runs that failed or lost the wire (drawn as crosses on its plot).
    flagged: Vec<f64>,
}

/// A metric's lines by the other keys' value places.
type Lines = BTreeMap<Vec<usize>, Line>;

/// A line ready to draw: label, x, mean y, and the x of its flagged runs.
type LineData = (String, Vec<f64>, Vec<f64>, Vec<f64>);

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
        let lines = axis.lines(table, mc, tracking);
        if lines.is_empty() {
            continue;
        }
        let data: Vec<LineData> = lines
            .into_values()
            .map(|line| {
                let (xs, ys) = line
                    .bins
                    .values()
                    .map(|(x, s, n)| (*x, s / *n as f64))
                    .unzip();
                let label = if line.label.is_empty() {
                    "mean over repeats".into()
                } else {
                    line.label
                };
                (label, xs, ys, line.flagged)
            })
            .collect();
        let flag_label = if tracking {
            "a run here lost the wire or failed (left out)"
        } else {
            "a run here lost the wire (kept) or failed (left out)"
        };
        files.extend(write_parts(
            &pdir,
            metric,
            meaning,
            &data,
            &axis.label(),
            flag_label,
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
    /// mean at each x, with the x of its runs that failed or lost the wire). A failed run
    /// has no value; a lost run's tracking figures measure distance from the wire, so both
    /// are left out of the lines; its other figures (slip until the wire was lost, energy,
    /// distance) stay in.
    fn lines(&self, table: &Table, mc: usize, tracking: bool) -> Lines {
        let mut lines: Lines = BTreeMap::new();
        for (_, _, cells) in &table.rows {
            let failed = self.outcome.map(|c| cells[c] != "ok").unwrap_or(false);
            let was_lost = self.lost.is_some_and(|c| cells[c] == "1");
            let Some((order, label, x)) = self.place(cells) else {
                continue;
            };
            let line = lines.entry(order).or_insert_with(|| Line {
                label,
                ..Line::default()
            });
            if (failed || was_lost) && !line.flagged.contains(&x) {
                line.flagged.push(x);
            }
            if failed || (tracking && was_lost) {
                continue;
            }
            let Ok(y) = cells[mc].parse::<f64>() else {
                continue;
            };
            // Keyed by x in fixed point so the map orders the points along x.
            let p = line
                .bins
                .entry((x * 1e9).round() as i64)
                .or_insert((x, 0.0, 0));
            p.1 += y;
            p.2 += 1;
        }
        lines
    }

    /// A run's line (the other keys' value places, and its label) and its x; `None` for
    /// a run whose x is not a value of the axis.
    fn place(&self, cells: &[String]) -> Option<(Vec<usize>, String, f64)> {
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
        x.is_finite().then(|| (order, label.join(" "), x))
    }
}

/// A metric's plot, its lines split over several files when there are more than one plot
/// can show (each saying which lines it holds: no combination is left out); the files.
fn write_parts(
    pdir: &Path,
    metric: &str,
    meaning: &str,
    data: &[LineData],
    x_label: &str,
    flag_label: &str,
) -> Result<Vec<PathBuf>, SweepError> {
    let mut files = vec![];
    let parts = data.len().div_ceil(MAX_SERIES).max(1);
    for part in 0..parts {
        let lo = part * MAX_SERIES;
        let chunk = &data[lo.min(data.len())..(lo + MAX_SERIES).min(data.len())];
        let series: Vec<Series> = chunk
            .iter()
            .enumerate()
            .map(|(i, (label, xs, ys, _))| Series::line(label, xs, ys, COLOURS[i % COLOURS.len()]))
            .collect();
        // Each part marks only its own lines' failed or lost runs: a cross on a part
        // whose lines all kept the wire would say one of them lost it.
        let mut flagged: Vec<f64> = vec![];
        for x in chunk.iter().flat_map(|(.., f)| f) {
            if !flagged.contains(x) {
                flagged.push(*x);
            }
        }
        let flags = (!flagged.is_empty()).then_some(Flags {
            label: flag_label,
            x: &flagged,
            colour: "#c00000",
        });
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A plot split over parts marks on each part only its own lines' lost or failed runs:
    /// a part whose lines all kept the wire has no cross.
    #[test]
    fn each_part_crosses_only_its_own_lines_lost_runs() {
        let dir = std::env::temp_dir().join(format!("agvsim_parts_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let data: Vec<LineData> = (0..12)
            .map(|i| {
                let flagged = if i == 2 { vec![4.0] } else { vec![] };
                (format!("line {i}"), vec![1.0, 4.0], vec![0.0, 0.1], flagged)
            })
            .collect();
        let files = write_parts(&dir, "m", "meaning", &data, "gain", "lost").unwrap();
        let texts: Vec<String> = files
            .iter()
            .map(|f| std::fs::read_to_string(f).unwrap())
            .collect();
        let _ = std::fs::remove_dir_all(&dir);
        assert_eq!(texts.len(), 2);
        assert!(texts[0].contains(">lost<"), "part 1 lost its cross");
        assert!(
            !texts[1].contains(">lost<"),
            "part 2 has a cross of part 1's line"
        );
    }
}
