//! Reads a recording in the exchange format (`shared/spec/recording-format.md`): `#`
//! metadata lines, a header of unit-suffixed column names, then rows. Empty cells are
//! missing values (`None`), never zero. Every contract breach is reported with the file,
//! the line and the column.

use super::channels as chan;
use crate::numtext::echoed;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::rig::RigKind;

/// A recording as read.
#[derive(Debug, Clone, PartialEq)]
pub struct Recording {
    /// The file it was read from.
    pub path: PathBuf,
    /// Metadata (`key: value` lines), in file order of keys.
    pub meta: BTreeMap<String, String>,
    /// What machine it was made on (`# rig: ...`).
    pub rig: RigKind,
    /// Sample times, s (strictly increasing).
    pub t_s: Vec<f64>,
    /// Column names after `t_s`, in file order.
    pub names: Vec<String>,
    /// Columns after `t_s`; `None` where the cell was empty.
    pub columns: Vec<Vec<Option<f64>>>,
    /// Rows where an independent record starts (`[0]` for one file; a record joined from
    /// several tests of one machine has one per test, each starting from rest).
    pub segment_starts: Vec<usize>,
}

/// The `# key: value` lines before the header, and the header's line number and text (the
/// first line that is neither metadata nor blank).
fn metadata_and_header<'t>(
    lines: &mut impl Iterator<Item = (usize, &'t str)>,
) -> (BTreeMap<String, String>, Option<(usize, &'t str)>) {
    let mut meta = BTreeMap::new();
    for (n, l) in lines {
        if let Some(rest) = l.strip_prefix('#') {
            if let Some((k, v)) = rest.split_once(':') {
                meta.insert(k.trim().to_string(), v.trim().to_string());
            }
            continue;
        }
        if l.trim().is_empty() {
            continue;
        }
        return (meta, Some((n, l)));
    }
    (meta, None)
}

/// The format version (it must be 1) and the rig kind the metadata states.
fn version_and_rig(
    meta: &BTreeMap<String, String>,
    path: &Path,
) -> Result<RigKind, RecordingError> {
    let file = |message: String| RecordingError::File {
        file: path.to_owned(),
        message,
    };
    match meta.get("agvsim-recording").map(String::as_str) {
        Some("1") => {}
        Some(v) => {
            return Err(RecordingError::Line {
                file: path.to_owned(),
                line: 1,
                message: format!("format version `{v}`: expected `# agvsim-recording: 1`"),
            })
        }
        None => {
            return Err(file(
                "missing metadata `# agvsim-recording: 1` before the header".into(),
            ))
        }
    }
    let rig = meta
        .get("rig")
        .ok_or_else(|| file("missing metadata `# rig: drive_axis` or `# rig: vehicle`".into()))?;
    match RigKind::from_name(rig) {
        // A base is a rig file's kind: what it records is a vehicle on the floor.
        Some(RigKind::Base) => Err(file(format!(
            "rig `{rig}`: a velocity-commanded base's recordings are `# rig: vehicle` (its rig file says `rig = \"base\"`)"
        ))),
        Some(kind) => Ok(kind),
        None => Err(file(format!(
            "rig `{rig}`: expected one of drive_axis, vehicle, drive_pair"
        ))),
    }
}

/// The header's column names: `t_s` first, each named once.
fn header_columns(header: &str, hline: usize, path: &Path) -> Result<Vec<String>, RecordingError> {
    let at = |message: String| RecordingError::Line {
        file: path.to_owned(),
        line: hline,
        message,
    };
    let cols: Vec<String> = header.split(',').map(|c| c.trim().to_string()).collect();
    if cols.first().map(String::as_str) != Some(chan::T_S) {
        return Err(at(format!("first column is `{}`: expected `t_s`", cols[0])));
    }
    for (i, c) in cols.iter().enumerate() {
        if c.is_empty() {
            return Err(at(format!("column {} has no name", i + 1)));
        }
        if cols[..i].contains(c) {
            return Err(at(format!("column `{c}` appears twice")));
        }
    }
    Ok(cols)
}

/// Largest magnitude of a cell, in the column's SI unit: beyond it no quantity of a
/// vehicle's recording lies (1e12 m is seven times the Sun's distance, 1e12 A or V or
/// rad/s is no machine; an encoder counting 10,000 a turn at 1,000 turns a second passes
/// it after three years). A cell of 1e300 or -1.7e308 is a sentinel or damage, and would
/// otherwise be fitted (a mass of 452 kg for 120) and scored (an RMS of inf).
pub const MAX_CELL_MAGNITUDE: f64 = 1e12;

/// The samples read so far.
struct Rows {
    t_s: Vec<f64>,
    columns: Vec<Vec<Option<f64>>>,
}

impl Rows {
    /// Takes one data line: a time after the last and a number or nothing per column;
    /// `at` makes the error of a message (adding the file and line).
    fn push(
        &mut self,
        l: &str,
        names: &[String],
        at: &dyn Fn(String) -> RecordingError,
    ) -> Result<(), RecordingError> {
        let cells: Vec<&str> = l.split(',').collect();
        if cells.len() != names.len() + 1 {
            return Err(at(format!(
                "{} cells: expected {} (one per header column)",
                cells.len(),
                names.len() + 1
            )));
        }
        let t = cells[0].trim();
        let t: f64 = t
            .parse()
            .map_err(|_| at(format!("column `t_s`: `{}` is not a number", echoed(t))))?;
        if !t.is_finite() || t.abs() > MAX_CELL_MAGNITUDE {
            return Err(at(format!(
                "column `t_s`: {} is {}",
                echoed(cells[0].trim()),
                if t.is_finite() {
                    "beyond any time in seconds (magnitude above 1e12 s, 30,000 years): nanoseconds?"
                } else {
                    "not finite"
                }
            )));
        }
        if let Some(&prev) = self.t_s.last() {
            if t <= prev {
                return Err(at(format!(
                    "column `t_s`: time {t} does not increase (previous row {prev})"
                )));
            }
        }
        self.t_s.push(t);
        for (k, cell) in cells[1..].iter().enumerate() {
            let cell = cell.trim();
            let v = if cell.is_empty() {
                None
            } else {
                let v: f64 = cell.parse().map_err(|_| {
                    at(format!(
                        "column `{}`: `{}` is not a number",
                        names[k],
                        echoed(cell)
                    ))
                })?;
                if !v.is_finite() {
                    return Err(at(format!(
                        "column `{}`: {} is not finite (leave the cell empty for a missing value)",
                        names[k],
                        echoed(cell)
                    )));
                }
                if v.abs() > MAX_CELL_MAGNITUDE {
                    return Err(at(format!(
                        "column `{}`: {} is beyond any physical value of a vehicle's recording (magnitude above {MAX_CELL_MAGNITUDE:e} in SI units): a logger's sentinel or a damaged cell? leave the cell empty for a missing value",
                        names[k],
                        echoed(cell)
                    )));
                }
                Some(v)
            };
            self.columns[k].push(v);
        }
        Ok(())
    }
}

/// Largest recording file read, bytes (100 MB: some hours of a vehicle's 27 columns at
/// 100 Hz; the thesis's and SysId's tests are a few MB).
pub const MAX_RECORDING_BYTES: u64 = 100 << 20;

/// A breach of the contract, located.
#[derive(Debug, thiserror::Error)]
pub enum RecordingError {
    /// The file could not be read.
    #[error("{file}: cannot read: {source}")]
    Read {
        /// The file.
        file: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The file breaks the format.
    #[error("{file}: {message}")]
    File {
        /// The recording.
        file: PathBuf,
        /// What breaks the format.
        message: String,
    },
    /// A line breaks the format.
    #[error("{file}:{line}: {message}")]
    Line {
        /// The file.
        file: PathBuf,
        /// The line.
        line: usize,
        /// What is wrong.
        message: String,
    },
}

/// Units a column name may end in.
pub const KNOWN_UNITS: [&str; 12] = [
    "s", "m", "rad", "rad_s", "m_s", "V", "A", "Nm", "N", "pct", "adc", "counts",
];

impl Recording {
    /// Reads and checks a recording.
    pub fn load(path: &Path) -> Result<Recording, RecordingError> {
        Recording::load_with_defaults(path, &[])
    }

    /// Reads and checks a commands file (`manoeuvre.commands`): a recording whose
    /// metadata may be left out, as a plain `t_s,cmd_linear_m_s,cmd_angular_rad_s` CSV
    /// (format 1, rig `vehicle`, where it says nothing else).
    pub fn load_commands(path: &Path) -> Result<Recording, RecordingError> {
        Recording::load_with_defaults(path, &[("agvsim-recording", "1"), ("rig", "vehicle")])
    }

    /// As [`Recording::load`], with metadata the file leaves out taken from `defaults`.
    fn load_with_defaults(
        path: &Path,
        defaults: &[(&str, &str)],
    ) -> Result<Recording, RecordingError> {
        // The size first: a fit of a recording this large would take hours and gigabytes
        // before it said anything.
        if let Ok(m) = std::fs::metadata(path) {
            if m.len() > MAX_RECORDING_BYTES {
                return Err(RecordingError::File {
                    file: path.to_owned(),
                    message: format!(
                        "{} MB: recordings of at most {} MB are read (an hour of 20 columns at 1 kHz is about 1 GB; cut the test out, or resample it)",
                        m.len() >> 20,
                        MAX_RECORDING_BYTES >> 20
                    ),
                });
            }
        }
        let text = crate::output::read_text_bounded(path, crate::output::MAX_INPUT_BYTES).map_err(
            |source| RecordingError::Read {
                file: path.to_owned(),
                source,
            },
        )?;
        Recording::parse_with_defaults(&text, path, defaults)
    }

    /// Parses text; `path` is used in messages. A leading UTF-8 byte-order mark (as some
    /// spreadsheet programs write) is skipped.
    pub fn parse(text: &str, path: &Path) -> Result<Recording, RecordingError> {
        Recording::parse_with_defaults(text, path, &[])
    }

    /// As [`Recording::parse`], with metadata the text leaves out taken from `defaults`.
    fn parse_with_defaults(
        text: &str,
        path: &Path,
        defaults: &[(&str, &str)],
    ) -> Result<Recording, RecordingError> {
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let file = || path.to_owned();
        let mut lines = text
            .lines()
            .enumerate()
            .map(|(i, l)| (i + 1, l.trim_end_matches('\r')));
        let (mut meta, header) = metadata_and_header(&mut lines);
        for (k, v) in defaults {
            meta.entry(k.to_string()).or_insert_with(|| v.to_string());
        }
        let (hline, header) = header.ok_or_else(|| RecordingError::File {
            file: file(),
            message: "empty recording: no header line and no samples".into(),
        })?;
        let rig = version_and_rig(&meta, path)?;
        let cols = header_columns(header, hline, path)?;
        let names: Vec<String> = cols[1..].to_vec();
        let mut rows = Rows {
            t_s: Vec::new(),
            columns: vec![Vec::new(); names.len()],
        };
        for (n, l) in lines {
            if l.trim().is_empty() || l.starts_with('#') {
                continue;
            }
            rows.push(l, &names, &|message| RecordingError::Line {
                file: file(),
                line: n,
                message,
            })?;
        }
        if rows.t_s.is_empty() {
            return Err(RecordingError::File {
                file: file(),
                message: "no samples after the header".into(),
            });
        }
        check_sample_time(&meta, &rows.t_s).map_err(|message| RecordingError::File {
            file: file(),
            message: message.to_string(),
        })?;
        Ok(Recording {
            path: path.to_owned(),
            meta,
            rig,
            t_s: rows.t_s,
            names,
            columns: rows.columns,
            segment_starts: vec![0],
        })
    }

    /// A column by name.
    pub fn column(&self, name: &str) -> Option<&[Option<f64>]> {
        self.names
            .iter()
            .position(|n| n == name)
            .map(|i| self.columns[i].as_slice())
    }

    /// A column that must be present and complete (an input), or an error naming it.
    pub fn require_complete(&self, name: &str) -> Result<Vec<f64>, RecordingError> {
        let col = self.column(name).ok_or_else(|| RecordingError::File {
            file: self.path.clone(),
            message: format!("column `{name}` is missing (the rig needs it as an input)"),
        })?;
        col.iter()
            .enumerate()
            .map(|(i, v)| {
                v.ok_or_else(|| RecordingError::File {
                    file: self.path.clone(),
                    message: format!("column `{name}` is empty at t = {} s (an input must be given on every row)", self.t_s[i]),
                })
            })
            .collect()
    }
}

/// The median interval of a time column, s (`None` under two rows): the sample time a
/// logger's jitter does not move.
pub fn median_interval_s(t_s: &[f64]) -> Option<f64> {
    let mut dts: Vec<f64> = t_s.windows(2).map(|w| w[1] - w[0]).collect();
    dts.sort_by(f64::total_cmp);
    dts.get(dts.len() / 2).copied()
}

/// Shortest interval between rows a recording is taken to mean when it does not state
/// `sample_time_s`, s: a megahertz logger's (a drive's current loop is logged at tens of
/// kilohertz at most).
pub const MIN_SAMPLE_TIME_S: f64 = 1e-6;

/// A stated `sample_time_s` must be the time column's: a header that says 1 ms over a
/// column stamped in seconds where milliseconds were meant (or the reverse) is a recording
/// whose every time constant would come out a thousand times off.
///
/// Unstated, the column's own interval must be one a logger keeps: rows nanoseconds
/// apart are a time column in ns (or µs) read as seconds, which a replay would step
/// through a million rows to a physics step.
fn check_sample_time(meta: &BTreeMap<String, String>, t_s: &[f64]) -> Result<(), SampleTime> {
    let Some(raw) = meta.get("sample_time_s") else {
        return match median_interval_s(t_s) {
            Some(median) if median < MIN_SAMPLE_TIME_S => Err(SampleTime::TooShort(median)),
            _ => Ok(()),
        };
    };
    let stated: f64 = raw
        .parse()
        .ok()
        .filter(|v: &f64| v.is_finite() && *v > 0.0)
        .ok_or_else(|| SampleTime::NotSeconds(raw.clone()))?;
    let Some(median) = median_interval_s(t_s) else {
        return Ok(());
    };
    // Loggers jitter and their clocks drift by a few percent; a unit slip is a factor of
    // ten or more and a decimated log a factor of two, so a quarter separates them.
    if (median / stated - 1.0).abs() > 0.25 {
        return Err(SampleTime::Disagrees {
            stated: raw.clone(),
            median,
        });
    }
    Ok(())
}

/// A time column whose interval no logger keeps, or that its header's `sample_time_s`
/// contradicts.
#[derive(Debug, thiserror::Error)]
enum SampleTime {
    /// Rows closer than [`MIN_SAMPLE_TIME_S`], unstated (the median interval, s).
    #[error("the time column's median interval is {} s, shorter than any logger's ({MIN_SAMPLE_TIME_S} s): a time column in ns or µs? (`t_s` is in seconds; say `# sample_time_s:` in the header if the interval is meant)", crate::scene::plausibility::sig(*.0))]
    TooShort(f64),
    /// A stated interval that is no positive number (as written).
    #[error("metadata `sample_time_s: {0}`: expected a positive number of seconds")]
    NotSeconds(String),
    /// A stated interval a quarter or more off the column's median.
    #[error("metadata `sample_time_s: {stated}` but the time column's median interval is {} s: which is right? (a time column in ms, or a header copied from another recording?)", crate::scene::plausibility::sig(*median))]
    Disagrees {
        /// As written.
        stated: String,
        /// The column's median interval, s.
        median: f64,
    },
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Recording, RecordingError> {
        Recording::parse(text, Path::new("r.csv"))
    }

    const HEAD: &str = "# agvsim-recording: 1\n# rig: drive_axis\n";

    #[test]
    fn a_cell_beyond_any_physical_value_is_refused_naming_its_line_and_column() {
        for cell in ["-1.7e308", "1e300", "2e12"] {
            let text =
                format!("# agvsim-recording: 1\n# rig: vehicle\nt_s,voltage_V\n0,1\n0.01,{cell}\n");
            let e = parse(&text).unwrap_err().to_string();
            assert!(
                e.contains("r.csv:5")
                    && e.contains("`voltage_V`")
                    && e.contains(cell)
                    && e.contains("beyond any physical value"),
                "{e}"
            );
        }
        let text = "# agvsim-recording: 1\n# rig: vehicle\nt_s,voltage_V\n1.7e18,1\n";
        let e = parse(text).unwrap_err().to_string();
        assert!(e.contains("nanoseconds?"), "{e}");
        // Large real values pass: an epoch time, a high encoder count.
        let text = "# agvsim-recording: 1\n# rig: vehicle\nt_s,left_encoder_counts\n1.7e9,9e11\n";
        assert!(parse(text).is_ok());
    }

    #[test]
    fn a_cell_of_two_million_digits_is_refused_with_a_short_message() {
        let huge = "9".repeat(2_000_000);
        for (row, column) in [
            (format!("0,{huge}\n"), "voltage_V"),
            (format!("0,1\n{huge},1\n"), "t_s"),
            (format!("0,1\n1,x{huge}\n"), "voltage_V"),
        ] {
            let text = format!("{HEAD}t_s,voltage_V\n{row}");
            let e = parse(&text).unwrap_err().to_string();
            assert!(
                e.len() < 300,
                "{} bytes: {}",
                e.len(),
                &e[..300.min(e.len())]
            );
            assert!(e.contains(column) && e.contains("characters)"), "{e}");
        }
    }

    #[test]
    fn reads_values_and_keeps_missing_cells_missing() {
        let r = parse(&format!(
            "{HEAD}t_s,voltage_V,motor_speed_rad_s\n0.0,1.0,\n0.001,1.5,2.0\n"
        ))
        .unwrap();
        assert_eq!(r.t_s, vec![0.0, 0.001]);
        assert_eq!(r.column("motor_speed_rad_s").unwrap(), &[None, Some(2.0)]);
        assert_eq!(r.require_complete("voltage_V").unwrap(), vec![1.0, 1.5]);
        assert!(r
            .require_complete("motor_speed_rad_s")
            .unwrap_err()
            .to_string()
            .contains("empty at t = 0"));
    }

    #[test]
    fn contract_breaches_name_the_line_and_column() {
        let e = parse(&format!("{HEAD}voltage_V,t_s\n1,0\n"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("r.csv:3") && e.contains("expected `t_s`"), "{e}");
        let e = parse(&format!("{HEAD}t_s,voltage_V\n0.0,1\n0.002,1\n0.001,1\n"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("r.csv:6") && e.contains("does not increase"),
            "{e}"
        );
        let e = parse(&format!("{HEAD}t_s,voltage_V\n0.0,NaN\n"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("r.csv:4") && e.contains("voltage_V") && e.contains("not finite"),
            "{e}"
        );
        let e = parse("").unwrap_err().to_string();
        assert!(e.contains("r.csv") && e.contains("empty"), "{e}");
        let e = parse(&format!("{HEAD}t_s,voltage_V\n"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("no samples"), "{e}");
        let e = parse(&format!("{HEAD}t_s,voltage_V\n0.0,1\n"))
            .unwrap()
            .require_complete("demand_pct")
            .unwrap_err();
        assert!(e.to_string().contains("`demand_pct` is missing"));
        let e = parse("# rig: vehicle\nt_s\n0\n").unwrap_err().to_string();
        assert!(e.contains("agvsim-recording"), "{e}");
    }
}
