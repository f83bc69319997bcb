//! The SysId routine in a WPILib DataLog, as `SysIdRoutineLog` writes it: a string entry
//! `sysid-test-state-LOG` holding `quasistatic-forward`, `quasistatic-reverse`,
//! `dynamic-forward`, `dynamic-reverse` or `none`, and per motor `M` the double entries
//! `voltage-M-LOG`, `position-M-LOG`, `velocity-M-LOG` (optionally `current-M-LOG`),
//! each with its unit as metadata (`Volts`, `Meters`, `MetersPerSecond`, `Rotations`,
//! `RotationsPerSecond`, `Amps`).
//!
//! A test is a stretch of the log in which the state holds one value other than `none`.
//! Its rows are the voltage samples of the (left) motor; every other channel is taken at
//! its sample nearest in time, within half a sample period, so that values logged a few
//! microseconds apart in one robot loop land in one row.

use super::datalog::{DataLog, Entry, Value};
use super::fault::LogFault;
use super::{unit, Mechanism, Sample, Side, SysIdLog, Test, Unit, STATE_PREFIX};

/// What the user says when the log alone does not decide.
#[derive(Debug, Clone, Default)]
pub struct Choice {
    /// Which routine (the `LOG` of `sysid-test-state-LOG`), when the log holds several.
    pub routine: Option<String>,
    /// The motor of a single mechanism, or the left and right motors of a drivetrain.
    pub motors: Vec<String>,
    /// The mechanism [default: a drivetrain for a left and a right motor, else simple].
    pub mechanism: Option<Mechanism>,
}

/// One motor's entries.
struct Motor<'a> {
    name: String,
    voltage: &'a Entry,
    position: &'a Entry,
    velocity: &'a Entry,
    current: Option<&'a Entry>,
}

fn find<'a>(log: &'a DataLog, name: &str) -> Option<&'a Entry> {
    log.entries.iter().find(|e| e.name == name)
}

/// The routine's name.
fn routine(log: &DataLog, choice: &Choice) -> Result<String, LogFault> {
    let names: Vec<&str> = log
        .entries
        .iter()
        .filter_map(|e| e.name.strip_prefix(STATE_PREFIX))
        .collect();
    match (&choice.routine, names.as_slice()) {
        (Some(r), _) if names.contains(&r.as_str()) => Ok(r.clone()),
        (Some(r), _) => Err(LogFault::NoSuchRoutine {
            routine: r.clone(),
            routines: names.iter().map(|n| n.to_string()).collect(),
        }),
        (None, [one]) => Ok(one.to_string()),
        (None, []) => Err(LogFault::NoRoutine {
            entries: log.entries.len(),
            examples: log.entries.iter().take(5).map(|e| e.name.clone()).collect(),
        }),
        (None, many) => Err(LogFault::SeveralRoutines(
            many.iter().map(|n| n.to_string()).collect(),
        )),
    }
}

/// The motors of the routine, as chosen or as the names say (left and right).
fn motors<'a>(
    log: &'a DataLog,
    routine: &str,
    choice: &Choice,
) -> Result<Vec<Motor<'a>>, LogFault> {
    let suffix = format!("-{routine}");
    let all: Vec<String> = log
        .entries
        .iter()
        .filter_map(|e| e.name.strip_prefix("voltage-")?.strip_suffix(&suffix))
        .map(String::from)
        .collect();
    let picked: Vec<String> = if !choice.motors.is_empty() {
        for m in &choice.motors {
            if !all.contains(m) {
                return Err(LogFault::NoSuchMotor {
                    motor: m.clone(),
                    routine: routine.to_string(),
                    motors: all,
                });
            }
        }
        choice.motors.clone()
    } else if all.len() == 1 {
        all.clone()
    } else {
        let side = |s: &str| {
            all.iter()
                .find(|m| m.to_ascii_lowercase().contains(s))
                .cloned()
        };
        match (all.len(), side("left"), side("right")) {
            (2, Some(l), Some(r)) => vec![l, r],
            _ => {
                return Err(LogFault::WhichMotors {
                    routine: routine.to_string(),
                    motors: all,
                })
            }
        }
    };
    if picked.len() > 2 {
        return Err(LogFault::TooManyMotors);
    }
    picked
        .into_iter()
        .map(|name| {
            let entry = |what: &str| {
                find(log, &format!("{what}-{name}{suffix}")).ok_or_else(|| LogFault::NoMotorEntry {
                    motor: name.clone(),
                    entry: format!("{what}-{name}{suffix}"),
                })
            };
            Ok(Motor {
                voltage: entry("voltage")?,
                position: entry("position")?,
                velocity: entry("velocity")?,
                current: entry("current").ok(),
                name,
            })
        })
        .collect()
}

/// The position unit the motor's entries declare (velocity must be the same per second).
fn declared_unit(m: &Motor) -> Result<Unit, LogFault> {
    let meta = |e: &Entry| e.metadata.trim().trim_matches('"').to_string();
    let volts = meta(m.voltage);
    if !matches!(volts.to_ascii_lowercase().as_str(), "volts" | "volt" | "v") {
        return Err(LogFault::NotVolts {
            entry: m.voltage.name.clone(),
            unit: volts,
        });
    }
    let p = meta(m.position);
    let u = unit(&p).ok_or_else(|| {
        if p.is_empty() {
            LogFault::NoPositionUnit(m.position.name.clone())
        } else {
            LogFault::UnknownPositionUnit {
                entry: m.position.name.clone(),
                unit: p.clone(),
            }
        }
    })?;
    let v = meta(m.velocity);
    let per = v
        .strip_suffix("PerSecond")
        .or_else(|| v.strip_suffix(" per second"))
        .and_then(unit);
    if per != Some(u) {
        return Err(LogFault::VelocityUnit {
            entry: m.velocity.name.clone(),
            unit: v,
            expected: u.name,
            position: m.position.name.clone(),
        });
    }
    Ok(u)
}

/// The numbers of an entry, (time s, value), NaNs refused.
fn numbers(e: &Entry) -> Result<Vec<(f64, f64)>, LogFault> {
    e.values
        .iter()
        .map(|(t, v)| match v {
            Value::Number(x) if x.is_finite() => Ok((*t as f64 * 1e-6, *x)),
            Value::Number(x) => Err(LogFault::NotFiniteValue {
                entry: e.name.clone(),
                t_s: *t as f64 * 1e-6,
                value: *x,
            }),
            _ => Err(LogFault::EntryType {
                entry: e.name.clone(),
                kind: e.kind.clone(),
                expected: "double",
            }),
        })
        .collect()
}

/// The value of `series` nearest `t`, if within `tol`.
fn nearest(series: &[(f64, f64)], t: f64, tol: f64) -> Option<f64> {
    let i = series.partition_point(|(ts, _)| *ts < t);
    [i.checked_sub(1), Some(i)]
        .into_iter()
        .flatten()
        .filter_map(|j| series.get(j))
        .filter(|(ts, _)| (ts - t).abs() <= tol)
        .min_by(|a, b| (a.0 - t).abs().total_cmp(&(b.0 - t).abs()))
        .map(|p| p.1)
}

/// The test stretches: (state, start s, end s).
fn stretches(state: &Entry) -> Result<Vec<(String, f64, f64)>, LogFault> {
    let mut marks: Vec<(i64, String)> = state
        .values
        .iter()
        .map(|(t, v)| match v {
            Value::Text(s) => Ok((*t, s.clone())),
            _ => Err(LogFault::EntryType {
                entry: state.name.clone(),
                kind: state.kind.clone(),
                expected: "string",
            }),
        })
        .collect::<Result<_, _>>()?;
    marks.sort_by_key(|m| m.0);
    let mut out: Vec<(String, f64, f64)> = Vec::new();
    let mut open: Option<(String, f64)> = None;
    for (t, s) in marks {
        let t = t as f64 * 1e-6;
        if open.as_ref().is_some_and(|(o, _)| *o == s) {
            continue;
        }
        if let Some((o, start)) = open.take() {
            out.push((o, start, t));
        }
        if s != "none" {
            open = Some((s, t));
        }
    }
    if let Some((o, start)) = open {
        out.push((o, start, f64::INFINITY));
    }
    Ok(out)
}

/// Extracts the routine's tests from a parsed log.
pub(crate) fn extract(log: &DataLog, choice: &Choice) -> Result<SysIdLog, LogFault> {
    let routine = routine(log, choice)?;
    let state = find(log, &format!("{STATE_PREFIX}{routine}")).expect("found by routine()");
    let motors = motors(log, &routine, choice)?;
    let unit = declared_unit(&motors[0])?;
    if let Some(r) = motors.get(1) {
        let u = declared_unit(r)?;
        if u != unit {
            return Err(LogFault::UnitsDiffer {
                left: motors[0].name.clone(),
                left_unit: unit.name,
                right: r.name.clone(),
                right_unit: u.name,
            });
        }
    }
    let chan = |m: &Motor| -> Result<[Vec<(f64, f64)>; 4], LogFault> {
        Ok([
            numbers(m.voltage)?,
            numbers(m.position)?,
            numbers(m.velocity)?,
            m.current.map(numbers).transpose()?.unwrap_or_default(),
        ])
    };
    let channels: Vec<[Vec<(f64, f64)>; 4]> = motors.iter().map(chan).collect::<Result<_, _>>()?;
    let mut tests: Vec<Test> = Vec::new();
    for (name, start, end) in stretches(state)? {
        let clock: Vec<f64> = channels[0][0]
            .iter()
            .map(|p| p.0)
            .filter(|t| *t >= start && *t < end)
            .collect();
        let mut periods: Vec<f64> = clock.windows(2).map(|w| w[1] - w[0]).collect();
        periods.sort_by(f64::total_cmp);
        let tol = 0.5 * periods.get(periods.len() / 2).copied().unwrap_or(0.0);
        let side = |c: &[Vec<(f64, f64)>; 4], m: &Motor, t: f64| -> Result<Side, LogFault> {
            let get = |k: usize, e: &Entry| {
                nearest(&c[k], t, tol).ok_or_else(|| LogFault::NoSample {
                    test: name.clone(),
                    t_s: t,
                    entry: e.name.clone(),
                    tolerance_ms: tol * 1e3,
                })
            };
            Ok(Side {
                voltage_v: get(0, m.voltage)?,
                position: get(1, m.position)?,
                velocity: get(2, m.velocity)?,
                current_a: nearest(&c[3], t, tol),
            })
        };
        let mut samples = Vec::with_capacity(clock.len());
        for &t in &clock {
            samples.push(Sample {
                t_s: t,
                left: side(&channels[0], &motors[0], t)?,
                right: match motors.get(1) {
                    Some(m) => Some(side(&channels[1], m, t)?),
                    None => None,
                },
                gyro_angle_rad: None,
                gyro_rate_rad_s: None,
            });
        }
        let name = unique_name(&tests, name);
        tests.push(Test { name, samples });
    }
    if tests.is_empty() {
        return Err(LogFault::NoTest(state.name.clone()));
    }
    let mechanism = mechanism_of(choice, motors.len(), &tests)?;
    let names: Vec<&str> = motors.iter().map(|m| m.name.as_str()).collect();
    Ok(SysIdLog {
        mechanism,
        unit,
        source: format!(
            "WPILib DataLog, routine `{routine}`, motor(s) {}",
            names.join(" and ")
        ),
        tests,
    })
}

/// The mechanism the user named (checked against the motors' count), else the one the
/// routine shows: one motor a simple mechanism, two a drivetrain, turning in place where
/// its sides are mostly driven in opposition.
fn mechanism_of(choice: &Choice, motors: usize, tests: &[Test]) -> Result<Mechanism, LogFault> {
    Ok(match (choice.mechanism, motors) {
        (Some(m), n) if m.is_drivetrain() != (n == 2) => {
            return Err(LogFault::MechanismMotors {
                mechanism: m.name(),
                needs: if m.is_drivetrain() { 2 } else { 1 },
                gives: n,
            })
        }
        (Some(m), _) => m,
        (None, 1) => Mechanism::Simple,
        (None, _) => {
            // Sides driven in opposition turn the robot in place.
            let opposed = tests
                .iter()
                .flat_map(|t| &t.samples)
                .filter(|s| {
                    s.right
                        .is_some_and(|r| r.voltage_v * s.left.voltage_v < 0.0)
                })
                .count();
            let total = tests.iter().map(|t| t.samples.len()).sum::<usize>();
            if 2 * opposed > total {
                Mechanism::DrivetrainAngular
            } else {
                Mechanism::Drivetrain
            }
        }
    })
}

/// A test's name, numbered (`quasistatic-forward-2`) where an earlier one has it.
fn unique_name(tests: &[Test], name: String) -> String {
    let repeats = tests
        .iter()
        .filter(|t| t.name == name || t.name.starts_with(&format!("{name}-")))
        .count();
    if repeats == 0 {
        name
    } else {
        format!("{name}-{}", repeats + 1)
    }
}
