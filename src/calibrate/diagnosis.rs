//! A diagnosis through the simulator, for recordings the fitting models cannot take (a
//! robot driven by velocity commands through its base controller): the scene's free keys
//! fitted first (the baseline), then calibrate's effect rounds, each effect switched on
//! through its scene key and kept where the recording gives evidence for it. The result
//! in the contract's diagnosis JSON.

use super::{Calibration, EffectTrial};
use crate::ident::effects::Effect;
use crate::model::GRAVITY_M_S2;
use crate::replay::Replay;
use crate::scene::Scene;

/// An accepted effect's parameter in the contract's terms: its name and value. The scene
/// keys hold the contract's parameters, in its units, but for castor drag, whose scene
/// key is the castors' rolling-resistance coefficient: the contract's `drag_N` is that
/// coefficient times the weight the castors carry.
pub fn contract_param(scene: &Scene, t: &EffectTrial) -> (&'static str, f64) {
    let name = t.effect.param_name(false);
    let value = match t.effect {
        Effect::CastorDrag => {
            let mass = scene.chassis.mass_kg + scene.payload.mass_kg;
            t.value * mass * GRAVITY_M_S2 * (1.0 - scene.chassis.drive_load_fraction)
        }
        _ => t.value,
    };
    (name, value)
}

/// The term outside the vocabulary the calibration accepted, if any.
fn accepted_term(c: &Calibration) -> Option<&super::terms::TermTrial> {
    c.terms.as_ref().and_then(|t| t.accepted())
}

/// The diagnosis's conclusion in the words `diagnose --rig` uses: a `Found:` line for each
/// effect accepted, with what it is and its value, then the fit from the baseline (the
/// scene's free keys fitted, no effect) to the diagnosed scene; or the verdict that
/// nothing is missing.
pub fn findings_text(c: &Calibration, baseline: &Replay) -> String {
    use crate::numtext::estimate;
    use std::fmt::Write as _;
    let mut s = String::new();
    let found: Vec<&EffectTrial> = c.effects.iter().filter(|t| t.accepted).collect();
    let term = accepted_term(c);
    if found.is_empty() && term.is_none() {
        let _ = writeln!(
            s,
            "Verdict: nothing is missing; no effect (or term outside the vocabulary) explains enough of the residual to be told from noise."
        );
    }
    for t in &found {
        let (param, value) = contract_param(&c.scene, t);
        let unit = t.effect.unit(false);
        // The contract's value in its units; the scene key's deviation scales with it.
        let std = t
            .std
            .map(|sd| sd * (value / t.value).abs())
            .filter(|_| t.value != 0.0);
        let _ = writeln!(
            s,
            "Found: {} — {} ({param} = {})",
            t.effect.name(),
            crate::diagnose::evidence::describe(t.effect, value, false),
            estimate(value, std, unit)
        );
    }
    if let Some(t) = term {
        let _ = writeln!(
            s,
            "Found outside the vocabulary: {} — {}",
            t.row.name,
            crate::diagnose::terms::describe(&t.row)
        );
    }
    let _ = writeln!(
        s,
        "fit        {:.1} % (baseline: the scene's keys fitted, no effect) -> {:.1} % diagnosed",
        baseline.mean_fit_pct(),
        c.after.mean_fit_pct()
    );
    s
}

/// The contract's diagnosis object for a calibration with effects. `baseline`: the
/// recording replayed on [`Calibration::baseline`] (the free keys fitted, no effect), as
/// `diagnose --rig`'s baseline is the nominal model fitted.
pub fn contract_json(
    recording: &str,
    scene_path: &str,
    c: &Calibration,
    baseline: &Replay,
) -> serde_json::Value {
    let baseline_params: serde_json::Map<String, serde_json::Value> = c
        .keys
        .iter()
        .filter(|k| !c.effects.iter().any(|e| e.key == k.key))
        .map(|k| {
            let v = super::keys::get(&c.baseline, &k.key).unwrap_or(k.before);
            (k.key.clone(), serde_json::json!(v))
        })
        .collect();
    let per_output = |r: &Replay| {
        r.outputs
            .iter()
            .map(|o| (o.name.clone(), serde_json::json!(o.fit_pct)))
            .collect::<serde_json::Map<_, _>>()
    };
    let mut effects: Vec<serde_json::Value> = c
        .effects
        .iter()
        .filter(|t| t.accepted)
        .map(|t| {
            let (name, value) = contract_param(&c.scene, t);
            let mut params = serde_json::json!({ name: value });
            if let (Effect::WheelGeometry, Some(g)) = (t.effect, c.wheel_geometry()) {
                params["left_radius_m"] = serde_json::json!(g.radii_m[0].0);
                params["right_radius_m"] = serde_json::json!(g.radii_m[1].0);
                params["umbmark_ed"] = serde_json::json!(g.ed());
                params["umbmark_eb"] = serde_json::json!(g.eb());
            }
            serde_json::json!({
                "name": t.effect.name(),
                "params": params,
                "std": { name: t.std },
                "scene_key": t.key,
                "fit_pct": c.after.mean_fit_pct(),
                "evidence": format!(
                    "through the simulator: switched on, it removes {:.1} % of the weighted residual (AIC gain {:.1})",
                    t.rss_reduction_pct, t.delta_aic
                ),
            })
        })
        .collect();
    effects.extend(accepted_term(c).map(|t| {
        let main = t.row.params.first().map_or(String::new(), |(n, _)| n.clone());
        serde_json::json!({
            "name": t.row.name,
            "outside_vocabulary": true,
            "params": t.row.params.iter().cloned().collect::<serde_json::Map<_, _>>(),
            "std": { main: t.row.std },
            "scene_keys": t.coefficients.iter().map(|(k, _, _)| k.clone()).collect::<Vec<_>>(),
            "fit_pct": c.after.mean_fit_pct(),
            "evidence": format!(
                "through the simulator: its screen removed {:.1} % of the held-out time blocks' residual; fitted, {:.1} % of the weighted residual (AIC gain {:.1})",
                t.row.held_out_reduction_pct, t.row.rss_reduction_pct, t.row.delta_aic
            ),
            "description": crate::diagnose::terms::describe(&t.row),
            "delta_aic": t.row.delta_aic,
            "held_out_reduction_pct": t.row.held_out_reduction_pct,
        })
    }));
    serde_json::json!({
        "recording": recording,
        "model": format!("the simulator on {scene_path}"),
        "baseline": {
            "fit_pct": baseline.mean_fit_pct(),
            "fit_pct_per_output": per_output(baseline),
            "params": baseline_params,
        },
        "effects": effects,
        "final": {
            "fit_pct": c.after.mean_fit_pct(),
            "fit_pct_per_output": per_output(&c.after),
            "params": c.keys.iter().map(|k| (k.key.clone(), serde_json::json!(k.after))).collect::<serde_json::Map<_, _>>(),
        },
        "left_out": c.left_out.iter().map(|l| serde_json::json!({"output": l.output, "why": l.why})).collect::<Vec<_>>(),
    })
}
