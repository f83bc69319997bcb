//! The evidence a candidate effect brings: how much of the residual it removes, counted
//! with the residual's effective number of independent samples, where it removes it, and
//! the words a report uses for the effect.

use std::collections::BTreeMap;

use super::regimes::RegimeShare;
use super::{MIN_DELTA_AIC, MIN_RSS_REDUCTION};
use crate::ident::data::Dataset;
use crate::ident::effects::Effect;
use crate::ident::fit::Fit;

/// What the fitted effect is, in words, with its value and units.
pub(crate) fn describe(e: Effect, v: f64, linear: bool) -> String {
    match e {
        Effect::Backlash => format!(
            "gear backlash of about {:.1} degrees ({v:.4} rad) of total play at the wheel",
            v.to_degrees()
        ),
        Effect::CoulombFriction if linear => {
            format!("Coulomb friction of about {v:.2} N opposing the motion")
        }
        Effect::CoulombFriction => format!(
            "Coulomb friction of about {:.1} mN m at the motor shaft (brushes, bearings)",
            1000.0 * v
        ),
        Effect::FrictionAsymmetry => {
            format!("viscous friction {v:.2} times stronger forwards than backwards")
        }
        Effect::Offset if linear => {
            format!("a constant bias force of {v:.2} N (gravity component, cable, sensor bias)")
        }
        Effect::Offset => format!(
            "a constant bias torque of {:.1} mN m at the motor shaft",
            1000.0 * v
        ),
        Effect::VoltageSaturation => {
            format!("the drive voltage clipped at about {v:.2} V by the supply")
        }
        Effect::BatterySag => format!(
            "the supply sagging with current through about {:.0} mohm of internal resistance",
            1000.0 * v
        ),
        Effect::TransportDelay => format!(
            "a dead time of about {:.1} ms between command and actuation",
            1000.0 * v
        ),
        Effect::SpeedFeedback => format!(
            "the motor controller closing its own speed loop with integral gain {v:.4} V/rad"
        ),
        Effect::WheelSlip => format!(
            "wheel slip: the tyres' grip limited by a peak floor friction coefficient of about {v:.2}"
        ),
        Effect::CastorDrag => format!(
            "drag of about {v:.1} N from the idler castors opposing the chassis's motion"
        ),
    }
}

/// Effective number of independent residuals per output: N / (1 + 2 sum of the residual's
/// autocorrelation over lags until it first falls below 0.05).
pub(crate) fn effective_n(data: &Dataset, predicted: &[Vec<f64>]) -> Vec<f64> {
    data.outputs
        .iter()
        .enumerate()
        .map(|(j, col)| {
            let e: Vec<f64> = col
                .iter()
                .zip(&predicted[j])
                .filter_map(|(y, p)| y.map(|y| y - p))
                .collect();
            let n = e.len() as f64;
            let m = e.iter().sum::<f64>() / n.max(1.0);
            let var: f64 = e.iter().map(|v| (v - m).powi(2)).sum();
            if var == 0.0 {
                return n.max(1.0);
            }
            let mut sum = 0.0;
            for lag in 1..(e.len() / 4).min(500) {
                let r: f64 = (0..e.len() - lag)
                    .map(|k| (e[k] - m) * (e[k + lag] - m))
                    .sum::<f64>()
                    / var;
                if r < 0.05 {
                    break;
                }
                sum += r;
            }
            (n / (1.0 + 2.0 * sum)).max(1.0)
        })
        .collect()
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
        if let Some(stem) = name.strip_suffix("position_m") {
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

/// Where the removed residual lies, as a sentence.
pub(crate) fn evidence(shares: &[RegimeShare], reduction_pct: f64) -> String {
    match shares.first() {
        Some(s) if s.concentration() > 1.5 => format!(
            "{:.0}% of the residual energy the effect removes lies in the {:.0}% of samples {} (RSS down {reduction_pct:.0}%)",
            s.energy_pct, s.samples_pct, s.regime
        ),
        _ => format!("the fit improves throughout the record, in no regime more than elsewhere (RSS down {reduction_pct:.0}%)"),
    }
}

/// What a richer fit earns over a reference fit of the same record.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Gain {
    /// Likelihood gain with the reference's effective residual counts ([`effective_n`]),
    /// less the AIC's two per added free parameter.
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
                - 2.0 * added,
            reduction: 1.0 - richer.cost / reference.cost,
        }
    }

    /// Whether the gain passes the selection rule: an AIC gain above [`MIN_DELTA_AIC`] and
    /// at least [`MIN_RSS_REDUCTION`] of the residual removed.
    pub fn passes(&self) -> bool {
        self.delta_aic > MIN_DELTA_AIC && self.reduction >= MIN_RSS_REDUCTION
    }
}
