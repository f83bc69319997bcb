//! A SysId log's tests as contract recordings, the speeds the feedforward regression
//! reads, and the nominal rig a linear fit gives.

use crate::model::chassis::ChassisParams;
use crate::model::gearbox::GearboxParams;
use crate::model::motor::MotorParams;
use crate::model::wheel::WheelParams;
use crate::record::channels as chan;
use crate::rig::keys::alias;
use std::fmt::Write as _;

use super::fault::LogFault;
use super::{Mechanism, Sample, SysIdLog, Test};
use crate::rig::{Rig, RigKind};
use crate::sysid::{self as feedforward, Feedforward, Gravity, Series};

/// What the log cannot say and the user may: each `None` takes the stated default.
#[derive(Debug, Clone, Default)]
pub struct Assumptions {
    /// Drive wheel radius, m (a drivetrain logged in rotations needs it; the vehicle rig
    /// always does) [default 0.0762 m, a 6-inch wheel].
    pub wheel_radius_m: Option<f64>,
    /// Motor resistance per side, ohm [default: from the logged current, else 0.05 ohm].
    pub resistance_ohm: Option<f64>,
    /// Track width, m [default: from the gyro of a turning test, else 0.6 m].
    pub track_width_m: Option<f64>,
    /// Battery voltage, V [default 12].
    pub supply_v: Option<f64>,
}

const DEFAULT_WHEEL_RADIUS_M: f64 = 0.0762;
const DEFAULT_RESISTANCE_OHM: f64 = 0.05;
const DEFAULT_TRACK_WIDTH_M: f64 = 0.6;
/// Electrical time constant assumed for the inductance, s.
const ELECTRICAL_TIME_S: f64 = 0.001;
/// Share of a drivetrain side's inertia (what kA accelerates, referred to the wheel) that
/// turns with the wheel: rotors through the gearbox and the wheel, half each (assumed;
/// two small motors through an 8:1 gearbox on a 6-inch wheel turn about a tenth of it).
/// The chassis carries the rest. The split is invisible to kA, but it sets how fast a
/// slipping wheel spins up against its tyre, a mode the wheel-slip model must resolve.
const DRIVE_ROTATING_SHARE: f64 = 0.1;

/// One converted test: its file stem suffix and its recording's text.
#[derive(Debug, Clone)]
pub struct Converted {
    /// The test's name (the recording's file-name suffix).
    pub test: String,
    /// The recording's text.
    pub text: String,
}

/// The factor from the log's speed unit to the recording's: m/s for a drivetrain's wheel,
/// rad/s for a single mechanism's shaft. Also the conversion's wording.
fn speed_factor(log: &SysIdLog, a: &Assumptions) -> Result<(f64, String), LogFault> {
    let u = log.unit;
    if log.mechanism.is_drivetrain() {
        if u.linear {
            return Ok((u.to_si, format!("{}/s x {}", u.name, u.to_si)));
        }
        let r = a.wheel_radius_m.ok_or(LogFault::NeedsWheelRadius(u.name))?;
        return Ok((
            u.to_si * r,
            format!("{}/s x {} rad x {r} m wheel radius", u.name, u.to_si),
        ));
    }
    if !u.linear {
        return Ok((
            u.to_si,
            format!(
                "{}/s x {} (the measured shaft is the rig's motor shaft, ratio 1)",
                u.name, u.to_si
            ),
        ));
    }
    let r = a.wheel_radius_m.ok_or(LogFault::NeedsDrumRadius(u.name))?;
    Ok((
        u.to_si / r,
        format!("{}/s x {} / {r} m drum radius", u.name, u.to_si),
    ))
}

/// The tests as recordings.
pub(crate) fn convert(
    log: &SysIdLog,
    source: &str,
    a: &Assumptions,
) -> Result<Vec<Converted>, LogFault> {
    let (f, how) = speed_factor(log, a)?;
    let mut out = Vec::new();
    for test in &log.tests {
        super::check_test(test)?;
        let t0 = test.samples[0].t_s;
        let drive = log.mechanism.is_drivetrain();
        let mut meta = vec![
            (
                "description",
                format!("WPILib SysId test {} ({})", test.name, log.mechanism.name()),
            ),
            ("source", format!("{source}: {}", log.source)),
            ("sample_time_s", format!("{}", median_period(test))),
            (
                "time_origin_s",
                format!("{t0} (the log's time of the test's first row; t_s counts from it)"),
            ),
        ];
        let current = test.samples.iter().any(|x| x.left.current_a.is_some());
        let rates: Vec<f64> = test
            .samples
            .iter()
            .filter_map(|x| x.gyro_rate_rad_s)
            .collect();
        // A gyro that reads one constant (a simulated log, or one not wired) says nothing
        // a fit can use, and an output reproduced exactly leaves the fit no noise to weigh.
        let constant = rates.windows(2).all(|w| w[0] == w[1]);
        let gyro = drive && !rates.is_empty() && !constant;
        if drive && !rates.is_empty() && constant {
            meta.push((
                "note",
                format!(
                    "yaw_rate_rad_s left out: the gyro reads {} rad/s throughout this test",
                    rates[0]
                ),
            ));
        }
        let mut header = vec![chan::T_S];
        if drive {
            meta.push((
                "conversion",
                format!("left_wheel_speed_m_s, right_wheel_speed_m_s = velocity in {how}"),
            ));
            header.extend([
                chan::LEFT_VOLTAGE_V,
                chan::RIGHT_VOLTAGE_V,
                chan::LEFT_WHEEL_SPEED_M_S,
                chan::RIGHT_WHEEL_SPEED_M_S,
            ]);
            if gyro {
                meta.push(("conversion", "yaw_rate_rad_s = the gyro's angular rate, rad/s as SysId's drivetrain logger sends it".into()));
                header.push(chan::YAW_RATE_RAD_S);
            }
        } else {
            meta.push((
                "conversion",
                format!(
                    "motor_speed_rad_s = velocity in {how}; motor_angle_rad likewise from position"
                ),
            ));
            header.extend([
                chan::VOLTAGE_V,
                chan::MOTOR_ANGLE_RAD,
                chan::MOTOR_SPEED_RAD_S,
            ]);
            if current {
                header.push(chan::CURRENT_A);
            }
        }
        let rig = if drive {
            RigKind::Vehicle
        } else {
            RigKind::DriveAxis
        };
        let mut s = crate::record::header(rig, &meta, &header);
        for x in &test.samples {
            let _ = writeln!(s, "{}", sample_row(x, t0, f, drive, gyro, current));
        }
        out.push(Converted {
            test: test.name.clone(),
            text: s,
        });
    }
    Ok(out)
}

/// One sample as a recording's row: time from the test's start `t0`, the voltages, and
/// the speeds (and positions) times `f`; a drivetrain's wheels and gyro (`gyro`), else the
/// shaft and its current (`current`).
fn sample_row(x: &Sample, t0: f64, f: f64, drive: bool, gyro: bool, current: bool) -> String {
    let mut row = vec![format!("{}", x.t_s - t0)];
    if let (true, Some(r)) = (drive, x.right) {
        row.extend(
            [
                x.left.voltage_v,
                r.voltage_v,
                x.left.velocity * f,
                r.velocity * f,
            ]
            .map(|v| format!("{v}")),
        );
        if gyro {
            row.push(x.gyro_rate_rad_s.map_or(String::new(), |v| format!("{v}")));
        }
    } else {
        row.extend(
            [x.left.voltage_v, x.left.position * f, x.left.velocity * f].map(|v| format!("{v}")),
        );
        if current {
            row.push(x.left.current_a.map_or(String::new(), |v| format!("{v}")));
        }
    }
    row.join(",")
}

fn median_period(test: &Test) -> f64 {
    let mut d: Vec<f64> = test
        .samples
        .windows(2)
        .map(|w| w[1].t_s - w[0].t_s)
        .collect();
    d.sort_by(f64::total_cmp);
    d.get(d.len() / 2).copied().unwrap_or(0.0)
}

/// The series SysId's regression reads, in the recording's units (m/s of wheel rim for a
/// drivetrain, both sides together as SysId combines them; rad/s of shaft otherwise). A
/// turning drivetrain is read as SysId reads it: the mean of the two sides' magnitudes,
/// signed by the direction of turn.
pub(crate) fn series(log: &SysIdLog, a: &Assumptions) -> Result<Vec<Series>, LogFault> {
    let (f, _) = speed_factor(log, a)?;
    let mut out = Vec::new();
    for test in &log.tests {
        let mut sides = vec![Series::default()];
        if log.mechanism == Mechanism::Drivetrain {
            sides.push(Series::default());
        }
        for x in &test.samples {
            let right = x.right;
            let (u, v) = match (log.mechanism, right) {
                (Mechanism::DrivetrainAngular, Some(r)) => {
                    let turn = x.gyro_rate_rad_s.unwrap_or(r.velocity - x.left.velocity);
                    let sign = if turn < 0.0 { -1.0 } else { 1.0 };
                    (
                        sign * 0.5 * (x.left.voltage_v.abs() + r.voltage_v.abs()),
                        sign * 0.5 * (x.left.velocity.abs() + r.velocity.abs()) * f,
                    )
                }
                _ => (x.left.voltage_v, x.left.velocity * f),
            };
            let angle = if log.unit.linear {
                0.0
            } else {
                x.left.position * log.unit.to_si
            };
            push(&mut sides[0], x.t_s, u, v, angle);
            if let (Some(s), Some(r)) = (sides.get_mut(1), right) {
                push(s, x.t_s, r.voltage_v, r.velocity * f, 0.0);
            }
        }
        out.extend(sides);
    }
    Ok(out)
}

fn push(s: &mut Series, t: f64, u: f64, v: f64, angle: f64) {
    s.t_s.push(t);
    s.voltage_v.push(u);
    s.speed.push(v);
    s.angle_rad.push(angle);
}

/// The gravity term SysId fits for the mechanism.
pub fn gravity(m: Mechanism) -> Gravity {
    match m {
        Mechanism::Elevator => Gravity::Constant,
        Mechanism::Arm => Gravity::Arm,
        _ => Gravity::None,
    }
}

/// The regression on the whole log.
pub(crate) fn feedforward(log: &SysIdLog, a: &Assumptions) -> Result<Feedforward, LogFault> {
    let s = series(log, a)?;
    feedforward::fit(
        &s,
        gravity(log.mechanism),
        feedforward::default_threshold(&s),
    )
    .map_err(LogFault::from)
}

/// Resistance from the logged current, by least squares on `u - kV v = R i` (no Coulomb
/// term: the rig is the linear machine).
fn resistance_from_current(log: &SysIdLog, kv: f64, f: f64) -> Option<f64> {
    let (mut num, mut den) = (0.0, 0.0);
    for x in log.tests.iter().flat_map(|t| &t.samples) {
        if let Some(i) = x.left.current_a {
            num += (x.left.voltage_v - kv * x.left.velocity * f) * i;
            den += i * i;
        }
    }
    (den > 0.0).then(|| num / den).filter(|r| *r > 0.0)
}

/// The nominal rig of the linear machine SysId's kV and kA describe, as TOML text with a
/// header that says which values came from the log and which were assumed.
pub(crate) fn nominal_rig(
    log: &SysIdLog,
    ff: &Feedforward,
    a: &Assumptions,
) -> Result<String, LogFault> {
    let (f, _) = speed_factor(log, a)?;
    let kv = ff.kv_v_s_per_unit.value;
    let ka = ff.ka_v_s2_per_unit.value;
    if !(kv > 0.0 && ka > 0.0) {
        return Err(LogFault::GainsNotPositive { kv, ka });
    }
    let mut notes = vec![format!("kV = {kv:.6}, kA = {ka:.6} from SysId's regression on every test (kS = {:.4} V left out: the rig is the linear machine; diagnosis looks for the friction)", ff.ks_v.value)];
    let (r_ohm, r_note) = match (a.resistance_ohm, resistance_from_current(log, kv, f)) {
        (Some(r), _) => (r, "given".to_string()),
        (None, Some(r)) => (r, "from the logged current".to_string()),
        (None, None) => (
            DEFAULT_RESISTANCE_OHM,
            "ASSUMED: the log has no current, so only J R / K^2 is known; give --resistance-ohm"
                .to_string(),
        ),
    };
    notes.push(format!("resistance {r_ohm:.5} ohm {r_note}; inductance = resistance x {ELECTRICAL_TIME_S} s (assumed)"));
    let mut rig = Rig::new(RigKind::DriveAxis);
    rig.set(MotorParams::resistance_ohm.key(), r_ohm);
    rig.set(MotorParams::inductance_h.key(), r_ohm * ELECTRICAL_TIME_S);
    rig.set(MotorParams::viscous_nm_s_rad.key(), 0.0);
    rig.set(GearboxParams::ratio.key(), 1.0);
    // SysId logs the voltage each controller applied (its output times the bus voltage it
    // measured): the battery's sag and limit are already in it. A supply is stated only
    // when given, for a simulation that needs one.
    match a.supply_v {
        Some(v) => {
            rig.set(alias::SUPPLY_VOLTAGE_V.key(), v);
        }
        None => notes.push("no [supply]: the logged voltages are what the controllers applied, the battery's sag and limit already in them (give --supply-v to state one)".into()),
    }
    if log.mechanism.is_drivetrain() {
        let r = a.wheel_radius_m.unwrap_or(DEFAULT_WHEEL_RADIUS_M);
        let k = kv * r;
        // What kA accelerates per side, referred to the wheel: kg m^2.
        let total = ka * k * r / r_ohm;
        let j = DRIVE_ROTATING_SHARE * total;
        let side_inertia = (total - j) / r; // kg m: the chassis's share, over r
        let w = a
            .track_width_m
            .or_else(|| track_width(log))
            .unwrap_or(DEFAULT_TRACK_WIDTH_M);
        let (mass, yaw) = if log.mechanism == Mechanism::DrivetrainAngular {
            let yaw = side_inertia * w * w / (2.0 * r);
            (6.0 * yaw / (w * w), yaw)
        } else {
            let mass = 2.0 * side_inertia / r;
            (mass, mass * w * w / 6.0)
        };
        if !(mass > 0.0) {
            return Err(LogFault::NoChassisInertia {
                ka,
                kv,
                resistance_ohm: r_ohm,
            });
        }
        rig.set(MotorParams::torque_constant_nm_a.key(), k);
        rig.set(MotorParams::rotor_inertia_kg_m2.key(), 0.5 * j);
        rig.rig = RigKind::Vehicle;
        rig.set(WheelParams::radius_m.key(), r);
        rig.set(WheelParams::inertia_kg_m2.key(), 0.5 * j);
        rig.set(ChassisParams::mass_kg.key(), mass);
        rig.set(ChassisParams::yaw_inertia_kg_m2.key(), yaw);
        rig.set(ChassisParams::track_width_m.key(), w);
        rig.set(ChassisParams::drive_load_fraction.key(), 1.0);
        notes.push(format!("gearbox ratio 1 and wheel radius {r} m ({}): the torque constant is kV x radius, referred to the wheel; rotor and wheel inertia {:.4} kg m^2 each: {:.0} % of kA's inertia turns with the wheels (assumed)", if a.wheel_radius_m.is_some() { "given" } else { "ASSUMED, give --wheel-radius-m" }, 0.5 * j, 100.0 * DRIVE_ROTATING_SHARE));
        notes.push(format!("track width {w} m ({}); {}", if a.track_width_m.is_some() { "given" } else if track_width(log).is_some() { "from the gyro" } else { "ASSUMED, give --track-width-m" }, if log.mechanism == Mechanism::DrivetrainAngular { "yaw inertia from kA, mass from it as a uniform square of side track width (assumed)" } else { "mass from kA, yaw inertia as a uniform square of side track width (assumed)" }));
    } else {
        rig.set(MotorParams::torque_constant_nm_a.key(), kv);
        rig.set(MotorParams::rotor_inertia_kg_m2.key(), ka * kv / r_ohm);
        rig.rig = RigKind::DriveAxis;
        rig.set(
            WheelParams::radius_m.key(),
            a.wheel_radius_m.unwrap_or(DEFAULT_WHEEL_RADIUS_M),
        );
        rig.set(WheelParams::inertia_kg_m2.key(), 0.0);
        notes.push("gearbox ratio 1: the measured shaft is the motor shaft; its whole inertia is the rotor's (kA x kV / resistance)".into());
    }
    let inertia_key = state_uncertainties(
        &mut rig,
        ff,
        a.resistance_ohm.is_none() && r_note.starts_with("ASSUMED"),
        log.mechanism,
    );
    notes.push(format!(
        "[uncertainty_pct]: motor.torque_constant_Nm_A and {inertia_key} as uncertain as SysId's kV and kA ({:.2} % and {:.2} %); what was assumed {ASSUMED_UNCERTAINTY_PCT} %",
        relative_pct(ff.kv_v_s_per_unit),
        relative_pct(ff.ka_v_s2_per_unit),
    ));
    let body = rig.to_toml();
    let mut s = format!(
        "# Nominal rig of {} from a linear fit (agvsim import wpilib)\n",
        log.source
    );
    for n in notes {
        let _ = writeln!(s, "# {n}");
    }
    Ok(s + &body)
}

/// One standard deviation of an assumed value, % of it: "within a factor of about two".
const ASSUMED_UNCERTAINTY_PCT: f64 = 100.0;

/// A gain's standard deviation, % of its value.
fn relative_pct(g: crate::sysid::Gain) -> f64 {
    100.0 * g.std / g.value.abs().max(1e-300)
}

/// The rig's `[uncertainty_pct]`: the values SysId's regression measured (the torque
/// constant from kV, the inertia kA accelerates) as uncertain as its standard deviations
/// say; the assumed ones (a resistance without a logged current, the inductance, the share
/// of kA's inertia that turns with the wheels) [`ASSUMED_UNCERTAINTY_PCT`]. A fit then holds
/// a value the record cannot determine at what SysId measured, by as much as SysId measured
/// it. (Those deviations assume a white residual and come from the log a fit of it reads;
/// beliefs at 30 % instead made the real drivetrain log's kS 6 % off, see issue 29.)
fn state_uncertainties(
    rig: &mut Rig,
    ff: &Feedforward,
    resistance_assumed: bool,
    m: Mechanism,
) -> &'static str {
    rig.set_uncertainty_pct(
        MotorParams::torque_constant_nm_a.key(),
        relative_pct(ff.kv_v_s_per_unit),
    );
    let inertia_key = match m {
        Mechanism::DrivetrainAngular => ChassisParams::yaw_inertia_kg_m2.key(),
        m if m.is_drivetrain() => ChassisParams::mass_kg.key(),
        _ => MotorParams::rotor_inertia_kg_m2.key(),
    };
    rig.set_uncertainty_pct(inertia_key, relative_pct(ff.ka_v_s2_per_unit));
    let mut assumed = vec![MotorParams::inductance_h.key()];
    if resistance_assumed {
        assumed.push(MotorParams::resistance_ohm.key());
    }
    if m.is_drivetrain() {
        assumed.extend([
            MotorParams::rotor_inertia_kg_m2.key(),
            WheelParams::inertia_kg_m2.key(),
        ]);
        // A straight run's kA is the mass's: the yaw inertia is the assumed square's.
        if inertia_key != ChassisParams::yaw_inertia_kg_m2.key() {
            assumed.push(ChassisParams::yaw_inertia_kg_m2.key());
        }
    }
    for key in assumed {
        rig.set_uncertainty_pct(key, ASSUMED_UNCERTAINTY_PCT);
    }
    inertia_key
}

/// Track width from the gyro, as SysId computes it: wheel travel over turned angle.
fn track_width(log: &SysIdLog) -> Option<f64> {
    if log.mechanism != Mechanism::DrivetrainAngular || !log.unit.linear {
        return None;
    }
    let (mut travel, mut angle) = (0.0, 0.0);
    for t in &log.tests {
        let (a, b) = (t.samples.first()?, t.samples.last()?);
        let (ar, br) = (a.right?, b.right?);
        travel += (b.left.position - a.left.position).abs() + (br.position - ar.position).abs();
        angle += (b.gyro_angle_rad? - a.gyro_angle_rad?).abs();
    }
    (angle > 0.0).then(|| travel * log.unit.to_si / angle)
}
