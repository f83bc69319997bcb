//! Plots of each metric against a varied value (SVG), one line per combination of the
//! other varied values, means over repeats.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::grid::Grid;
use super::results::{Table, METRICS};
use super::{io_err, SweepError};
use crate::ident::plot::{svg, Series};

/// Line colours of the sweep and study plots, in order.
pub const COLOURS: [&str; 10] = [
    "#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
    "#bcbd22", "#17becf",
];

/// Most lines on one plot; more would be unreadable (the CSV has them all).
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
    let xi = x_key(grid);
    let xv = &grid.varies[xi];
    let numeric_x = xv.values.iter().all(|x| x.parse::<f64>().is_ok());
    let x_of = |s: &str| -> f64 {
        if numeric_x {
            s.parse().unwrap_or(f64::NAN)
        } else {
            xv.values
                .iter()
                .position(|v| v == s)
                .map(|i| i as f64)
                .unwrap_or(f64::NAN)
        }
    };
    let outcome = table.column("outcome");
    let key_cols: Vec<Option<usize>> = grid.varies.iter().map(|v| table.column(&v.key)).collect();
    let mut files = vec![];
    for (metric, meaning) in METRICS.iter().filter(|(m, _)| *m != "faults") {
        let Some(mc) = table.column(metric) else {
            continue;
        };
        // series label -> x -> (sum, count)
        let mut lines: BTreeMap<Vec<usize>, (String, BTreeMap<i64, (f64, f64, usize)>)> =
            BTreeMap::new();
        for (_, _, cells) in &table.rows {
            if outcome.map(|c| cells[c] != "ok").unwrap_or(false) {
                continue;
            }
            let Ok(y) = cells[mc].parse::<f64>() else {
                continue;
            };
            let mut order = vec![];
            let mut label = vec![];
            let mut x = f64::NAN;
            for (k, (v, col)) in grid.varies.iter().zip(&key_cols).enumerate() {
                let Some(col) = col else { continue };
                let val = &cells[*col];
                if k == xi {
                    x = x_of(val);
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
        if lines.is_empty() {
            continue;
        }
        let data: Vec<(String, Vec<f64>, Vec<f64>)> = lines
            .into_values()
            .take(MAX_SERIES)
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
        let series: Vec<Series> = data
            .iter()
            .enumerate()
            .map(|(i, (label, xs, ys))| Series {
                label,
                x: xs,
                y: ys,
                colour: COLOURS[i % COLOURS.len()],
                stems: false,
            })
            .collect();
        let x_label = if numeric_x {
            xv.key.clone()
        } else {
            format!("{} ({})", xv.key, xv.values.join(", "))
        };
        let text = svg(meaning, &x_label, metric, &series, None);
        let path = pdir.join(format!("{metric}.svg"));
        std::fs::write(&path, text).map_err(io_err(&path))?;
        files.push(path);
    }
    Ok(files)
}

/// `tyre.compound` -> `compound`: legends stay short.
fn short_key(key: &str) -> &str {
    key.rsplit('.').next().unwrap_or(key)
}
