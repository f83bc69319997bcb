//! Several records of one machine as one: the tests of a characterisation routine (SysId's
//! quasistatic and dynamic tests, forward and backward) share the machine's parameters, so
//! they are fitted together. Each keeps its own start from rest: the joined record marks
//! where each begins, and a model simulates each from its own initial state.

use super::{Recording, RecordingError};

impl Recording {
    /// The records one after another on one time base (each shifted to start one sample
    /// interval after the previous ends), with [`Recording::segment_starts`] marking them.
    /// They must come from the same kind of rig and have the same columns.
    pub fn join(parts: Vec<Recording>) -> Result<Recording, RecordingError> {
        let mut parts = parts.into_iter();
        let Some(mut joined) = parts.next() else {
            return Err(RecordingError::File {
                file: "(no recording)".into(),
                message: "nothing to join: give at least one recording".into(),
            });
        };
        let mut paths = vec![joined.path.display().to_string()];
        for next in parts {
            let refuse = |message: String| RecordingError::File {
                file: next.path.clone(),
                message,
            };
            if next.rig != joined.rig {
                return Err(refuse(format!(
                    "rig `{}`, but {} is `{}`: records joined for one fit come from one machine",
                    next.rig, paths[0], joined.rig
                )));
            }
            if let Some(c) = joined.names.iter().find(|c| !next.names.contains(c)) {
                return Err(refuse(format!(
                    "no column `{c}`, which {} has: records fitted together need the same columns",
                    paths[0]
                )));
            }
            if let Some(c) = next.names.iter().find(|c| !joined.names.contains(c)) {
                return Err(refuse(format!(
                    "column `{c}` is not in {}: records fitted together need the same columns",
                    paths[0]
                )));
            }
            let n = joined.t_s.len();
            let last_interval = if n > 1 {
                joined.t_s[n - 1] - joined.t_s[n - 2]
            } else {
                next.t_s.get(1).map_or(1.0, |t| t - next.t_s[0])
            };
            let shift = joined.t_s[n - 1] + last_interval - next.t_s[0];
            joined
                .segment_starts
                .extend(next.segment_starts.iter().map(|s| s + n));
            joined.t_s.extend(next.t_s.iter().map(|t| t + shift));
            for (name, col) in joined.names.iter().zip(joined.columns.iter_mut()) {
                col.extend_from_slice(next.column(name).expect("checked above"));
            }
            paths.push(next.path.display().to_string());
        }
        // One name for the joined record: the files' names in their folder when they share
        // one (reports name the record by its last path component), else the full paths.
        let files: Vec<std::path::PathBuf> = paths.iter().map(std::path::PathBuf::from).collect();
        let parent = files[0].parent().map(|p| p.to_path_buf());
        joined.path = if files.len() > 1
            && files
                .iter()
                .all(|f| f.parent().map(|p| p.to_path_buf()) == parent)
        {
            let names: Vec<String> = files
                .iter()
                .map(|f| {
                    f.file_name()
                        .unwrap_or_default()
                        .to_string_lossy()
                        .into_owned()
                })
                .collect();
            parent.unwrap_or_default().join(names.join(" + "))
        } else {
            paths.join(" + ").into()
        };
        Ok(joined)
    }

    /// Loads one recording, or several tests of one machine joined ([`Recording::join`]).
    pub fn load_joined(paths: &[std::path::PathBuf]) -> Result<Recording, RecordingError> {
        // The same test twice would count its evidence twice: deviations shrink by
        // sqrt 2 for nothing.
        let same =
            |a: &std::path::Path, b: &std::path::Path| match (a.canonicalize(), b.canonicalize()) {
                (Ok(x), Ok(y)) => x == y,
                _ => a == b,
            };
        for (i, p) in paths.iter().enumerate() {
            if paths[..i].iter().any(|q| same(p, q)) {
                return Err(RecordingError::File {
                    file: p.clone(),
                    message: "given twice: each test of a machine may be joined once (the same rows twice would halve the variance for nothing)".into(),
                });
            }
        }
        Recording::join(
            paths
                .iter()
                .map(|p| Recording::load(p))
                .collect::<Result<Vec<_>, _>>()?,
        )
    }

    /// The first `rows` rows (all of them if there are fewer), with the metadata and the
    /// segments that start within them: a recording that starts as this one does.
    pub fn prefix(&self, rows: usize) -> Recording {
        let n = rows.min(self.t_s.len());
        Recording {
            path: self.path.clone(),
            meta: self.meta.clone(),
            rig: self.rig,
            t_s: self.t_s[..n].to_vec(),
            names: self.names.clone(),
            columns: self.columns.iter().map(|c| c[..n].to_vec()).collect(),
            segment_starts: self
                .segment_starts
                .iter()
                .copied()
                .filter(|&s| s < n)
                .collect(),
        }
    }

    /// Row ranges of the independent records.
    pub fn segments(&self) -> Vec<std::ops::Range<usize>> {
        super::segment_ranges(&self.segment_starts, self.t_s.len())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn rec(name: &str, header: &str, rows: &[&str]) -> Recording {
        let columns: Vec<&str> = header.split(',').collect();
        let text = format!(
            "{}{}\n",
            crate::record::header(crate::rig::RigKind::DriveAxis, &[], &columns),
            rows.join("\n")
        );
        Recording::parse(&text, Path::new(name)).unwrap()
    }

    /// Joined tests follow one another on one increasing time base, each marked where it
    /// starts, columns matched by name whatever their order.
    #[test]
    fn joined_records_keep_their_rows_and_mark_where_each_starts() {
        let a = rec(
            "d/a.csv",
            "t_s,voltage_V,motor_speed_rad_s",
            &["0,1,0", "0.01,1,5", "0.02,1,7"],
        );
        let b = rec(
            "d/b.csv",
            "t_s,motor_speed_rad_s,voltage_V",
            &["100,0,-2", "100.01,-4,-2"],
        );
        let j = Recording::join(vec![a, b]).unwrap();
        assert_eq!(j.segment_starts, [0, 3]);
        assert_eq!(j.segments(), [0..3, 3..5]);
        assert!(j.t_s.windows(2).all(|w| w[1] > w[0]), "{:?}", j.t_s);
        assert!((j.t_s[3] - 0.03).abs() < 1e-12, "{:?}", j.t_s);
        let v: Vec<f64> = j
            .column("voltage_V")
            .unwrap()
            .iter()
            .flatten()
            .copied()
            .collect();
        assert_eq!(v, [1.0, 1.0, 1.0, -2.0, -2.0]);
        let w: Vec<f64> = j
            .column("motor_speed_rad_s")
            .unwrap()
            .iter()
            .flatten()
            .copied()
            .collect();
        assert_eq!(w, [0.0, 5.0, 7.0, 0.0, -4.0]);
        assert_eq!(j.path, Path::new("d/a.csv + b.csv"));
    }

    /// Records of different columns or rigs are refused, naming the file and the column.
    #[test]
    fn records_that_differ_in_columns_are_refused_naming_file_and_column() {
        let a = rec(
            "a.csv",
            "t_s,voltage_V,motor_speed_rad_s",
            &["0,1,0", "0.01,1,5"],
        );
        let b = rec("b.csv", "t_s,voltage_V,current_A", &["0,1,0", "0.01,1,5"]);
        let e = Recording::join(vec![a, b]).unwrap_err().to_string();
        assert!(
            e.starts_with("b.csv") && e.contains("`motor_speed_rad_s`"),
            "{e}"
        );
        assert!(Recording::join(vec![]).is_err());
    }
}
