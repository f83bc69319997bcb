//! The three shareable reports: a calibration, a diagnosis, an identification. Each has
//! the recording's summary, the numbers as tables (every estimate with its standard
//! deviation and verdict), the fit per output before and after with the plots, what
//! changed, the report as the command printed it, and the command.

use super::{Cell, Document};
use crate::calibrate::Calibration;
use crate::diagnose::Diagnosis;
use crate::ident::Identification;
use crate::numtext::{estimate, quantity, sig};
use crate::record::Recording;
use crate::rig::keys::unit_of_key;

/// A percentage to one decimal, as the reports print fits.
fn pct(v: f64) -> Cell {
    Cell::Num(if v.is_finite() {
        format!("{v:.1} %")
    } else {
        "-".into()
    })
}

/// The calibration report, titled `what` ("Calibration", or "Diagnosis" where
/// `diagnose --scene` asked the open question through calibrate).
pub fn calibration(
    what: &str,
    c: &Calibration,
    scene_path: &str,
    recording_names: &str,
    rec: &Recording,
    text_report: &str,
    command: &str,
) -> String {
    let mut d = Document::new(&format!("{what} of {scene_path} against {recording_names}"));
    d.paragraph(
        &format!(
            "The scene's keys fitted to the recording through the simulator, and the effects the recording shows: mean replay fit {:.1} % with the scene as written, {:.1} % calibrated, over the fitted outputs ({} solver iterations in all stages).",
            crate::calibrate::write::mean_fit(&c.before, &c.outputs),
            crate::calibrate::write::mean_fit(&c.after, &c.outputs),
            c.iterations
        ),
        "",
    );
    d.heading("The recording");
    d.recording(recording_names, rec);
    d.heading("Fitted keys");
    key_table(&mut d, c);
    if let Some(l) = c.residual_links.first() {
        let (text, class) = if l.says_model_wrong() {
            (format!("Model check failed: {}. The calibrated model does not reproduce the recording down to its noise; the intervals above assume a right model and are not to be trusted.", l.describe()), "bad")
        } else {
            (format!("Model check passed: no output's residual follows a signal the model knows (the strongest, {:.0} % of the way to failing: {}).", 100.0 * l.strength(), l.describe()), "note")
        };
        d.paragraph(&text, class);
    }
    if !c.effects.is_empty() {
        effect_table(&mut d, c);
    }
    if let Some(g) = c.wheel_geometry() {
        geometry_table(&mut d, &g);
    }
    d.heading("Replay fit per output");
    let rows = c
        .outputs
        .iter()
        .filter_map(|name| {
            let (b, a) = (c.before.output(name)?, c.after.output(name)?);
            Some(vec![name.as_str().into(), pct(b.fit_pct), pct(a.fit_pct)])
        })
        .collect();
    d.table(&["output", "scene as written", "calibrated"], rows);
    for l in &c.left_out {
        d.paragraph(&format!("Left out: {} ({})", l.output, l.why), "note");
    }
    d.figures(&crate::calibrate::write::figures(c, recording_names));
    d.heading("What the calibrated scene changes");
    changes_table(&mut d, c);
    d.heading("The report as printed");
    d.pre(text_report);
    d.command(command);
    d.finish()
}

/// The wheel geometry the recording shows: effective radii and track against the
/// configured ones, UMBmark's figures, and `diff_drive_controller`'s multipliers.
fn geometry_table(d: &mut Document, g: &crate::calibrate::WheelGeometry) {
    d.heading("Wheel geometry");
    let num = |v: f64| Cell::Num(sig(v, 6));
    let m = g.controller_multipliers();
    let rows = vec![
        vec![
            "left wheel's effective radius".into(),
            Cell::Num(estimate(g.radii_m[0].0, g.radii_m[0].1, "m")),
            Cell::Num(quantity(g.configured_m.0, 6, "m")),
        ],
        vec![
            "right wheel's effective radius".into(),
            Cell::Num(estimate(g.radii_m[1].0, g.radii_m[1].1, "m")),
            Cell::Num(quantity(g.configured_m.0, 6, "m")),
        ],
        vec![
            "effective track".into(),
            Cell::Num(estimate(g.track_m.0, g.track_m.1, "m")),
            Cell::Num(quantity(g.configured_m.1, 6, "m")),
        ],
        vec![
            "UMBmark Ed (right/left diameter)".into(),
            num(g.ed()),
            num(1.0),
        ],
        vec![
            "UMBmark Eb (track/configured)".into(),
            num(g.eb()),
            num(1.0),
        ],
        vec![
            "diff_drive_controller wheel_separation_multiplier".into(),
            num(m.wheel_separation),
            "".into(),
        ],
        vec![
            "diff_drive_controller left_wheel_radius_multiplier".into(),
            num(m.left_wheel_radius),
            "".into(),
        ],
        vec![
            "diff_drive_controller right_wheel_radius_multiplier".into(),
            num(m.right_wheel_radius),
            "".into(),
        ],
    ];
    d.table(&["", "from the recording", "configured"], rows);
}

/// Each key before and after, with its verdict.
fn key_table(d: &mut Document, c: &Calibration) {
    let rows = c
        .keys
        .iter()
        .map(|k| {
            let unit = unit_of_key(&k.key);
            let (value, note) = crate::calibrate::write::key_cells(k, unit);
            vec![
                k.key.as_str().into(),
                unit.into(),
                Cell::Num(sig(k.before, 6)),
                Cell::Num(value.unwrap_or_else(|| sig(k.after, 6))),
                note.unwrap_or_else(|| "estimate".into()).into(),
            ]
        })
        .collect();
    d.table(
        &["key", "unit", "scene", "calibrated ± 1 std", "verdict"],
        rows,
    );
}

/// Each effect tried with its evidence.
fn effect_table(d: &mut Document, c: &Calibration) {
    d.heading("Effects tried");
    d.paragraph("Each effect's evidence: the Akaike information criterion's gain and the change of the weighted residual with the effect against without it.", "note");
    let rows = c
        .effects
        .iter()
        .map(|t| {
            let unit = unit_of_key(&t.key);
            vec![
                t.effect.name().into(),
                t.key.as_str().into(),
                Cell::Num(if t.accepted {
                    estimate(t.value, t.std, unit)
                } else {
                    quantity(t.value, 4, unit)
                }),
                Cell::Num(if t.delta_aic.is_finite() {
                    format!("{:.1}", t.delta_aic)
                } else {
                    "-".into()
                }),
                Cell::Num(crate::numtext::change_pct(-t.rss_reduction_pct)),
                crate::calibrate::write::verdict(t, unit).into(),
            ]
        })
        .collect();
    d.table(
        &["effect", "key", "value", "AIC gain", "residual", "verdict"],
        rows,
    );
}

/// What the calibrated scene changes: keys fitted, effects removed, switches set.
fn changes_table(d: &mut Document, c: &Calibration) {
    let mut rows: Vec<Vec<Cell>> = c
        .keys
        .iter()
        // A change below what 6 figures show is not one to list.
        .filter(|k| k.calibrated() && sig(k.after, 6) != sig(k.before, 6))
        .map(|k| {
            vec![
                k.key.as_str().into(),
                Cell::Num(quantity(k.before, 6, unit_of_key(&k.key))),
                Cell::Num(quantity(k.after, 6, unit_of_key(&k.key))),
                "fitted".into(),
            ]
        })
        .collect();
    rows.extend(c.removed.iter().map(|r| {
        vec![
            r.key.as_str().into(),
            Cell::Num(quantity(r.was, 6, unit_of_key(&r.key))),
            Cell::Num(quantity(r.off, 6, unit_of_key(&r.key))),
            format!(
                "{} removed: the recording does not support it",
                r.effect.name()
            )
            .into(),
        ]
    }));
    rows.extend(c.switches.iter().map(|s| {
        vec![
            s.key.as_str().into(),
            "".into(),
            Cell::Num(s.value.clone()),
            format!("set to switch {} on", s.effect.name()).into(),
        ]
    }));
    if rows.is_empty() {
        d.paragraph("Nothing: every key keeps the scene's value.", "note");
    } else {
        d.table(&["key", "scene", "calibrated scene", "why"], rows);
    }
}

/// The terms outside the vocabulary a diagnosis found, and what it left unexplained.
fn terms_found(d: &mut Document, diag: &crate::diagnose::Diagnosis) {
    for t in &diag.terms {
        d.paragraph(
            &format!(
                "{} (outside the vocabulary) — {}",
                t.row.name, t.description
            ),
            "bad",
        );
        d.paragraph(&format!("Evidence: {}", t.evidence), "");
    }
    if let Some(u) = &diag.unexplained {
        d.paragraph(
            &format!(
                "Unexplained: structure remains that no effect and no family of terms explains ({:.1} % of the residual): {}",
                u.fit_gap_pct, u.where_
            ),
            "bad",
        );
    }
}

/// The diagnosis report.
pub fn diagnosis(
    diag: &Diagnosis,
    recording_names: &str,
    rec: &Recording,
    text_report: &str,
    command: &str,
) -> String {
    let mut d = Document::new(&format!("Diagnosis of {recording_names}"));
    d.paragraph(
        &format!(
            "Model: {}. Fit {:.1} % with the nominal model fitted (the baseline), {:.1} % diagnosed.",
            diag.model, diag.baseline_fit_pct, diag.final_fit_pct
        ),
        "",
    );
    d.heading("The recording");
    d.recording(recording_names, rec);
    d.heading("Found");
    terms_found(&mut d, diag);
    if diag.findings.is_empty() && diag.terms.is_empty() {
        d.paragraph(
            "Nothing is missing: no effect explains enough of the residual to be told from noise.",
            "good",
        );
    }
    for f in &diag.findings {
        d.paragraph(
            &format!(
                "{} — {} ({} = {})",
                f.effect.name(),
                f.description,
                f.param,
                estimate(f.value, f.std, f.effect.unit(false))
            ),
            "bad",
        );
        d.paragraph(&format!("Evidence: {}", f.evidence), "");
        for a in &f.alternatives {
            d.paragraph(
                &format!(
                    "The recording cannot tell it from {} ({} = {}, dAIC {:.1} behind): {}",
                    a.name,
                    a.param,
                    sig(a.value, 4),
                    a.delta_aic_behind,
                    a.separated_by
                ),
                "note",
            );
        }
    }
    d.heading("Fit per output");
    let rows = diag
        .baseline
        .fit_pct
        .iter()
        .map(|(name, b)| {
            vec![
                name.as_str().into(),
                pct(*b),
                pct(diag
                    .diagnosed
                    .fit_pct
                    .get(name)
                    .copied()
                    .unwrap_or(f64::NAN)),
            ]
        })
        .collect();
    d.table(&["output", "baseline", "diagnosed"], rows);
    if let Ok(figures) = crate::diagnose::plots::figures(diag) {
        d.figures(&figures);
    }
    d.heading("Parameters");
    let rows = diag
        .final_estimates
        .iter()
        .filter(|p| p.free)
        .map(|p| {
            vec![
                p.name.as_str().into(),
                Cell::Num(sig(p.nominal, 6)),
                Cell::Num(match p.at_bound {
                    Some(b) => format!("at bound {}", sig(b, 4)),
                    None => estimate(p.value, p.std, ""),
                }),
            ]
        })
        .collect();
    d.table(&["parameter", "rig", "diagnosed ± 1 std"], rows);
    d.heading("The report as printed");
    d.pre(text_report);
    d.command(command);
    d.finish()
}

/// The identification report.
pub fn identification(
    id: &Identification,
    recording_names: &str,
    rec: &Recording,
    text_report: &str,
    command: &str,
) -> String {
    let mut d = Document::new(&format!("Identification of {recording_names}"));
    d.paragraph(
        &format!(
            "Model: {} on the rig {}. {} free parameters, {} residuals, loss (FPE) {}, AIC {:.1}; {} after {} iterations from {} starts.",
            id.model,
            id.rig,
            id.n_free,
            id.n_residuals,
            sig(id.fpe, 4),
            id.aic,
            if id.converged { "converged" } else { "not converged" },
            id.iterations,
            id.starts
        ),
        if id.converged { "" } else { "bad" },
    );
    d.heading("The recording");
    d.recording(recording_names, rec);
    d.heading("Parameters");
    let rows = id
        .params
        .iter()
        .map(|p| {
            vec![
                p.name.as_str().into(),
                Cell::Num(sig(p.nominal, 6)),
                Cell::Num(match (p.free, p.at_bound) {
                    (false, _) => sig(p.value, 6),
                    (true, Some(b)) => format!("at bound {}", sig(b, 4)),
                    (true, None) => estimate(p.value, p.std, ""),
                }),
                (if !p.free {
                    "fixed at the rig's value"
                } else if p.at_bound.is_some() {
                    "at a bound: not an estimate (check the rig's value or the model)"
                } else if p.std.is_none() {
                    "undetermined by the recording"
                } else {
                    "estimate"
                })
                .into(),
            ]
        })
        .collect();
    d.table(&["parameter", "rig", "identified ± 1 std", "verdict"], rows);
    d.heading("Fit per output");
    let rows = id
        .estimation
        .fit_pct
        .iter()
        .map(|(name, f)| {
            let v = id
                .validation
                .as_ref()
                .and_then(|v| v.fit_pct.get(name).copied())
                .unwrap_or(f64::NAN);
            vec![name.as_str().into(), pct(*f), pct(v)]
        })
        .collect();
    d.table(&["output", "estimation", "validation"], rows);
    if let Ok(f) = crate::ident::plots::evaluation_figures("estimation", &id.estimation) {
        d.figures(&f);
    }
    if let Some(Ok(f)) = id
        .validation
        .as_ref()
        .map(|v| crate::ident::plots::evaluation_figures("validation", v))
    {
        d.figures(&f);
    }
    d.heading("The report as printed");
    d.pre(text_report);
    d.command(command);
    d.finish()
}
