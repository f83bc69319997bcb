//! The calibration as JSON (the contract's diagnosis fields beside calibrate's own).

use super::mean_fit;
use crate::calibrate::Calibration;

/// The wheel geometry as the JSON carries it: radii and track with their deviations,
/// the configured values, UMBmark's figures and `diff_drive_controller`'s multipliers.
fn geometry_json(g: &crate::calibrate::WheelGeometry) -> serde_json::Value {
    let m = g.controller_multipliers();
    serde_json::json!({
        "left_radius_m": g.radii_m[0].0, "left_radius_std_m": g.radii_m[0].1,
        "right_radius_m": g.radii_m[1].0, "right_radius_std_m": g.radii_m[1].1,
        "track_m": g.track_m.0, "track_std_m": g.track_m.1,
        "configured_radius_m": g.configured_m.0, "configured_separation_m": g.configured_m.1,
        "umbmark_ed": g.ed(), "umbmark_eb": g.eb(),
        "diff_drive_controller": {
            "wheel_separation_multiplier": m.wheel_separation,
            "left_wheel_radius_multiplier": m.left_wheel_radius,
            "right_wheel_radius_multiplier": m.right_wheel_radius,
        },
    })
}

/// The calibration as JSON: each key (before, after, std, at bound) and each fitted
/// output's replay fit on the original and the calibrated scene.
pub fn json(c: &Calibration, scene: &str, recording: &str) -> serde_json::Value {
    let keys: Vec<serde_json::Value> = c
        .keys
        .iter()
        .map(|k| {
            serde_json::json!({
                "key": k.key,
                "scene": k.before,
                "calibrated": k.after,
                "fitted": k.fitted,
                "std": k.std,
                "at_bound": k.at_bound,
                "held_by_belief": k.held,
                "trades_with": k.trades_with.iter().map(|(key, r)| serde_json::json!({"key": key, "correlation": r})).collect::<Vec<_>>(),
                "confounded": k.confounded,
                "moves_with_held": k.moves_with_held.iter().map(|(key, shift)| serde_json::json!({"key": key, "shift_per_10_pct": shift})).collect::<Vec<_>>(),
                "conditional_on_held": k.conditional(),
                "estimate": k.calibrated(),
                "loosely_determined": k.loose_share().is_some(),
            })
        })
        .collect();
    let fits: serde_json::Map<String, serde_json::Value> = c
        .outputs
        .iter()
        .filter_map(|n| {
            let (b, a) = (c.before.output(n)?, c.after.output(n)?);
            Some((
                n.clone(),
                serde_json::json!({"original_pct": b.fit_pct, "calibrated_pct": a.fit_pct}),
            ))
        })
        .collect();
    let effects: Vec<serde_json::Value> = c
        .effects
        .iter()
        .map(|t| {
            serde_json::json!({
                "name": t.effect.name(),
                "key": t.key,
                "value": t.value,
                "std": t.std,
                "at_bound": t.at_bound,
                "delta_aic": t.delta_aic,
                "rss_reduction_pct": t.rss_reduction_pct,
                "accepted": t.accepted,
                "removed": t.removed,
                "raced_only": t.raced_only,
                "unconfirmed": t.unconfirmed.map(|u| match u {
                    crate::calibrate::Unconfirmed::Simulator => "simulator",
                    crate::calibrate::Unconfirmed::Validation => "validation",
                }),
                "scene_value": t.scene_value,
            })
        })
        .collect();
    let switches: Vec<serde_json::Value> = c
        .switches
        .iter()
        .map(|s| serde_json::json!({"effect": s.effect.name(), "key": s.key, "value": s.value}))
        .collect();
    serde_json::json!({
        "scene": scene,
        "recording": recording,
        "keys": keys,
        "effects": effects,
        "switches": switches,
        "removed": c.removed.iter().map(|r| serde_json::json!({"effect": r.effect.name(), "key": r.key, "was": r.was, "now": r.off})).collect::<Vec<_>>(),
        "replay_fit": fits,
        "left_out": c.left_out,
        "mean_fit_pct": {"original": mean_fit(&c.before, &c.outputs), "calibrated": mean_fit(&c.after, &c.outputs)},
        "wheel_geometry": c.wheel_geometry().map(|g| geometry_json(&g)),
        "iterations": c.iterations,
        "residual_correlation_s": c.residual_correlation_s,
        "model_check": {
            "passes": !c.model_check_fails(),
            "residual_links": c.residual_links.iter().map(link_json).collect::<Vec<_>>(),
        },
        "terms": c.terms.as_ref().map(|t| serde_json::json!({
            "screened": t.screened,
            "fitted": t.trials.iter().map(|trial| serde_json::json!({
                "name": trial.row.name,
                "outside_vocabulary": true,
                "params": trial.row.params.iter().cloned().collect::<serde_json::Map<String, serde_json::Value>>(),
                "std": trial.row.std,
                "keys": trial.coefficients.iter().map(|(k, v, sd)| serde_json::json!({"key": k, "value": v, "std": sd})).collect::<Vec<_>>(),
                "setting": trial.setting.as_ref().map(|(k, v)| serde_json::json!({"key": k, "value": v})),
                "delta_aic": trial.row.delta_aic,
                "rss_reduction_pct": trial.row.rss_reduction_pct,
                "held_out_reduction_pct": trial.row.held_out_reduction_pct,
                "at_bound": trial.row.at_bound,
                "undetermined": trial.row.undetermined,
                "wrong_sign": trial.wrong_sign,
                "accepted": trial.accepted,
            })).collect::<Vec<_>>(),
        })),
    })
}

/// A residual link ([`crate::calibrate::adequacy`]) as JSON: its output, signal, strength
/// (above 1: the model is wrong) and numbers.
fn link_json(l: &crate::calibrate::adequacy::ResidualLink) -> serde_json::Value {
    use crate::calibrate::adequacy::How;
    let how = match l.how {
        How::Lagged {
            lag_s,
            correlation,
            band,
        } => serde_json::json!({
            "lagged": {"lag_s": lag_s, "correlation": correlation, "band_99": band}
        }),
        How::Binned {
            from,
            to,
            mean,
            std_error,
        } => serde_json::json!({
            "binned": {"from": from, "to": to, "mean": mean, "std_error": std_error}
        }),
    };
    serde_json::json!({
        "output": l.output,
        "signal": l.signal,
        "strength": l.strength(),
        "says_model_wrong": l.says_model_wrong(),
        "how": how,
    })
}
