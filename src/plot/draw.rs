//! What a plot draws: a series (its pieces, markers, dashes), flagged points as crosses,
//! and the legend's keys.

use std::fmt::Write;

use super::{Series, Style, MARKERS_UP_TO};

pub(super) fn cross(s: &mut String, x: f64, y: f64, colour: &str) {
    let _ = writeln!(
        s,
        r#"<path d="M{:.1},{:.1}L{:.1},{:.1}M{:.1},{:.1}L{:.1},{:.1}" stroke="{colour}" stroke-width="2"/>"#,
        x - 4.0,
        y - 4.0,
        x + 4.0,
        y + 4.0,
        x - 4.0,
        y + 4.0,
        x + 4.0,
        y - 4.0
    );
}

/// An open triangle pointing up: a value above this point (censored).
pub(super) fn above_marker(s: &mut String, x: f64, y: f64, colour: &str) {
    let _ = writeln!(
        s,
        r#"<path d="M{:.1},{:.1}L{:.1},{:.1}L{:.1},{:.1}Z" fill="white" stroke="{colour}" stroke-width="1.8"/>"#,
        x,
        y - 6.0,
        x - 5.0,
        y + 3.0,
        x + 5.0,
        y + 3.0
    );
}

pub(super) fn marker(s: &mut String, x: f64, y: f64, colour: &str) {
    let _ = writeln!(
        s,
        r#"<circle cx="{x:.1}" cy="{y:.1}" r="3.5" fill="{colour}" stroke="white" stroke-width="1"/>"#
    );
}

pub(super) fn legend_key(
    s: &mut String,
    x: f64,
    y: f64,
    colour: &str,
    style: Style,
    in_scale: bool,
    is_flag: bool,
) {
    if is_flag {
        cross(s, x + 11.0, y, colour);
        return;
    }
    let (width, opacity) = match style {
        Style::Measured => (5.0, 0.45),
        _ => (3.0, 1.0),
    };
    let dash = if in_scale {
        ""
    } else {
        r#" stroke-dasharray="6,3""#
    };
    if style == Style::Above {
        above_marker(s, x + 11.0, y, colour);
        return;
    }
    if style != Style::Points {
        let _ = writeln!(
            s,
            r#"<line x1="{x:.1}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="{colour}" stroke-width="{width}" stroke-opacity="{opacity}"{dash}/>"#,
            x + 22.0
        );
    }
    if style == Style::Points {
        marker(s, x + 11.0, y, colour);
    }
}

/// The points cut into the runs between breaks (a run starts at the first point at or
/// past each break).
pub(super) fn pieces<'p>(points: &'p [(f64, f64)], breaks: &[f64]) -> Vec<&'p [(f64, f64)]> {
    let mut out = Vec::new();
    let mut start = 0;
    for k in 1..points.len() {
        let (before, at) = (points[k - 1].0, points[k].0);
        if breaks.iter().any(|&b| before < b && at >= b) {
            out.push(&points[start..k]);
            start = k;
        }
    }
    out.push(&points[start..]);
    out
}

pub(super) fn draw_series(
    s: &mut String,
    ser: &Series,
    px: &dyn Fn(f64) -> f64,
    py: &dyn Fn(f64) -> f64,
) {
    let finite: Vec<(f64, f64)> = ser
        .x
        .iter()
        .zip(ser.y)
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .map(|(x, y)| (*x, *y))
        .collect();
    let clip = r#" clip-path="url(#data)""#;
    match ser.style {
        Style::Stems => {
            for (x, y) in &finite {
                let _ = writeln!(
                    s,
                    r#"<line x1="{:.1}" y1="{:.1}" x2="{:.1}" y2="{:.1}" stroke="{}" stroke-width="2"{clip}/>"#,
                    px(*x),
                    py(0.0),
                    px(*x),
                    py(*y),
                    ser.colour
                );
            }
        }
        Style::Points => {
            for (x, y) in &finite {
                marker(s, px(*x), py(*y), ser.colour);
            }
        }
        Style::Above => {
            for (x, y) in &finite {
                above_marker(s, px(*x), py(*y), ser.colour);
            }
        }
        Style::Line | Style::Measured => {
            // Thin long series to about two points per pixel column.
            let stride = (finite.len() / 2000).max(1);
            let thinned: Vec<(f64, f64)> = finite.iter().step_by(stride).copied().collect();
            let (width, opacity) = if ser.style == Style::Measured {
                (4.0, 0.45)
            } else {
                (1.4, 1.0)
            };
            let dash = if ser.in_scale {
                ""
            } else {
                r#" stroke-dasharray="6,3""#
            };
            for piece in pieces(&thinned, ser.breaks) {
                let pts: Vec<String> = piece
                    .iter()
                    .map(|(x, y)| format!("{:.1},{:.1}", px(*x), py(*y)))
                    .collect();
                let _ = writeln!(
                    s,
                    r#"<polyline fill="none" stroke="{}" stroke-width="{width}" stroke-opacity="{opacity}"{dash}{clip} points="{}"/>"#,
                    ser.colour,
                    pts.join(" ")
                );
            }
            if ser.style == Style::Line && finite.len() <= MARKERS_UP_TO && ser.in_scale {
                for (x, y) in &finite {
                    marker(s, px(*x), py(*y), ser.colour);
                }
            }
        }
    }
}
