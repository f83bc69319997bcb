//! Recordings in the exchange format, read by the contract's reader and written so that
//! what is written always loads: the columns cross to Python as little-endian f64 bytes.

use std::path::PathBuf;

use pyo3::prelude::*;
use pyo3::types::PyBytes;

use crate::{bad_argument, to_py, InputError};

/// A recording as the library reads it: its rig, metadata (in the file's order), column
/// names (without `t_s`), time and columns as little-endian f64 bytes (an empty cell is
/// NaN), and the rows where each joined segment starts.
type RecordingParts = (
    String,
    Vec<(String, String)>,
    Vec<String>,
    Py<PyBytes>,
    Vec<Py<PyBytes>>,
    Vec<usize>,
);

/// Little-endian f64 bytes, for `numpy.frombuffer`.
pub(crate) fn f64_bytes<'py>(py: Python<'py>, values: impl Iterator<Item = f64>) -> Py<PyBytes> {
    let bytes: Vec<u8> = values.flat_map(f64::to_le_bytes).collect();
    PyBytes::new(py, &bytes).unbind()
}

/// Reads a recording in the exchange format (the contract's reader, every check it makes).
#[pyfunction]
pub fn read_recording(py: Python<'_>, path: PathBuf) -> PyResult<RecordingParts> {
    let rec = py
        .allow_threads(|| agvsim::record::Recording::load(&path))
        .map_err(|e| to_py((e.to_string(), 2)))?;
    let columns = rec
        .columns
        .iter()
        .map(|c| f64_bytes(py, c.iter().map(|v| v.unwrap_or(f64::NAN))))
        .collect();
    Ok((
        rec.rig.as_str().to_string(),
        rec.meta
            .iter()
            .map(|(k, v)| (k.clone(), v.clone()))
            .collect(),
        rec.names.clone(),
        f64_bytes(py, rec.t_s.iter().copied()),
        columns,
        rec.segment_starts.clone(),
    ))
}

/// One cell as the exchange format writes it: the shortest decimal that reads back as the
/// same f64 (no exponent), empty for a value that was not measured (NaN).
fn cell(v: f64) -> String {
    if v.is_nan() {
        String::new()
    } else {
        format!("{v}")
    }
}

/// Writes a recording in the exchange format; the text is read back by the contract's
/// reader before it is written (so what is written always loads), and it is written under
/// a temporary name and renamed (never half-written).
#[pyfunction]
pub fn write_recording(
    py: Python<'_>,
    path: PathBuf,
    rig: String,
    meta: Vec<(String, String)>,
    names: Vec<String>,
    t_s: Vec<f64>,
    columns: Vec<Vec<f64>>,
) -> PyResult<()> {
    use std::fmt::Write as _;
    if columns.len() != names.len() {
        return Err(bad_argument(
            "columns",
            columns.len(),
            &format!("one column per name ({} names)", names.len()),
        ));
    }
    if let Some((name, c)) = names
        .iter()
        .zip(&columns)
        .find(|(_, c)| c.len() != t_s.len())
    {
        return Err(InputError::new_err(format!(
            "column {name}: {} values, expected one per time ({})",
            c.len(),
            t_s.len()
        )));
    }
    let kind = agvsim::rig::RigKind::from_name(&rig).ok_or_else(|| {
        bad_argument(
            "rig",
            &rig,
            &format!("one of {}", agvsim::rig::RigKind::names()),
        )
    })?;
    py.allow_threads(|| {
        let meta: Vec<(&str, String)> = meta.iter().map(|(k, v)| (k.as_str(), v.clone())).collect();
        let header_names: Vec<&str> = std::iter::once("t_s")
            .chain(names.iter().map(String::as_str))
            .collect();
        let mut text = agvsim::record::header(kind, &meta, &header_names);
        for (row, t) in t_s.iter().enumerate() {
            text.push_str(&cell(*t));
            for c in &columns {
                let _ = write!(text, ",{}", cell(c[row]));
            }
            text.push('\n');
        }
        agvsim::record::Recording::parse(&text, &path).map_err(|e| (e.to_string(), 2))?;
        agvsim::output::write_atomically(&path, text.as_bytes())
            .map_err(|e| (format!("{}: {e}", path.display()), 1))
    })
    .map_err(to_py)
}
