//! Text reports of an identification, in the spirit of the thesis's MATLAB printouts.

use std::fmt::Write;

use super::{Evaluation, Identification, StateSpaceReport};
use crate::numtext::{estimate, quantity, sig, unit_of_name};
use crate::rig::keys::unit_key_or_name;

fn pm(v: f64, s: Option<f64>) -> String {
    match s {
        Some(s) => format!("{v:>11.4} ± {s:<9.4}"),
        None => format!("{v:>11.4} ± {:<9}", "undet."),
    }
}

/// Relative standard deviation as a percentage, or a mark when undetermined.
fn rel(v: f64, s: Option<f64>) -> String {
    match s {
        Some(s) if v != 0.0 => format!("{:.2} %", 100.0 * s / v.abs()),
        Some(_) => "-".into(),
        None => "not determined by the data".into(),
    }
}

fn matrix(out: &mut String, name: &str, m: &[Vec<f64>], s: &[Vec<Option<f64>>]) {
    for (r, row) in m.iter().enumerate() {
        let label = if r == 0 {
            format!("{name} =")
        } else {
            String::new()
        };
        let cells: Vec<String> = row.iter().zip(&s[r]).map(|(v, s)| pm(*v, *s)).collect();
        let _ = writeln!(out, "  {label:<4} [ {} ]", cells.join("  "));
    }
}

/// The thesis-style A and B table.
pub fn state_space_table(ss: &StateSpaceReport) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "Continuous-time state-space model, states = motor speeds (left, right){}:",
        if ss.a.len() > 2 {
            ", then the speed-loop integrators"
        } else {
            ""
        }
    );
    matrix(&mut out, "A", &ss.a, &ss.a_std);
    matrix(&mut out, "B", &ss.b, &ss.b_std);
    let _ = writeln!(
        out,
        "  (inputs: forward, turn demand in pct; A in 1/s, B in rad/s^2 per pct)"
    );
    out
}

fn evaluation(out: &mut String, title: &str, e: &Evaluation) {
    let _ = writeln!(out, "{title}: {} ({} samples)", e.recording, e.n_samples);
    for (name, fit) in &e.fit_pct {
        let _ = writeln!(
            out,
            "  fit {name:<26} {fit:8.2} %   residual RMS {}",
            quantity(e.rms[name], 4, unit_of_name(name))
        );
    }
    let _ = writeln!(out, "  loss V = {}", sig(e.loss, 6));
    for c in &e.checks {
        let w = &c.whiteness;
        let _ = writeln!(
            out,
            "  residual {}: whiteness {} ({} of {} lags outside the 99 % band ±{:.3})",
            c.output,
            if w.passes { "ok" } else { "FAILS" },
            w.outside,
            w.lags.len(),
            w.band
        );
        for (input, x) in &c.independence {
            let _ = writeln!(
                out,
                "    vs input {input}: independence {} ({} of {} lags outside ±{:.3})",
                if x.passes { "ok" } else { "FAILS" },
                x.outside,
                x.lags.len(),
                x.band
            );
        }
    }
}

/// The full report.
pub fn render(id: &Identification) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "Model: {}", id.model);
    if !id.ignored_inputs.is_empty() {
        let _ = writeln!(
            out,
            "Ignored: {} (the model has no input for it)",
            id.ignored_inputs.join(", ")
        );
    }
    let _ = writeln!(
        out,
        "Solver: Levenberg-Marquardt, {} start(s), {} iterations, {} simulations, {}",
        id.starts,
        id.iterations,
        id.evaluations,
        if id.converged {
            "converged"
        } else {
            "stopped at the iteration limit"
        }
    );
    let _ = writeln!(
        out,
        "\n{:<34} {:<16} {:>12}   {:<28} {:>10}",
        "parameter", "unit", "nominal", "estimate ± 1 std", "rel. std"
    );
    for p in &id.params {
        let unit = unit_key_or_name(&p.name);
        let head = format!("{:<34} {:<16} {:>12}", p.name, unit, sig(p.nominal, 6));
        if let Some(b) = p.at_bound {
            let _ = writeln!(
                out,
                "{head}   {:<28} AT BOUND {}: not an estimate; the rig's belief or the model is wrong",
                sig(p.value, 6),
                quantity(b, 4, unit)
            );
        } else if p.free {
            let _ = writeln!(
                out,
                "{head}   {:<28} {:>10}",
                estimate(p.value, p.std, ""),
                rel(p.value, p.std)
            );
        } else {
            let _ = writeln!(out, "{head}   {:<28} (fixed)", sig(p.value, 6));
        }
    }
    if let Some(ss) = &id.state_space {
        let _ = writeln!(out);
        out.push_str(&state_space_table(ss));
    }
    if let Some(ff) = &id.feedforward {
        let _ = writeln!(out);
        out.push_str(&crate::ident::sysid_regression::render_report(ff));
    }
    let _ = writeln!(
        out,
        "\nLoss function V = {}   Akaike FPE = {}   AIC = {:.2}   ({} free parameters, {} residuals)",
        sig(id.estimation.loss, 6),
        sig(id.fpe, 6),
        id.aic,
        id.n_free,
        id.n_residuals
    );
    evaluation(&mut out, "\nEstimation", &id.estimation);
    if let Some(v) = &id.validation {
        evaluation(&mut out, "\nValidation", v);
    }
    out
}
