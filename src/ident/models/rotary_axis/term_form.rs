//! A term outside the vocabulary as the rotary axis fits it: its family, the form the
//! search chose, and its coefficients with their search bounds.

use crate::model::term::{Drifting, Family, TermParams};

/// A term's form: its family and what the search chose of it (the exponent, order or
/// thermal time constant in `order`; the drifting parameter of a time drift).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TermForm {
    /// The family.
    pub family: Family,
    /// Exponent (`speed_power`, `current_power`), periods per turn (the periodic
    /// families) or the thermal time constant in s (`thermal_drift`); unused otherwise.
    pub order: f64,
    /// The parameter a `time_drift` lets drift.
    pub drifting: Drifting,
}

/// One fitted coefficient of a term: its parameter's name (as the contract and the
/// report name it), the key of [`TermParams`] it sets, its start and search bounds.
#[derive(Debug, Clone, PartialEq)]
pub struct TermCoefficient {
    /// The parameter's name.
    pub name: &'static str,
    /// The key it sets.
    pub key: &'static str,
    /// Start of its search.
    pub start: f64,
    /// Lower bound of its search.
    pub lo: f64,
    /// Upper bound of its search.
    pub hi: f64,
}

impl TermForm {
    /// The form's fitted coefficients, each at `start` within `[-limit, limit]` (or
    /// `[0, limit]` where a negative value is no such physics), `limit` each coefficient's
    /// physical ceiling, in the coefficient's own unit.
    pub fn coefficients(&self, limits: &[f64]) -> Vec<TermCoefficient> {
        let c = |name, key: crate::param::ParamKey, signed: bool, i: usize| TermCoefficient {
            name,
            key: key.key(),
            start: 0.0,
            lo: if signed { -limits[i] } else { 0.0 },
            hi: limits[i],
        };
        match self.family {
            Family::SpeedPower => vec![c(
                "coefficient",
                TermParams::speed_power_coefficient,
                false,
                0,
            )],
            Family::PeriodicMotorAngle => vec![
                c(
                    "sin_coefficient_Nm",
                    TermParams::motor_periodic_sin_nm,
                    true,
                    0,
                ),
                c(
                    "cos_coefficient_Nm",
                    TermParams::motor_periodic_cos_nm,
                    true,
                    1,
                ),
            ],
            Family::PeriodicWheelAngle => vec![
                c(
                    "sin_coefficient_Nm",
                    TermParams::wheel_periodic_sin_nm,
                    true,
                    0,
                ),
                c(
                    "cos_coefficient_Nm",
                    TermParams::wheel_periodic_cos_nm,
                    true,
                    1,
                ),
            ],
            Family::LoadDependentFriction => {
                vec![c(
                    "friction_ratio",
                    TermParams::load_friction_ratio,
                    false,
                    0,
                )]
            }
            Family::ThermalDrift => vec![c(
                "heating_coefficient_1_A2",
                TermParams::heating_coefficient_1_a2,
                false,
                0,
            )],
            Family::CurrentPower => vec![c(
                "coefficient",
                TermParams::current_power_coefficient,
                false,
                0,
            )],
            Family::TimeDrift => vec![match self.drifting {
                Drifting::Resistance => c(
                    "resistance_drift_1_s",
                    TermParams::resistance_drift_1_s,
                    true,
                    0,
                ),
                Drifting::TorqueConstant => c(
                    "torque_constant_drift_1_s",
                    TermParams::torque_constant_drift_1_s,
                    true,
                    0,
                ),
                Drifting::Viscous => c("viscous_drift_1_s", TermParams::viscous_drift_1_s, true, 0),
            }],
        }
    }

    /// The form's fixed choice as a parameter held at its value: name, key and value.
    pub fn fixed(&self) -> Option<(&'static str, &'static str, f64)> {
        let f = |name, key: crate::param::ParamKey| Some((name, key.key(), self.order));
        match self.family {
            Family::SpeedPower => f("exponent", TermParams::speed_power_exponent),
            Family::PeriodicMotorAngle => f("order", TermParams::motor_periodic_order),
            Family::PeriodicWheelAngle => f("order", TermParams::wheel_periodic_order),
            Family::ThermalDrift => f(
                "thermal_time_constant_s",
                TermParams::thermal_time_constant_s,
            ),
            Family::CurrentPower => f("exponent", TermParams::current_power_exponent),
            Family::LoadDependentFriction | Family::TimeDrift => None,
        }
    }
}
