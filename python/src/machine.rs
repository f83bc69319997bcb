//! What the machine is, in numbers rather than files: its plant linearised (`agvsim
//! linearize`) and the tyre presets (`agvsim presets`).

use std::path::PathBuf;

use pyo3::prelude::*;

use agvsim::model::tyre_presets::{COMPOUNDS, SURFACES};
use agvsim::sim::linearize as linear;

use crate::failed;

/// Complex numbers as `[re, im]` pairs (JSON has no complex type).
fn pairs(poles: &[(f64, f64)]) -> Vec<[f64; 2]> {
    poles.iter().map(|&(re, im)| [re, im]).collect()
}

/// `agvsim linearize SCENE --set ...`: what it prints, and as JSON the export's matrices,
/// names and units (`--export FILE.json`) with the analysis: ranks, each state's share
/// outside the controllable and observable subspaces, the open loop's poles and, where the
/// scene's controller is a P-D law, the closed loop's.
#[pyfunction]
#[pyo3(signature = (scene, set))]
pub fn linearize(py: Python<'_>, scene: PathBuf, set: Vec<String>) -> PyResult<(String, String)> {
    let loaded = agvsim::scene::Scene::load(&scene, &set).map_err(failed)?;
    let l = py
        .allow_threads(|| linear::linearise(&loaded))
        .map_err(failed)?;
    let reach = linear::analyse(&l);
    let closed = linear::close_loop(&l);
    let mut json = linear::export::to_json(&l);
    json["analysis"] = serde_json::json!({
        "controllable_rank": reach.controllable_rank,
        "observable_rank": reach.observable_rank,
        "uncontrollable_share": reach.uncontrollable_share,
        "unobservable_share": reach.unobservable_share,
        "poles": pairs(&reach.poles),
        "closed_loop_poles": closed.as_ref().map(|c| pairs(&c.poles)),
        "closed_loop_stable": closed.as_ref().map(|c| c.stable()),
    });
    let report = agvsim::commands::linearize::report(&scene, &l, &reach);
    Ok((report, json.to_string()))
}

/// One compound on one surface: their names and the tyre values they combine into.
type PresetRow = (String, String, f64, f64, f64, f64, f64);

/// `agvsim presets`: every compound on every surface (compound, surface, peak mu, sliding
/// mu, longitudinal stiffness 1/N/slip, lateral stiffness 1/N/rad, relaxation length m),
/// each compound's note, each surface's friction factor and note, and the printed table.
#[pyfunction]
#[allow(clippy::type_complexity)]
pub fn presets() -> (
    Vec<PresetRow>,
    Vec<(String, String)>,
    Vec<(String, f64, String)>,
    String,
) {
    let rows = agvsim::scene::presets_table::pairs()
        .into_iter()
        .map(|(c, s, t)| {
            (
                c.to_string(),
                s.to_string(),
                t.peak_mu,
                t.sliding_mu,
                t.long_stiffness_per_N,
                t.lat_stiffness_per_N,
                t.relaxation_length_m,
            )
        })
        .collect();
    let compounds = COMPOUNDS
        .iter()
        .map(|c| (c.name.to_string(), c.note.to_string()))
        .collect();
    let surfaces = SURFACES
        .iter()
        .map(|s| (s.name.to_string(), s.friction_factor, s.note.to_string()))
        .collect();
    (
        rows,
        compounds,
        surfaces,
        agvsim::scene::presets_table::render(),
    )
}
