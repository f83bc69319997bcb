//! The evidence a candidate effect brings: how much of the residual it removes, counted
//! with the residual's effective number of independent samples, where it removes it, and
//! the words a report uses for the effect.

use std::collections::BTreeMap;

use super::regimes::RegimeShare;
use super::{MIN_DELTA_AIC, MIN_RSS_REDUCTION};
use crate::ident::data::Dataset;
use crate::ident::effects::Effect;
use crate::ident::fit::Fit;
use crate::record::channels as chan;

/// What the fitted effect is, in words, with its value and units (its declaration's
/// words, [`crate::ident::effects::EffectDef::describe`]).
pub(crate) fn describe(e: Effect, v: f64, linear: bool) -> String {
    (e.def().describe)(v, linear)
}

pub(crate) use crate::ident::weighting::effective_n;

/// Why a record cannot tell two effects apart that explain it equally, and what record
/// would: the physics each adds, where it differs.
pub(crate) fn what_separates(a: Effect, b: Effect) -> String {
    use Effect::*;
    let pair = |x: Effect, y: Effect| (a == x && b == y) || (a == y && b == x);
    if pair(CoulombFriction, CastorDrag) {
        "castor drag or Coulomb friction: the same constant force on a straight run; a turn on the spot separates them (castor drag resists turning through the castors' lever, Coulomb friction acts at each motor), as does a test with the drive wheels lifted (no castor then)".into()
    } else if pair(CoulombFriction, Offset) {
        "Coulomb friction or an offset: the same constant force while the motion keeps one direction; a record moving both ways separates them (friction reverses with the motion, an offset does not)".into()
    } else if pair(VoltageSaturation, BatterySag) {
        "a clipped drive voltage or a sagging battery: both lower the voltage at large commands; steps of several sizes separate them (a clip is the same at every current, a sag grows with it), as does a recorded current".into()
    } else if pair(WheelSlip, VoltageSaturation) || pair(WheelSlip, BatterySag) {
        format!(
            "wheel slip or {}: both cap the acceleration at a hard step; a measured ground speed (a pose tracker) separates them (slip makes the wheels outrun the chassis, a weaker drive slows both), as do steps of several sizes",
            if pair(WheelSlip, BatterySag) { "a sagging battery" } else { "a clipped drive voltage" }
        )
    } else if pair(TransportDelay, Backlash) {
        "a dead time or gear play: both delay the response after a reversal; steps in one direction separate them (a delay acts at every step, a play only where the motion reverses)".into()
    } else if pair(CoulombFriction, FrictionAsymmetry) || pair(Offset, FrictionAsymmetry) {
        "a constant force or a direction-dependent viscous friction: both make one direction slower; runs at several speeds each way separate them (viscous friction grows with speed, a constant force does not)".into()
    } else {
        format!(
            "{} or {}: they change this record's outputs alike; a record that excites them differently (other amplitudes, both directions, a turn) would separate them",
            a.name(),
            b.name()
        )
    }
}

/// Sum of squared residuals per output.
fn output_rss(data: &Dataset, predicted: &[Vec<f64>]) -> Vec<f64> {
    data.outputs
        .iter()
        .zip(predicted)
        .map(|(col, p)| {
            col.iter()
                .zip(p)
                .filter_map(|(y, p)| y.map(|y| (y - p).powi(2)))
                .sum::<f64>()
                .max(1e-300)
        })
        .collect()
}

/// Log-likelihood gain of a richer model, outputs with their own unknown noise levels:
/// `sum_j n_j ln(RSS_j before / RSS_j after)`, each output counting its effective number
/// of independent residuals (the larger of the two models': when the effect is what
/// colours the baseline residual, the richer model's residual is whiter). An output that
/// drifts (a pose integrated from speeds) is strongly coloured and counts for little; the
/// others keep their weight.
fn likelihood_gain(
    data: &Dataset,
    before: &[Vec<f64>],
    n_before: &[f64],
    after: &[Vec<f64>],
) -> f64 {
    let n_after = effective_n(data, after);
    output_rss(data, before)
        .iter()
        .zip(output_rss(data, after))
        .enumerate()
        .map(|(j, (b, a))| n_before[j].max(n_after[j]) * (b / a).ln())
        .sum()
}

/// `|y - yhat| / |y|` in % per output over measured cells; for a position output also its
/// speed, both differenced over the same rows (the way benchmark papers report speed).
pub fn relative_errors(data: &Dataset, predicted: &[Vec<f64>]) -> BTreeMap<String, f64> {
    let mut out = BTreeMap::new();
    let rel = |pairs: &[(f64, f64)]| {
        let e: f64 = pairs
            .iter()
            .map(|(y, p)| (y - p).powi(2))
            .sum::<f64>()
            .sqrt();
        let n: f64 = pairs.iter().map(|(y, _)| y * y).sum::<f64>().sqrt();
        100.0 * e / n.max(1e-300)
    };
    for (j, name) in data.output_names.iter().enumerate() {
        let pairs: Vec<(f64, f64)> = data.outputs[j]
            .iter()
            .zip(&predicted[j])
            .filter_map(|(y, p)| y.map(|y| (y, *p)))
            .collect();
        out.insert(name.clone(), rel(&pairs));
        if let Some(stem) = name.strip_suffix(chan::POSITION_M) {
            let mut speed = Vec::new();
            for k in 1..data.len() {
                if let (Some(a), Some(b)) = (data.outputs[j][k - 1], data.outputs[j][k]) {
                    let dt = data.t_s[k] - data.t_s[k - 1];
                    speed.push(((b - a) / dt, (predicted[j][k] - predicted[j][k - 1]) / dt));
                }
            }
            out.insert(
                format!("{stem}speed_m_s (differenced position)"),
                rel(&speed),
            );
        }
    }
    out
}

/// Where the removed residual lies, as a sentence: the regime where the effect's removal
/// is most concentrated, passing over regimes an earlier finding already named (`named`:
/// regime and effect), so that two findings do not print the same evidence.
pub(crate) fn evidence(
    shares: &[RegimeShare],
    reduction_pct: f64,
    named: &[(String, &str)],
) -> (String, Option<String>) {
    let concentrated = |s: &&RegimeShare| s.concentration() > 1.5;
    let fresh = shares
        .iter()
        .filter(concentrated)
        .find(|s| !named.iter().any(|(r, _)| *r == s.regime));
    let sentence = |s: &RegimeShare| {
        format!(
            "{:.0}% of the residual energy the effect removes lies in the {:.0}% of samples {} (RSS down {reduction_pct:.0}%)",
            s.energy_pct, s.samples_pct, s.regime
        )
    };
    if let Some(s) = fresh {
        return (sentence(s), Some(s.regime.clone()));
    }
    match shares.iter().find(concentrated) {
        Some(s) => {
            let by = named
                .iter()
                .find(|(r, _)| *r == s.regime)
                .map_or("", |(_, e)| e);
            (
                format!("as for {by}: {}", sentence(s)),
                None,
            )
        }
        None => (
            format!("the fit improves throughout the record, in no regime more than elsewhere (RSS down {reduction_pct:.0}%)"),
            None,
        ),
    }
}

/// What a richer fit earns over a reference fit of the same record.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Gain {
    /// Likelihood gain with the reference's effective residual counts ([`effective_n`]),
    /// less the AIC's two per added free parameter, less what the richer fit's parameters
    /// moved away from the rig's beliefs (the change in the priors' part of -2 ln
    /// posterior): a gain bought by dragging the mass to ten times its belief is no
    /// evidence for the effect.
    pub delta_aic: f64,
    /// Share of the reference's residual sum of squares removed.
    pub reduction: f64,
}

impl Gain {
    /// `richer` against `reference`, whose effective residual counts are `reference_n`.
    pub fn of(data: &Dataset, reference: &Fit, reference_n: &[f64], richer: &Fit) -> Gain {
        let added = (richer.free.len() - reference.free.len()) as f64;
        Gain {
            delta_aic: likelihood_gain(data, &reference.predicted, reference_n, &richer.predicted)
                - 2.0 * added
                - (richer.prior_sq - reference.prior_sq),
            reduction: 1.0 - richer.rss() / reference.rss(),
        }
    }

    /// `predicted` (one more parameter than `reference`, the others as the reference
    /// fitted them: a screen of an effect's key) against `reference`; residuals weighted by
    /// the reference's output weights.
    pub fn of_prediction(
        data: &Dataset,
        reference: &Fit,
        reference_n: &[f64],
        predicted: &[Vec<f64>],
    ) -> Gain {
        let rss: f64 = crate::ident::fit::residuals(data, predicted, &reference.weighting.outputs)
            .iter()
            .map(|r| r * r)
            .sum();
        Gain {
            delta_aic: likelihood_gain(data, &reference.predicted, reference_n, predicted) - 2.0,
            reduction: 1.0 - rss / reference.rss(),
        }
    }

    /// `after` against `before`, two predictions of the same data by models `added`
    /// parameters apart (no fits: a step found on another model, replayed), residuals
    /// weighted by `weights`, counted with `before`'s effective residual counts.
    pub fn of_predictions(
        data: &Dataset,
        before: &[Vec<f64>],
        after: &[Vec<f64>],
        added: usize,
        weights: &[f64],
    ) -> Gain {
        let rss = |p: &[Vec<f64>]| -> f64 {
            crate::ident::fit::residuals(data, p, weights)
                .iter()
                .map(|r| r * r)
                .sum()
        };
        let n_before = effective_n(data, before);
        Gain {
            delta_aic: likelihood_gain(data, before, &n_before, after) - 2.0 * added as f64,
            reduction: 1.0 - rss(after) / rss(before),
        }
    }

    /// Whether the gain passes the selection rule: an AIC gain above [`MIN_DELTA_AIC`] and
    /// at least [`MIN_RSS_REDUCTION`] of the residual removed.
    pub fn passes(&self) -> bool {
        self.delta_aic > MIN_DELTA_AIC && self.reduction >= MIN_RSS_REDUCTION
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn share(regime: &str, energy_pct: f64, samples_pct: f64) -> RegimeShare {
        RegimeShare {
            regime: regime.into(),
            samples_pct,
            energy_pct,
            energy_of_baseline_pct: energy_pct,
        }
    }

    #[test]
    fn a_ratio_below_one_is_friction_stronger_backwards() {
        let d = describe(Effect::FrictionAsymmetry, 0.68, false);
        assert!(d.contains("1.47 times as strong backwards"), "{d}");
        assert!(!d.contains("stronger forwards"), "{d}");
        let d = describe(Effect::FrictionAsymmetry, 1.3, false);
        assert!(d.contains("1.30 times as strong forwards"), "{d}");
    }

    #[test]
    fn a_torque_is_printed_in_newton_metres_at_any_size() {
        let d = describe(Effect::CoulombFriction, 2.73243, false);
        assert!(d.contains("2.73 N m"), "{d}");
        let d = describe(Effect::CoulombFriction, 0.0489, false);
        assert!(d.contains("0.0489 N m"), "{d}");
    }

    #[test]
    fn a_second_finding_names_another_regime_than_the_first() {
        let shares = [
            share("after a reversal", 30.0, 2.0),
            share("at the hardest accelerations", 25.0, 10.0),
        ];
        let (first, regime) = evidence(&shares, 80.0, &[]);
        assert!(first.contains("after a reversal"), "{first}");
        let named = [(regime.unwrap(), "coulomb_friction")];
        let (second, regime) = evidence(&shares, 8.0, &named);
        assert!(second.contains("hardest accelerations"), "{second}");
        assert_eq!(regime.as_deref(), Some("at the hardest accelerations"));
        // Where only the named regime concentrates it, the sentence says whose it was.
        let (third, regime) = evidence(&shares[..1], 5.0, &named);
        assert!(third.starts_with("as for coulomb_friction:"), "{third}");
        assert_eq!(regime, None);
    }
}
