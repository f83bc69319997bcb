//! A MATLAB file (MAT level 5) to a contract recording, by the same map file as a CSV:
//! each map `column` names a variable, a vector (n x 1 or 1 x n) of the record's length.
//! The EMPS benchmark's `DATA_EMPS.mat`, for example:
//!
//! ```toml
//! rig = "drive_axis"
//! time = { column = "t" }
//! [columns]
//! reference_m = { column = "qg" }
//! command_V = { column = "vir" }
//! position_m = { column = "qm" }
//! ```

use std::fmt::Write as _;
use std::path::Path;

use super::csv_map::{self, CsvMap};
use super::ImportError;
use crate::matfile::{self, Data};

/// Converts a MAT-file's bytes by `map` into the exchange format's text.
pub fn convert(
    bytes: &[u8],
    mat_file: &Path,
    map: &CsvMap,
    map_file: &Path,
) -> Result<String, ImportError> {
    let data_err = |line: usize, message: String| ImportError::Data {
        file: mat_file.to_owned(),
        line,
        message,
    };
    let vars = matfile::read(bytes).map_err(|e| data_err(0, e.to_string()))?;
    let wanted: Vec<&str> = std::iter::once(map.time.column.as_str())
        .chain(map.columns.values().map(|c| c.column.as_str()))
        .collect();
    let mut names: Vec<&str> = Vec::new();
    let mut cols: Vec<&[f64]> = Vec::new();
    for w in wanted {
        if names.contains(&w) {
            continue;
        }
        let Some(v) = vars.iter().find(|v| v.name == w) else {
            let have: Vec<String> = vars
                .iter()
                .map(|v| format!("{} {:?}", v.name, v.dims))
                .collect();
            return Err(ImportError::Map {
                file: map_file.to_owned(),
                message: format!(
                    "variable `{w}` is not in {} (its variables: {})",
                    mat_file.display(),
                    have.join(", ")
                ),
            });
        };
        let Data::Numeric(values) = &v.data else {
            return Err(data_err(
                0,
                format!(
                    "variable `{w}` is not a real numeric array ({:?})",
                    v.data_kind()
                ),
            ));
        };
        if v.dims.iter().filter(|d| **d > 1).count() > 1 {
            return Err(data_err(
                0,
                format!(
                    "variable `{w}` is a {:?} matrix; a column needs a vector (n x 1 or 1 x n)",
                    v.dims
                ),
            ));
        }
        if let Some(first) = cols.first().filter(|c| c.len() != values.len()) {
            return Err(data_err(0, format!("variable `{w}` has {} values, `{}` has {}: columns of one record have one length", values.len(), names[0], first.len())));
        }
        names.push(w);
        cols.push(values);
    }
    // The variables as a CSV table (shortest round-trip decimals: the values survive
    // exactly), converted by the CSV path so that both formats follow one set of rules.
    let mut table = names.join(",");
    table.push('\n');
    for k in 0..cols[0].len() {
        let row: Vec<String> = cols
            .iter()
            .map(|c| {
                if c[k].is_nan() {
                    "NaN".into()
                } else {
                    format!("{}", c[k])
                }
            })
            .collect();
        let _ = writeln!(table, "{}", row.join(","));
    }
    csv_map::convert(&table, mat_file, map, map_file).map_err(|e| match e {
        // A table line is a MAT row (the header is line 1).
        ImportError::Data {
            file,
            line,
            message,
        } => ImportError::Data {
            file,
            line: 0,
            message: format!("row {}: {message}", line.saturating_sub(1)),
        },
        other => other,
    })
}

impl matfile::Variable {
    /// MATLAB's word for what the variable holds.
    pub fn data_kind(&self) -> &'static str {
        match &self.data {
            Data::Numeric(_) => "numeric",
            Data::Text(_) => "char",
            Data::Texts(_) => "cell of char",
            Data::Other(c) => c,
        }
    }
}
