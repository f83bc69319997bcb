//! The samples an identification works on: a recording's inputs (complete, zero-order held)
//! and outputs (possibly with missing cells), picked by the model's column names.

use crate::record::channels as chan;
use crate::record::{Recording, RecordingError};

/// Inputs and outputs of one recording, row-aligned.
#[derive(Debug, Clone)]
pub struct Dataset {
    /// Recording file name, for reports.
    pub name: String,
    /// Sample times, s (strictly increasing, possibly irregular).
    pub t_s: Vec<f64>,
    /// Input column names, in the model's order.
    pub input_names: Vec<String>,
    /// `inputs[i][k]`: input i on row k, held from t_k to t_k+1.
    pub inputs: Vec<Vec<f64>>,
    /// Output column names the recording has, in the model's order.
    pub output_names: Vec<String>,
    /// `outputs[j][k]`: output j on row k, `None` where not measured.
    pub outputs: Vec<Vec<Option<f64>>>,
    /// Rows where an independent record starts, each from its own state of rest (`[0]`
    /// for one record; see [`Recording::join`]).
    pub segment_starts: Vec<usize>,
}

impl Dataset {
    /// The first `rows` rows (all of them if there are fewer): a record that starts as
    /// this one does, from the same state of rest, for a search cheaper than the whole.
    pub fn prefix(&self, rows: usize) -> Dataset {
        let mut d = self.rows(0..rows.min(self.t_s.len()));
        d.segment_starts = self
            .segment_starts
            .iter()
            .copied()
            .filter(|&s| s < d.len())
            .collect();
        d
    }

    /// Rows `range` as a record of their own (one segment).
    pub fn rows(&self, range: std::ops::Range<usize>) -> Dataset {
        Dataset {
            name: self.name.clone(),
            t_s: self.t_s[range.clone()].to_vec(),
            input_names: self.input_names.clone(),
            inputs: self
                .inputs
                .iter()
                .map(|u| u[range.clone()].to_vec())
                .collect(),
            output_names: self.output_names.clone(),
            outputs: self
                .outputs
                .iter()
                .map(|y| y[range.clone()].to_vec())
                .collect(),
            segment_starts: vec![0],
        }
    }

    /// Times at which an independent record after the first starts, s (where plotted
    /// lines break).
    pub fn segment_start_times(&self) -> Vec<f64> {
        self.segment_starts
            .iter()
            .filter(|&&k| k > 0)
            .map(|&k| self.t_s[k])
            .collect()
    }

    /// The same record without the outputs `names`.
    pub fn without_outputs(&self, names: &[String]) -> Dataset {
        let keep: Vec<usize> = (0..self.output_names.len())
            .filter(|&j| !names.contains(&self.output_names[j]))
            .collect();
        Dataset {
            output_names: keep.iter().map(|&j| self.output_names[j].clone()).collect(),
            outputs: keep.iter().map(|&j| self.outputs[j].clone()).collect(),
            ..self.clone()
        }
    }

    /// Row ranges of the independent records.
    pub fn segments(&self) -> Vec<std::ops::Range<usize>> {
        crate::record::segment_ranges(&self.segment_starts, self.len())
    }

    /// Picks the model's inputs (all required, complete; the measured angle's line,
    /// [`MEASURED_ANGLE_INTERCEPT`] and [`MEASURED_ANGLE_RATE`], made from the record) and those of its outputs the
    /// recording has (at least one, with at least two measured cells).
    pub fn from_recording(
        rec: &Recording,
        inputs: &[String],
        outputs: &[String],
    ) -> Result<Dataset, RecordingError> {
        if rec.t_s.len() < 2 {
            return Err(RecordingError::File {
                file: rec.path.clone(),
                message: format!(
                    "too few samples: {} row(s); a fit needs a record over time",
                    rec.t_s.len()
                ),
            });
        }
        let input_cols = inputs
            .iter()
            .map(|n| match measured_angle_line(rec, n) {
                Some(line) => line,
                None => rec.require_complete(n),
            })
            .collect::<Result<Vec<_>, _>>()?;
        let mut output_names = Vec::new();
        let mut output_cols = Vec::new();
        for n in outputs {
            if let Some(c) = rec.column(n) {
                if c.iter().filter(|v| v.is_some()).count() >= 2 {
                    output_names.push(n.clone());
                    output_cols.push(c.to_vec());
                }
            }
        }
        if output_names.is_empty() {
            return Err(RecordingError::File {
                file: rec.path.clone(),
                message: format!(
                    "no output column the model can compare with: expected one of {}",
                    outputs.join(", ")
                ),
            });
        }
        Ok(Dataset {
            name: rec
                .path
                .file_name()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default(),
            t_s: rec.t_s.clone(),
            input_names: inputs.to_vec(),
            inputs: input_cols,
            output_names,
            outputs: output_cols,
            segment_starts: rec.segment_starts.clone(),
        })
    }

    /// The outputs whose measured cells are all one value, each with why: no normalised
    /// fit can score a column without spread (its fit divides by the spread), and a model
    /// fitted to it learns the sensor's fault (a stuck encoder read as a slipping wheel).
    pub fn flat_outputs(&self) -> Vec<(String, String)> {
        self.output_names
            .iter()
            .zip(&self.outputs)
            .filter_map(|(name, col)| {
                let v = constant_value(col)?;
                Some((
                    name.clone(),
                    format!(
                        "constant at {} over its {} measured cells: no spread to fit (a stuck sensor, or a quantity the record does not move)",
                        crate::param::plain_number(v),
                        col.iter().flatten().count()
                    ),
                ))
            })
            .collect()
    }

    /// The median interval between consecutive rows, s (0 with fewer than two rows): the
    /// record's sample interval, whatever gaps or jitter it has.
    pub fn median_interval_s(&self) -> f64 {
        let mut dts: Vec<f64> = self.t_s.windows(2).map(|w| w[1] - w[0]).collect();
        dts.sort_by(f64::total_cmp);
        dts.get(dts.len() / 2).copied().unwrap_or(0.0)
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.t_s.len()
    }

    /// Whether there are no rows.
    pub fn is_empty(&self) -> bool {
        self.t_s.is_empty()
    }

    /// Output `j`'s measured rows and its residual there, `y - predicted`, in row order.
    pub fn measured_residual(&self, j: usize, predicted: &[f64]) -> (Vec<usize>, Vec<f64>) {
        self.outputs[j]
            .iter()
            .zip(predicted)
            .enumerate()
            .filter_map(|(k, (y, p))| y.map(|y| (k, y - p)))
            .unzip()
    }

    /// Index of an output by column name.
    pub fn output_index(&self, name: &str) -> Option<usize> {
        self.output_names.iter().position(|n| n == name)
    }

    /// The first measured value of an output.
    pub fn first_measured(&self, name: &str) -> Option<f64> {
        self.output_index(name)
            .and_then(|j| self.outputs[j].iter().flatten().next().copied())
    }

    /// Input values on row k.
    pub fn input_row(&self, k: usize, u: &mut [f64]) {
        for (i, col) in self.inputs.iter().enumerate() {
            u[i] = col[k];
        }
    }

    /// Input values at time t (zero-order held; the first row's before the record).
    pub fn input_at(&self, t: f64, u: &mut [f64]) {
        let k = self.t_s.partition_point(|&x| x <= t).saturating_sub(1);
        self.input_row(k, u);
    }

    /// Number of measured output cells.
    pub fn measured_cells(&self) -> usize {
        self.outputs
            .iter()
            .map(|c| c.iter().filter(|v| v.is_some()).count())
            .sum()
    }
}

/// The recording's contract input columns a model neither takes as an input nor
/// compares as an output (`used`: the model's inputs and outputs): named in the report,
/// never dropped silently.
pub fn ignored_inputs(rec: &Recording, used: &[String]) -> Vec<String> {
    rec.names
        .iter()
        .filter(|n| chan::is_contract_input(n) && !used.contains(n))
        .cloned()
        .collect()
}

/// Derived input: the intercept `a_k` of the measured motor angle's line over the interval
/// from row k to the next, `theta(t) = a_k + b_k t` (rad; t the record's time in s). A
/// term that depends on where the shaft is (a periodic torque) is fitted with the angle
/// the encoder measured: a model's own angle drifts from it by its speed error, which over
/// a thousand radians of travel scrambles any phase.
pub const MEASURED_ANGLE_INTERCEPT: &str = "measured_motor_angle_intercept_rad";
/// Derived input: the slope `b_k` of that line (rad/s).
pub const MEASURED_ANGLE_RATE: &str = "measured_motor_angle_rate_rad_s";

/// Whether an input is derived from the record's outputs (no command: no regime of its
/// own, nothing to excite).
pub fn is_derived_input(name: &str) -> bool {
    name == MEASURED_ANGLE_INTERCEPT || name == MEASURED_ANGLE_RATE
}

/// The measured angle's line, if `name` is one of its derived inputs (see
/// [`angle_line`]); an error where the record has neither an angle nor a speed.
fn measured_angle_line(rec: &Recording, name: &str) -> Option<Result<Vec<f64>, RecordingError>> {
    if name != MEASURED_ANGLE_INTERCEPT && name != MEASURED_ANGLE_RATE {
        return None;
    }
    let angle = rec.require_complete(chan::MOTOR_ANGLE_RAD).ok();
    let line = angle_line(
        &rec.t_s,
        angle.as_deref(),
        rec.column(chan::MOTOR_SPEED_RAD_S),
    );
    Some(match line {
        Some((a, b)) => Ok(if name == MEASURED_ANGLE_RATE { b } else { a }),
        None => Err(RecordingError::File {
            file: rec.path.clone(),
            message: format!(
                "{name}: a term of the motor angle needs motor_angle_rad or motor_speed_rad_s"
            ),
        }),
    })
}

/// The measured motor angle at each row, rad: a recorded angle, or the motor speed
/// integrated (an encoder's speed is the count difference over the interval ending at its
/// row, so the integral is exact to a count), zero at the first row. `None` without
/// either, or with fewer than two rows.
pub fn measured_angle(
    t: &[f64],
    angle: Option<&[f64]>,
    speed: Option<&[Option<f64>]>,
) -> Option<Vec<f64>> {
    let n = t.len();
    if n < 2 {
        return None;
    }
    match (angle, speed) {
        (Some(a), _) => Some(a.to_vec()),
        (None, Some(speed)) => {
            let mut theta = vec![0.0; n];
            let mut last = 0.0;
            for k in 1..n {
                last = speed[k].unwrap_or(last);
                theta[k] = theta[k - 1] + last * (t[k] - t[k - 1]);
            }
            Some(theta)
        }
        (None, None) => None,
    }
}

/// The measured motor angle's line over each sample interval, `theta(t) = a_k + b_k t`
/// (intercepts, slopes), from [`measured_angle`]. `None` without it.
pub fn angle_line(
    t: &[f64],
    angle: Option<&[f64]>,
    speed: Option<&[Option<f64>]>,
) -> Option<(Vec<f64>, Vec<f64>)> {
    let angle = measured_angle(t, angle, speed)?;
    let n = t.len();
    let slope: Vec<f64> = (0..n)
        .map(|k| {
            let k = k.min(n - 2);
            (angle[k + 1] - angle[k]) / (t[k + 1] - t[k])
        })
        .collect();
    let intercept = (0..n).map(|k| angle[k] - slope[k] * t[k]).collect();
    Some((intercept, slope))
}

impl Dataset {
    /// This record with the measured angle's line as two more inputs
    /// ([`MEASURED_ANGLE_INTERCEPT`], [`MEASURED_ANGLE_RATE`]), from its motor angle or
    /// motor speed output; `None` where it has neither.
    pub fn with_measured_angle(&self) -> Option<Dataset> {
        let out = |name: &str| self.output_index(name).map(|j| &self.outputs[j]);
        let angle: Option<Vec<f64>> =
            out(chan::MOTOR_ANGLE_RAD).and_then(|c| c.iter().copied().collect());
        let (a, b) = angle_line(
            &self.t_s,
            angle.as_deref(),
            out(chan::MOTOR_SPEED_RAD_S).map(|c| c.as_slice()),
        )?;
        let mut d = self.clone();
        d.input_names.extend([
            MEASURED_ANGLE_INTERCEPT.to_string(),
            MEASURED_ANGLE_RATE.to_string(),
        ]);
        d.inputs.extend([a, b]);
        Some(d)
    }
}

/// The one value every measured cell holds, when there are at least two and they are
/// all equal: a column without spread, which no normalised fit scores.
pub fn constant_value(measured: &[Option<f64>]) -> Option<f64> {
    let mut cells = measured.iter().flatten();
    let first = *cells.next()?;
    let mut n = 1;
    for v in cells {
        if *v != first {
            return None;
        }
        n += 1;
    }
    (n >= 2).then_some(first)
}

/// An output of a record left out of the fit, and why.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct LeftOut {
    /// The output column.
    pub output: String,
    /// Why the record cannot show it ([`GreyBox::unexcited_outputs`]).
    pub why: String,
}

impl LeftOut {
    /// The outputs of `unexcited` (output, why) that `data` measures, then those whose
    /// measured cells do not spread ([`Dataset::flat_outputs`]): one rule for every fit.
    pub fn of(data: &Dataset, unexcited: Vec<(String, String)>) -> Vec<LeftOut> {
        let mut left: Vec<LeftOut> = unexcited
            .into_iter()
            .filter(|(o, _)| data.output_index(o).is_some())
            .map(|(output, why)| LeftOut { output, why })
            .collect();
        for (output, why) in data.flat_outputs() {
            if !left.iter().any(|l| l.output == output) {
                left.push(LeftOut { output, why });
            }
        }
        left
    }
}
