//! The diagnosis in plain words: what `agvsim diagnose` prints and its report folder
//! holds.

use std::fmt::Write as _;

use super::Diagnosis;

/// The diagnosis in plain words.
pub fn render(d: &Diagnosis) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "Recording: {}   model: {}", d.recording, d.model);
    let _ = writeln!(
        s,
        "Baseline (nominal model, parameters fitted): fit {:.2} %",
        d.baseline_fit_pct
    );
    if !d.ignored_inputs.is_empty() {
        let _ = writeln!(
            s,
            "Ignored: {} (the model has no input for it)",
            d.ignored_inputs.join(", ")
        );
    }
    for (name, bound) in &d.baseline_at_bound {
        let _ = writeln!(
            s,
            "WARNING: {name} ended at its search bound {bound:.4e}: not an estimate; the rig's belief or the model's structure is wrong, and effects found below may be standing in for that"
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
    for (i, round) in d.rounds.iter().enumerate() {
        let _ = writeln!(
            s,
            "Candidates, round {} (effective residual count {:.0}):",
            i + 1,
            d.effective_n
        );
        for c in round {
            let _ = writeln!(
                s,
                "  {:<20} {} = {:<12.5e} RSS -{:5.1} %  dAIC {:9.1}  {}",
                c.name,
                c.param,
                c.value,
                c.rss_reduction_pct,
                c.delta_aic,
                if c.significant {
                    "significant"
                } else if c.reached_without_it {
                    "not the effect's: the stage refitted from its fit reaches it"
                } else if c.screened_only {
                    "screened (full search skipped)"
                } else {
                    ""
                }
            );
        }
    }
    if d.findings.is_empty() {
        let _ = writeln!(s, "Verdict: nothing is missing; no effect explains enough of the residual to be told from noise.");
    }
    for f in &d.findings {
        let std = f.std.map(|v| format!(" ± {v:.3e}")).unwrap_or_default();
        let _ = writeln!(
            s,
            "Found: {} — {} ({} = {:.5e}{std})",
            f.effect.name(),
            f.description,
            f.param,
            f.value
        );
        let _ = writeln!(s, "  evidence: {}", f.evidence);
        let _ = writeln!(s, "  fit {:.2} % -> {:.2} %", d.baseline_fit_pct, f.fit_pct);
    }
    if let Some(ff) = &d.feedforward {
        s.push_str(&crate::ident::feedforward::render_report(ff));
        if let Some(f) = d.findings.iter().find(|f| f.param == "coulomb_torque_Nm") {
            let _ = writeln!(
                s,
                "  beside it, diagnosis's coulomb_friction: {:.4e} N m at the motor shaft",
                f.value
            );
        }
        if let Some(ks) = d.coulomb_as_ks_v() {
            let _ = writeln!(
                s,
                "  diagnosis's coulomb_friction as SysId's kS (Tc R / K, diagnosed K and R): {ks:.4} V"
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
            "Validation {}: fit {:.2} % (baseline) -> {:.2} % (diagnosed)",
            b.recording, b.fit_pct_mean, a.fit_pct_mean
        );
    }
    s
}
