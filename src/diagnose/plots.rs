//! The diagnosis report's plots (SVG): each output measured against the baseline and the
//! diagnosed model, the residual before and after over time, the residual energy by
//! operating regime before and after, and each term found: the residual against the
//! quantity it depends on, before and after.

use std::path::{Path, PathBuf};

use super::regimes::RegimeShare;
use super::Diagnosis;
use crate::plot::{bar_chart, svg, BarGroup, Figure, Series, Style};

/// Writes `OUTPUT_compare.svg` and `OUTPUT_residual.svg` per output and `regimes.svg`.
pub fn write(dir: &Path, d: &Diagnosis) -> std::io::Result<Vec<PathBuf>> {
    crate::plot::write_figures(dir, &figures(d)?)
}

/// The report's figures: per output the comparison and the residual, then the regimes.
pub fn figures(d: &Diagnosis) -> std::io::Result<Vec<Figure>> {
    let Some(data) = d.baseline.data.as_ref() else {
        return Err(std::io::Error::other("the diagnosis holds no data to plot"));
    };
    let mut files = Vec::new();
    let found = d.found_names();
    let name_of_final = if found.is_empty() {
        "diagnosed (= baseline)".to_string()
    } else {
        format!("diagnosed (+ {})", found.join(", "))
    };
    let breaks = data.segment_start_times();
    for (j, name) in data.output_names.iter().enumerate() {
        let (t, y) = crate::plot::measured_points(&data.t_s, &data.outputs[j]);
        let doc = svg(
            &format!(
                "{name}: measured, baseline ({:.1} %) and diagnosed ({:.1} %)",
                d.baseline.fit_pct[name], d.diagnosed.fit_pct[name]
            ),
            "t (s)",
            name,
            &[
                Series::line("measured", &t, &y, "#555")
                    .with_style(Style::Measured)
                    .broken_at(&breaks),
                Series::line("baseline", &data.t_s, &d.baseline.predicted[j], "#d08000")
                    .broken_at(&breaks),
                Series::line(
                    &name_of_final,
                    &data.t_s,
                    &d.diagnosed.predicted[j],
                    "#1f5fbf",
                )
                .broken_at(&breaks),
            ],
            None,
        );
        files.push(Figure {
            file: format!("{name}_compare.svg"),
            svg: doc,
        });
        let residual = |pred: &[f64]| -> (Vec<f64>, Vec<f64>) {
            data.outputs[j]
                .iter()
                .zip(pred)
                .zip(&data.t_s)
                .filter_map(|((v, p), t)| v.map(|v| (*t, v - p)))
                .unzip()
        };
        let (tb, rb) = residual(&d.baseline.predicted[j]);
        let (ta, ra) = residual(&d.diagnosed.predicted[j]);
        let doc = svg(
            &format!("{name}: residual (measured - simulated) before and after"),
            "t (s)",
            name,
            &[
                Series::line("baseline", &tb, &rb, "#d08000").broken_at(&breaks),
                Series::line("diagnosed", &ta, &ra, "#1f5fbf").broken_at(&breaks),
            ],
            None,
        );
        files.push(Figure {
            file: format!("{name}_residual.svg"),
            svg: doc,
        });
    }
    files.push(Figure {
        file: "regimes.svg".into(),
        svg: regime_bars(&d.where_before, &d.where_after),
    });
    files.extend(term_evidence(d, data));
    Ok(files)
}

/// Bins of a term's evidence plot.
const TERM_BINS: usize = 24;

/// Per term found and output, `term_FAMILY_OUTPUT.svg`: the residual's mean in bins of
/// the quantity the term depends on, before (baseline) and after (diagnosed). Before, it
/// follows the term's law (a sine in the phase, a power of the speed); after, it is flat.
fn term_evidence(d: &Diagnosis, data: &crate::ident::data::Dataset) -> Vec<Figure> {
    let mut files = Vec::new();
    for t in &d.terms {
        let Some((label, x)) = &t.quantity else {
            continue;
        };
        for (j, name) in data.output_names.iter().enumerate() {
            let binned = |pred: &[f64]| {
                let residual: Vec<f64> = data.outputs[j]
                    .iter()
                    .zip(pred)
                    .map(|(v, p)| v.map_or(f64::NAN, |v| v - p))
                    .collect();
                binned_means(x, &residual, TERM_BINS)
            };
            let (xb, rb) = binned(&d.baseline.predicted[j]);
            let (xa, ra) = binned(&d.diagnosed.predicted[j]);
            let doc = svg(
                &format!(
                    "{name}: residual against the {} term's quantity, mean in {TERM_BINS} bins",
                    t.row.name
                ),
                label,
                name,
                &[
                    Series::line("baseline", &xb, &rb, "#d08000"),
                    Series::line("diagnosed", &xa, &ra, "#1f5fbf"),
                ],
                None,
            );
            files.push(Figure {
                file: format!("term_{}_{name}.svg", t.row.name),
                svg: doc,
            });
        }
    }
    files
}

/// The mean of `y` in `bins` equal bins of `x` over its range (bin centres, means), bins
/// without a finite pair left out.
fn binned_means(x: &[f64], y: &[f64], bins: usize) -> (Vec<f64>, Vec<f64>) {
    let finite = || {
        x.iter()
            .zip(y)
            .filter(|(a, b)| a.is_finite() && b.is_finite())
    };
    let lo = finite().map(|(a, _)| *a).fold(f64::INFINITY, f64::min);
    let hi = finite().map(|(a, _)| *a).fold(f64::NEG_INFINITY, f64::max);
    if !(hi > lo) {
        return (vec![], vec![]);
    }
    let width = (hi - lo) / bins as f64;
    let mut sum = vec![0.0; bins];
    let mut count = vec![0usize; bins];
    for (a, b) in finite() {
        let k = (((a - lo) / width) as usize).min(bins - 1);
        sum[k] += b;
        count[k] += 1;
    }
    (0..bins)
        .filter(|&k| count[k] > 0)
        .map(|k| (lo + (k as f64 + 0.5) * width, sum[k] / count[k] as f64))
        .unzip()
}

/// A horizontal bar chart: per regime, its share of the samples, and the residual energy
/// in it before and after the diagnosis, both as a share of the baseline's total residual
/// energy (one total, so the diagnosed bar shows how much was removed there). A regime
/// whose baseline bar outgrows its sample bar is where the mismatch lives.
pub fn regime_bars(before: &[RegimeShare], after: &[RegimeShare]) -> String {
    let groups: Vec<BarGroup> = before
        .iter()
        .map(|b| {
            let a = after
                .iter()
                .find(|a| a.regime == b.regime)
                .map_or(0.0, |a| a.energy_of_baseline_pct);
            BarGroup {
                label: b.regime.clone(),
                values: vec![b.samples_pct, b.energy_of_baseline_pct, a],
            }
        })
        .collect();
    bar_chart(
        "Residual energy by operating regime, before and after the diagnosis",
        "samples: % of all samples; energies: % of the baseline's total residual energy",
        &[
            ("samples", "#bbb"),
            ("baseline residual energy", "#d08000"),
            ("diagnosed residual energy", "#1f5fbf"),
        ],
        &groups,
        "%",
    )
}

#[cfg(test)]
mod tests {
    #[test]
    fn binned_means_average_each_bin_of_the_range() {
        let x = [0.0, 0.1, 0.9, 1.0];
        let y = [1.0, 3.0, 10.0, f64::NAN];
        // The range is the finite pairs': 0 to 0.9.
        let (c, m) = super::binned_means(&x, &y, 2);
        assert_eq!(c, vec![0.225, 0.675]);
        assert_eq!(m, vec![2.0, 10.0]);
    }
}
