//! A diagnosis run: the baseline, the rounds of candidates and terms, the settled model and
//! its validation, and the report assembled from them.

use crate::model::motor::MotorParams;

use std::collections::BTreeMap;
use std::path::Path;

use super::evidence::effective_n;
use super::regimes::RegimeShare;
use super::scales::scales;
use super::{regimes, relative_errors, Stage};
use super::{
    round, terms, Candidate, Diagnosis, Finding, Unexplained, MIN_SAMPLES, UNEXPLAINED_REDUCTION,
};
use crate::ident::data::Dataset;
use crate::ident::effects::Choice;
use crate::ident::fit::Fit;
use crate::ident::{
    build_structure, evaluate, fit_structure, Evaluation, IdentError, IdentifyOptions, Structure,
};
use crate::record::Recording;
use crate::rig::Rig;

/// Options of a diagnosis.
#[derive(Debug, Clone, Default)]
pub struct DiagnoseOptions {
    /// The identification's settings (iterations, starts, residual lags).
    pub ident: IdentifyOptions,
    /// Which candidate effects to try (by default every one that applies to the
    /// structure).
    pub effects: Choice,
    /// Told each stage as it happens (the baseline, each round's candidates as they
    /// finish), from worker threads too: the command prints it, a test leaves it `None`.
    pub progress: Option<fn(&str)>,
}

/// Diagnoses a recording against its rig: the baseline fitted, then up to [`ROUNDS`]
/// rounds of candidate effects ([`round`]), then the diagnosis reported.
pub fn diagnose(
    rig: &Rig,
    rig_path: &Path,
    rec: &Recording,
    validation: Option<&Recording>,
    opts: &DiagnoseOptions,
) -> Result<Diagnosis, IdentError> {
    let structure = diagnosable_structure(rig, rig_path, rec, opts)?;
    let model = structure.model();
    let (data, left_out) = crate::ident::dataset_for(model, rec)?;
    check_decidable(&data, rec)?;
    // A rotary axis carries the measured angle's line beside its input, for a periodic
    // term (fitted on the angle the encoder measured); the other models read their own
    // inputs first and leave it.
    let data = match &structure {
        Structure::Rotary(_) => data.with_measured_angle().unwrap_or(data),
        _ => data,
    };
    let free = model.default_free_for(&data);
    crate::ident::enough_data(rec, &data, free.len())?;
    let base_fit = fit_structure(model, &data, &free, &opts.ident, &model.nominal())
        .map_err(|e| crate::ident::diverging_start(rec, &data, e))?;
    let weights = base_fit.weighting.clone();
    let speed = regimes::measured_speed(&data);
    let regs = regimes::regimes(&data, &speed);
    let base_energy = regimes::energy_per_sample(&data, &base_fit.predicted, &weights.outputs);
    let scales = scales(&structure, &base_fit.params, &data, &speed);
    let baseline_eval = evaluate(&data, base_fit.predicted.clone(), opts.ident.max_lag);
    crate::ident::finite_loss(rec, &data, &baseline_eval)?;
    let tell = |msg: String| {
        if let Some(p) = opts.progress {
            p(&msg);
        }
    };
    tell(format!(
        "baseline fitted ({} iterations); trying the candidate effects",
        base_fit.iterations
    ));
    let rounds_of = round::Rounds {
        data: &data,
        regimes: &regs,
        base_energy: &base_energy,
        linear: matches!(structure, Structure::Linear(_)),
        tell: &tell,
    };
    let (stage, outcome) = rounds_of.run(
        Stage {
            structure: structure.clone(),
            fit: base_fit.clone(),
        },
        &free,
        &scales,
        opts,
    );
    let validation = validation
        .map(|v| validate(&structure, &base_fit, &stage, v, opts.ident.max_lag))
        .transpose()?;
    Ok(report_of(
        rec,
        &data,
        Baseline {
            structure: &structure,
            fit: &base_fit,
            eval: baseline_eval,
            energy: &base_energy,
        },
        stage,
        Found {
            regimes: &regs,
            rounds: outcome.rounds,
            findings: outcome.findings,
            terms: outcome.terms,
            term_rounds: outcome.term_rounds,
            left_out,
            validation,
            max_lag: opts.ident.max_lag,
        },
    ))
}

/// The rig's structure for this recording, if a diagnosis can take it and every effect
/// named applies to it.
fn diagnosable_structure(
    rig: &Rig,
    rig_path: &Path,
    rec: &Recording,
    opts: &DiagnoseOptions,
) -> Result<Structure, IdentError> {
    let structure = build_structure(rig, rig_path, rec, opts.ident.model)?;
    if !matches!(
        structure,
        Structure::Rotary(_) | Structure::Linear(_) | Structure::Vehicle(_)
    ) {
        return Err(IdentError::NotDiagnosable {
            file: rec.path.clone(),
            rig: rig_path.to_path_buf(),
            model: structure.model().name(),
        });
    }
    let applicable = structure.applicable();
    if let Choice::Named(asked) = &opts.effects {
        if let Some(e) = asked.iter().find(|e| !applicable.contains(e)) {
            return Err(IdentError::EffectNotApplicable {
                effect: e.name().into(),
                model: structure.model().name(),
                applicable: applicable
                    .iter()
                    .map(|e| e.name())
                    .collect::<Vec<_>>()
                    .join(", "),
            });
        }
    }
    Ok(structure)
}

/// The baseline's and the diagnosed model's evaluations on a validation recording.
fn validate(
    structure: &Structure,
    base_fit: &Fit,
    stage: &Stage,
    v: &Recording,
    max_lag: usize,
) -> Result<(Evaluation, Evaluation), IdentError> {
    let (vd, _) = crate::ident::dataset_for(structure.model(), v)?;
    let sim = |s: &Structure, p: &[f64]| {
        s.model()
            .simulate_record(p, &vd)
            .map_err(|d| IdentError::Mismatch {
                file: v.path.clone(),
                message: format!("the model {d} on the validation recording"),
            })
    };
    let b = evaluate(&vd, sim(structure, &base_fit.params)?, max_lag);
    let d = evaluate(&vd, sim(&stage.structure, &stage.fit.params)?, max_lag);
    Ok((b, d))
}

/// The nominal model as first fitted.
struct Baseline<'a> {
    structure: &'a Structure,
    fit: &'a Fit,
    eval: Evaluation,
    /// Its residual energy per sample.
    energy: &'a [f64],
}

/// What the rounds found, and what the report needs beside it.
struct Found<'a> {
    regimes: &'a [regimes::Regime],
    rounds: Vec<Vec<Candidate>>,
    findings: Vec<Finding>,
    terms: Vec<terms::TermFinding>,
    term_rounds: Vec<Option<terms::Search>>,
    left_out: Vec<crate::ident::LeftOut>,
    validation: Option<(Evaluation, Evaluation)>,
    max_lag: usize,
}

/// The diagnosis as reported: the baseline beside the diagnosed model (`stage`), where
/// their residuals lie, SysId's view of the same record.
fn report_of(
    rec: &Recording,
    data: &Dataset,
    base: Baseline,
    stage: Stage,
    found: Found,
) -> Diagnosis {
    let (structure, base_fit) = (base.structure, base.fit);
    let final_energy =
        regimes::energy_per_sample(data, &stage.fit.predicted, &base_fit.weighting.outputs);
    let base_total_energy: f64 = base.energy.iter().sum();
    let diagnosed_eval = evaluate(data, stage.fit.predicted.clone(), found.max_lag);
    let unexplained = unexplained(
        &found,
        &regimes::shares(found.regimes, &final_energy, final_energy.iter().sum()),
    );
    let params_of = |s: &Structure, p: &[f64]| -> BTreeMap<String, f64> {
        let m = s.model();
        m.params()
            .iter()
            .zip(p)
            .enumerate()
            .filter(|(i, _)| m.reports(*i))
            .map(|(_, (s, v))| (s.name.clone(), *v))
            .collect()
    };
    let baseline_params = params_of(structure, &base_fit.params);
    let final_params = params_of(&stage.structure, &stage.fit.params);
    // SysId's kS beside the diagnosed model: both as a torque at the motor shaft, with
    // the diagnosed model's own torque constant and resistance (the baseline's absorbed
    // the missing friction).
    let feedforward = crate::ident::sysid_regression::of_recording(
        rec,
        final_params
            .get(MotorParams::torque_constant_nm_a.key())
            .copied(),
        final_params.get(MotorParams::resistance_ohm.key()).copied(),
    );
    let sysid_terms = feedforward.as_ref().and_then(|ff| {
        let unit = match ff.speed_unit.as_str() {
            "m/s" => "m/s",
            "rad/s" => "rad/s",
            _ => return None,
        };
        crate::ident::sysid_terms::of_fit(stage.structure.model(), &stage.fit, unit)
    });
    let dt = data.median_interval_s();
    Diagnosis {
        sysid_terms,
        baseline_estimates: crate::ident::param_reports(structure.model(), base_fit),
        final_estimates: crate::ident::param_reports(stage.structure.model(), &stage.fit),
        correlation_s: stage.fit.correlation_rows as f64 * dt,
        correlation_rows: stage.fit.correlation_rows,
        feedforward,
        relative_error_before_pct: relative_errors(data, &base_fit.predicted),
        relative_error_after_pct: relative_errors(data, &stage.fit.predicted),
        recording: data.name.clone(),
        model: structure.model().name(),
        baseline_fit_pct: base.eval.fit_pct_mean,
        baseline_params,
        baseline_at_bound: at_bound_of(structure, base_fit),
        left_out: found.left_out,
        ignored_inputs: crate::ident::ignored_inputs(
            rec,
            &crate::ident::model_columns(structure.model()),
        ),
        where_before: regimes::shares(found.regimes, base.energy, base_total_energy),
        where_after: regimes::shares(found.regimes, &final_energy, base_total_energy),
        unexplained,
        terms: found.terms,
        term_rounds: found.term_rounds,
        rounds: found.rounds,
        final_fit_pct: diagnosed_eval.fit_pct_mean,
        final_params,
        findings: found.findings,
        effective_n: effective_n(data, &base_fit.predicted).iter().sum(),
        baseline: base.eval,
        diagnosed: diagnosed_eval,
        validation: found.validation,
    }
}

/// Structure left unexplained: the last round accepted nothing, and a term fitted there
/// removed at least [`UNEXPLAINED_REDUCTION`] of the residual yet failed the rules (its
/// coefficient on a bound, undetermined, or not clear of zero; or too little evidence
/// counted with the effective residual count). A screen alone claims nothing: its
/// linearisation fails where the model is rough (a gear play).
fn unexplained(found: &Found, final_shares: &[RegimeShare]) -> Option<Unexplained> {
    let accepted = found.findings.len() + found.terms.len();
    if accepted >= found.rounds.len() {
        return None;
    }
    let search = found.term_rounds.last()?.as_ref()?;
    let top = search
        .fitted
        .iter()
        .filter(|t| !t.significant)
        .max_by(|a, b| a.rss_reduction_pct.total_cmp(&b.rss_reduction_pct))?;
    if top.rss_reduction_pct < 100.0 * UNEXPLAINED_REDUCTION {
        return None;
    }
    let regime = final_shares
        .iter()
        .filter(|s| s.concentration() > 1.5)
        .max_by(|a, b| a.concentration().total_cmp(&b.concentration()))
        .map_or("spread over the record".to_string(), |s| {
            format!(
                "{:.0}% of it in the {:.0}% of samples {}",
                s.energy_pct, s.samples_pct, s.regime
            )
        });
    let quantity = crate::model::term::Family::from_name(&top.name).map_or("", |f| f.quantity());
    Some(Unexplained {
        fit_gap_pct: top.rss_reduction_pct,
        where_: format!(
            "the residual lies {regime}; it follows the {quantity} most ({} removes {:.1} % of it but fails the rules)",
            top.name, top.rss_reduction_pct
        ),
    })
}

/// Refuses records that cannot support a decision. An input is excited when it takes at
/// least two levels and changes: within a test, or, for a test that starts from rest, by
/// the step from rest to its first value (a dynamic test's step is applied as the record
/// starts).
fn check_decidable(data: &Dataset, rec: &Recording) -> Result<(), IdentError> {
    let refuse = |why: String| IdentError::Mismatch {
        file: rec.path.clone(),
        message: why,
    };
    if data.len() < MIN_SAMPLES {
        return Err(refuse(format!(
            "{} samples is too short to decide whether physics is missing (at least {MIN_SAMPLES} needed)",
            data.len()
        )));
    }
    let speed = regimes::measured_speed(data);
    let segments: Vec<(std::ops::Range<usize>, bool)> = data
        .segments()
        .into_iter()
        .map(|r| (r.clone(), starts_at_rest(&speed, r)))
        .collect();
    for (i, u) in data.inputs.iter().enumerate() {
        let mut levels: Vec<f64> = u.clone();
        let mut changes = 0;
        for (segment, at_rest) in &segments {
            let u = &u[segment.clone()];
            changes += u.windows(2).filter(|w| w[0] != w[1]).count();
            if *at_rest && u[0] != 0.0 {
                levels.push(0.0);
                changes += 1;
            }
        }
        let (lo, hi) = levels
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(*v), b.max(*v))
            });
        if hi - lo <= 0.0 || changes < MIN_INPUT_CHANGES {
            return Err(refuse(format!(
                "input `{}` is not excited (range {lo}..{hi}, {changes} changes, counting a step from rest at a test's start): the record cannot tell the model's parameters from missing physics",
                data.input_names[i]
            )));
        }
    }
    Ok(())
}

/// Fewest input changes (a step from rest counts as one) a diagnosis decides on: one step
/// already shows the gain and the lag of the response.
pub const MIN_INPUT_CHANGES: usize = 1;

/// Whether a test starts at rest: its measured speed (the forward speed of a vehicle,
/// the shaft's of an axis) on its first row within 2 % of the test's largest (sensor noise
/// at standstill).
fn starts_at_rest(speed: &[f64], rows: std::ops::Range<usize>) -> bool {
    let speed = &speed[rows];
    let largest = speed.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    largest > 0.0 && speed[0].abs() <= 0.02 * largest
}

/// The free parameters of a fit that ended on a bound of their search, with the bound.
fn at_bound_of(s: &Structure, f: &crate::ident::fit::Fit) -> BTreeMap<String, f64> {
    let specs = s.model().params();
    f.free
        .iter()
        .filter_map(|&i| {
            let p = &specs[i];
            crate::ident::bound_reached(f.params[i], p.lo, p.hi).map(|b| (p.name.clone(), b))
        })
        .collect()
}
