//! Plots as SVG files, written directly (no plotting dependency): measured against
//! simulated outputs, and the residual checks with their confidence bands.

use std::fmt::Write;
use std::path::{Path, PathBuf};

use super::Evaluation;

const W: f64 = 900.0;
const H: f64 = 320.0;
const MARGIN_L: f64 = 70.0;
const MARGIN_R: f64 = 20.0;
const MARGIN_T: f64 = 34.0;
const MARGIN_B: f64 = 40.0;

/// One line of a plot.
pub struct Series<'a> {
    pub label: &'a str,
    pub x: &'a [f64],
    pub y: &'a [f64],
    pub colour: &'a str,
    /// Draw as vertical stems (correlations) instead of a line.
    pub stems: bool,
}

fn nice_ticks(lo: f64, hi: f64) -> Vec<f64> {
    let span = (hi - lo).max(1e-300);
    let raw = span / 5.0;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| span / s <= 6.0)
        .unwrap_or(10.0 * mag);
    let mut t = (lo / step).ceil() * step;
    let mut out = Vec::new();
    while t <= hi + 1e-9 * span {
        out.push(t);
        t += step;
    }
    out
}

/// An SVG line plot; `band` draws a dashed ±band about zero.
pub fn svg(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    band: Option<f64>,
) -> String {
    let finite = |v: &&f64| v.is_finite();
    let xs = series.iter().flat_map(|s| s.x.iter()).filter(finite);
    let (x0, x1) = xs.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(*v), b.max(*v))
    });
    let ys = series.iter().flat_map(|s| s.y.iter()).filter(finite);
    let (mut y0, mut y1) = ys.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(*v), b.max(*v))
    });
    if let Some(b) = band {
        y0 = y0.min(-b);
        y1 = y1.max(b);
    }
    if series.iter().any(|s| s.stems) {
        y0 = y0.min(0.0);
        y1 = y1.max(0.0);
    }
    if !(y1 > y0) {
        y0 -= 1.0;
        y1 += 1.0;
    }
    let pad = 0.05 * (y1 - y0);
    let (y0, y1) = (y0 - pad, y1 + pad);
    let (x0, x1) = if x1 > x0 {
        (x0, x1)
    } else {
        (x0 - 1.0, x0 + 1.0)
    };
    let px = |x: f64| MARGIN_L + (x - x0) / (x1 - x0) * (W - MARGIN_L - MARGIN_R);
    let py = |y: f64| MARGIN_T + (y1 - y) / (y1 - y0) * (H - MARGIN_T - MARGIN_B);
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" font-family="sans-serif" font-size="12">"#
    );
    let _ = writeln!(s, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = writeln!(
        s,
        r#"<text x="{}" y="20" font-size="14" text-anchor="middle">{}</text>"#,
        W / 2.0,
        escape(title)
    );
    for t in nice_ticks(x0, x1) {
        let x = px(t);
        let _ = writeln!(
            s,
            r##"<line x1="{x:.1}" y1="{MARGIN_T}" x2="{x:.1}" y2="{:.1}" stroke="#eee"/><text x="{x:.1}" y="{:.1}" text-anchor="middle">{}</text>"##,
            H - MARGIN_B,
            H - MARGIN_B + 15.0,
            fmt_tick(t)
        );
    }
    for t in nice_ticks(y0, y1) {
        let y = py(t);
        let _ = writeln!(
            s,
            r##"<line x1="{MARGIN_L}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="#eee"/><text x="{:.1}" y="{:.1}" text-anchor="end">{}</text>"##,
            W - MARGIN_R,
            MARGIN_L - 5.0,
            y + 4.0,
            fmt_tick(t)
        );
    }
    let _ = writeln!(
        s,
        r#"<rect x="{MARGIN_L}" y="{MARGIN_T}" width="{:.1}" height="{:.1}" fill="none" stroke="black"/>"#,
        W - MARGIN_L - MARGIN_R,
        H - MARGIN_T - MARGIN_B
    );
    let _ = writeln!(
        s,
        r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">{}</text>"#,
        (W + MARGIN_L) / 2.0,
        H - 6.0,
        escape(x_label)
    );
    let _ = writeln!(
        s,
        r#"<text transform="translate(14,{:.1}) rotate(-90)" text-anchor="middle">{}</text>"#,
        H / 2.0,
        escape(y_label)
    );
    if let Some(b) = band {
        for v in [b, -b] {
            let _ = writeln!(
                s,
                r##"<line x1="{MARGIN_L}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="#c00" stroke-dasharray="5,4"/>"##,
                W - MARGIN_R,
                y = py(v)
            );
        }
    }
    for (i, ser) in series.iter().enumerate() {
        if ser.stems {
            for (x, y) in ser.x.iter().zip(ser.y) {
                let _ = writeln!(
                    s,
                    r#"<line x1="{:.1}" y1="{:.1}" x2="{:.1}" y2="{:.1}" stroke="{}" stroke-width="2"/>"#,
                    px(*x),
                    py(0.0),
                    px(*x),
                    py(*y),
                    ser.colour
                );
            }
        } else {
            // Thin long series to about two points per pixel column.
            let stride = (ser.x.len() / 2000).max(1);
            let pts: Vec<String> = ser
                .x
                .iter()
                .zip(ser.y)
                .step_by(stride)
                .filter(|(x, y)| x.is_finite() && y.is_finite())
                .map(|(x, y)| format!("{:.1},{:.1}", px(*x), py(*y)))
                .collect();
            let _ = writeln!(
                s,
                r#"<polyline fill="none" stroke="{}" stroke-width="1.2" points="{}"/>"#,
                ser.colour,
                pts.join(" ")
            );
        }
        let ly = MARGIN_T + 14.0 + 16.0 * i as f64;
        let _ = writeln!(
            s,
            r#"<line x1="{:.1}" y1="{ly:.1}" x2="{:.1}" y2="{ly:.1}" stroke="{}" stroke-width="3"/><text x="{:.1}" y="{:.1}">{}</text>"#,
            W - 200.0,
            W - 180.0,
            ser.colour,
            W - 175.0,
            ly + 4.0,
            escape(ser.label)
        );
    }
    s.push_str("</svg>\n");
    s
}

fn fmt_tick(t: f64) -> String {
    if t == 0.0 {
        "0".into()
    } else if t.abs() >= 1e4 || t.abs() < 1e-3 {
        format!("{t:.1e}")
    } else {
        format!("{}", (t * 1e6).round() / 1e6)
    }
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// Writes `PREFIX_OUTPUT_fit.svg` and `PREFIX_OUTPUT_resid.svg` for each output of an
/// evaluation into `dir`; returns the files written.
pub fn write_evaluation(dir: &Path, prefix: &str, e: &Evaluation) -> std::io::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir)?;
    let Some(data) = e.data.as_ref() else {
        return Err(std::io::Error::other(
            "the evaluation holds no data to plot",
        ));
    };
    let mut files = Vec::new();
    for (j, name) in data.output_names.iter().enumerate() {
        let (t, y): (Vec<f64>, Vec<f64>) = data.outputs[j]
            .iter()
            .zip(&data.t_s)
            .filter_map(|(v, t)| v.map(|v| (*t, v)))
            .unzip();
        let fit = e.fit_pct[name];
        let doc = svg(
            &format!(
                "{name}: measured and simulated ({} , fit {fit:.1} %)",
                e.recording
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
                    label: "simulated",
                    x: &data.t_s,
                    y: &e.predicted[j],
                    colour: "#1f5fbf",
                    stems: false,
                },
            ],
            None,
        );
        let f = dir.join(format!("{prefix}_{name}_fit.svg"));
        std::fs::write(&f, doc)?;
        files.push(f);
        let c = &e.checks[j];
        let lags: Vec<f64> = c.whiteness.lags.iter().map(|&l| l as f64).collect();
        let mut doc = svg(
            &format!("{name}: residual autocorrelation (99 % band)"),
            "lag (samples)",
            "correlation",
            &[Series {
                label: "residual",
                x: &lags,
                y: &c.whiteness.values,
                colour: "#1f5fbf",
                stems: true,
            }],
            Some(c.whiteness.band),
        );
        for (input, x) in &c.independence {
            let lags: Vec<f64> = x.lags.iter().map(|&l| l as f64).collect();
            doc.push_str(&svg(
                &format!("{name}: cross-correlation with input {input} (99 % band)"),
                "lag (samples, input leading)",
                "correlation",
                &[Series {
                    label: input,
                    x: &lags,
                    y: &x.values,
                    colour: "#b05000",
                    stems: true,
                }],
                Some(x.band),
            ));
        }
        // Several <svg> roots stack as one document inside an outer svg.
        let n = 1 + c.independence.len();
        let body = doc.replace("<svg xmlns", "<svg y=\"__Y__\" xmlns");
        let mut stacked = String::new();
        for (k, part) in body.split_inclusive("</svg>\n").enumerate() {
            stacked.push_str(&part.replace("__Y__", &format!("{}", k as f64 * H)));
        }
        let outer = format!(
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{W}\" height=\"{}\">\n{stacked}</svg>\n",
            n as f64 * H
        );
        let f = dir.join(format!("{prefix}_{name}_resid.svg"));
        std::fs::write(&f, outer)?;
        files.push(f);
    }
    Ok(files)
}
