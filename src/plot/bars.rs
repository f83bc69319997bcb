//! Horizontal grouped bar charts: one row per group, one bar per series, every bar on
//! the same stated scale.

use std::fmt::Write;

use super::{escape, CHAR_W, W};

/// One row of bars: its label and one value per series.
pub struct BarGroup {
    /// The group's label.
    pub label: String,
    /// One value per series.
    pub values: Vec<f64>,
}

/// A bar chart. `series` gives each bar's legend text and colour; `unit` is printed after
/// each value and in the scale note, which says what every bar is a share of. A value
/// that is not finite has no bar and reads "none".
pub fn bar_chart(
    title: &str,
    scale_note: &str,
    series: &[(&str, &str)],
    groups: &[BarGroup],
    unit: &str,
) -> String {
    let bar_h = 12.0;
    let row_h = bar_h * series.len() as f64 + 18.0;
    // The label column is as wide as the longest label, so none is cut.
    let longest = groups
        .iter()
        .map(|g| g.label.chars().count())
        .max()
        .unwrap_or(0);
    let left = (CHAR_W * longest as f64 + 24.0).clamp(120.0, 0.6 * W);
    let width = W - left - 80.0;
    let top = 74.0;
    let h = top + row_h * groups.len() as f64 + 12.0;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{W}\" height=\"{h}\" font-family=\"sans-serif\" font-size=\"12\">\n<rect width=\"{W}\" height=\"{h}\" fill=\"white\"/>"
    );
    let _ = writeln!(
        s,
        "<text x=\"{}\" y=\"20\" text-anchor=\"middle\" font-size=\"14\">{}</text>",
        W / 2.0,
        escape(title)
    );
    let _ = writeln!(
        s,
        "<text x=\"{}\" y=\"38\" text-anchor=\"middle\" fill=\"#555\">{}</text>",
        W / 2.0,
        escape(scale_note)
    );
    let mut x = 20.0;
    for (label, colour) in series {
        let _ = writeln!(
            s,
            "<rect x=\"{x}\" y=\"50\" width=\"12\" height=\"10\" fill=\"{colour}\"/><text x=\"{}\" y=\"59\">{}</text>",
            x + 16.0,
            escape(label)
        );
        x += 16.0 + CHAR_W * label.chars().count() as f64 + 24.0;
    }
    let max = groups
        .iter()
        .flat_map(|g| g.values.iter())
        .copied()
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max)
        .max(1e-300);
    for (i, g) in groups.iter().enumerate() {
        let y = top + i as f64 * row_h;
        let _ = writeln!(
            s,
            "<text x=\"{}\" y=\"{:.1}\" text-anchor=\"end\">{}</text>",
            left - 8.0,
            y + row_h / 2.0,
            escape(&g.label)
        );
        for (k, ((_, colour), v)) in series.iter().zip(&g.values).enumerate() {
            let yy = y + 4.0 + k as f64 * bar_h;
            if !v.is_finite() {
                // No value (none in the range looked at): no bar, said in words.
                let _ = writeln!(
                    s,
                    "<text x=\"{:.1}\" y=\"{:.1}\" font-size=\"10\" fill=\"#555\">none</text>",
                    left + 4.0,
                    yy + 9.5
                );
                continue;
            }
            let w = width * v.max(0.0) / max;
            let _ = writeln!(
                s,
                "<rect x=\"{left:.1}\" y=\"{yy:.1}\" width=\"{w:.1}\" height=\"{:.1}\" fill=\"{colour}\"/><text x=\"{:.1}\" y=\"{:.1}\" font-size=\"10\">{} {unit}</text>",
                bar_h - 1.0,
                left + w + 4.0,
                yy + 9.5,
                crate::numtext::sig(*v, 3)
            );
        }
    }
    s.push_str("</svg>\n");
    s
}
