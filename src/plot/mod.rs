//! Plots as SVG, written directly (no plotting dependency), shared by identify, diagnose,
//! sweep, study and prove: line plots of series against x, horizontal bar charts, and
//! dot-and-whisker charts.
//!
//! Rules every plot keeps, so it reads at a glance: the legend sits below the data and
//! wraps rather than being cut; a series of few points gets markers; a series marked out
//! of scale (a run that lost the wire) is drawn clipped and dashed and does not set the
//! axes; flagged points (failed runs) are drawn as crosses along the top edge, outside the
//! scale; tick labels are rounded to their step; a measured trace is drawn wide and pale
//! under the simulated one so both stay visible.

mod axes;
pub mod bars;
mod draw;
mod intervals;

use std::fmt::Write;

pub use axes::{fmt_tick, nice_ticks};
use axes::{legend_layout, on_canvas, range_of};
pub use bars::{bar_chart, BarGroup};
use draw::{cross, draw_series, legend_key};
pub use intervals::{interval_chart, IntervalRow, Reference};

/// Canvas width, px.
pub const W: f64 = 900.0;
/// Height of the data area, px.
const PLOT_H: f64 = 250.0;
const MARGIN_L: f64 = 80.0;
const MARGIN_R: f64 = 20.0;
const MARGIN_T: f64 = 34.0;
/// Below the data area: tick labels and the x label.
const AXIS_H: f64 = 42.0;
const LEGEND_ROW_H: f64 = 18.0;
/// Width of one character at the 12 px font, px (a generous estimate, so text fits).
pub const CHAR_W: f64 = 7.0;
/// A line series with at most this many points also gets a marker at each.
const MARKERS_UP_TO: usize = 40;

/// Colours for successive series.
pub const COLOURS: [&str; 10] = [
    "#1f5fbf", "#d08000", "#2a9d3a", "#c02a2a", "#7b4fb0", "#8c564b", "#d04f9c", "#555555",
    "#9aa01a", "#17a2b8",
];

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Style {
    /// A thin line (markers too when it has few points).
    Line,
    /// Wide and pale, for measured data under a simulated line.
    Measured,
    /// Vertical stems from zero (correlations).
    Stems,
    /// Markers only, no line.
    Points,
    /// Censored values: an open triangle pointing up at each point, "above this: none
    /// found up to here" (an onset not reached at the top of the values searched).
    Above,
}

/// One series of a plot.
pub struct Series<'a> {
    /// Legend text.
    pub label: &'a str,
    /// x values.
    pub x: &'a [f64],
    /// y values.
    pub y: &'a [f64],
    /// Colour (SVG).
    pub colour: &'a str,
    /// How it is drawn.
    pub style: Style,
    /// Whether the series sets the axes' range. A series out of scale (a run that lost
    /// the wire) is clipped to the frame and dashed.
    pub in_scale: bool,
    /// x values where the line is broken: an independent record starts there (a test of
    /// several joined), so no line joins its first point to the previous record's last.
    pub breaks: &'a [f64],
}

impl<'a> Series<'a> {
    /// A thin line that sets the scale.
    pub fn line(label: &'a str, x: &'a [f64], y: &'a [f64], colour: &'a str) -> Self {
        Series {
            label,
            x,
            y,
            colour,
            style: Style::Line,
            in_scale: true,
            breaks: &[],
        }
    }

    /// The same series with its line broken at these x values.
    pub fn broken_at(mut self, breaks: &'a [f64]) -> Self {
        self.breaks = breaks;
        self
    }

    /// The same series drawn another way.
    pub fn with_style(mut self, style: Style) -> Self {
        self.style = style;
        self
    }

    /// Marks the series as out of scale (drawn clipped and dashed).
    pub fn out_of_scale(mut self) -> Self {
        self.in_scale = false;
        self
    }
}

/// Points drawn as crosses along the top edge, outside the scale, with one legend entry
/// (for example the grid points where every run lost the wire).
#[derive(Clone, Copy)]
pub struct Flags<'a> {
    /// Legend text.
    pub label: &'a str,
    /// Where the crosses are, x.
    pub x: &'a [f64],
    /// Colour (SVG).
    pub colour: &'a str,
}

/// A line plot.
pub struct Plot<'a> {
    /// Title.
    pub title: &'a str,
    /// x axis label, with its unit.
    pub x_label: &'a str,
    /// y axis label, with its unit.
    pub y_label: &'a str,
    /// The series.
    pub series: &'a [Series<'a>],
    /// A dashed +/-band about zero (a confidence band).
    pub band: Option<f64>,
    /// Crosses along the top edge, if any.
    pub flags: Option<Flags<'a>>,
    /// Shown in the data area when there is nothing to draw.
    pub empty_note: &'a str,
}

/// A figure: the file name it is written under and its SVG text.
#[derive(Debug, Clone)]
pub struct Figure {
    /// File name, `NAME.svg`.
    pub file: String,
    /// The SVG document.
    pub svg: String,
}

/// Writes each figure into `dir` (each atomically); returns the files written.
pub fn write_figures(
    dir: &std::path::Path,
    figures: &[Figure],
) -> std::io::Result<Vec<std::path::PathBuf>> {
    std::fs::create_dir_all(dir)?;
    figures
        .iter()
        .map(|f| {
            let path = dir.join(&f.file);
            crate::output::write_atomically(&path, &f.svg)?;
            Ok(path)
        })
        .collect()
}

/// A simple line plot (the common case).
pub fn svg(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    band: Option<f64>,
) -> String {
    Plot {
        title,
        x_label,
        y_label,
        series,
        band,
        flags: None,
        empty_note: "no data",
    }
    .render()
}

/// The measured cells of a column as plot points: times and values where a value was
/// recorded (missing samples leave gaps, not zeros).
pub fn measured_points(t_s: &[f64], column: &[Option<f64>]) -> (Vec<f64>, Vec<f64>) {
    column
        .iter()
        .zip(t_s)
        .filter_map(|(v, t)| v.map(|v| (*t, v)))
        .unzip()
}

/// Text escaped for SVG.
pub fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

impl Plot<'_> {
    /// The axes' ranges: x over every series and flag, y over the in-scale series (and
    /// the band, and zero for stems), padded by 5 %.
    fn ranges(&self) -> ((f64, f64), (f64, f64)) {
        let flag_x = self.flags.iter().flat_map(|f| f.x.iter());
        let (x0, x1) = range_of(self.series.iter().flat_map(|s| s.x.iter()).chain(flag_x));
        let scaled = self.series.iter().filter(|s| s.in_scale);
        let (mut y0, mut y1) = range_of(scaled.flat_map(|s| s.y.iter()));
        if let Some(b) = self.band {
            y0 = y0.min(-b);
            y1 = y1.max(b);
        }
        if self.series.iter().any(|s| s.style == Style::Stems) {
            y0 = y0.min(0.0);
            y1 = y1.max(0.0);
        }
        if !(y1 > y0) {
            let c = if y0.is_finite() { y0 } else { 0.0 };
            let h = if c == 0.0 { 1.0 } else { 0.1 * c.abs() };
            // One value, 0 or more: do not invent negative values (a fraction that is
            // 0 everywhere reads 0..1, not -1..1).
            let lo = if c >= 0.0 { (c - h).max(0.0) } else { c - h };
            (y0, y1) = (lo, c + h);
        }
        let pad = 0.05 * (y1 - y0);
        // Room along the top for the flags' crosses, clear of the data.
        let top_pad = if self.flags.is_some() { 3.0 * pad } else { pad };
        let x = if x1 > x0 {
            (x0, x1)
        } else if x0.is_finite() {
            let h = if x0 == 0.0 { 1.0 } else { 0.1 * x0.abs() };
            // A single x: do not invent negative values of a quantity that has none.
            let lo = if x0 >= 0.0 { (x0 - h).max(0.0) } else { x0 - h };
            (lo, x0 + h)
        } else {
            (0.0, 1.0)
        };
        (x, (y0 - pad, y1 + top_pad))
    }

    /// The plot as an SVG document.
    pub fn render(&self) -> String {
        self.render_in(self.ranges())
    }

    /// The plot with a metre on x as long as a metre on y (a path seen from above): the
    /// ranges widened about their middles until both scales agree.
    pub fn render_to_scale(&self) -> String {
        let ((x0, x1), (y0, y1)) = self.ranges();
        let (wx, wy) = (x1 - x0, y1 - y0);
        let (ux, uy) = (wx / (W - MARGIN_L - MARGIN_R), wy / PLOT_H);
        let ranges = if ux > uy {
            let half = 0.5 * ux * PLOT_H;
            let c = 0.5 * (y0 + y1);
            ((x0, x1), (c - half, c + half))
        } else {
            let half = 0.5 * uy * (W - MARGIN_L - MARGIN_R);
            let c = 0.5 * (x0 + x1);
            ((c - half, c + half), (y0, y1))
        };
        self.render_in(ranges)
    }

    /// The plot drawn over the given axes' ranges.
    fn render_in(&self, ((x0, x1), (y0, y1)): ((f64, f64), (f64, f64))) -> String {
        let px = |x: f64| on_canvas(MARGIN_L + (x - x0) / (x1 - x0) * (W - MARGIN_L - MARGIN_R));
        let py = |y: f64| on_canvas(MARGIN_T + (y1 - y) / (y1 - y0) * PLOT_H);
        let owned = self.legend_labels();
        let mut labels: Vec<&str> = owned.iter().map(String::as_str).collect();
        if let Some(f) = &self.flags {
            labels.push(f.label);
        }
        let legend = legend_layout(&labels);
        let rows = legend.last().map_or(0, |l| l.1 + 1);
        let h = MARGIN_T + PLOT_H + AXIS_H + rows as f64 * LEGEND_ROW_H + 8.0;
        let mut s = String::new();
        let _ = writeln!(
            s,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{h}" font-family="sans-serif" font-size="12">"#
        );
        let _ = writeln!(s, r#"<rect width="100%" height="100%" fill="white"/>"#);
        let _ = writeln!(
            s,
            r#"<defs><clipPath id="data"><rect x="{MARGIN_L}" y="{MARGIN_T}" width="{:.1}" height="{PLOT_H}"/></clipPath></defs>"#,
            W - MARGIN_L - MARGIN_R
        );
        let _ = writeln!(
            s,
            r#"<text x="{}" y="20" font-size="14" text-anchor="middle">{}</text>"#,
            W / 2.0,
            escape(self.title)
        );
        self.axes(&mut s, (x0, x1), (y0, y1), &px, &py);
        let drawn = self.series.iter().any(|ser| {
            ser.x
                .iter()
                .zip(ser.y)
                .any(|(x, y)| x.is_finite() && y.is_finite())
        }) || self.flags.as_ref().is_some_and(|f| !f.x.is_empty());
        if !drawn {
            let _ = writeln!(
                s,
                r##"<text x="{:.1}" y="{:.1}" text-anchor="middle" fill="#888" font-size="14">{}</text>"##,
                (W + MARGIN_L) / 2.0,
                MARGIN_T + PLOT_H / 2.0,
                escape(self.empty_note)
            );
        }
        // Measured data first, so simulated lines are drawn over it.
        let mut order: Vec<usize> = (0..self.series.len()).collect();
        order.sort_by_key(|&i| self.series[i].style != Style::Measured);
        for i in order {
            draw_series(&mut s, &self.series[i], &px, &py);
        }
        if let Some(f) = &self.flags {
            for x in f.x.iter().filter(|x| x.is_finite()) {
                cross(&mut s, px(*x), MARGIN_T + 8.0, f.colour);
            }
        }
        self.draw_legend(&mut s, &legend, &labels);
        s.push_str("</svg>\n");
        s
    }

    /// Each series' legend label; a series with nothing to draw says so in the legend
    /// rather than vanishing.
    fn legend_labels(&self) -> Vec<String> {
        self.series
            .iter()
            .map(|ser| {
                let any = ser
                    .x
                    .iter()
                    .zip(ser.y)
                    .any(|(x, y)| x.is_finite() && y.is_finite());
                if any {
                    ser.label.to_string()
                } else {
                    format!("{} (no values)", ser.label)
                }
            })
            .collect()
    }

    /// The legend below the axes: each series' key and label, then the flags'.
    fn draw_legend(&self, s: &mut String, legend: &[(f64, usize)], labels: &[&str]) {
        let top = MARGIN_T + PLOT_H + AXIS_H;
        for (k, (x, row)) in legend.iter().enumerate() {
            let y = top + *row as f64 * LEGEND_ROW_H;
            let (colour, style, in_scale) = match self.series.get(k) {
                Some(ser) => (ser.colour, ser.style, ser.in_scale),
                None => (
                    self.flags.as_ref().map_or("#000", |f| f.colour),
                    Style::Points,
                    true,
                ),
            };
            legend_key(s, *x, y, colour, style, in_scale, k >= self.series.len());
            let _ = writeln!(
                s,
                r#"<text x="{:.1}" y="{:.1}">{}</text>"#,
                x + 28.0,
                y + 4.0,
                escape(labels[k])
            );
        }
    }

    fn axes(
        &self,
        s: &mut String,
        (x0, x1): (f64, f64),
        (y0, y1): (f64, f64),
        px: &dyn Fn(f64) -> f64,
        py: &dyn Fn(f64) -> f64,
    ) {
        let bottom = MARGIN_T + PLOT_H;
        let (xt, xd) = nice_ticks(x0, x1);
        for t in xt {
            let x = px(t);
            let _ = writeln!(
                s,
                r##"<line x1="{x:.1}" y1="{MARGIN_T}" x2="{x:.1}" y2="{bottom:.1}" stroke="#eee"/><text x="{x:.1}" y="{:.1}" text-anchor="middle">{}</text>"##,
                bottom + 15.0,
                fmt_tick(t, xd)
            );
        }
        let (yt, yd) = nice_ticks(y0, y1);
        for t in yt {
            let y = py(t);
            let _ = writeln!(
                s,
                r##"<line x1="{MARGIN_L}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="#eee"/><text x="{:.1}" y="{:.1}" text-anchor="end">{}</text>"##,
                W - MARGIN_R,
                MARGIN_L - 5.0,
                y + 4.0,
                fmt_tick(t, yd)
            );
        }
        let _ = writeln!(
            s,
            r#"<rect x="{MARGIN_L}" y="{MARGIN_T}" width="{:.1}" height="{PLOT_H}" fill="none" stroke="black"/>"#,
            W - MARGIN_L - MARGIN_R,
        );
        let _ = writeln!(
            s,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">{}</text>"#,
            (W + MARGIN_L) / 2.0,
            bottom + 32.0,
            escape(self.x_label)
        );
        let _ = writeln!(
            s,
            r#"<text transform="translate(16,{:.1}) rotate(-90)" text-anchor="middle">{}</text>"#,
            MARGIN_T + PLOT_H / 2.0,
            escape(self.y_label)
        );
        if let Some(b) = self.band {
            for v in [b, -b] {
                let _ = writeln!(
                    s,
                    r##"<line x1="{MARGIN_L}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="#c00" stroke-dasharray="5,4"/>"##,
                    W - MARGIN_R,
                    y = py(v)
                );
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Joined records are drawn as separate lines: none joins the end of one test to the
    /// start of the next, and without breaks one line runs through every point.
    #[test]
    fn a_line_breaks_where_an_independent_record_starts() {
        let x = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0];
        let y = [0.0, 1.0, 2.0, -2.0, -1.0, 0.0];
        let lines = |breaks: &[f64]| {
            svg(
                "t",
                "x",
                "y",
                &[Series::line("a", &x, &y, "#000").broken_at(breaks)],
                None,
            )
            .matches("<polyline")
            .count()
        };
        assert_eq!(lines(&[]), 1);
        assert_eq!(lines(&[3.0]), 2);
        assert_eq!(lines(&[2.5, 4.0]), 3);
    }

    #[test]
    fn ticks_are_whole_steps_and_labels_are_rounded() {
        let (t, d) = nice_ticks(-0.7, 0.7);
        assert!(t.contains(&0.0), "{t:?}");
        let labels: Vec<String> = t.iter().map(|v| fmt_tick(*v, d)).collect();
        assert!(labels.iter().all(|l| !l.contains('e')), "{labels:?}");
        assert!(labels.contains(&"0".to_string()));
        assert_eq!(fmt_tick(0.30000000000000004, 1), "0.3");
    }

    #[test]
    fn long_legends_wrap_inside_the_canvas() {
        let long = "compound=hard_polyurethane floor=painted_concrete payload=200";
        let labels = vec![long; 5];
        let l = legend_layout(&labels);
        for (x, _) in &l {
            assert!(x + 50.0 + CHAR_W * long.len() as f64 <= W, "{x}");
        }
        assert!(l.last().unwrap().1 >= 2, "{l:?}");
    }

    /// A quantity that is 0 everywhere (a sliding fraction of runs that never slid) gets
    /// an axis from 0 up, not an invented -1..1.
    #[test]
    fn a_constant_zero_series_gets_no_negative_axis() {
        let x = [1.0, 2.0, 3.0];
        let y = [0.0; 3];
        let series = [Series::line("never slid", &x, &y, "#000")];
        let p = Plot {
            title: "t",
            x_label: "x",
            y_label: "y",
            series: &series,
            band: None,
            flags: None,
            empty_note: "",
        };
        let (_, (y0, y1)) = p.ranges();
        assert!((-0.06..0.0).contains(&y0) && y1 > 0.9, "{y0} {y1}");
        let neg = [-2.0; 3];
        let series = [Series::line("constant below 0", &x, &neg, "#000")];
        let (_, (y0, y1)) = Plot {
            series: &series,
            ..p
        }
        .ranges();
        assert!(y0 < -2.0 && y1 > -2.0, "{y0} {y1}");
    }

    #[test]
    fn out_of_scale_series_do_not_set_the_axes() {
        let x = [0.0, 1.0, 2.0];
        let near = [0.01, -0.02, 0.015];
        let lost = [0.0, -3.0, -5.0];
        let series = [
            Series::line("held", &x, &near, "#000"),
            Series::line("lost", &x, &lost, "#f00").out_of_scale(),
        ];
        let p = Plot {
            title: "t",
            x_label: "x",
            y_label: "y",
            series: &series,
            band: None,
            flags: None,
            empty_note: "",
        };
        let (_, (y0, y1)) = p.ranges();
        assert!(y0 > -0.03 && y1 < 0.03, "{y0} {y1}");
    }
}

#[cfg(test)]
mod sentinel_tests {
    use super::*;

    /// A sentinel cell (-1.7e308, near f64's limit) does not make the axis span overflow:
    /// every coordinate written is a finite number of a few digits.
    #[test]
    fn a_sentinel_value_leaves_every_coordinate_finite_and_short() {
        let x = [0.0, 1.0, 2.0, 3.0];
        let y = [0.5, -1.7e308, 0.7, 1e300];
        let series = [Series::line("v", &x, &y, "#000")];
        let p = Plot {
            title: "t",
            x_label: "x",
            y_label: "y",
            series: &series,
            band: None,
            flags: None,
            empty_note: "",
        };
        let svg = p.render();
        assert!(!svg.contains("NaN") && !svg.contains("inf"), "{svg}");
        for number in svg
            .split(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-' || c == 'e'))
            .filter(|t| t.chars().any(|c| c.is_ascii_digit()))
        {
            assert!(number.len() < 40, "{number}");
        }
    }
}
