//! WPILib SysId logs to contract recordings: the JSON data files of SysId (2022-2023) and
//! the DataLog (`.wpilog`) files that `SysIdRoutineLog` writes (2024 on). Both become a
//! [`SysIdLog`]: the mechanism, the position unit and the tests (quasistatic and dynamic,
//! forward and backward), each a list of samples in the log's own units. `convert`
//! turns each test into a recording (rig `vehicle` for drivetrains, `drive_axis` for a
//! single mechanism) with every unit conversion stated in its header, and `nominal_rig`
//! writes the rig a linear fit (SysId's kV and kA, [`crate::sysid`]) gives;
//! [`WpilibImport`] is the command's request, which makes the files.

pub mod datalog;
mod json;
pub mod wpilog;

mod convert;
mod fault;
mod importer;
use convert::{convert, feedforward, nominal_rig};
pub use convert::{gravity, Assumptions, Converted};
use fault::LogFault;
pub use importer::WpilibImport;

/// SysId's four tests, in the order it lists them (a JSON log's keys).
pub const TESTS: [&str; 4] = [
    "slow-forward",
    "slow-backward",
    "fast-forward",
    "fast-backward",
];

/// The prefix of a `.wpilog`'s entry of a routine's test state (`sysid-test-state-NAME`).
pub const STATE_PREFIX: &str = "sysid-test-state-";

use std::f64::consts::TAU;

/// The mechanism SysId characterised.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mechanism {
    /// Left and right sides driven the same way (straight line).
    Drivetrain,
    /// Sides driven in opposition (turning in place).
    DrivetrainAngular,
    /// One motor, no gravity (flywheel, roller).
    Simple,
    /// One motor lifting a constant weight.
    Elevator,
    /// One motor swinging a weight about a pivot.
    Arm,
}

impl std::str::FromStr for Mechanism {
    type Err = String;

    /// The mechanism as the command line names it (`drivetrain`, `drivetrain-angular`,
    /// `simple`, `elevator`, `arm`).
    fn from_str(s: &str) -> Result<Mechanism, String> {
        match s {
            "drivetrain" => Ok(Mechanism::Drivetrain),
            "drivetrain-angular" => Ok(Mechanism::DrivetrainAngular),
            "simple" => Ok(Mechanism::Simple),
            "elevator" => Ok(Mechanism::Elevator),
            "arm" => Ok(Mechanism::Arm),
            _ => Err(format!(
                "`{s}`: expected drivetrain, drivetrain-angular, simple, elevator or arm"
            )),
        }
    }
}

impl Mechanism {
    /// The name SysId's JSON uses in `"test"`.
    pub fn name(self) -> &'static str {
        match self {
            Mechanism::Drivetrain => "Drivetrain",
            Mechanism::DrivetrainAngular => "Drivetrain (Angular)",
            Mechanism::Simple => "Simple",
            Mechanism::Elevator => "Elevator",
            Mechanism::Arm => "Arm",
        }
    }

    /// The mechanism by its SysId name (any case).
    pub fn from_name(s: &str) -> Option<Mechanism> {
        [
            Mechanism::Drivetrain,
            Mechanism::DrivetrainAngular,
            Mechanism::Simple,
            Mechanism::Elevator,
            Mechanism::Arm,
        ]
        .into_iter()
        .find(|m| m.name().eq_ignore_ascii_case(s))
    }

    /// Whether it is a drivetrain (two sides).
    pub fn is_drivetrain(self) -> bool {
        matches!(self, Mechanism::Drivetrain | Mechanism::DrivetrainAngular)
    }
}

/// A unit of position as SysId names it, and its SI factor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Unit {
    /// The name as the log gives it (`Meters`, `Rotations`, ...).
    pub name: &'static str,
    /// Factor to metres (linear) or radians (angular).
    pub to_si: f64,
    /// Whether it is a length (else an angle).
    pub linear: bool,
}

/// The position units SysId offers.
pub const UNITS: [Unit; 6] = [
    Unit {
        name: "Meters",
        to_si: 1.0,
        linear: true,
    },
    Unit {
        name: "Feet",
        to_si: 0.3048,
        linear: true,
    },
    Unit {
        name: "Inches",
        to_si: 0.0254,
        linear: true,
    },
    Unit {
        name: "Rotations",
        to_si: TAU,
        linear: false,
    },
    Unit {
        name: "Radians",
        to_si: 1.0,
        linear: false,
    },
    Unit {
        name: "Degrees",
        to_si: TAU / 360.0,
        linear: false,
    },
];

/// The unit named `s` (SysId's names, singular or plural, any case).
pub fn unit(s: &str) -> Option<Unit> {
    let t = s.trim().to_ascii_lowercase();
    UNITS.iter().copied().find(|u| {
        let n = u.name.to_ascii_lowercase();
        t == n
            || t == n.trim_end_matches('s')
            || (n == "feet" && t == "foot")
            || (n == "inches" && t == "inch")
    })
}

/// One side's (or the one motor's) measurements at a sample, in the log's units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Side {
    /// Voltage, V.
    pub voltage_v: f64,
    /// Position, in the log's unit.
    pub position: f64,
    /// Position unit per second.
    pub velocity: f64,
    /// Current, A, when logged.
    pub current_a: Option<f64>,
}

/// One sample of a test.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Time, s.
    pub t_s: f64,
    /// The left side, or the mechanism's one motor.
    pub left: Side,
    /// The right side of a drivetrain.
    pub right: Option<Side>,
    /// Gyro heading, rad, and its rate, rad/s (drivetrains, when logged).
    pub gyro_angle_rad: Option<f64>,
    /// The gyro's rate, rad/s.
    pub gyro_rate_rad_s: Option<f64>,
}

/// One test of the routine.
#[derive(Debug, Clone, PartialEq)]
pub struct Test {
    /// `quasistatic-forward`, `dynamic-reverse`, ... (SysId's JSON says `slow-forward`,
    /// `fast-backward`; both are kept as the log names them).
    pub name: String,
    /// Its samples, in time order.
    pub samples: Vec<Sample>,
}

/// A whole SysId log.
#[derive(Debug, Clone, PartialEq)]
pub struct SysIdLog {
    /// The mechanism characterised.
    pub mechanism: Mechanism,
    /// Its position unit.
    pub unit: Unit,
    /// What each test says about where the data came from (file kind, entries).
    pub source: String,
    /// The tests, in log order.
    pub tests: Vec<Test>,
}

/// Why a log cannot be imported: the file and the field, test, row or record at fault.
#[derive(Debug, thiserror::Error)]
#[error("{file}: {message}")]
pub struct SysIdError {
    /// The log.
    pub file: std::path::PathBuf,
    /// What is wrong, with the test, row or record.
    pub message: String,
}

/// Checks a test's samples as the contract needs them: times strictly increasing, every
/// value finite. Reported with the test and the row (from 0), never fixed.
pub(crate) fn check_test(test: &Test) -> Result<(), LogFault> {
    let mut last: Option<f64> = None;
    for (i, s) in test.samples.iter().enumerate() {
        let mut values = vec![
            ("timestamp", s.t_s),
            ("voltage", s.left.voltage_v),
            ("position", s.left.position),
            ("velocity", s.left.velocity),
        ];
        if let Some(r) = s.right {
            values.extend([
                ("right voltage", r.voltage_v),
                ("right position", r.position),
                ("right velocity", r.velocity),
            ]);
        }
        values.extend(s.gyro_angle_rad.map(|v| ("gyro angle", v)));
        values.extend(s.gyro_rate_rad_s.map(|v| ("gyro rate", v)));
        if let Some((what, v)) = values.iter().find(|(_, v)| !v.is_finite()) {
            return Err(LogFault::NotFinite {
                test: test.name.clone(),
                row: i,
                what,
                value: *v,
            });
        }
        // A timestamp is microseconds since the robot started: far below 1e12 s.
        if let Some((what, v)) = values
            .iter()
            .find(|(_, v)| v.abs() > crate::record::MAX_CELL_MAGNITUDE)
        {
            return Err(LogFault::Unphysical {
                test: test.name.clone(),
                row: i,
                what,
                value: *v,
            });
        }
        if let Some(prev) = last.filter(|p| s.t_s <= *p) {
            let how = if s.t_s == prev {
                "repeats"
            } else {
                "goes back from"
            };
            return Err(LogFault::TimeBack {
                test: test.name.clone(),
                row: i,
                t_s: s.t_s,
                how,
                previous_s: prev,
            });
        }
        last = Some(s.t_s);
    }
    if test.samples.len() < 2 {
        return Err(LogFault::TooFewRows {
            test: test.name.clone(),
            rows: test.samples.len(),
        });
    }
    check_gaps(test)
}

/// A gap in a test's time stamps far beyond its sampling (a corrupt or mistyped stamp):
/// fitted as it stands it makes the fits' time constants absurd, so it is reported.
fn check_gaps(test: &Test) -> Result<(), LogFault> {
    let dts: Vec<f64> = test
        .samples
        .windows(2)
        .map(|w| w[1].t_s - w[0].t_s)
        .collect();
    let mut sorted = dts.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    // A logger may pause between bursts; a jump of a thousand intervals and a second
    // or more is no pause of a SysId test.
    let limit = (1000.0 * median).max(1.0);
    if let Some((i, dt)) = dts.iter().enumerate().find(|(_, dt)| **dt > limit) {
        return Err(LogFault::TimeGap {
            test: test.name.clone(),
            row: i + 1,
            t_s: test.samples[i + 1].t_s,
            gap_s: *dt,
            times: dt / median,
            median_s: median,
        });
    }
    Ok(())
}

/// Reads a SysId log, JSON or DataLog (told apart by the DataLog's `WPILOG` mark).
pub fn load(path: &std::path::Path, choice: &wpilog::Choice) -> Result<SysIdLog, SysIdError> {
    let fail = |message: String| SysIdError {
        file: path.to_owned(),
        message,
    };
    let bytes = crate::output::read_bounded(path, crate::output::MAX_INPUT_BYTES)
        .map_err(|e| fail(format!("cannot read: {e}")))?;
    if bytes.starts_with(b"WPILOG") {
        let log = datalog::parse(&bytes).map_err(|e| fail(e.to_string()))?;
        wpilog::extract(&log, choice).map_err(|e| fail(e.to_string()))
    } else {
        if !choice.motors.is_empty() || choice.routine.is_some() || choice.mechanism.is_some() {
            return Err(fail("--routine, --motors and --mechanism choose inside a DataLog (.wpilog); a JSON file says its own".into()));
        }
        let text = String::from_utf8(bytes)
            .map_err(|_| fail("neither a DataLog (no `WPILOG` mark) nor UTF-8 JSON text".into()))?;
        json::parse(&text).map_err(|e| fail(e.to_string()))
    }
}

/// An imported log: one recording per test, the nominal rig and SysId's gains.
#[derive(Debug, Clone)]
pub struct Imported {
    /// The log as read.
    pub log: SysIdLog,
    /// One recording per test.
    pub recordings: Vec<Converted>,
    /// The nominal rig's text.
    pub rig: String,
    /// SysId's gains from its own regression.
    pub feedforward: crate::sysid::Feedforward,
    /// The speed unit the gains are per (`m/s` or `rad/s`).
    pub speed_unit: &'static str,
}

/// Reads, checks and converts a SysId log.
pub fn import(
    path: &std::path::Path,
    choice: &wpilog::Choice,
    assumptions: &Assumptions,
) -> Result<Imported, SysIdError> {
    let log = load(path, choice)?;
    let fail = |fault: LogFault| SysIdError {
        file: path.to_owned(),
        message: fault.to_string(),
    };
    let recordings = convert(&log, &path.display().to_string(), assumptions).map_err(fail)?;
    let feedforward = feedforward(&log, assumptions).map_err(fail)?;
    let rig = nominal_rig(&log, &feedforward, assumptions).map_err(fail)?;
    let speed_unit = if log.mechanism.is_drivetrain() {
        "m/s"
    } else {
        "rad/s"
    };
    Ok(Imported {
        log,
        recordings,
        rig,
        feedforward,
        speed_unit,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A velocity of 1e300 is refused naming the test, the row and the value (its speed
    /// made SysId's motion threshold infinite: "0 pairs above the motion threshold inf").
    #[test]
    fn a_value_beyond_any_physical_one_is_refused_naming_its_row() {
        let side = |velocity| Side {
            voltage_v: 1.0,
            position: 0.0,
            velocity,
            current_a: None,
        };
        let sample = |t_s, velocity| Sample {
            t_s,
            left: side(velocity),
            right: None,
            gyro_angle_rad: None,
            gyro_rate_rad_s: None,
        };
        let mut test = Test {
            name: "slow-forward".into(),
            samples: vec![sample(0.0, 0.1), sample(0.02, 1e300)],
        };
        let e = check_test(&test).unwrap_err().to_string();
        assert!(
            e.contains("test `slow-forward`, row 1: velocity is 1e300, beyond any physical value"),
            "{e}"
        );
        test.samples[1].left.velocity = 0.2;
        assert!(check_test(&test).is_ok());
    }
}
