//! Identification plots: each output measured against simulated, and the residual
//! checks (autocorrelation, cross-correlation with each input) with their bands.

use std::path::{Path, PathBuf};

use super::Evaluation;
use crate::plot::{measured_points, svg, Figure, Series, Style, W};

/// Height of one stacked residual plot, px (as rendered by [`svg`] with a one-row legend).
fn stacked_height(doc: &str) -> f64 {
    doc.split("height=\"")
        .nth(1)
        .and_then(|r| r.split('"').next())
        .and_then(|v| v.parse().ok())
        .unwrap_or(320.0)
}

/// Writes `PREFIX_OUTPUT_fit.svg` and `PREFIX_OUTPUT_resid.svg` for each output of an
/// evaluation into `dir`; returns the files written.
pub fn write_evaluation(dir: &Path, prefix: &str, e: &Evaluation) -> std::io::Result<Vec<PathBuf>> {
    crate::plot::write_figures(dir, &evaluation_figures(prefix, e)?)
}

/// The figures of [`write_evaluation`]: per output the fit and the residual checks.
pub fn evaluation_figures(prefix: &str, e: &Evaluation) -> std::io::Result<Vec<Figure>> {
    let Some(data) = e.data.as_ref() else {
        return Err(std::io::Error::other(
            "the evaluation holds no data to plot",
        ));
    };
    let mut files = Vec::new();
    let breaks = data.segment_start_times();
    for (j, name) in data.output_names.iter().enumerate() {
        let (t, y) = measured_points(&data.t_s, &data.outputs[j]);
        let fit = e.fit_pct[name];
        let doc = svg(
            &format!(
                "{name}: measured and simulated ({}, fit {fit:.1} %)",
                e.recording
            ),
            "t (s)",
            name,
            &[
                Series::line("measured", &t, &y, "#555")
                    .with_style(Style::Measured)
                    .broken_at(&breaks),
                Series::line("simulated", &data.t_s, &e.predicted[j], "#1f5fbf").broken_at(&breaks),
            ],
            None,
        );
        files.push(Figure {
            file: format!("{prefix}_{name}_fit.svg"),
            svg: doc,
        });
        let c = &e.checks[j];
        let lags: Vec<f64> = c.whiteness.lags.iter().map(|&l| l as f64).collect();
        let mut doc = svg(
            &format!("{name}: residual autocorrelation (99 % band)"),
            "lag (samples)",
            "correlation",
            &[
                Series::line("residual", &lags, &c.whiteness.values, "#1f5fbf")
                    .with_style(Style::Stems),
            ],
            Some(c.whiteness.band),
        );
        for (input, x) in &c.independence {
            let lags: Vec<f64> = x.lags.iter().map(|&l| l as f64).collect();
            doc.push_str(&svg(
                &format!("{name}: cross-correlation with input {input} (99 % band)"),
                "lag (samples, input leading)",
                "correlation",
                &[Series::line(input, &lags, &x.values, "#b05000").with_style(Style::Stems)],
                Some(x.band),
            ));
        }
        // Several <svg> roots stack as one document inside an outer svg.
        let mut stacked = String::new();
        let mut y = 0.0;
        for part in doc.split_inclusive("</svg>\n") {
            stacked.push_str(&part.replacen("<svg xmlns", &format!("<svg y=\"{y}\" xmlns"), 1));
            y += stacked_height(part);
        }
        let outer = format!(
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{W}\" height=\"{y}\">\n{stacked}</svg>\n"
        );
        files.push(Figure {
            file: format!("{prefix}_{name}_resid.svg"),
            svg: outer,
        });
    }
    Ok(files)
}
