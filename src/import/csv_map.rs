//! Any CSV to a contract recording, by a map file that names, for the time and each
//! contract column, the source column and how to convert it:
//!
//! ```toml
//! rig = "drive_axis"                                 # the contract rig of the recording
//! description = "bench run, 2026-11-02"              # optional
//! time = { column = "time_ms", unit = "ms" }         # becomes t_s
//! [columns]
//! voltage_V = { column = "volts" }                   # already in the contract's unit
//! motor_speed_rad_s = { column = "vel_rpm", unit = "rpm" }
//! current_A = { column = "amps_x10", scale = 0.1 }   # or any factor (and offset)
//! ```
//!
//! Every conversion is stated in the recording's header. Rows with repeated or backwards
//! time stamps, cells that are not numbers (NaN included) and units the map does not know
//! are reported with their line and column, never fixed silently; an empty cell stays
//! empty (a missing sample, as the contract says).

use crate::record::channels as chan;
use crate::rig::RigKind;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use serde::Deserialize;

use super::ImportError;

/// How one source column becomes a contract column: `value x scale + offset`, with the
/// scale given directly or by a unit name.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ColumnMap {
    /// The column's name in the source file's header.
    pub column: String,
    /// The source unit (`rpm`, `deg`, `ms`, `mm`, ...), converted to the contract's unit.
    pub unit: Option<String>,
    /// A factor to the contract's unit (instead of `unit`).
    pub scale: Option<f64>,
    /// Added after scaling, in the contract's unit.
    #[serde(default)]
    pub offset: f64,
}

/// A map file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CsvMap {
    /// The recording's rig kind.
    pub rig: String,
    /// A description for the recording's metadata.
    #[serde(default)]
    pub description: String,
    /// The time column.
    pub time: ColumnMap,
    /// Contract column name -> source.
    pub columns: BTreeMap<String, ColumnMap>,
}

/// Source units and their factor to the contract unit each converts to.
pub const UNITS: [(&str, f64, &str); 14] = [
    ("s", 1.0, "s"),
    ("ms", 1e-3, "s"),
    ("us", 1e-6, "s"),
    ("rpm", std::f64::consts::TAU / 60.0, "rad_s"),
    ("rad_s", 1.0, "rad_s"),
    ("deg_s", std::f64::consts::PI / 180.0, "rad_s"),
    ("deg", std::f64::consts::PI / 180.0, "rad"),
    ("rev", std::f64::consts::TAU, "rad"),
    ("mm", 1e-3, "m"),
    ("cm", 1e-2, "m"),
    ("mm_s", 1e-3, "m_s"),
    ("mV", 1e-3, "V"),
    ("mA", 1e-3, "A"),
    ("mNm", 1e-3, "Nm"),
];

/// The factor of a column map, checked against the contract column's unit suffix.
fn factor(target: &str, m: &ColumnMap, map_file: &Path) -> Result<(f64, String), ImportError> {
    let bad = |message: String| ImportError::Map {
        file: map_file.to_owned(),
        message,
    };
    match (&m.unit, m.scale) {
        (Some(_), Some(_)) => Err(bad(format!("`{target}`: give `unit` or `scale`, not both"))),
        (None, Some(s)) if s.is_finite() && s != 0.0 => Ok((s, format!("x {s}"))),
        (None, Some(s)) => Err(bad(format!(
            "`{target}`: scale = {s}: expected a finite, non-zero factor"
        ))),
        (None, None) => Ok((1.0, "as is".into())),
        (Some(u), None) => {
            let Some((_, f, to)) = UNITS.iter().find(|(n, _, _)| n == u) else {
                let known: Vec<&str> = UNITS.iter().map(|u| u.0).collect();
                return Err(bad(format!(
                    "`{target}`: unit `{u}` is not one agvsim converts; known: {} (or give `scale`)",
                    known.join(", ")
                )));
            };
            if !(target.ends_with(&format!("_{to}")) || target == chan::T_S && *to == "s") {
                return Err(bad(format!(
                    "`{target}`: unit `{u}` converts to {to}, but the column's unit is another"
                )));
            }
            Ok((*f, format!("{u} -> {to} (x {f})")))
        }
    }
}

impl CsvMap {
    /// The rig kind the map names: a drive axis or a vehicle (a map converts one table).
    pub fn kind(&self, map_file: &Path) -> Result<RigKind, ImportError> {
        match RigKind::from_name(&self.rig) {
            Some(k @ (RigKind::DriveAxis | RigKind::Vehicle)) => Ok(k),
            _ => Err(ImportError::Map {
                file: map_file.to_owned(),
                message: format!(
                    "rig = \"{}\": expected \"drive_axis\" or \"vehicle\"",
                    self.rig
                ),
            }),
        }
    }
}

/// Reads a map file.
pub fn load_map(path: &Path) -> Result<CsvMap, ImportError> {
    let text = crate::output::read_text_bounded(path, crate::output::MAX_INPUT_BYTES).map_err(
        |source| ImportError::Read {
            file: path.to_owned(),
            source,
        },
    )?;
    let map: CsvMap = toml::from_str(&text).map_err(|e| ImportError::Map {
        file: path.to_owned(),
        message: e.to_string().trim_end().to_string(),
    })?;
    map.kind(path)?;
    if map.columns.is_empty() {
        return Err(ImportError::Map {
            file: path.to_owned(),
            message: "[columns] is empty: name at least one contract column".into(),
        });
    }
    if map.columns.contains_key(chan::T_S) {
        return Err(ImportError::Map {
            file: path.to_owned(),
            message: "[columns] names `t_s`: the time is the map's `time = { column = \"...\", unit = \"...\" }` line, not a column of [columns]".into(),
        });
    }
    Ok(map)
}

/// Converts `data` (CSV text, with a header) by `map` into the exchange format's text.
pub fn convert(
    data: &str,
    data_file: &Path,
    map: &CsvMap,
    map_file: &Path,
) -> Result<String, ImportError> {
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(true)
        .trim(csv::Trim::All)
        .from_reader(data.trim_start_matches('\u{feff}').as_bytes());
    let header: Vec<String> = reader
        .headers()
        .map_err(|e| ImportError::Data {
            file: data_file.to_owned(),
            line: 1,
            message: e.to_string(),
        })?
        .iter()
        .map(String::from)
        .collect();
    let plan = plan_of(&header, map, map_file, data_file)?;
    let meta = meta_of(&header, &plan, map, map_file, data_file);
    let names: Vec<&str> = plan.iter().map(|p| p.0.as_str()).collect();
    let mut out = crate::record::header(map.kind(map_file)?, &meta, &names);
    let mut last_t: Option<f64> = None;
    for rec in reader.records() {
        let rec = rec.map_err(|e| ImportError::Data {
            file: data_file.to_owned(),
            line: e.position().map_or(0, |p| p.line() as usize),
            message: e.to_string(),
        })?;
        let line = rec.position().map_or(0, |p| p.line() as usize);
        let cells = converted_row(&rec, &plan, &header, &mut last_t, (data_file, line))?;
        let _ = writeln!(out, "{}", cells.join(","));
    }
    if last_t.is_none() {
        return Err(ImportError::Data {
            file: data_file.to_owned(),
            line: 2,
            message: "no data rows".into(),
        });
    }
    Ok(out)
}

/// One converted column: its contract name, its source column's place, the factor and
/// how it converts, the offset.
type Planned = (String, usize, (f64, String), f64);

/// Each contract column's source column, factor and offset, time first.
fn plan_of(
    header: &[String],
    map: &CsvMap,
    map_file: &Path,
    data_file: &Path,
) -> Result<Vec<Planned>, ImportError> {
    let index = |m: &ColumnMap| {
        header
            .iter()
            .position(|h| *h == m.column)
            .ok_or_else(|| ImportError::Map {
                file: map_file.to_owned(),
                message: format!(
                    "column `{}` is not in {} (its columns: {})",
                    m.column,
                    data_file.display(),
                    header.join(", ")
                ),
            })
    };
    let mut plan = vec![(
        chan::T_S.to_string(),
        index(&map.time)?,
        factor(chan::T_S, &map.time, map_file)?,
        map.time.offset,
    )];
    for (target, m) in &map.columns {
        plan.push((
            target.clone(),
            index(m)?,
            factor(target, m, map_file)?,
            m.offset,
        ));
    }
    Ok(plan)
}

/// The recording's metadata: the description, the source and each column's conversion.
fn meta_of(
    header: &[String],
    plan: &[Planned],
    map: &CsvMap,
    map_file: &Path,
    data_file: &Path,
) -> Vec<(&'static str, String)> {
    let mut meta = Vec::new();
    if !map.description.is_empty() {
        meta.push(("description", map.description.clone()));
    }
    meta.push((
        "source",
        format!(
            "{} imported by agvsim with {}",
            data_file.display(),
            map_file.display()
        ),
    ));
    for (target, col, (_, how), offset) in plan {
        let off = if *offset != 0.0 {
            format!(" + {offset}")
        } else {
            String::new()
        };
        meta.push((
            "conversion",
            format!("{target} = {} {how}{off}", header[*col]),
        ));
    }
    meta
}

/// A data row's cells converted (empty where the source is); the time must rise.
fn converted_row(
    rec: &csv::StringRecord,
    plan: &[Planned],
    header: &[String],
    last_t: &mut Option<f64>,
    (data_file, line): (&Path, usize),
) -> Result<Vec<String>, ImportError> {
    let mut cells = Vec::with_capacity(plan.len());
    for (target, col, (f, _), offset) in plan {
        let raw = rec.get(*col).unwrap_or("");
        if raw.is_empty() {
            if target == chan::T_S {
                return Err(ImportError::Data {
                    file: data_file.to_owned(),
                    line,
                    message: format!("column `{}` (time) is empty", header[*col]),
                });
            }
            cells.push(String::new());
            continue;
        }
        let v: f64 = raw.parse().ok().filter(|v: &f64| v.is_finite()).ok_or_else(|| ImportError::Data {
            file: data_file.to_owned(),
            line,
            message: format!("column `{}`: `{}` is not a finite number (an empty cell marks a missing sample)", header[*col], crate::numtext::echoed(raw)),
        })?;
        let x = v * f + offset;
        // Checked here, where the source's line and the map's conversion can be named: the
        // converted file's reader would name a line of a file not yet written.
        if !(x.is_finite() && x.abs() <= crate::record::MAX_CELL_MAGNITUDE) {
            return Err(ImportError::Data {
                file: data_file.to_owned(),
                line,
                message: format!(
                    "column `{}`: {} converted to {target} by the map ({} x {}{}) is {}, beyond any physical value (magnitude above 1e12 in SI units): a wrong scale or unit in the map?",
                    header[*col],
                    crate::numtext::echoed(raw),
                    crate::param::plain_number(v),
                    crate::param::plain_number(*f),
                    if *offset != 0.0 { format!(" + {}", crate::param::plain_number(*offset)) } else { String::new() },
                    crate::param::plain_number(x)
                ),
            });
        }
        if target == chan::T_S {
            if let Some(prev) = last_t.filter(|p| x <= *p) {
                return Err(ImportError::Data {
                    file: data_file.to_owned(),
                    line,
                    message: format!(
                        "time {x} s is not after the previous row's {prev} s (repeated or backwards time stamps are reported, not fixed)"
                    ),
                });
            }
            *last_t = Some(x);
        }
        cells.push(format!("{x}"));
    }
    Ok(cells)
}
