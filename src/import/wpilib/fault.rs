//! What can be wrong with a SysId log, by where it is found: the JSON file's keys and rows,
//! the DataLog's routine, motors and entries, a test's samples, and what the conversion
//! needs. [`super::load`] and [`super::import`] report each with the file as a
//! [`super::SysIdError`].

use super::{STATE_PREFIX, TESTS};
use crate::sysid::FeedforwardError;

/// One fault of a SysId log; its text names the key, entry, test and row at fault.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LogFault {
    // The JSON file.
    /// Not JSON at all.
    #[error("not valid JSON at line {line}, column {column}: {error} (NaN or Infinity are not JSON numbers)")]
    NotJson {
        /// Where the parser stopped (from 1).
        line: usize,
        /// Where the parser stopped (from 1).
        column: usize,
        /// What the parser says.
        error: String,
    },
    /// JSON, but not an object.
    #[error("expected a JSON object with SysId's keys (\"test\", \"units\", ...)")]
    NotAnObject,
    /// An object without SysId's mark.
    #[error("no `\"sysid\": true`: not a SysId data file (an frc-characterization file must be opened and saved by SysId first)")]
    NotSysId,
    /// A key that must be text is missing or is not.
    #[error("`{0}`: missing or not a string")]
    TextKey(&'static str),
    /// No position unit.
    #[error("`units`: missing or not a string; the file must declare its position unit")]
    NoUnits,
    /// A `test` SysId does not write.
    #[error(
        "`test` = \"{0}\": expected Drivetrain, Drivetrain (Angular), Simple, Elevator or Arm"
    )]
    UnknownTest(String),
    /// A `units` SysId does not write.
    #[error("`units` = \"{0}\": expected Meters, Feet, Inches, Rotations, Radians or Degrees")]
    UnknownUnits(String),
    /// No usable `unitsPerRotation`.
    #[error("`unitsPerRotation`: missing, or not a positive number")]
    UnitsPerRotation,
    /// One of the four tests is missing.
    #[error("`{0}`: missing (SysId's four tests are {tests})", tests = TESTS.join(", "))]
    MissingTest(&'static str),
    /// A test that is not a list.
    #[error("`{0}`: expected a list of rows")]
    NotRows(&'static str),
    /// A row of the wrong shape.
    #[error("`{test}`, row {row}: expected a list of {width} numbers for a {mechanism} test")]
    RowWidth {
        /// The test.
        test: &'static str,
        /// The row, from 0.
        row: usize,
        /// How many numbers a row of the mechanism has.
        width: usize,
        /// The mechanism's name.
        mechanism: &'static str,
    },
    /// A cell that is not a number.
    #[error("`{test}`, row {row}, column {column}: `{cell}` is not a number")]
    NotANumber {
        /// The test.
        test: &'static str,
        /// The row, from 0.
        row: usize,
        /// The column, from 0.
        column: usize,
        /// The cell as written.
        cell: String,
    },

    // The DataLog.
    /// The routine asked for is not in the log.
    #[error("no entry `{prefix}{routine}`; the log's routines: {}", list_or(.routines, "none"), prefix = STATE_PREFIX)]
    NoSuchRoutine {
        /// The routine asked for.
        routine: String,
        /// The log's routines.
        routines: Vec<String>,
    },
    /// No routine at all.
    #[error("no `{prefix}...` entry: not a log of a WPILib SysIdRoutine ({entries} entries, e.g. {})", crate::numtext::backticked(.examples), prefix = STATE_PREFIX)]
    NoRoutine {
        /// How many entries the log has.
        entries: usize,
        /// The first few entries' names.
        examples: Vec<String>,
    },
    /// Several routines, none chosen.
    #[error("the log holds several routines ({}); choose one with --routine", .0.join(", "))]
    SeveralRoutines(Vec<String>),
    /// A motor asked for that the routine does not log.
    #[error("no motor `{motor}` in routine `{routine}`; its motors: {}", .motors.join(", "))]
    NoSuchMotor {
        /// The motor asked for.
        motor: String,
        /// The routine.
        routine: String,
        /// The routine's motors.
        motors: Vec<String>,
    },
    /// Motors that are not one, nor a left and a right.
    #[error("routine `{routine}` logs motors {}; name the one motor, or the left and right motors, with --motors", list_or(.motors, "(none)"))]
    WhichMotors {
        /// The routine.
        routine: String,
        /// Its motors.
        motors: Vec<String>,
    },
    /// More than two motors asked for.
    #[error("--motors takes one motor, or a left and a right motor")]
    TooManyMotors,
    /// A motor without one of its entries.
    #[error("motor `{motor}` has no `{entry}` entry")]
    NoMotorEntry {
        /// The motor.
        motor: String,
        /// The entry it lacks.
        entry: String,
    },
    /// A voltage entry not in volts.
    #[error("entry `{entry}` declares its unit as `{unit}`; expected Volts")]
    NotVolts {
        /// The entry.
        entry: String,
        /// Its unit as declared.
        unit: String,
    },
    /// A position entry without a unit.
    #[error(
        "entry `{0}` declares no unit (empty metadata); the log must say what its positions are in"
    )]
    NoPositionUnit(String),
    /// A position unit SysId does not use.
    #[error("entry `{entry}`: unit `{unit}` is not one SysId uses (Meters, Feet, Inches, Rotations, Radians, Degrees)")]
    UnknownPositionUnit {
        /// The entry.
        entry: String,
        /// Its unit as declared.
        unit: String,
    },
    /// A velocity unit that is not the position's per second.
    #[error(
        "entry `{entry}` declares `{unit}`; expected {expected}PerSecond to match `{position}`"
    )]
    VelocityUnit {
        /// The velocity entry.
        entry: String,
        /// Its unit as declared.
        unit: String,
        /// The position's unit.
        expected: &'static str,
        /// The position entry.
        position: String,
    },
    /// Two motors in different units.
    #[error(
        "motor `{left}` logs {left_unit} and motor `{right}` {right_unit}: one unit is needed"
    )]
    UnitsDiffer {
        /// The first motor.
        left: String,
        /// Its unit.
        left_unit: &'static str,
        /// The second motor.
        right: String,
        /// Its unit.
        right_unit: &'static str,
    },
    /// A value that is not finite.
    #[error("entry `{entry}` at t = {t_s} s: value {value} is not finite")]
    NotFiniteValue {
        /// The entry.
        entry: String,
        /// When, s.
        t_s: f64,
        /// The value.
        value: f64,
    },
    /// An entry of the wrong type.
    #[error("entry `{entry}` has type `{kind}`; expected {expected}")]
    EntryType {
        /// The entry.
        entry: String,
        /// Its type.
        kind: String,
        /// The type it needs.
        expected: &'static str,
    },
    /// A channel with no sample near a test's time.
    #[error("test `{test}` at t = {t_s:.6} s: entry `{entry}` has no sample within {tolerance_ms:.1} ms")]
    NoSample {
        /// The test.
        test: String,
        /// The time, s.
        t_s: f64,
        /// The entry.
        entry: String,
        /// How near a sample must be, ms.
        tolerance_ms: f64,
    },
    /// The routine's state never names a test.
    #[error("entry `{0}` never leaves `none`: the log holds no test")]
    NoTest(String),
    /// A mechanism named with the wrong number of motors.
    #[error("--mechanism {mechanism}: needs {needs} motor(s), the routine gives {gives}")]
    MechanismMotors {
        /// The mechanism named.
        mechanism: &'static str,
        /// How many motors it needs.
        needs: usize,
        /// How many the routine gives.
        gives: usize,
    },

    // A test's samples.
    /// A value beyond any physical one (its magnitude past
    /// [`crate::record::MAX_CELL_MAGNITUDE`]): its speed would make the motion threshold
    /// infinite.
    #[error("test `{test}`, row {row}: {what} is {value:e}, beyond any physical value (magnitude above 1e12): a damaged log or a sentinel?")]
    Unphysical {
        /// The test.
        test: String,
        /// The row, from 0.
        row: usize,
        /// Which value.
        what: &'static str,
        /// The value.
        value: f64,
    },
    /// A value that is not finite.
    #[error("test `{test}`, row {row}: {what} is {value}, not a finite number")]
    NotFinite {
        /// The test.
        test: String,
        /// The row, from 0.
        row: usize,
        /// Which value.
        what: &'static str,
        /// The value.
        value: f64,
    },
    /// A timestamp that repeats or goes back.
    #[error("test `{test}`, row {row}: timestamp {t_s} s {how} the previous row's {previous_s} s (reported, not fixed)")]
    TimeBack {
        /// The test.
        test: String,
        /// The row, from 0.
        row: usize,
        /// Its timestamp, s.
        t_s: f64,
        /// `repeats` or `goes back from`.
        how: &'static str,
        /// The previous row's, s.
        previous_s: f64,
    },
    /// Too few rows to fit.
    #[error("test `{test}` has {rows} row(s); at least two are needed")]
    TooFewRows {
        /// The test.
        test: String,
        /// Its rows.
        rows: usize,
    },
    /// A gap far beyond the test's sampling.
    #[error("test `{test}`, row {row}: timestamp {} s is {} s after the previous row's, {times:.0} times the test's median interval of {} s: a corrupt time stamp? (reported, not fixed)", plain(.t_s), plain(.gap_s), plain(.median_s))]
    TimeGap {
        /// The test.
        test: String,
        /// The row after the gap, from 0.
        row: usize,
        /// Its timestamp, s.
        t_s: f64,
        /// The gap, s.
        gap_s: f64,
        /// The gap over the median interval.
        times: f64,
        /// The test's median interval, s.
        median_s: f64,
    },

    // The conversion.
    /// A drivetrain's rotary speeds without a wheel radius.
    #[error("the drivetrain's speeds are in {0}/s; wheel speeds in m/s need the wheel radius: give --wheel-radius-m")]
    NeedsWheelRadius(&'static str),
    /// A mechanism's linear speeds without a drum radius.
    #[error("the mechanism's speeds are in {0}/s; a drive axis turns them into shaft speed by a drum radius: give --wheel-radius-m")]
    NeedsDrumRadius(&'static str),
    /// The regression failed.
    #[error("{0}")]
    Feedforward(#[from] FeedforwardError),
    /// Gains no linear machine has.
    #[error("SysId's gains kV = {kv}, kA = {ka} are not both positive: no linear machine has them; the rig is not written")]
    GainsNotPositive {
        /// kV.
        kv: f64,
        /// kA.
        ka: f64,
    },
    /// Gains that give no chassis inertia.
    #[error("kA = {ka} with kV = {kv} and resistance {resistance_ohm} ohm gives no positive chassis inertia: SysId's kA must be positive")]
    NoChassisInertia {
        /// kA.
        ka: f64,
        /// kV.
        kv: f64,
        /// The armature resistance, ohm.
        resistance_ohm: f64,
    },
}

/// A number as reports print it ([`crate::param::plain_number`]).
fn plain(v: &f64) -> String {
    crate::param::plain_number(*v)
}

/// Names joined by commas, or `empty` for none.
fn list_or(names: &[String], empty: &str) -> String {
    if names.is_empty() {
        empty.to_string()
    } else {
        names.join(", ")
    }
}
