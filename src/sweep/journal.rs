//! The results file while a sweep runs: rows are appended to `results.csv.partial` in run
//! order as soon as every earlier run has finished, and flushed, so that a sweep killed
//! at any moment leaves a valid prefix of its results. `--resume` reads that prefix back
//! (checking every row against the grid) and runs the rest; the file is renamed to
//! `results.csv` when the last row is in.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::Write;
use std::ops::Range;
use std::path::{Path, PathBuf};

use super::grid::Grid;
use super::results::{self, Table};
use super::run::RunResult;
use super::{io_err, SweepError};

/// The in-progress results of a sweep folder.
pub fn partial_path(dir: &Path) -> PathBuf {
    crate::output::partial_name(&dir.join(results::RESULTS_FILE))
}

/// Rows waiting for their predecessors, and the file the finished prefix is in.
pub struct Journal {
    path: PathBuf,
    file: File,
    /// The next run number the file expects.
    next: usize,
    /// Finished runs that wait for an earlier one, by run number.
    waiting: BTreeMap<usize, Vec<String>>,
}

impl Journal {
    /// Starts a new results file (the header only) for the grid.
    pub fn create(dir: &Path, grid: &Grid, first_run: usize) -> Result<Journal, SweepError> {
        let path = partial_path(dir);
        let mut file = File::create(&path).map_err(io_err(&path))?;
        file.write_all(results::csv_text(&results::header(grid), std::iter::empty()).as_bytes())
            .map_err(io_err(&path))?;
        Ok(Journal {
            path,
            file,
            next: first_run,
            waiting: BTreeMap::new(),
        })
    }

    /// Continues a results file whose valid prefix ends before run `next`.
    pub fn append(dir: &Path, next: usize) -> Result<Journal, SweepError> {
        let path = partial_path(dir);
        let file = std::fs::OpenOptions::new()
            .append(true)
            .open(&path)
            .map_err(io_err(&path))?;
        Ok(Journal {
            path,
            file,
            next,
            waiting: BTreeMap::new(),
        })
    }

    /// Takes a finished run; writes (and flushes) every row now in sequence.
    pub fn push(&mut self, run: &RunResult) -> Result<(), SweepError> {
        self.waiting
            .insert(run.point.index, results::row_cells(run));
        let mut text = vec![];
        while let Some(cells) = self.waiting.remove(&self.next) {
            text.extend_from_slice(results::csv_row(&cells).as_bytes());
            self.next += 1;
        }
        if !text.is_empty() {
            self.file.write_all(&text).map_err(io_err(&self.path))?;
            self.file.flush().map_err(io_err(&self.path))?;
        }
        Ok(())
    }

    /// Runs written so far end before this run number.
    pub fn next(&self) -> usize {
        self.next
    }

    /// Renames the complete file to `results.csv`, returning its path.
    pub fn finish(self) -> Result<PathBuf, SweepError> {
        self.file.sync_all().map_err(io_err(&self.path))?;
        let done = self.path.with_file_name(results::RESULTS_FILE);
        std::fs::rename(&self.path, &done).map_err(io_err(&done))?;
        Ok(done)
    }
}

/// Reads the valid prefix an interrupted sweep left in `dir`: rows for runs
/// `range.start..`, consecutive, each on the grid. A last line cut short by the kill is
/// dropped (and the file truncated to the prefix). Returns the number of runs finished.
pub fn read_prefix(dir: &Path, grid: &Grid, range: &Range<usize>) -> Result<usize, SweepError> {
    let path = partial_path(dir);
    let mut text = std::fs::read_to_string(&path).map_err(io_err(&path))?;
    // A row is complete once its newline is written; anything after the last newline is a
    // row the kill cut short.
    let complete = text.rfind('\n').map_or(0, |i| i + 1);
    if complete < text.len() {
        text.truncate(complete);
        crate::output::write_atomically(&path, &text).map_err(io_err(&path))?;
    }
    if text.is_empty() {
        return Err(SweepError::Format {
            path,
            message: "empty: the sweep was stopped before it wrote its header; start it again without --resume".into(),
        });
    }
    let table = Table::parse(&text, &path)?;
    if table.header != results::header(grid) {
        return Err(SweepError::Format {
            path,
            message: "its columns are not this sweep's; start it again without --resume".into(),
        });
    }
    for (k, (run, line, cells)) in table.rows.iter().enumerate() {
        if *run != range.start + k {
            return Err(SweepError::Format {
                path: path.clone(),
                message: format!(
                    "line {line}: run {run} where run {} was expected (the rows are written in run order); start the sweep again without --resume",
                    range.start + k
                ),
            });
        }
        table
            .check_on_grid(grid, &path, *line, cells)
            .map_err(|e| SweepError::Format {
                path: path.clone(),
                message: e.to_string(),
            })?;
    }
    if range.start + table.rows.len() > range.end {
        return Err(SweepError::Format {
            path,
            message: format!(
                "{} rows where this sweep has {} runs",
                table.rows.len(),
                range.len()
            ),
        });
    }
    Ok(table.rows.len())
}
