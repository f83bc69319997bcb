//! The diagnosis in plain words: what `agvsim diagnose` prints and its report folder
//! holds.

use std::fmt::Write as _;

use super::{Candidate, Diagnosis, ROUNDS};
use crate::ident::effects::Effect;
use crate::ident::ParamReport;
use crate::numtext::{change_pct, estimate, quantity, sig};
use crate::rig::keys::unit_key_or_name;

/// The unit of a candidate's parameter, from its effect (rotary or linear by the
/// parameter's name).
fn unit_of(effect: &str, param: &str) -> &'static str {
    match Effect::from_name(effect) {
        Some(e) => e.unit(e.param_name(false) != param),
        None => crate::numtext::unit_of_name(param),
    }
}

/// The diagnosis in plain words.
pub fn render(d: &Diagnosis) -> String {
    let mut s = String::new();
    baseline_lines(&mut s, d);
    candidate_lines(&mut s, d);
    term_lines(&mut s, d);
    stop_line(&mut s, d);
    finding_lines(&mut s, d);
    uncertainty_line(&mut s, d);
    sysid_and_error_lines(&mut s, d);
    s
}

/// The recording, the baseline's fit and where its residual lives.
fn baseline_lines(s: &mut String, d: &Diagnosis) {
    let _ = writeln!(s, "Recording: {}   model: {}", d.recording, d.model);
    if !d.ignored_inputs.is_empty() {
        let _ = writeln!(
            s,
            "Ignored: {} (the model has no input for it)",
            d.ignored_inputs.join(", ")
        );
    }
    for l in &d.left_out {
        let _ = writeln!(s, "Left out of the fit: {}: {}", l.output, l.why);
    }
    let _ = writeln!(
        s,
        "Baseline (nominal model, parameters fitted): fit {:.2} %{}",
        d.baseline_fit_pct,
        per_output(&d.baseline.fit_pct)
    );
    held_lines(s, &d.baseline_estimates, "the baseline");
    for (name, bound) in &d.baseline_at_bound {
        let _ = writeln!(
            s,
            "WARNING: {name} ended at its search bound {}: not an estimate; the rig's belief or the model's structure is wrong, and effects found below may be standing in for that",
            quantity(*bound, 4, unit_key_or_name(name))
        );
    }
    let _ = writeln!(
        s,
        "Where the baseline residual lives (energy share against share of samples):"
    );
    for r in d.where_before.iter().take(4) {
        let _ = writeln!(
            s,
            "  {:5.1} % of the energy in {:5.1} % of samples {}",
            r.energy_pct, r.samples_pct, r.regime
        );
    }
}

/// Each round's candidates with their gains and verdicts.
fn candidate_lines(s: &mut String, d: &Diagnosis) {
    for (i, round) in d.rounds.iter().enumerate() {
        let _ = writeln!(
            s,
            "Candidates, round {} (effective residual count {:.0}):",
            i + 1,
            d.effective_n
        );
        let taken = d
            .findings
            .iter()
            .find(|f| f.round == i + 1)
            .map(|f| f.effect.name());
        for c in round {
            let value = format!(
                "{} = {}",
                c.param,
                quantity(c.value, 4, unit_of(&c.name, &c.param))
            );
            let _ = writeln!(
                s,
                "  {:<20} {value:<42} RSS {:>8}  dAIC {:9.1}  {}",
                c.name,
                change_pct(-c.rss_reduction_pct),
                c.delta_aic,
                verdict(c, taken)
            );
        }
    }
}

/// Each round's terms outside the vocabulary: the best screens (held-out share removed)
/// and the forms fitted, with their verdicts.
fn term_lines(s: &mut String, d: &Diagnosis) {
    for (i, search) in d.term_rounds.iter().enumerate() {
        let Some(search) = search else { continue };
        let _ = writeln!(
            s,
            "Terms outside the vocabulary, round {} ({} forms screened; share of the held-out blocks' residual each removes):",
            i + 1,
            search.screened.len()
        );
        for t in search.screened.iter().take(4) {
            let order = if t.drifting.is_empty() {
                format!("order {}", t.order)
            } else {
                t.drifting.to_string()
            };
            let _ = writeln!(
                s,
                "  {:<24} {order:<24} held out {:>6.1} %",
                t.family, t.held_out_reduction_pct
            );
        }
        for t in &search.fitted {
            let verdict = if t.significant {
                "passes"
            } else if t.at_bound {
                "a coefficient at a bound of its search: no estimate"
            } else if t.undetermined {
                "not determined by the record"
            } else {
                "below the rule"
            };
            let _ = writeln!(
                s,
                "  fitted {:<17} RSS {:>8}  dAIC {:9.1}  {verdict}",
                t.name,
                change_pct(-t.rss_reduction_pct),
                t.delta_aic
            );
        }
    }
}

/// The effects found (or that nothing is missing) and the diagnosed model's fit.
fn finding_lines(s: &mut String, d: &Diagnosis) {
    if d.findings.is_empty() && d.terms.is_empty() {
        let _ = writeln!(s, "Verdict: nothing is missing; no effect (or term outside the vocabulary) explains enough of the residual to be told from noise.");
    }
    for t in &d.terms {
        let (main, value) = t
            .row
            .params
            .first()
            .map_or((String::new(), f64::NAN), |(n, v)| {
                (n.clone(), v.as_f64().unwrap_or(f64::NAN))
            });
        let sd = t
            .row
            .std
            .map_or(String::new(), |sd| format!(" ± {}", sig(sd, 2)));
        let _ = writeln!(
            s,
            "Found outside the vocabulary: {} — {} ({main} = {}{sd})",
            t.row.name,
            t.description,
            sig(value, 4)
        );
        let _ = writeln!(s, "  evidence: {}", t.evidence);
        let _ = writeln!(
            s,
            "  fit {:.2} % -> {:.2} %",
            d.baseline_fit_pct, t.row.fit_pct
        );
    }
    if let Some(u) = &d.unexplained {
        let _ = writeln!(
            s,
            "Unexplained: structure remains that no effect and no family explains ({:.1} % of the residual follows a quantity): {}",
            u.fit_gap_pct, u.where_
        );
    }
    for f in &d.findings {
        let _ = writeln!(
            s,
            "Found: {} — {} ({} = {})",
            f.effect.name(),
            f.description,
            f.param,
            estimate(f.value, f.std, unit_of(f.effect.name(), &f.param))
        );
        let _ = writeln!(s, "  evidence: {}", f.evidence);
        for a in &f.alternatives {
            let _ = writeln!(
                s,
                "  the record cannot tell it from {} ({} = {}, dAIC {:.1} behind): {}",
                a.name,
                a.param,
                quantity(a.value, 4, unit_of(&a.name, &a.param)),
                a.delta_aic_behind,
                a.separated_by
            );
        }
        let _ = writeln!(s, "  fit {:.2} % -> {:.2} %", d.baseline_fit_pct, f.fit_pct);
    }
    if !d.findings.is_empty() || !d.terms.is_empty() {
        let _ = writeln!(
            s,
            "Diagnosed model: fit {:.2} %{}",
            d.final_fit_pct,
            per_output(&d.diagnosed.fit_pct)
        );
        held_lines(s, &d.final_estimates, "the diagnosed model");
    }
}

/// SysId's regression beside the diagnosed model's terms, the relative errors and the
/// validation.
fn sysid_and_error_lines(s: &mut String, d: &Diagnosis) {
    if let Some(ff) = &d.feedforward {
        s.push_str(&crate::ident::sysid_regression::render_report(ff));
        if let Some(t) = &d.sysid_terms {
            let speed = &t.speed_unit;
            let _ = writeln!(
                s,
                "  the diagnosed model in SysId's terms (kS = R Tc / K, kV = (K + R b / K) n, kA = R J n / K): kS = {}, kV = {}, kA = {}",
                estimate(t.value.ks_v, t.std.map(|t| t.ks_v), "V"),
                estimate(t.value.kv, t.std.map(|t| t.kv), &format!("V/({speed})")),
                estimate(t.value.ka, t.std.map(|t| t.ka), &format!("V/({speed}/s)")),
            );
        }
    }
    let _ = writeln!(
        s,
        "Relative simulation error |y - yhat| / |y| (baseline -> diagnosed):"
    );
    for (k, before) in &d.relative_error_before_pct {
        let _ = writeln!(
            s,
            "  {k:<40} {before:9.4} % -> {:9.4} %",
            d.relative_error_after_pct[k]
        );
    }
    if let Some((b, a)) = &d.validation {
        let _ = writeln!(
            s,
            "Validation {}: fit {:.2} % (baseline) -> {:.2} % (diagnosed){}",
            b.recording,
            b.fit_pct_mean,
            a.fit_pct_mean,
            per_output(&a.fit_pct)
        );
    }
}

/// Why a candidate was or was not taken, in words; `taken` is the effect its round found.
fn verdict(c: &Candidate, taken: Option<&str>) -> &'static str {
    if c.significant && taken == Some(c.name.as_str()) {
        "significant: found"
    } else if c.significant {
        "significant, but another explains more"
    } else if c.at_bound.is_some() {
        "at its search bound: no estimate"
    } else if c.undetermined {
        "the record does not determine its parameter"
    } else if c.reached_without_it {
        "not the effect's: the stage refitted from its fit reaches it"
    } else if c.screened_only {
        "screened (full search skipped)"
    } else {
        ""
    }
}

/// Says that the search ended at its last round, when a candidate there passed the rule
/// but was not taken: the search finds at most [`ROUNDS`] effects.
fn stop_line(s: &mut String, d: &Diagnosis) {
    if d.rounds.len() < ROUNDS {
        return;
    }
    let taken = d
        .findings
        .iter()
        .find(|f| f.round == ROUNDS)
        .map(|f| f.effect.name());
    let left: Vec<&str> = d.rounds[ROUNDS - 1]
        .iter()
        .filter(|c| c.significant && Some(c.name.as_str()) != taken)
        .map(|c| c.name.as_str())
        .collect();
    if !left.is_empty() {
        let _ = writeln!(
            s,
            "The search stops after {ROUNDS} rounds (at most {ROUNDS} effects): {} passed the rule in round {ROUNDS} behind the effect found there and is not tested further; `agvsim calibrate`, whose rounds go on until no effect passes, tests it on a scene",
            left.join(", ")
        );
    }
}

/// " (output a %, output b %)" for several outputs; nothing for one.
fn per_output(fits: &std::collections::BTreeMap<String, f64>) -> String {
    if fits.len() < 2 {
        return String::new();
    }
    let parts: Vec<String> = fits.iter().map(|(o, f)| format!("{o} {f:.2} %")).collect();
    format!(" ({})", parts.join(", "))
}

/// The parameters a fit's beliefs held, each with what the record alone determines.
fn held_lines(s: &mut String, estimates: &[ParamReport], whose: &str) {
    let held: Vec<&ParamReport> = estimates.iter().filter(|p| p.held).collect();
    if held.is_empty() {
        return;
    }
    let _ = writeln!(
        s,
        "Held near the rig's belief in {whose} (the record determines them less well than the belief does):"
    );
    for p in held {
        let alone = match p.data_std {
            Some(sd) => format!("± {:.0} %", 100.0 * sd / p.value.abs().max(1e-300)),
            None => "nothing".into(),
        };
        let _ = writeln!(
            s,
            "  {} = {} (belief {} ± {:.0} %; the record alone: {alone})",
            p.name,
            quantity(p.value, 6, unit_key_or_name(&p.name)),
            sig(p.nominal, 6),
            p.belief_sd_pct.unwrap_or(f64::NAN)
        );
    }
}

/// How far the standard deviations can be trusted: the residual's correlation time.
fn uncertainty_line(s: &mut String, d: &Diagnosis) {
    if d.correlation_rows > 1 {
        let _ = writeln!(
            s,
            "Standard deviations: the residual is not white (it stays correlated over {:.3} s); they come from the spread of {:.3} s blocks' scores with the rig's beliefs, not from a white-noise assumption",
            d.correlation_s, d.correlation_s
        );
    }
}
