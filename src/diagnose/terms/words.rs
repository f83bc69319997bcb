//! A fitted term in the contract's parameters and in words a user understands.

use super::{drifting_key, Ceilings, TermRow};
use crate::ident::data::Dataset;
use crate::ident::fit::Fit;
use crate::ident::models::rotary_axis::TermForm;
use crate::model::term::{amplitude_phase, Family};
use crate::record::channels as chan;

/// The contract's parameters of a fitted form (the main coefficient first).
pub(crate) fn contract_params(
    form: TermForm,
    v: &[f64],
    data: &Dataset,
    stage: &Fit,
    ceilings: &Ceilings,
) -> Vec<(String, serde_json::Value)> {
    let p = |name: &str, x: f64| (name.to_string(), serde_json::json!(x));
    match form.family {
        Family::SpeedPower => vec![p("coefficient", v[0]), p("exponent", form.order)],
        Family::PeriodicMotorAngle | Family::PeriodicWheelAngle => {
            let (amplitude, phase) = amplitude_phase(v[0], v[1]);
            vec![
                p("amplitude_Nm", amplitude),
                p("phase_rad", phase),
                p("order", form.order),
                p("sin_coefficient_Nm", v[0]),
                p("cos_coefficient_Nm", v[1]),
            ]
        }
        Family::LoadDependentFriction => vec![p("friction_ratio", v[0])],
        Family::ThermalDrift => {
            let heat = final_heat_a2(data, stage, form.order);
            vec![
                p("resistance_rise_pct", 100.0 * v[0] * heat),
                p("thermal_time_constant_s", form.order),
                p("heating_coefficient_1_A2", v[0]),
            ]
        }
        Family::CurrentPower => vec![p("coefficient", v[0]), p("exponent", form.order)],
        Family::TimeDrift => vec![
            p("change_pct", 100.0 * v[0] * ceilings.duration_s),
            ("key".into(), serde_json::json!(drifting_key(form.drifting))),
        ],
    }
}

/// The heat state at the record's end (A^2): the measured current squared, low-passed
/// over the time constant (the predicted current where none is measured).
fn final_heat_a2(data: &Dataset, stage: &Fit, tau_s: f64) -> f64 {
    let j = match data.output_index(chan::CURRENT_A) {
        Some(j) => j,
        None => return 0.0,
    };
    let mut q = 0.0;
    for k in 1..data.len() {
        let dt = data.t_s[k] - data.t_s[k - 1];
        let i = data.outputs[j][k].unwrap_or(stage.predicted[j][k]);
        q += (1.0 - (-dt / tau_s).exp()) * (i * i - q);
    }
    q
}

/// What the main contract parameter is per unit of the fitted coefficient: a time drift's
/// change in % over the record, a thermal term's rise in % at its end; 1 otherwise.
fn main_scale(form: TermForm, data: &Dataset, stage: &Fit, ceilings: &Ceilings) -> f64 {
    match form.family {
        Family::TimeDrift => 100.0 * ceilings.duration_s,
        Family::ThermalDrift => 100.0 * final_heat_a2(data, stage, form.order),
        _ => 1.0,
    }
}

/// The main contract parameter's standard deviation, in its unit, from the coefficients'
/// (`stds`): the coefficient's own, or a periodic term's amplitude's (the larger of its
/// parts'), scaled as the parameter is ([`main_scale`]).
pub(crate) fn main_std(
    form: TermForm,
    stds: &[Option<f64>],
    data: &Dataset,
    stage: &Fit,
    ceilings: &Ceilings,
) -> Option<f64> {
    let sd = match form.family {
        Family::PeriodicMotorAngle | Family::PeriodicWheelAngle => stds[0]?.max(stds[1]?),
        _ => stds[0]?,
    };
    Some(sd * main_scale(form, data, stage, ceilings))
}

/// An accepted term: its row, the round that accepted it, where its evidence lies and
/// what it is in words.
#[derive(Debug, Clone)]
pub struct TermFinding {
    /// The fitted term as judged.
    pub row: TermRow,
    /// The round (from 1) that accepted it.
    pub round: usize,
    /// Where the residual it removes lay, and what the held-out blocks said.
    pub evidence: String,
    /// The physics in words.
    pub description: String,
    /// What the term depends on, measured, one value per row of the record (NaN where
    /// nothing was measured), with its label: the evidence plot's axis.
    pub quantity: Option<(String, Vec<f64>)>,
}

/// The quantity a term of `form` depends on, over the record's rows, as measured: the
/// wheel speed (the motor's over the gear `ratio`), a periodic term's phase (its order
/// times the encoder's angle, in [0, 2 pi)), the current (a load-dependent friction's
/// torque is the current's through K), the heat (the current squared low-passed over
/// the time constant) or the time. `None` where the record lacks the measurement.
pub(crate) fn quantity_series(
    form: TermForm,
    data: &Dataset,
    ratio: f64,
) -> Option<(String, Vec<f64>)> {
    let column = |name: &str| -> Option<Vec<f64>> {
        let j = data.output_index(name)?;
        Some(
            data.outputs[j]
                .iter()
                .map(|v| v.unwrap_or(f64::NAN))
                .collect(),
        )
    };
    let phase = |per_motor_turn: f64| -> Option<Vec<f64>> {
        let speed = data
            .output_index(chan::MOTOR_SPEED_RAD_S)
            .map(|j| data.outputs[j].as_slice());
        let angle: Option<Vec<f64>> = data
            .output_index(chan::MOTOR_ANGLE_RAD)
            .and_then(|j| data.outputs[j].iter().copied().collect());
        let theta = crate::ident::data::measured_angle(&data.t_s, angle.as_deref(), speed)?;
        Some(
            theta
                .iter()
                .map(|a| (per_motor_turn * a).rem_euclid(std::f64::consts::TAU))
                .collect(),
        )
    };
    Some(match form.family {
        Family::SpeedPower => (
            "wheel speed (rad/s)".into(),
            column(chan::MOTOR_SPEED_RAD_S)?
                .iter()
                .map(|w| w / ratio)
                .collect(),
        ),
        Family::PeriodicMotorAngle => (
            format!("phase {} x motor angle (rad)", form.order),
            phase(form.order)?,
        ),
        Family::PeriodicWheelAngle => (
            format!("phase {} x wheel angle (rad)", form.order),
            phase(form.order / ratio)?,
        ),
        Family::LoadDependentFriction | Family::CurrentPower => {
            ("current (A)".into(), column(chan::CURRENT_A)?)
        }
        Family::ThermalDrift => {
            let i = column(chan::CURRENT_A)?;
            let mut q = 0.0;
            let mut heat = Vec::with_capacity(i.len());
            for k in 0..i.len() {
                if k > 0 && i[k].is_finite() {
                    let dt = data.t_s[k] - data.t_s[k - 1];
                    q = crate::model::term::heat_after_a2(q, i[k], form.order, dt);
                }
                heat.push(q);
            }
            ("heat q: the current squared low-passed (A^2)".into(), heat)
        }
        Family::TimeDrift => ("time (s)".into(), data.t_s.clone()),
    })
}

/// A parameter of a row by name, as a number.
pub fn param(row: &TermRow, name: &str) -> Option<f64> {
    row.params
        .iter()
        .find(|(n, _)| n == name)
        .and_then(|(_, v)| v.as_f64())
}

/// What a fitted term is, in words a user understands, with its numbers.
pub fn describe(row: &TermRow) -> String {
    let get = |n: &str| param(row, n).unwrap_or(f64::NAN);
    let q = crate::numtext::quantity;
    match Family::from_name(&row.name) {
        Some(Family::SpeedPower) => format!(
            "a wheel-side torque of {} (s/rad)^n growing with the wheel speed to the power n = {}: fluid or air drag (n = 2), a seal or churning oil",
            q(get("coefficient"), 3, "N m"),
            get("exponent")
        ),
        Some(Family::PeriodicMotorAngle) => format!(
            "{} periods per motor turn of {} amplitude at the motor shaft: cogging, a commutator or a motor-side gear defect",
            get("order"),
            q(get("amplitude_Nm"), 3, "N m")
        ),
        Some(Family::PeriodicWheelAngle) => format!(
            "{} periods per wheel turn of {} amplitude at the wheel: 1 per turn is an eccentric or out-of-round wheel or a bent axle, 2 an oval wheel",
            get("order"),
            q(get("amplitude_Nm"), 3, "N m")
        ),
        Some(Family::LoadDependentFriction) => format!(
            "friction proportional to the torque the gears carry ({:.1} % of it): a gear efficiency of about {:.0} %",
            100.0 * get("friction_ratio"),
            100.0 * (1.0 - get("friction_ratio"))
        ),
        Some(Family::ThermalDrift) => format!(
            "the windings heat up: their resistance rose by {:.1} % over the recording (thermal time constant {})",
            get("resistance_rise_pct"),
            q(get("thermal_time_constant_s"), 2, "s")
        ),
        Some(Family::CurrentPower) => format!(
            "the torque per ampere falls at high current as 1 - k |i|^n (k = {:.3e}, n = {}): magnetic saturation",
            get("coefficient"),
            get("exponent")
        ),
        Some(Family::TimeDrift) => format!(
            "{} changed by {:.1} % over the recording",
            row.params
                .iter()
                .find(|(n, _)| n == "key")
                .and_then(|(_, v)| v.as_str())
                .unwrap_or("a parameter"),
            get("change_pct")
        ),
        None => row.name.clone(),
    }
}
