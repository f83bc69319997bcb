//! SysId's JSON data file (2022-2023): `"sysid": true`, `"test"` (the mechanism),
//! `"units"` and `"unitsPerRotation"` (positions and speeds in the rows are encoder
//! rotations times that factor), and the four tests `slow-forward`, `slow-backward`,
//! `fast-forward`, `fast-backward`, each a list of rows:
//! `[time, voltage, position, velocity]` for a single mechanism, and
//! `[time, l voltage, r voltage, l position, r position, l velocity, r velocity, angle, angular rate]`
//! for a drivetrain (the gyro's angle in rad and rate in rad/s).

use super::fault::LogFault;
use serde_json::Value;

use super::{unit, Mechanism, Sample, Side, SysIdLog, Test, TESTS};

/// Parses a SysId JSON file's text. Errors name the key, test and row.
pub(crate) fn parse(text: &str) -> Result<SysIdLog, LogFault> {
    let root: Value = serde_json::from_str(text.trim_start_matches('\u{feff}')).map_err(|e| {
        LogFault::NotJson {
            line: e.line(),
            column: e.column(),
            error: e.to_string(),
        }
    })?;
    let obj = root.as_object().ok_or(LogFault::NotAnObject)?;
    if obj.get("sysid").and_then(Value::as_bool) != Some(true) {
        return Err(LogFault::NotSysId);
    }
    let text_key = |k: &'static str| -> Result<&str, LogFault> {
        obj.get(k)
            .and_then(Value::as_str)
            .ok_or(LogFault::TextKey(k))
    };
    let test = text_key("test")?;
    let mechanism =
        Mechanism::from_name(test).ok_or_else(|| LogFault::UnknownTest(test.to_string()))?;
    let units = text_key("units").map_err(|_| LogFault::NoUnits)?;
    let unit = unit(units).ok_or_else(|| LogFault::UnknownUnits(units.to_string()))?;
    let factor = obj
        .get("unitsPerRotation")
        .and_then(Value::as_f64)
        .filter(|f| f.is_finite() && *f > 0.0)
        .ok_or(LogFault::UnitsPerRotation)?;
    let width = if mechanism.is_drivetrain() { 9 } else { 4 };
    let mut tests = Vec::new();
    for name in TESTS {
        let rows = obj
            .get(name)
            .ok_or(LogFault::MissingTest(name))?
            .as_array()
            .ok_or(LogFault::NotRows(name))?;
        let mut samples = Vec::with_capacity(rows.len());
        for (i, row) in rows.iter().enumerate() {
            let cells = row
                .as_array()
                .filter(|c| c.len() == width)
                .ok_or(LogFault::RowWidth {
                    test: name,
                    row: i,
                    width,
                    mechanism: mechanism.name(),
                })?;
            let mut v = Vec::with_capacity(width);
            for (j, c) in cells.iter().enumerate() {
                v.push(c.as_f64().ok_or_else(|| LogFault::NotANumber {
                    test: name,
                    row: i,
                    column: j,
                    cell: c.to_string(),
                })?);
            }
            samples.push(sample(&v, factor));
        }
        tests.push(Test {
            name: name.to_string(),
            samples,
        });
    }
    Ok(SysIdLog {
        mechanism,
        unit,
        source: format!(
            "SysId JSON, test \"{}\", units \"{}\", unitsPerRotation {factor}",
            mechanism.name(),
            unit.name
        ),
        tests,
    })
}

/// One row as a sample; positions and speeds are scaled by `unitsPerRotation`.
fn sample(v: &[f64], factor: f64) -> Sample {
    if v.len() == 4 {
        return Sample {
            t_s: v[0],
            left: Side {
                voltage_v: v[1],
                position: v[2] * factor,
                velocity: v[3] * factor,
                current_a: None,
            },
            right: None,
            gyro_angle_rad: None,
            gyro_rate_rad_s: None,
        };
    }
    let side = |volt: f64, pos: f64, vel: f64| Side {
        voltage_v: volt,
        position: pos * factor,
        velocity: vel * factor,
        current_a: None,
    };
    Sample {
        t_s: v[0],
        left: side(v[1], v[3], v[5]),
        right: Some(side(v[2], v[4], v[6])),
        gyro_angle_rad: Some(v[7]),
        gyro_rate_rad_s: Some(v[8]),
    }
}
