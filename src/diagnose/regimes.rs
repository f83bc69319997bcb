//! Operating regimes of a recording, and where in them a residual's energy lives: the
//! "locate" step of a diagnosis.

use serde::Serialize;

use crate::ident::data::Dataset;
use crate::record::channels as chan;

/// A set of samples with a physical meaning.
#[derive(Debug, Clone)]
pub struct Regime {
    /// Plain words, e.g. "within 0.15 s after a speed reversal".
    pub label: String,
    /// Which samples fall in it.
    pub mask: Vec<bool>,
}

/// How much of some residual energy a regime holds against how much of the record it covers.
#[derive(Debug, Clone, Serialize)]
pub struct RegimeShare {
    /// The regime's name.
    pub regime: String,
    /// Share of the samples, %.
    pub samples_pct: f64,
    /// Share of the energy, %.
    pub energy_pct: f64,
    /// The energy in the regime as a share of the baseline's total residual energy, %
    /// (equal to `energy_pct` for the baseline itself), so that before and after compare
    /// on one total.
    pub energy_of_baseline_pct: f64,
}

impl RegimeShare {
    /// Energy share over sample share: > 1 where the energy concentrates.
    pub fn concentration(&self) -> f64 {
        self.energy_pct / self.samples_pct.max(1e-9)
    }
}

/// Mean rate of change of a series, per second, by central differences.
fn rate(t: &[f64], y: &[f64]) -> Vec<f64> {
    let n = y.len();
    (0..n)
        .map(|k| {
            let (a, b) = (k.saturating_sub(1), (k + 1).min(n - 1));
            if b > a {
                (y[b] - y[a]) / (t[b] - t[a])
            } else {
                0.0
            }
        })
        .collect()
}

/// Marks the samples within `window_s` after each event.
fn after(t: &[f64], events: &[usize], window_s: f64) -> Vec<bool> {
    let mut m = vec![false; t.len()];
    for &e in events {
        let mut k = e;
        while k < t.len() && t[k] - t[e] <= window_s {
            m[k] = true;
            k += 1;
        }
    }
    m
}

/// A measured series with missing cells filled by the previous value (for regime tests only).
fn filled(col: &[Option<f64>]) -> Vec<f64> {
    let mut last = col.iter().flatten().next().copied().unwrap_or(0.0);
    col.iter()
        .map(|v| {
            if let Some(v) = v {
                last = *v;
            }
            last
        })
        .collect()
}

/// The regimes of a recording: speed reversals, near-zero speed, hard acceleration, input
/// near its extreme, step onsets. `speed` is the measured (or differentiated) speed.
pub fn regimes(data: &Dataset, speed: &[f64]) -> Vec<Regime> {
    let t = &data.t_s;
    let n = t.len();
    let vmax = speed.iter().map(|v| v.abs()).fold(0.0, f64::max).max(1e-12);
    let mut out = Vec::new();
    // Reversals with hysteresis, so that noise about zero is not a reversal.
    let h = 0.03 * vmax;
    let mut sign = 0.0;
    let mut reversals = Vec::new();
    for (k, v) in speed.iter().enumerate() {
        if v.abs() > h {
            let s = v.signum();
            if sign != 0.0 && s != sign {
                reversals.push(k);
            }
            sign = s;
        }
    }
    out.push(Regime {
        label: "within 0.15 s after a speed reversal".into(),
        mask: after(t, &reversals, 0.15),
    });
    out.push(Regime {
        label: "near zero speed (below 5 % of the largest)".into(),
        mask: speed.iter().map(|v| v.abs() < 0.05 * vmax).collect(),
    });
    let acc = rate(t, speed);
    let mut sorted: Vec<f64> = acc.iter().map(|a| a.abs()).collect();
    sorted.sort_by(f64::total_cmp);
    let top = sorted[(0.9 * (n - 1) as f64) as usize];
    out.push(Regime {
        label: "at the hardest 10 % of accelerations".into(),
        mask: acc.iter().map(|a| a.abs() >= top && top > 0.0).collect(),
    });
    out.push(Regime {
        label: "at high speed (above 80 % of the largest)".into(),
        mask: speed.iter().map(|v| v.abs() > 0.8 * vmax).collect(),
    });
    if let (Some(l), Some(r)) = (
        data.output_index(chan::LEFT_MOTOR_SPEED_RAD_S),
        data.output_index(chan::RIGHT_MOTOR_SPEED_RAD_S),
    ) {
        // Turning: the two sides' speed difference, against its largest.
        let (l, r) = (filled(&data.outputs[l]), filled(&data.outputs[r]));
        let diff: Vec<f64> = l.iter().zip(&r).map(|(a, b)| (b - a).abs()).collect();
        let dmax = diff.iter().copied().fold(0.0, f64::max);
        out.push(Regime {
            label: "while turning hard (side speed difference above 50 % of its largest)".into(),
            mask: diff.iter().map(|d| dmax > 0.0 && *d > 0.5 * dmax).collect(),
        });
    }
    for (i, name) in data.input_names.iter().enumerate() {
        if crate::ident::data::is_derived_input(name) {
            continue;
        }
        let u = &data.inputs[i];
        let umax = u.iter().map(|v| v.abs()).fold(0.0, f64::max);
        if umax == 0.0 {
            continue;
        }
        out.push(Regime {
            label: format!("with {name} above 90 % of its largest magnitude"),
            mask: u.iter().map(|v| v.abs() > 0.9 * umax).collect(),
        });
        let (lo, hi) = u
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(*v), b.max(*v))
            });
        let steps: Vec<usize> = (1..n)
            .filter(|&k| (u[k] - u[k - 1]).abs() > 0.1 * (hi - lo))
            .collect();
        out.push(Regime {
            label: format!("within 0.1 s after a step in {name}"),
            mask: after(t, &steps, 0.1),
        });
    }
    out
}

/// The measured speed a recording's regimes are judged by: the first speed output, or the
/// rate of the first position or angle output.
pub fn measured_speed(data: &Dataset) -> Vec<f64> {
    let pick = |suffix: &str| data.output_names.iter().position(|n| n.ends_with(suffix));
    // A vehicle: its forward speed is the mean of the two motors' (or, without motor
    // speeds, of the two wheels': never the yaw rate, which is another `_rad_s`).
    for (left, right) in [
        (chan::LEFT_MOTOR_SPEED_RAD_S, chan::RIGHT_MOTOR_SPEED_RAD_S),
        (chan::LEFT_WHEEL_SPEED_M_S, chan::RIGHT_WHEEL_SPEED_M_S),
    ] {
        if let (Some(l), Some(r)) = (data.output_index(left), data.output_index(right)) {
            let (l, r) = (filled(&data.outputs[l]), filled(&data.outputs[r]));
            return l.iter().zip(&r).map(|(a, b)| 0.5 * (a + b)).collect();
        }
    }
    if let Some(j) = pick("_rad_s").or_else(|| pick("_m_s")) {
        return filled(&data.outputs[j]);
    }
    if let Some(j) = pick("_m").or_else(|| pick("_rad")) {
        return rate(&data.t_s, &filled(&data.outputs[j]));
    }
    vec![0.0; data.len()]
}

/// The largest share of a recording a regime may cover and still locate something: a
/// "regime" of most samples (steps in a multisine, which changes every sample) says no
/// more than "somewhere in the recording".
pub const MAX_REGIME_SAMPLES_SHARE: f64 = 0.5;

/// Shares of `energy` (one value per sample) by regime, most concentrated first; regimes
/// of no sample or of more than [`MAX_REGIME_SAMPLES_SHARE`] of them are left out.
pub fn shares(regimes: &[Regime], energy: &[f64], baseline_total: f64) -> Vec<RegimeShare> {
    let total: f64 = energy.iter().sum::<f64>().max(1e-300);
    let reference = baseline_total.max(1e-300);
    let n = energy.len() as f64;
    let mut out: Vec<RegimeShare> = regimes
        .iter()
        .filter(|r| {
            let count = r.mask.iter().filter(|m| **m).count() as f64;
            count > 0.0 && count <= MAX_REGIME_SAMPLES_SHARE * n
        })
        .map(|r| {
            let count = r.mask.iter().filter(|m| **m).count() as f64;
            let e: f64 = r
                .mask
                .iter()
                .zip(energy)
                .filter(|(m, _)| **m)
                .map(|(_, e)| e)
                .sum();
            RegimeShare {
                regime: r.label.clone(),
                samples_pct: 100.0 * count / n,
                energy_pct: 100.0 * e / total,
                energy_of_baseline_pct: 100.0 * e / reference,
            }
        })
        .collect();
    out.sort_by(|a, b| b.concentration().total_cmp(&a.concentration()));
    out
}

/// Residual energy per sample, summed over outputs with the fit's weights.
pub fn energy_per_sample(data: &Dataset, predicted: &[Vec<f64>], weights: &[f64]) -> Vec<f64> {
    (0..data.len())
        .map(|k| {
            data.outputs
                .iter()
                .enumerate()
                .filter_map(|(j, c)| c[k].map(|y| (weights[j] * (y - predicted[j][k])).powi(2)))
                .sum()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_regime_of_most_samples_locates_nothing_and_is_left_out() {
        let n = 100;
        let regime = |label: &str, upto: usize| Regime {
            label: label.into(),
            mask: (0..n).map(|k| k < upto).collect(),
        };
        // The energy sits in the first 20 samples.
        let energy: Vec<f64> = (0..n).map(|k| if k < 20 { 1.0 } else { 0.01 }).collect();
        let s = shares(
            &[
                regime("nearly all", 90),
                regime("the first fifth", 20),
                regime("none", 0),
            ],
            &energy,
            energy.iter().sum(),
        );
        let names: Vec<&str> = s.iter().map(|r| r.regime.as_str()).collect();
        assert_eq!(names, ["the first fifth"]);
        assert!((s[0].samples_pct - 20.0).abs() < 1e-9);
        assert!(s[0].concentration() > 4.0, "{:?}", s[0]);
    }
}
