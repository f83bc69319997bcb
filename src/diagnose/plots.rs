//! The diagnosis report's plots (SVG): each output measured against the baseline and the
//! diagnosed model, the residual before and after over time, and the residual energy by
//! operating regime before and after.

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
    Ok(files)
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
