//! The diagnosis report's plots (SVG): each output measured against the baseline and the
//! diagnosed model, the residual before and after over time, and the residual energy by
//! operating regime before and after.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::regimes::RegimeShare;
use super::Diagnosis;
use crate::ident::plot::{svg, Series};

/// Writes `OUTPUT_compare.svg` and `OUTPUT_residual.svg` per output and `regimes.svg`.
pub fn write(dir: &Path, d: &Diagnosis) -> std::io::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir)?;
    let Some(data) = d.baseline.data.as_ref() else {
        return Err(std::io::Error::other("the diagnosis holds no data to plot"));
    };
    let mut files = Vec::new();
    let name_of_final = if d.findings.is_empty() {
        "diagnosed (= baseline)".to_string()
    } else {
        format!(
            "diagnosed (+ {})",
            d.findings
                .iter()
                .map(|f| f.effect.name())
                .collect::<Vec<_>>()
                .join(", ")
        )
    };
    for (j, name) in data.output_names.iter().enumerate() {
        let (t, y): (Vec<f64>, Vec<f64>) = data.outputs[j]
            .iter()
            .zip(&data.t_s)
            .filter_map(|(v, t)| v.map(|v| (*t, v)))
            .unzip();
        let doc = svg(
            &format!(
                "{name}: measured, baseline ({:.1} %) and diagnosed ({:.1} %)",
                d.baseline.fit_pct[name], d.diagnosed.fit_pct[name]
            ),
            "t (s)",
            name,
            &[
                Series {
                    label: "measured",
                    x: &t,
                    y: &y,
                    colour: "#888",
                    stems: false,
                },
                Series {
                    label: "baseline",
                    x: &data.t_s,
                    y: &d.baseline.predicted[j],
                    colour: "#d08000",
                    stems: false,
                },
                Series {
                    label: &name_of_final,
                    x: &data.t_s,
                    y: &d.diagnosed.predicted[j],
                    colour: "#1f5fbf",
                    stems: false,
                },
            ],
            None,
        );
        let f = dir.join(format!("{name}_compare.svg"));
        std::fs::write(&f, doc)?;
        files.push(f);
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
                Series {
                    label: "baseline",
                    x: &tb,
                    y: &rb,
                    colour: "#d08000",
                    stems: false,
                },
                Series {
                    label: "diagnosed",
                    x: &ta,
                    y: &ra,
                    colour: "#1f5fbf",
                    stems: false,
                },
            ],
            None,
        );
        let f = dir.join(format!("{name}_residual.svg"));
        std::fs::write(&f, doc)?;
        files.push(f);
    }
    let f = dir.join("regimes.svg");
    std::fs::write(&f, regime_bars(&d.where_before, &d.where_after))?;
    files.push(f);
    Ok(files)
}

/// A horizontal bar chart: per regime, its share of the samples and of the residual energy
/// before and after the diagnosis (a regime whose energy bar outgrows its sample bar is
/// where the mismatch lives).
pub fn regime_bars(before: &[RegimeShare], after: &[RegimeShare]) -> String {
    let row_h = 54.0;
    let left = 330.0;
    let width = 520.0;
    let top = 50.0;
    let h = top + row_h * before.len() as f64 + 30.0;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"900\" height=\"{h}\" font-family=\"sans-serif\" font-size=\"12\">\n<rect width=\"900\" height=\"{h}\" fill=\"white\"/>"
    );
    let _ = writeln!(
        s,
        "<text x=\"450\" y=\"20\" text-anchor=\"middle\" font-size=\"14\">Residual energy by regime: share of samples, of the baseline's and of the diagnosed model's residual energy</text>"
    );
    let legend = [
        ("samples", "#bbb"),
        ("baseline energy", "#d08000"),
        ("diagnosed energy", "#1f5fbf"),
    ];
    for (i, (label, colour)) in legend.iter().enumerate() {
        let x = left + i as f64 * 170.0;
        let _ = writeln!(
            s,
            "<rect x=\"{x}\" y=\"30\" width=\"12\" height=\"10\" fill=\"{colour}\"/><text x=\"{}\" y=\"39\">{label}</text>",
            x + 16.0
        );
    }
    let max = before
        .iter()
        .chain(after)
        .flat_map(|r| [r.samples_pct, r.energy_pct])
        .fold(1.0, f64::max);
    for (i, b) in before.iter().enumerate() {
        let y = top + i as f64 * row_h;
        let a = after
            .iter()
            .find(|a| a.regime == b.regime)
            .map_or(0.0, |a| a.energy_pct);
        let _ = writeln!(
            s,
            "<text x=\"{}\" y=\"{}\" text-anchor=\"end\">{}</text>",
            left - 8.0,
            y + 24.0,
            b.regime.replace('&', "&amp;").replace('<', "&lt;")
        );
        for (k, (v, colour)) in [
            (b.samples_pct, "#bbb"),
            (b.energy_pct, "#d08000"),
            (a, "#1f5fbf"),
        ]
        .iter()
        .enumerate()
        {
            let yy = y + 6.0 + k as f64 * 14.0;
            let w = width * v / max;
            let _ = writeln!(
                s,
                "<rect x=\"{left}\" y=\"{yy}\" width=\"{w:.1}\" height=\"12\" fill=\"{colour}\"/><text x=\"{:.1}\" y=\"{:.1}\" font-size=\"10\">{v:.1} %</text>",
                left + w + 4.0,
                yy + 10.0
            );
        }
    }
    s.push_str("</svg>\n");
    s
}
