//! Dot-and-whisker charts: one row per group, a dot per series at its value with a whisker
//! over its interval, on one horizontal scale with labelled reference lines (the shares an
//! interval claims, beside the shares it realised).

use std::fmt::Write;

use super::{escape, fmt_tick, nice_ticks, CHAR_W, W};

/// One row: its label and, per series, a value with the interval's low and high ends
/// (`None`: nothing to draw for that series).
pub struct IntervalRow {
    /// The row's label.
    pub label: String,
    /// Per series: `(value, low, high)`.
    pub values: Vec<Option<(f64, f64, f64)>>,
}

/// A vertical line across every row at `x`, dashed, in `colour`, labelled at its top.
pub struct Reference<'a> {
    /// Where, on the x scale.
    pub x: f64,
    /// Colour (SVG).
    pub colour: &'a str,
    /// Its label.
    pub label: &'a str,
}

/// The chart. `series` gives each dot's legend text and colour; `x_range` the scale
/// (values and whiskers beyond it are clipped to it, the whisker's end then open);
/// `note` under the title says what the whiskers are.
pub fn interval_chart(
    title: &str,
    note: &str,
    x_label: &str,
    series: &[(&str, &str)],
    rows: &[IntervalRow],
    references: &[Reference],
    x_range: (f64, f64),
) -> String {
    let row_h = 10.0 * series.len() as f64 + 14.0;
    let longest = rows
        .iter()
        .map(|r| r.label.chars().count())
        .max()
        .unwrap_or(0);
    let top = 96.0;
    let frame = Frame {
        left: (CHAR_W * longest as f64 + 24.0).clamp(120.0, 0.6 * W),
        right: W - 30.0,
        top,
        bottom: top + row_h * rows.len() as f64,
        x_range,
    };
    let h = frame.bottom + 50.0;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{W}\" height=\"{h}\" font-family=\"sans-serif\" font-size=\"12\">\n<rect width=\"{W}\" height=\"{h}\" fill=\"white\"/>"
    );
    let mid = W / 2.0;
    let _ = writeln!(
        s,
        "<text x=\"{mid}\" y=\"20\" text-anchor=\"middle\" font-size=\"14\">{}</text>\n<text x=\"{mid}\" y=\"38\" text-anchor=\"middle\" fill=\"#555\">{}</text>",
        escape(title),
        escape(note)
    );
    legend(&mut s, series);
    frame.scale(&mut s, x_label, references);
    for (i, row) in rows.iter().enumerate() {
        frame.row(&mut s, i, row_h, row, series);
    }
    let _ = writeln!(
        s,
        "<rect x=\"{}\" y=\"{}\" width=\"{:.1}\" height=\"{:.1}\" fill=\"none\" stroke=\"#888\"/>",
        frame.left,
        frame.top,
        frame.right - frame.left,
        frame.bottom - frame.top
    );
    s.push_str("</svg>\n");
    s
}

/// The data area of an interval chart, px, and the values its width spans.
struct Frame {
    left: f64,
    right: f64,
    top: f64,
    bottom: f64,
    x_range: (f64, f64),
}

impl Frame {
    /// Where `x` lands, clipped to the frame.
    fn at(&self, x: f64) -> f64 {
        let (x0, x1) = self.x_range;
        self.left + (self.right - self.left) * ((x.clamp(x0, x1) - x0) / (x1 - x0))
    }

    /// The grid with its tick labels, the x label and the reference lines.
    fn scale(&self, s: &mut String, x_label: &str, references: &[Reference]) {
        let (x0, x1) = self.x_range;
        let (top, bottom) = (self.top, self.bottom);
        let (ticks, decimals) = nice_ticks(x0, x1);
        for t in ticks.iter().filter(|t| (x0..=x1).contains(*t)) {
            let x = self.at(*t);
            let _ = writeln!(
                s,
                "<line x1=\"{x:.1}\" y1=\"{top}\" x2=\"{x:.1}\" y2=\"{bottom}\" stroke=\"#e4e4e4\"/><text x=\"{x:.1}\" y=\"{:.1}\" text-anchor=\"middle\">{}</text>",
                bottom + 16.0,
                fmt_tick(*t, decimals)
            );
        }
        let _ = writeln!(
            s,
            "<text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"middle\">{}</text>",
            0.5 * (self.left + self.right),
            bottom + 36.0,
            escape(x_label)
        );
        for r in references {
            let x = self.at(r.x);
            let _ = writeln!(
                s,
                "<line x1=\"{x:.1}\" y1=\"{:.1}\" x2=\"{x:.1}\" y2=\"{bottom}\" stroke=\"{}\" stroke-dasharray=\"5,4\"/><text x=\"{x:.1}\" y=\"{:.1}\" text-anchor=\"middle\" font-size=\"11\" fill=\"{}\">{}</text>",
                top - 10.0,
                r.colour,
                top - 14.0,
                r.colour,
                escape(r.label)
            );
        }
    }

    /// Row `i`: its shading (every other row), label, and a dot with its whisker per series.
    fn row(
        &self,
        s: &mut String,
        i: usize,
        row_h: f64,
        row: &IntervalRow,
        series: &[(&str, &str)],
    ) {
        let (left, right) = (self.left, self.right);
        let y = self.top + i as f64 * row_h;
        if i % 2 == 1 {
            let _ = writeln!(
                s,
                "<rect x=\"{left}\" y=\"{y:.1}\" width=\"{:.1}\" height=\"{row_h}\" fill=\"#000\" fill-opacity=\"0.03\"/>",
                right - left
            );
        }
        let _ = writeln!(
            s,
            "<text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"end\">{}</text>",
            left - 8.0,
            y + row_h / 2.0 + 4.0,
            escape(&row.label)
        );
        for (k, ((_, colour), v)) in series.iter().zip(&row.values).enumerate() {
            let Some((v, lo, hi)) = v else { continue };
            let yy = y + 7.0 + 10.0 * k as f64 + 5.0;
            let _ = writeln!(
                s,
                "<line x1=\"{:.1}\" y1=\"{yy:.1}\" x2=\"{:.1}\" y2=\"{yy:.1}\" stroke=\"{colour}\" stroke-width=\"1.5\"/><circle cx=\"{:.1}\" cy=\"{yy:.1}\" r=\"3.5\" fill=\"{colour}\"/>",
                self.at(*lo),
                self.at(*hi),
                self.at(*v)
            );
        }
    }
}

/// The series' legend: a dot with a whisker and the text, in a row under the note.
fn legend(s: &mut String, series: &[(&str, &str)]) {
    let mut x = 20.0;
    for (label, colour) in series {
        let _ = writeln!(
            s,
            "<line x1=\"{x}\" y1=\"55\" x2=\"{}\" y2=\"55\" stroke=\"{colour}\" stroke-width=\"1.5\"/><circle cx=\"{}\" cy=\"55\" r=\"3.5\" fill=\"{colour}\"/><text x=\"{}\" y=\"59\">{}</text>",
            x + 16.0,
            x + 8.0,
            x + 22.0,
            escape(label)
        );
        x += 22.0 + CHAR_W * label.chars().count() as f64 + 24.0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A value and its whisker land where the scale puts them, and a whisker beyond the
    /// scale is clipped to the frame, not drawn outside it.
    #[test]
    fn dots_and_whiskers_sit_on_the_scale_and_stay_inside_it() {
        let rows = [IntervalRow {
            label: "kind".into(),
            values: vec![Some((50.0, 40.0, 130.0))],
        }];
        let svg = interval_chart(
            "t",
            "n",
            "x",
            &[("a", "#123456")],
            &rows,
            &[Reference {
                x: 95.0,
                colour: "#654321",
                label: "95 %",
            }],
            (0.0, 100.0),
        );
        let left = (CHAR_W * 4.0 + 24.0).clamp(120.0, 0.6 * W);
        let right = W - 30.0;
        let at = |x: f64| left + (right - left) * x / 100.0;
        assert!(svg.contains(&format!("cx=\"{:.1}\"", at(50.0))), "{svg}");
        assert!(svg.contains(&format!("x1=\"{:.1}\"", at(40.0))));
        // 130 is beyond the scale: the whisker ends at the frame's right edge.
        assert!(svg.contains(&format!("x2=\"{:.1}\"", at(100.0))));
        assert!(svg.contains(&format!("x1=\"{:.1}\"", at(95.0))));
        assert!(!svg.contains(&format!("{:.1}", at(130.0))));
    }
}
