//! Writes a vehicle recording in the exchange format: `#` metadata lines, a header of
//! unit-suffixed column names, one row per sample. Numbers are printed with a fixed
//! number of decimals so that the same run gives the same bytes.

use super::channels as chan;
use crate::rig::RigKind;
use std::io::Write;

use crate::sim::Snapshot;

/// A column: name (ending in its unit) and how to read it from a snapshot.
pub struct Column {
    /// The column's name, ending in its unit.
    pub name: &'static str,
    /// Decimals written (the recording's resolution of the column).
    pub decimals: usize,
    /// The column's value in a snapshot.
    pub value: fn(&Snapshot) -> f64,
}

/// The vehicle rig's columns (inputs, outputs), then our extra ones.
pub fn vehicle_columns() -> Vec<Column> {
    fn c(name: &'static str, decimals: usize, value: fn(&Snapshot) -> f64) -> Column {
        Column {
            name,
            decimals,
            value,
        }
    }
    vec![
        c(chan::T_S, 4, |s| s.t_s),
        c(chan::DEMAND_FWD_PCT, 3, |s| s.demand_pct[0]),
        c(chan::DEMAND_TURN_PCT, 3, |s| s.demand_pct[1]),
        c(chan::LEFT_VOLTAGE_V, 4, |s| s.sides[0].voltage_v),
        c(chan::RIGHT_VOLTAGE_V, 4, |s| s.sides[1].voltage_v),
        c(chan::X_M, 6, |s| s.pose.x_m),
        c(chan::Y_M, 6, |s| s.pose.y_m),
        c(chan::HEADING_RAD, 6, |s| s.pose.heading_rad),
        c(chan::LEFT_MOTOR_SPEED_RAD_S, 4, |s| {
            s.sides[0].motor_speed_rad_s
        }),
        c(chan::RIGHT_MOTOR_SPEED_RAD_S, 4, |s| {
            s.sides[1].motor_speed_rad_s
        }),
        c(chan::SENSOR_LEFT_ADC, 2, |s| s.sensors_adc[0]),
        c(chan::SENSOR_RIGHT_ADC, 2, |s| s.sensors_adc[1]),
        c(chan::LEFT_WHEEL_SPEED_M_S, 5, |s| s.sides[0].wheel_rim_m_s),
        c(chan::RIGHT_WHEEL_SPEED_M_S, 5, |s| s.sides[1].wheel_rim_m_s),
        c(chan::YAW_RATE_RAD_S, 5, |s| s.yaw_rate_rad_s),
        c("lateral_error_m", 6, |s| s.lateral_error_m),
        c(chan::LEFT_CURRENT_A, 3, |s| s.sides[0].current_a),
        c(chan::RIGHT_CURRENT_A, 3, |s| s.sides[1].current_a),
        c("left_slip_ratio", 5, |s| s.sides[0].slip_ratio),
        c("right_slip_ratio", 5, |s| s.sides[1].slip_ratio),
        c("left_tyre_force_N", 3, |s| s.sides[0].tyre_force_n[0]),
        c("right_tyre_force_N", 3, |s| s.sides[1].tyre_force_n[0]),
        c("left_backlash_gap_rad", 5, |s| s.sides[0].backlash_gap_rad),
        c("right_backlash_gap_rad", 5, |s| s.sides[1].backlash_gap_rad),
        c("turn_command_counts", 3, |s| s.command_counts[1]),
        c("castor_drag_N", 3, |s| s.castor_drag_n),
        c(chan::BATTERY_V, 4, |s| s.battery_v),
    ]
}

/// The head of a recording in the exchange format: the format's version, the rig, one
/// `# key: value` line per metadata entry (a value's newlines become spaces, so a
/// description cannot break the metadata), then the column names.
pub fn header(rig: RigKind, meta: &[(&str, String)], columns: &[&str]) -> String {
    use std::fmt::Write as _;
    let mut s = format!("# agvsim-recording: 1\n# rig: {rig}\n");
    for (k, v) in meta {
        let _ = writeln!(s, "# {k}: {}", v.replace('\n', " "));
    }
    s.push_str(&columns.join(","));
    s.push('\n');
    s
}

/// Streams rows to any writer.
pub struct RecordingWriter<W: Write> {
    out: W,
    columns: Vec<Column>,
    line: String,
}

impl<W: Write> RecordingWriter<W> {
    /// Writes the metadata and header. `meta` are extra `key: value` lines.
    pub fn new(
        mut out: W,
        rig: RigKind,
        meta: &[(&str, String)],
        columns: Vec<Column>,
    ) -> std::io::Result<Self> {
        let names: Vec<&str> = columns.iter().map(|c| c.name).collect();
        out.write_all(header(rig, meta, &names).as_bytes())?;
        Ok(RecordingWriter {
            out,
            columns,
            line: String::new(),
        })
    }

    /// Writes one snapshot as a row.
    pub fn row(&mut self, s: &Snapshot) -> std::io::Result<()> {
        use std::fmt::Write as _;
        self.line.clear();
        for (i, c) in self.columns.iter().enumerate() {
            if i > 0 {
                self.line.push(',');
            }
            let v = (c.value)(s);
            // "-0.000" and "0.000" must not differ between otherwise equal runs.
            let v = if v == 0.0 { 0.0 } else { v };
            let _ = write!(self.line, "{:.*}", c.decimals, v);
        }
        self.line.push('\n');
        self.out.write_all(self.line.as_bytes())
    }

    /// Flushes the rows and hands back the writer.
    pub fn finish(mut self) -> std::io::Result<W> {
        self.out.flush()?;
        Ok(self.out)
    }
}
