//! Joining shard folders back into the unsharded sweep: their manifests checked to be
//! slices of one sweep, their rows in run order, the manifest, traces and plots.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::grid::Shard;
use super::results::{csv_text, trace_name, Manifest, Table, RESULTS_FILE, TRACES_DIR};
use super::{io_err, SweepError};

/// Joins shard folders into `out`: checks they are slices of one sweep and cover every
/// run exactly once, writes their rows in run order (as the shards wrote them), the
/// manifest, traces and plots. Returns the merged `results.csv` path.
pub fn merge(shards: &[PathBuf], out: &Path) -> Result<(PathBuf, Vec<PathBuf>), SweepError> {
    let manifests = slices_of_one_sweep(shards, out)?;
    let first = &manifests[0];
    let (header, rows) = rows_in_run_order(shards, &first.grid())?;
    every_run_once(&rows, first.total_runs)?;
    std::fs::create_dir_all(out).map_err(io_err(out))?;
    let csv = csv_text(&header, rows.into_values());
    let path = out.join(RESULTS_FILE);
    crate::output::write_atomically(&path, &csv).map_err(io_err(&path))?;
    let merged = Manifest {
        shard: Shard::WHOLE.to_string(),
        runs: [0, first.total_runs],
        ..first.clone()
    };
    merged.write(out)?;
    if first.traces {
        copy_traces(&manifests, shards, out)?;
    }
    let table = Table::parse(&csv, &path)?;
    let plots = super::plots::write(out, &merged.grid(), &table)?;
    Ok((path, plots))
}

/// The shards' manifests, checked to be slices of one sweep, with `out` none of their
/// folders.
fn slices_of_one_sweep(shards: &[PathBuf], out: &Path) -> Result<Vec<Manifest>, SweepError> {
    if shards.is_empty() {
        return Err(SweepError::Merge("no shard folders given".into()));
    }
    // Merging into a shard's own folder would replace that shard's results.
    let same = |a: &Path, b: &Path| match (a.canonicalize(), b.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => a == b,
    };
    if let Some(d) = shards.iter().find(|d| same(d, out)) {
        return Err(SweepError::Merge(format!(
            "--out {} is one of the shard folders; merging there would replace that shard: give a new folder",
            d.display()
        )));
    }
    let manifests: Vec<Manifest> = shards
        .iter()
        .map(|d| Manifest::read(d))
        .collect::<Result<_, _>>()?;
    let first = &manifests[0];
    for (m, d) in manifests.iter().zip(shards).skip(1) {
        if !first.same_sweep(m) {
            return Err(SweepError::Merge(format!(
                "{} is not a slice of the same sweep as {} (scene text, --set, --vary, --repeat or version differ)",
                d.display(),
                shards[0].display()
            )));
        }
    }
    Ok(manifests)
}

/// A sweep's rows by run: each row's cells.
type Rows = BTreeMap<usize, Vec<String>>;

/// The header and every shard's rows by run, each checked on the grid, its metrics
/// finite and its run given once; an interrupted shard is refused.
fn rows_in_run_order(
    shards: &[PathBuf],
    grid: &super::grid::Grid,
) -> Result<(Vec<String>, Rows), SweepError> {
    let mut rows: Rows = BTreeMap::new();
    let mut header: Option<Vec<String>> = None;
    for d in shards {
        let path = d.join(RESULTS_FILE);
        let partial = super::journal::partial_path(d);
        if !path.is_file() && partial.is_file() {
            let runs = std::fs::read_to_string(&partial)
                .map(|t| t.lines().count().saturating_sub(1))
                .unwrap_or(0);
            return Err(SweepError::Merge(format!(
                "{} holds an interrupted shard ({runs} runs finished, in {}); finish it with its sweep command and --resume",
                d.display(),
                partial.display()
            )));
        }
        let text = crate::output::read_text_bounded(&path, crate::output::MAX_INPUT_BYTES)
            .map_err(io_err(&path))?;
        let table = Table::parse(&text, &path)?;
        match &header {
            None => header = Some(table.header.clone()),
            Some(h) if *h != table.header => {
                return Err(SweepError::Merge(format!(
                    "{}: its columns differ from the first shard's",
                    path.display()
                )))
            }
            _ => {}
        }
        for (run, line, cells) in &table.rows {
            table.check_on_grid(grid, &path, *line, cells)?;
            finite_metrics(&table.header, &path, *line, cells)?;
            if rows.insert(*run, cells.clone()).is_some() {
                return Err(SweepError::Merge(format!(
                    "run {run} appears twice (in {} and an earlier shard); give each shard once",
                    path.display()
                )));
            }
        }
    }
    Ok((header.unwrap_or_default(), rows))
}

/// Every run of the sweep is among the rows.
fn every_run_once(rows: &Rows, total_runs: usize) -> Result<(), SweepError> {
    let missing: Vec<usize> = (0..total_runs).filter(|i| !rows.contains_key(i)).collect();
    if !missing.is_empty() || rows.len() != total_runs {
        let shown: Vec<String> = missing.iter().take(10).map(|i| i.to_string()).collect();
        return Err(SweepError::Merge(format!(
            "{} of {} runs are missing (runs {}{}); is a shard folder left out or unfinished?",
            missing.len(),
            total_runs,
            shown.join(", "),
            if missing.len() > 10 { ", ..." } else { "" }
        )));
    }
    Ok(())
}

/// Each shard's traces into the merged folder's.
fn copy_traces(manifests: &[Manifest], shards: &[PathBuf], out: &Path) -> Result<(), SweepError> {
    let tdir = out.join(TRACES_DIR);
    std::fs::create_dir_all(&tdir).map_err(io_err(&tdir))?;
    for (m, d) in manifests.iter().zip(shards) {
        for i in m.runs[0]..m.runs[1] {
            let from = d.join(TRACES_DIR).join(trace_name(i));
            let to = tdir.join(trace_name(i));
            std::fs::copy(&from, &to).map_err(io_err(&from))?;
        }
    }
    Ok(())
}

/// Every number after a row's `outcome` is finite: a run writes no NaN or infinite
/// metric (a diverged run is an `error:` outcome with empty cells), so one is an edit.
fn finite_metrics(
    header: &[String],
    path: &Path,
    line: usize,
    cells: &[String],
) -> Result<(), SweepError> {
    let Some(from) = header.iter().position(|h| h == "outcome") else {
        return Ok(());
    };
    for (name, cell) in header.iter().zip(cells).skip(from + 1) {
        if let Ok(v) = cell.trim().parse::<f64>() {
            if !v.is_finite() {
                return Err(SweepError::Format {
                    path: path.to_owned(),
                    message: format!(
                        "line {line}: column `{name}`: `{cell}`: expected a finite number or an empty cell (a sweep writes no NaN or infinity; was the file edited?)"
                    ),
                });
            }
        }
    }
    Ok(())
}
