//! SysId's gains of a contract recording ([`crate::sysid`]'s regression on its voltage and
//! speed columns), reported beside a fitted grey-box model by `ident` and `diagnose`.

use serde::Serialize;

use crate::record::channels as chan;
use crate::sysid::{default_threshold, fit, render, Feedforward, Gravity, Series};

/// SysId's gains of a recording, beside a fitted model: which columns they came from and
/// the Coulomb torque at the motor shaft that kS amounts to with the fitted motor.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Report {
    /// The input and speed columns regressed (both sides of a vehicle together).
    pub columns: Vec<String>,
    /// The speed unit the gains are per (`m/s`, `rad/s`).
    pub speed_unit: String,
    /// The gains.
    pub gains: Feedforward,
    /// `kS K / R`: the constant motor torque whose voltage drop SysId's kS is, N m, with
    /// the fitted torque constant and resistance.
    pub coulomb_equivalent_nm: Option<f64>,
}

/// The voltage and speed column pairs of a recording SysId's regression can read.
fn drive_columns(
    rec: &crate::record::Recording,
) -> Option<(Vec<(&'static str, &'static str)>, &'static str)> {
    let has = |n: &str| rec.column(n).is_some_and(|c| c.iter().all(Option::is_some));
    let pairs: [(&[(&str, &str)], &str); 4] = [
        (&[(chan::VOLTAGE_V, chan::MOTOR_SPEED_RAD_S)], "rad/s"),
        (
            &[
                (chan::LEFT_VOLTAGE_V, chan::LEFT_WHEEL_SPEED_M_S),
                (chan::RIGHT_VOLTAGE_V, chan::RIGHT_WHEEL_SPEED_M_S),
            ],
            "m/s",
        ),
        (
            &[
                (chan::LEFT_VOLTAGE_V, chan::LEFT_MOTOR_SPEED_RAD_S),
                (chan::RIGHT_VOLTAGE_V, chan::RIGHT_MOTOR_SPEED_RAD_S),
            ],
            "rad/s",
        ),
        (&[(chan::VOLTAGE_V, chan::SPEED_M_S)], "m/s"),
    ];
    pairs
        .into_iter()
        .find(|(p, _)| p.iter().all(|(u, v)| has(u) && has(v)))
        .map(|(p, unit)| (p.to_vec(), unit))
}

/// SysId's gains of a voltage-driven recording (`None` when it has no complete voltage
/// and speed columns, or the regression cannot be made: the report is an aside).
pub fn of_recording(
    rec: &crate::record::Recording,
    torque_constant_nm_a: Option<f64>,
    resistance_ohm: Option<f64>,
) -> Option<Report> {
    let (pairs, unit) = drive_columns(rec)?;
    let values = |n: &str| -> Vec<f64> {
        rec.column(n)
            .into_iter()
            .flatten()
            .flatten()
            .copied()
            .collect()
    };
    // One series per side and test: SysId pairs samples only within a test.
    let series: Vec<Series> = pairs
        .iter()
        .flat_map(|(u, v)| {
            let (voltage, speed) = (values(u), values(v));
            rec.segments().into_iter().map(move |r| Series {
                t_s: rec.t_s[r.clone()].to_vec(),
                voltage_v: voltage[r.clone()].to_vec(),
                speed: speed[r.clone()].to_vec(),
                angle_rad: vec![0.0; r.len()],
            })
        })
        .collect();
    let gains = fit(&series, Gravity::None, default_threshold(&series)).ok()?;
    let coulomb_equivalent_nm = match (torque_constant_nm_a, resistance_ohm) {
        (Some(k), Some(r)) if r > 0.0 => Some(gains.ks_v.value * k / r),
        _ => None,
    };
    Some(Report {
        columns: pairs
            .iter()
            .flat_map(|(u, v)| [u.to_string(), v.to_string()])
            .collect(),
        speed_unit: unit.into(),
        gains,
        coulomb_equivalent_nm,
    })
}

/// The report's lines.
pub fn render_report(r: &Report) -> String {
    let mut s = format!(
        "SysId feedforward (its discrete-time OLS on {}):\n",
        r.columns.join(", ")
    );
    s += &render(&r.gains, &r.speed_unit);
    if let Some(c) = r.coulomb_equivalent_nm {
        s += &format!(
            "  kS as a Coulomb torque at the motor shaft (kS K / R, fitted K and R): {}\n",
            crate::numtext::quantity(c, 4, "N m")
        );
    }
    s
}
