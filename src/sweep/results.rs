//! The sweep's files: `results.csv` (one row per run), `sweep.toml` (what was swept, so
//! that shards can be checked before they are merged) and `traces/`.

use std::fmt::Write as _;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::grid::{Grid, Vary};
use super::run::{RunResult, SweepOptions};
use super::{io_err, SweepError};
use crate::sim::metrics::RunSummary;

/// The results table's file name.
pub const RESULTS_FILE: &str = "results.csv";
/// The manifest's file name.
pub const MANIFEST_FILE: &str = "sweep.toml";
/// The traces' folder name.
pub const TRACES_DIR: &str = "traces";

/// Printed with a merge: what was checked.
pub const MERGE_NOTE: &str =
    "shards checked: same scene text, overrides, grid and repeats; every run exactly once";

/// The metric columns of `results.csv`, after the run's identity columns, with what each
/// means (also the plot titles).
pub const METRICS: [(&str, &str); 18] = [
    (
        "rms_lateral_error_m",
        "RMS lateral error over error_window, m",
    ),
    (
        "peak_lateral_error_m",
        "peak |lateral error| over error_window, m",
    ),
    (
        "error_window",
        "what the RMS and peak cover: after_settling, until_wire_lost, until_wire_end or whole_run",
    ),
    (
        "settling_distance_m",
        "distance travelled before the error stays within 10 mm, m",
    ),
    (
        "limit_cycle_amplitude_m",
        "limit-cycle amplitude (half peak-to-peak; 0: none; empty: the window too short to tell), m",
    ),
    ("limit_cycle_period_s", "limit-cycle period, s"),
    (
        "peak_slip_ratio",
        "peak |slip ratio| of the drive tyres over slip_window",
    ),
    (
        "mean_slip_ratio",
        "time-mean |slip ratio| of the drive tyres over slip_window",
    ),
    (
        "sliding_fraction",
        "share of slip_window in which a drive tyre slides beyond its peak",
    ),
    (
        "slip_window",
        "what the slip figures cover: second_half, second_half_until_wire_lost or second_half_until_wire_end",
    ),
    ("battery_energy_J", "energy drawn from the battery, J"),
    (
        "castor_shimmy_rad_s",
        "castor shimmy: RMS swivel rate over the second half, rad/s",
    ),
    ("distance_m", "distance travelled, m"),
    ("final_lateral_error_m", "lateral error at the end, m"),
    ("lost_wire", "the sensors lost the wire (1) or not (0)"),
    (
        "wire_lost_t_s",
        "time the sensors first lost the wire, s (empty: never)",
    ),
    (
        "wire_end_t_s",
        "time the axle passed the far end of the wire, s (empty: never)",
    ),
    ("faults", "DCMC faults and bumper stops"),
];

/// Numbers as short, exact-enough text: nine significant digits.
fn num(v: f64) -> String {
    if !v.is_finite() {
        return String::new();
    }
    let r: f64 = format!("{v:.8e}").parse().unwrap_or(v);
    format!("{r}")
}

/// The limit-cycle amplitude: 0 where the window shows none, empty where it is too short
/// to tell (a swing with fewer than two periods in the window is not "no cycle").
fn cycle_amplitude_cell(s: &RunSummary) -> String {
    use crate::sim::metrics::NoCycleReason;
    match (s.limit_cycle, s.no_cycle) {
        (Some(c), _) => num(c.amplitude_m),
        (None, Some(n)) if n.reason == NoCycleReason::TooShort => String::new(),
        _ => num(0.0),
    }
}

fn metric_cells(s: &RunSummary) -> Vec<String> {
    let mut faults = s.faults.clone();
    if s.bumper_stop {
        faults.push("bumper_stop".into());
    }
    vec![
        num(s.rms_lateral_error_m),
        num(s.peak_lateral_error_m),
        s.error_window.name().to_string(),
        s.settling_distance_m.map(num).unwrap_or_default(),
        cycle_amplitude_cell(s),
        s.limit_cycle.map(|c| num(c.period_s)).unwrap_or_default(),
        num(s.peak_abs_slip_ratio),
        num(s.mean_abs_slip_ratio),
        num(s.sliding_fraction),
        s.slip_window.name().to_string(),
        num(s.battery_energy_j),
        num(s.castor_shimmy_rad_s),
        num(s.distance_m),
        num(s.final_lateral_error_m),
        (s.lost_wire as u8).to_string(),
        s.wire_lost.map(|e| num(e.t_s)).unwrap_or_default(),
        s.wire_end.map(|e| num(e.t_s)).unwrap_or_default(),
        faults.join(" "),
    ]
}

/// The header of `results.csv` for a grid.
pub fn header(grid: &Grid) -> Vec<String> {
    let mut h = vec!["run".to_string()];
    h.extend(grid.varies.iter().map(|v| v.key.clone()));
    h.extend(["repeat", "seed", "outcome"].map(String::from));
    h.extend(METRICS.iter().map(|(c, _)| c.to_string()));
    h
}

/// CSV text of a header and rows (fields quoted where they need it).
pub fn csv_text(header: &[String], rows: impl IntoIterator<Item = Vec<String>>) -> String {
    let mut w = csv::WriterBuilder::new().from_writer(vec![]);
    // Writing to memory cannot fail.
    let _ = w.write_record(header);
    for r in rows {
        let _ = w.write_record(&r);
    }
    String::from_utf8(w.into_inner().unwrap_or_default()).unwrap_or_default()
}

/// A run's row of `results.csv`: its number, varied values, repeat, seed, outcome and
/// metrics (empty when it failed).
pub fn row_cells(r: &RunResult) -> Vec<String> {
    let mut cells = vec![r.point.index.to_string()];
    cells.extend(r.point.values.iter().cloned());
    cells.push(r.point.repeat.to_string());
    cells.push(r.point.seed.to_string());
    match &r.outcome {
        Ok(s) => {
            cells.push("ok".into());
            cells.extend(metric_cells(s));
        }
        Err(e) => {
            cells.push(format!("error: {e}"));
            cells.extend(std::iter::repeat_n(String::new(), METRICS.len()));
        }
    }
    cells
}

/// One row as CSV text, with its newline (fields quoted where they need it).
pub fn csv_row(cells: &[String]) -> String {
    let mut w = csv::WriterBuilder::new().from_writer(vec![]);
    // Writing to memory cannot fail.
    let _ = w.write_record(cells);
    String::from_utf8(w.into_inner().unwrap_or_default()).unwrap_or_default()
}

/// `results.csv` text: the header, then one row per run in grid order.
pub fn results_csv(grid: &Grid, results: &[RunResult]) -> String {
    csv_text(&header(grid), results.iter().map(row_cells))
}

/// Writes `traces/run_NNNNN.csv` for each run that has a trace.
pub fn write_traces(dir: &Path, results: &[RunResult]) -> Result<(), SweepError> {
    for r in results {
        write_trace(dir, r)?;
    }
    Ok(())
}

/// Writes the run's `traces/run_NNNNN.csv` (whole or not at all) if it has a trace.
pub fn write_trace(dir: &Path, r: &RunResult) -> Result<(), SweepError> {
    let Some(t) = &r.trace else { return Ok(()) };
    let tdir = dir.join(TRACES_DIR);
    std::fs::create_dir_all(&tdir).map_err(io_err(&tdir))?;
    let mut s = String::from("t_s,distance_m,x_m,y_m,lateral_error_m\n");
    for i in 0..t.t_s.len() {
        let _ = writeln!(
            s,
            "{},{},{},{},{}",
            num(t.t_s[i]),
            num(t.distance_m[i]),
            num(t.x_m[i]),
            num(t.y_m[i]),
            num(t.lateral_error_m[i])
        );
    }
    let path = tdir.join(trace_name(r.point.index));
    crate::output::write_atomically(&path, s).map_err(io_err(&path))
}

/// A run's trace file name.
pub fn trace_name(index: usize) -> String {
    format!("run_{index:05}.csv")
}

/// A parsed `results.csv`: the header and the rows' cells, kept as text so that a merge
/// writes back exactly what the shards wrote.
#[derive(Debug, Clone)]
pub struct Table {
    /// The column names.
    pub header: Vec<String>,
    /// (run number, file line of the row, cells).
    pub rows: Vec<(usize, usize, Vec<String>)>,
}

impl Table {
    /// Reads a results table, checking its columns and run numbers.
    pub fn parse(text: &str, path: &Path) -> Result<Table, SweepError> {
        let bad = |line: u64, message: String| SweepError::Format {
            path: path.to_owned(),
            message: format!("line {line}: {message}"),
        };
        let mut reader = csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(true)
            .from_reader(text.as_bytes());
        let mut records = reader.records();
        let header: Vec<String> = match records.next() {
            Some(Ok(r)) => r.iter().map(String::from).collect(),
            Some(Err(e)) => return Err(bad(1, e.to_string())),
            None => return Err(bad(1, "empty file; expected the header `run,...`".into())),
        };
        if header.first().map(String::as_str) != Some("run") {
            return Err(bad(1, "expected a header starting with `run`".into()));
        }
        let mut rows = vec![];
        for r in records {
            let r = r.map_err(|e| bad(e.position().map_or(0, |p| p.line()), e.to_string()))?;
            let line = r.position().map_or(0, |p| p.line());
            let cells: Vec<String> = r.iter().map(String::from).collect();
            if cells.len() == 1 && cells[0].is_empty() {
                continue;
            }
            if cells.len() != header.len() {
                return Err(bad(
                    line,
                    format!(
                        "{} cells where the header has {}",
                        cells.len(),
                        header.len()
                    ),
                ));
            }
            let run: usize = cells[0]
                .parse()
                .map_err(|_| bad(line, format!("`{}`: expected a run number", cells[0])))?;
            rows.push((run, line as usize, cells));
        }
        Ok(Table { header, rows })
    }

    /// A column's place by name.
    pub fn column(&self, name: &str) -> Option<usize> {
        self.header.iter().position(|h| h == name)
    }

    /// Checks a row's identity cells (varied values, repeat, seed) against the run the
    /// grid has at its number: a row edited or from another sweep is named.
    pub fn check_on_grid(
        &self,
        grid: &Grid,
        path: &Path,
        line: usize,
        cells: &[String],
    ) -> Result<(), SweepError> {
        let run: usize = cells[0].parse().unwrap_or(usize::MAX);
        if run >= grid.total() {
            return Err(SweepError::Merge(format!(
                "{} line {line}: run {run} is not in the sweep's grid of {} runs",
                path.display(),
                grid.total()
            )));
        }
        let p = grid.point(run);
        let mut expected: Vec<(String, String)> = grid
            .varies
            .iter()
            .zip(&p.values)
            .map(|(v, x)| (v.key.clone(), x.clone()))
            .collect();
        expected.push(("repeat".into(), p.repeat.to_string()));
        expected.push(("seed".into(), p.seed.to_string()));
        for (col, want) in expected {
            let got = self.column(&col).map(|c| cells[c].as_str());
            if got != Some(want.as_str()) {
                return Err(SweepError::Merge(format!(
                    "{} line {line}: run {run} has {col} = `{}` where the sweep's grid has `{want}`; the row was edited or comes from another sweep",
                    path.display(),
                    got.unwrap_or("(no such column)")
                )));
            }
        }
        Ok(())
    }
}

/// `sweep.toml`: what a sweep folder holds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// The agvsim version that wrote it.
    pub agvsim_version: String,
    /// The scene file.
    pub scene: String,
    /// FNV-1a hash of the scene text (hex): shards of different scenes are not merged.
    pub scene_hash: String,
    /// The `--set` overrides.
    pub set: Vec<String>,
    /// Runs per grid point.
    pub repeat: usize,
    /// Noise seed of the first repeat.
    pub base_seed: u64,
    /// Runs of the whole sweep.
    pub total_runs: usize,
    /// `I/N`.
    pub shard: String,
    /// Run numbers `[first, end)` in this folder.
    pub runs: [usize; 2],
    /// Whether traces were written.
    pub traces: bool,
    /// The varied keys and values.
    pub vary: Vec<ManifestVary>,
}

/// One varied key in a manifest.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ManifestVary {
    /// The dotted key.
    pub key: String,
    /// Its values.
    pub values: Vec<String>,
}

fn fnv1a(text: &str) -> String {
    let mut h: u64 = 0xcbf29ce484222325;
    for b in text.bytes() {
        h ^= b as u64;
        h = h.wrapping_mul(0x100000001b3);
    }
    format!("{h:016x}")
}

impl Manifest {
    /// The manifest of a sweep's options.
    pub fn of(opts: &SweepOptions) -> Manifest {
        let total = opts.grid.total();
        let r = opts.shard.range(total);
        Manifest {
            agvsim_version: env!("CARGO_PKG_VERSION").into(),
            scene: opts.scene_path.display().to_string(),
            scene_hash: fnv1a(&opts.scene_text),
            set: opts.set.clone(),
            repeat: opts.grid.repeat,
            base_seed: opts.grid.base_seed,
            total_runs: total,
            shard: opts.shard.to_string(),
            runs: [r.start, r.end],
            traces: opts.traces,
            vary: opts
                .grid
                .varies
                .iter()
                .map(|v| ManifestVary {
                    key: v.key.clone(),
                    values: v.values.clone(),
                })
                .collect(),
        }
    }

    /// The grid it describes.
    pub fn grid(&self) -> Grid {
        Grid {
            varies: self
                .vary
                .iter()
                .map(|v| Vary {
                    key: v.key.clone(),
                    values: v.values.clone(),
                })
                .collect(),
            repeat: self.repeat,
            base_seed: self.base_seed,
        }
    }

    /// Writes `sweep.toml` into `dir`.
    pub fn write(&self, dir: &Path) -> Result<(), SweepError> {
        let path = dir.join(MANIFEST_FILE);
        let text = toml::to_string(self).map_err(|e| SweepError::Format {
            path: path.clone(),
            message: e.to_string(),
        })?;
        crate::output::write_atomically(&path, text).map_err(io_err(&path))
    }

    /// Reads `sweep.toml` from `dir`.
    pub fn read(dir: &Path) -> Result<Manifest, SweepError> {
        let path = dir.join(MANIFEST_FILE);
        let text = std::fs::read_to_string(&path).map_err(io_err(&path))?;
        toml::from_str(&text).map_err(|e| SweepError::Format {
            path: path.clone(),
            message: format!("not a sweep manifest: {}", e.message()),
        })
    }

    /// The same sweep, whatever the slice.
    pub(super) fn same_sweep(&self, other: &Manifest) -> bool {
        let strip = |m: &Manifest| Manifest {
            shard: String::new(),
            runs: [0, 0],
            scene: String::new(),
            ..m.clone()
        };
        strip(self) == strip(other)
    }
}
