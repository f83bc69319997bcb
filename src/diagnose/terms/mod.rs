//! Terms outside the vocabulary: when no effect explains what the residual still shows,
//! the families of the contract's table ([`crate::model::term`]) are searched, each at
//! every order or exponent it may take, and the best is fitted and judged.
//!
//! 1. **Screen** (every family at every order): the term's effect on the outputs is
//!    linearised at the stage's fit (one simulation per coefficient, the coefficient a
//!    thousandth of its physical ceiling), beside the stage's own free parameters (the
//!    Jacobian, one simulation each), so that what a refit of the stage would absorb (a
//!    drag growing with w|w| is mostly a viscous friction) is not credited to the term.
//!    Each form's coefficients are fitted by least squares on half the record's time
//!    blocks and judged on the other half: the share of the held-out residual removed.
//! 2. **Fit**: the best-screened form is fitted to the whole record with the stage's free
//!    parameters; where it fails the rules, the best of another family (at most
//!    [`CONFIRMED`] families). The family that passes has its next orders fitted too
//!    where they screened nearly as well ([`ORDER_RIVALS`], [`RIVAL_SHARE`]): the whole
//!    record's fit chooses the order.
//! 3. **Judge**: the vocabulary's rules (the AIC gain with the effective residual count,
//!    the share of the residual removed, a coefficient inside its bounds and determined
//!    by the record) and the held-out share removed ([`MIN_HELD_OUT_REDUCTION`]).

use rayon::prelude::*;
use serde::Serialize;

use super::evidence::Gain;
use super::{Stage, MIN_RSS_REDUCTION};
use crate::ident::data::Dataset;
use crate::ident::fit::{self, Fit, FitSettings};
use crate::ident::models::rotary_axis::{AxisInput, RotaryAxis, TermCoefficient, TermForm};
use crate::ident::Structure;
use crate::model::term::{Drifting, Family};
use crate::record::channels as chan;

pub(crate) mod screen;
mod words;
use screen::Linearised;
pub(crate) use words::quantity_series;
pub(crate) use words::{contract_params, main_std};
pub use words::{describe, param, TermFinding};

/// Time blocks the record is cut into for the screen: fitted on the even ones, judged on
/// the odd ones (interleaved, so that both halves see every regime of the record).
pub const HELD_OUT_BLOCKS: usize = 10;
/// Smallest share of the held-out blocks' residual a term's screen must remove.
pub const MIN_HELD_OUT_REDUCTION: f64 = MIN_RSS_REDUCTION;
/// Forms fitted to the whole record after the screen (the best of distinct families).
pub const CONFIRMED: usize = 2;
/// Other orders of a passing family fitted to the whole record beside its first.
pub const ORDER_RIVALS: usize = 2;
/// Share of the family's best held-out reduction a rival order must screen at to be
/// fitted.
pub const RIVAL_SHARE: f64 = 0.9;
/// A coefficient's screen perturbation, as a share of its physical ceiling.
pub(crate) const SCREEN_STEP: f64 = 1e-3;

/// The forms a rotary axis driven by `input` is searched over: exponents of the speed
/// from 0.5 to 4 (1 is the viscous friction the model has), 1-12 periods per motor turn,
/// 1-6 per wheel turn, thermal time constants from 3 s to 300 s, the current's exponents
/// 1-2, and a drift of each armature and friction parameter.
pub fn forms(input: AxisInput) -> Vec<TermForm> {
    let form = |family, order| TermForm {
        family,
        order,
        drifting: Drifting::Resistance,
    };
    let mut out: Vec<TermForm> = [0.5, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0]
        .map(|n| form(Family::SpeedPower, n))
        .to_vec();
    out.extend((1..=12).map(|n| form(Family::PeriodicMotorAngle, n as f64)));
    out.extend((1..=6).map(|n| form(Family::PeriodicWheelAngle, n as f64)));
    out.push(form(Family::LoadDependentFriction, 0.0));
    if matches!(input, AxisInput::Torque(_)) {
        // Behind a current amplifier the armature's laws do not act.
        out.push(TermForm {
            drifting: Drifting::Viscous,
            ..form(Family::TimeDrift, 0.0)
        });
        return out;
    }
    out.extend([3.0, 10.0, 30.0, 100.0, 300.0].map(|tau| form(Family::ThermalDrift, tau)));
    out.extend([1.0, 1.5, 2.0].map(|n| form(Family::CurrentPower, n)));
    out.extend(
        [
            Drifting::Resistance,
            Drifting::TorqueConstant,
            Drifting::Viscous,
        ]
        .map(|d| TermForm {
            drifting: d,
            ..form(Family::TimeDrift, 0.0)
        }),
    );
    out
}

/// One form as screened.
#[derive(Debug, Clone, Serialize)]
pub struct Screened {
    /// The family's name.
    pub family: &'static str,
    /// Its order, exponent or time constant (0 where the family has none).
    pub order: f64,
    /// The drifting parameter of a time drift (empty otherwise).
    pub drifting: &'static str,
    /// Share of the held-out blocks' residual the linearised term removes, %.
    pub held_out_reduction_pct: f64,
    /// Share of the whole record's residual it removes, %.
    pub reduction_pct: f64,
    #[serde(skip)]
    form: Option<TermForm>,
    #[serde(skip)]
    start: Vec<f64>,
}

/// A term fitted to the whole record, with its verdict.
#[derive(Debug, Clone, Serialize)]
pub struct TermRow {
    /// The family's name.
    pub name: String,
    /// Its parameters as the contract names them (the main coefficient first).
    pub params: Vec<(String, serde_json::Value)>,
    /// The main coefficient's standard deviation, if the record determines it.
    pub std: Option<f64>,
    /// The normalised fit with the term, %, mean over outputs.
    pub fit_pct: f64,
    /// Share of the stage's residual removed, %.
    pub rss_reduction_pct: f64,
    /// Share of the held-out blocks' residual its screen removed, %.
    pub held_out_reduction_pct: f64,
    /// AIC gain with the effective number of residuals.
    pub delta_aic: f64,
    /// Whether it passed every rule.
    pub significant: bool,
    /// A coefficient ended on a bound of its search (no estimate then).
    pub at_bound: bool,
    /// The record does not determine a coefficient.
    pub undetermined: bool,
}

/// A fitted term: its form, the structure and fit with it, its gain over the stage, and
/// its row.
#[derive(Debug, Clone)]
pub(crate) struct Fitted {
    pub form: TermForm,
    pub structure: Structure,
    pub fit: Fit,
    pub gain: Gain,
    pub row: TermRow,
}

/// What a round's term search found: every form's screen (best first), the forms fitted,
/// and the best significant one.
#[derive(Debug, Clone, Default)]
pub struct Search {
    /// Every form's screen, best first.
    pub screened: Vec<Screened>,
    /// The forms fitted to the whole record, in the order fitted.
    pub fitted: Vec<TermRow>,
    /// The best that passed the rules.
    pub(crate) best: Option<Fitted>,
}

/// The record a form is fitted on: with the measured angle's line for a periodic term.
fn on_data<'a>(
    form: TermForm,
    data: &'a Dataset,
    with_angle: Option<&'a Dataset>,
) -> Option<&'a Dataset> {
    match form.family {
        Family::PeriodicMotorAngle | Family::PeriodicWheelAngle => with_angle,
        _ => Some(data),
    }
}

/// The rotary axis of a structure, when terms can be searched on it.
fn axis(s: &Structure) -> Option<&RotaryAxis> {
    match s {
        Structure::Rotary(m) if m.term.is_none() => Some(m),
        _ => None,
    }
}

/// Searches the families on the stage: `None` where the model takes no terms (not a
/// rotary axis, or a term already on).
pub(super) fn search(
    data: &Dataset,
    stage: &Stage,
    stage_n: &[f64],
    max_iterations: usize,
    tell: &(dyn Fn(String) + Sync),
) -> Option<Search> {
    let m = axis(&stage.structure)?;
    let ceilings = Ceilings::of(m, data, &stage.fit.params);
    let lin = Linearised::at(data, stage)?;
    let with_angle = if data
        .input_names
        .iter()
        .any(|n| n == crate::ident::data::MEASURED_ANGLE_RATE)
    {
        Some(data.clone())
    } else {
        data.with_measured_angle()
    };
    let mut screened: Vec<Screened> = forms(m.input)
        .into_par_iter()
        .filter_map(|form| {
            let d = on_data(form, data, with_angle.as_ref())?;
            lin.screen(m, form, &ceilings.of_form(form), d)
        })
        .collect();
    screened.sort_by(|a, b| {
        b.held_out_reduction_pct
            .total_cmp(&a.held_out_reduction_pct)
    });
    let mut chosen: Vec<&Screened> = Vec::new();
    for s in &screened {
        if chosen.len() < CONFIRMED
            && s.held_out_reduction_pct >= 100.0 * MIN_HELD_OUT_REDUCTION
            && !chosen.iter().any(|c| c.family == s.family)
        {
            chosen.push(s);
        }
    }
    tell(format!(
        "{} forms of {} families screened; to fit: {}",
        screened.len(),
        Family::ALL.len(),
        if chosen.is_empty() {
            "none (no form removes enough of the held-out residual)".to_string()
        } else {
            chosen
                .iter()
                .map(|s| format!("{} (order {})", s.family, s.order))
                .collect::<Vec<_>>()
                .join(", then where it fails ")
        }
    ));
    // The best screen first; the next family only where it fails the rules (a screen
    // ranks well, and each fit costs as much as a candidate effect's).
    let mut fits: Vec<Fitted> = Vec::new();
    for s in chosen {
        let Some(d) = s.form.and_then(|f| on_data(f, data, with_angle.as_ref())) else {
            continue;
        };
        let fitted = confirm(d, stage, stage_n, m, s, &ceilings, max_iterations);
        let passed = fitted.as_ref().is_some_and(|f| f.row.significant);
        fits.extend(fitted);
        if passed {
            break;
        }
    }
    // The order a passing family's screen ranked first may have near ties (speed powers
    // of 2 and 2.5 screen within a few percent of each other): its rivals of the same
    // family are fitted too, and the whole record's fit decides.
    if let Some(winner) = fits.iter().find(|f| f.row.significant).map(|f| f.form) {
        let lead = screened
            .iter()
            .find(|s| s.form.is_some_and(|f| f.family == winner.family))
            .map_or(0.0, |s| s.held_out_reduction_pct);
        let rivals: Vec<&Screened> = screened
            .iter()
            .filter(|s| s.form.is_some_and(|f| f.family == winner.family))
            .skip(1)
            .take(ORDER_RIVALS)
            .filter(|s| s.held_out_reduction_pct >= RIVAL_SHARE * lead)
            .collect();
        let rival_fits: Vec<Fitted> = rivals
            .par_iter()
            .filter_map(|s| {
                let d = on_data(s.form?, data, with_angle.as_ref())?;
                confirm(d, stage, stage_n, m, s, &ceilings, max_iterations)
            })
            .collect();
        fits.extend(rival_fits);
    }
    let best = fits
        .iter()
        .filter(|f| f.row.significant)
        .max_by(|a, b| a.gain.delta_aic.total_cmp(&b.gain.delta_aic))
        .cloned();
    Some(Search {
        fitted: fits.into_iter().map(|f| f.row).collect(),
        screened,
        best,
    })
}

/// Each family's physical ceilings, from the record and the stage's motor: the torque of
/// the peak drive (stall torque at the largest voltage, or the largest commanded torque)
/// bounds every torque a term may add.
#[derive(Debug, Clone)]
pub(crate) struct Ceilings {
    /// Peak motor torque, N m.
    torque_nm: f64,
    /// Peak current, A.
    current_a: f64,
    /// Mean square of the current (measured, or the peak's square), A^2: the heat a
    /// thermal term's coefficient is bounded by (a doubling of the resistance there).
    heat_a2: f64,
    /// Largest wheel speed of the record, rad/s.
    wheel_speed_rad_s: f64,
    /// Gear ratio.
    ratio: f64,
    /// The record's duration, s.
    duration_s: f64,
}

impl Ceilings {
    fn of(m: &RotaryAxis, data: &Dataset, p: &[f64]) -> Ceilings {
        let a = m.declared(p);
        let peak_input = data.inputs[0].iter().fold(0.0f64, |x, u| x.max(u.abs()));
        let (torque_nm, current_a) = match m.torque_command() {
            Some(c) => (c.per_volt_nm_v * peak_input, 1.0),
            None => {
                let v = m.voltage(&a, peak_input);
                let i = v.abs() / a.motor.resistance_ohm;
                (a.motor.torque_constant_nm_a * i, i)
            }
        };
        Ceilings::of_record(data, torque_nm, current_a, m.ratio)
    }

    /// The ceilings of a drive whose peak motor torque is `torque_nm` (N m) and peak
    /// current `current_a` (A) through a gear of `ratio`, from the record: its mean
    /// square current (the peak's square without a current), its largest motor speed
    /// through the gear and its duration.
    pub(crate) fn of_record(
        data: &Dataset,
        torque_nm: f64,
        current_a: f64,
        ratio: f64,
    ) -> Ceilings {
        let column = |name: &str| data.output_index(name).map(|j| &data.outputs[j]);
        let speed = column(chan::MOTOR_SPEED_RAD_S)
            .map(|c| c.iter().flatten().fold(0.0f64, |x, v| x.max(v.abs())))
            .unwrap_or(0.0);
        let heat_a2 = column(chan::CURRENT_A)
            .map(|c| {
                let sq: Vec<f64> = c.iter().flatten().map(|i| i * i).collect();
                sq.iter().sum::<f64>() / sq.len().max(1) as f64
            })
            .unwrap_or(current_a * current_a);
        Ceilings {
            torque_nm: torque_nm.max(1e-9),
            current_a: current_a.max(1e-9),
            heat_a2: heat_a2.max(1e-9),
            wheel_speed_rad_s: (speed / ratio).max(1e-9),
            ratio,
            duration_s: (data.t_s.last().unwrap_or(&1.0) - data.t_s.first().unwrap_or(&0.0))
                .max(1e-9),
        }
    }

    /// A form's ceilings, one per coefficient in the form's order.
    pub(crate) fn of_form(&self, form: TermForm) -> Vec<f64> {
        match form.family {
            Family::SpeedPower => {
                vec![self.torque_nm * self.ratio / self.wheel_speed_rad_s.powf(form.order)]
            }
            Family::PeriodicMotorAngle => vec![self.torque_nm; 2],
            Family::PeriodicWheelAngle => vec![self.torque_nm * self.ratio; 2],
            Family::LoadDependentFriction => vec![0.9],
            Family::ThermalDrift => vec![1.0 / self.heat_a2],
            Family::CurrentPower => vec![0.9 / self.current_a.powf(form.order)],
            Family::TimeDrift => vec![1.0 / self.duration_s],
        }
    }
}

/// The stage's parameters with a form's fixed choice and its coefficients (at zero).
fn start_vector(stage: &[f64], form: TermForm, coefficients: &[TermCoefficient]) -> Vec<f64> {
    let mut p = stage.to_vec();
    if let Some((_, _, v)) = form.fixed() {
        p.push(v);
    }
    p.extend(coefficients.iter().map(|c| c.start));
    p
}

/// The name a time drift's parameter goes by.
pub(crate) fn drifting_key(d: Drifting) -> &'static str {
    use crate::model::motor::MotorParams;
    match d {
        Drifting::Resistance => MotorParams::resistance_ohm.key(),
        Drifting::TorqueConstant => MotorParams::torque_constant_nm_a.key(),
        Drifting::Viscous => MotorParams::viscous_nm_s_rad.key(),
    }
}

/// A screened form fitted to the whole record with the stage's free parameters, from the
/// screen's coefficients and from zero, and judged.
fn confirm(
    data: &Dataset,
    stage: &Stage,
    stage_n: &[f64],
    m: &RotaryAxis,
    s: &Screened,
    ceilings: &Ceilings,
    max_iterations: usize,
) -> Option<Fitted> {
    let form = s.form?;
    let mut coefficients = form.coefficients(&ceilings.of_form(form));
    for (c, start) in coefficients.iter_mut().zip(&s.start) {
        c.start = *start;
    }
    let (with, indices) = m.with_term(form, &coefficients);
    let structure = Structure::Rotary(with);
    let mut free = stage.fit.free.clone();
    let refined = (form.family == Family::ThermalDrift).then(|| indices[0] - 1);
    free.extend(refined);
    free.extend(&indices);
    let from_screen = start_vector(&stage.fit.params, form, &coefficients);
    let settings = FitSettings {
        free,
        weighting: stage.fit.weighting.clone(),
        max_iterations,
        starts: vec![from_screen],
    };
    let f = fit::fit(structure.model(), data, &settings).ok()?;
    let gain = Gain::of(data, &stage.fit, stage_n, &f);
    // The coefficients' slots among the free parameters (the last ones).
    let slots: Vec<usize> = (f.free.len() - indices.len()..f.free.len()).collect();
    let at_bound = indices.iter().zip(&coefficients).any(|(&i, c)| {
        // A coefficient whose search starts at zero may rest there: that is the term
        // absent, judged by its gain; a bound away from zero is a bound.
        let v = f.params[i];
        (c.lo != 0.0 && crate::ident::bound_reached(v, c.lo, c.hi) == Some(c.lo))
            || crate::ident::bound_reached(v, c.lo, c.hi) == Some(c.hi)
    });
    // A refined time constant on a bound is a heating the record cannot place in time.
    let at_bound = at_bound
        || refined.is_some_and(|i| {
            let spec = &structure.model().params()[i];
            crate::ident::bound_reached(f.params[i], spec.lo, spec.hi).is_some()
        });
    let form = TermForm {
        order: refined.map_or(form.order, |i| f.params[i]),
        ..form
    };
    let undetermined = slots.iter().any(|&k| f.std[k].is_none());
    // The coefficients together must stand clear of zero: two standard deviations.
    let z_sq: f64 = slots
        .iter()
        .zip(&indices)
        .map(|(&k, &i)| f.std[k].map_or(0.0, |sd| (f.params[i] / sd).powi(2)))
        .sum();
    let significant = gain.passes()
        && s.held_out_reduction_pct >= 100.0 * MIN_HELD_OUT_REDUCTION
        && !at_bound
        && !undetermined
        && z_sq > 4.0;
    let values: Vec<f64> = indices.iter().map(|&i| f.params[i]).collect();
    let stds: Vec<Option<f64>> = slots.iter().map(|&k| f.std[k]).collect();
    let row = TermRow {
        name: form.family.name().into(),
        params: contract_params(form, &values, data, &stage.fit, ceilings),
        std: main_std(form, &stds, data, &stage.fit, ceilings),
        fit_pct: crate::ident::fit_pct_mean(data, &f.predicted),
        rss_reduction_pct: 100.0 * gain.reduction,
        held_out_reduction_pct: s.held_out_reduction_pct,
        delta_aic: gain.delta_aic,
        significant,
        at_bound,
        undetermined,
    };
    Some(Fitted {
        form,
        structure,
        fit: f,
        gain,
        row,
    })
}
