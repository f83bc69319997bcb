//! The table `agvsim presets` prints: every tyre compound on every floor surface, the tyre
//! values they combine into, and what each compound and surface is.

use std::fmt::Write;

use crate::model::tyre::TyreParams;
use crate::model::tyre_presets::{COMPOUNDS, SURFACES};

/// Every compound on every surface, compounds outer: their names and the tyre values they
/// combine into.
pub fn pairs() -> Vec<(&'static str, &'static str, TyreParams)> {
    COMPOUNDS
        .iter()
        .flat_map(|c| {
            SURFACES
                .iter()
                .map(move |s| (c.name, s.name, TyreParams::of(c, s)))
        })
        .collect()
}

/// The compounds on the surfaces, one row each, then each compound's and surface's note.
pub fn render() -> String {
    let rows: Vec<(String, TyreParams)> = pairs()
        .into_iter()
        .map(|(c, s, t)| (format!("{c} on {s}"), t))
        .collect();
    let width = rows.iter().map(|(n, _)| n.len()).max().unwrap_or(0);
    let mut out = format!(
        "{:<width$}  {:>7}  {:>8}  {:>13}  {:>13}  {:>12}\n",
        "compound on surface", "peak mu", "slide mu", "Cx (1/N/slip)", "Cy (1/N/rad)", "relax (m)"
    );
    for (name, t) in &rows {
        let _ = writeln!(
            out,
            "{name:<width$}  {:>7.3}  {:>8.3}  {:>13.1}  {:>13.1}  {:>12.3}",
            t.peak_mu,
            t.sliding_mu,
            t.long_stiffness_per_N,
            t.lat_stiffness_per_N,
            t.relaxation_length_m
        );
    }
    out.push_str("\ncompounds:\n");
    let cw = COMPOUNDS.iter().map(|c| c.name.len()).max().unwrap_or(0);
    for c in &COMPOUNDS {
        let _ = writeln!(out, "  {:<cw$}  {}", c.name, c.note);
    }
    out.push_str("surfaces (friction relative to bare concrete):\n");
    let sw = SURFACES.iter().map(|s| s.name.len()).max().unwrap_or(0);
    for s in &SURFACES {
        let _ = writeln!(
            out,
            "  {:<sw$}  x{:.2}  {}",
            s.name, s.friction_factor, s.note
        );
    }
    out
}
