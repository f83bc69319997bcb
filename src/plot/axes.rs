//! A plot's axes: round ticks and their labels, the ranges the series span (sentinels
//! held at the frame), and the legend's rows.

use super::{CHAR_W, MARGIN_L, MARGIN_R, W};

/// Axis ticks at round steps covering `[lo, hi]`, and the number of decimals their step
/// needs. Ticks are whole multiples of the step, so a tick at zero reads `0`, never
/// `-1.4e-17`.
pub fn nice_ticks(lo: f64, hi: f64) -> (Vec<f64>, usize) {
    let span = (hi - lo).max(1e-300);
    let raw = span / 5.0;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| span / s <= 6.0)
        .unwrap_or(10.0 * mag);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step + 1e-9).floor() as i64;
    let ticks = (first..=last).map(|k| k as f64 * step).collect();
    let decimals = (-step.log10().floor()).max(0.0) as usize;
    (ticks, decimals)
}

/// A tick label: rounded to the step's decimals; scientific for very large or very small
/// magnitudes.
pub fn fmt_tick(t: f64, decimals: usize) -> String {
    if t == 0.0 {
        return "0".into();
    }
    if t.abs() >= 1e5 || decimals > 4 {
        return format!("{t:.1e}");
    }
    format!("{t:.decimals$}")
}

/// Legend entries laid out in rows across the width below the plot, wrapping instead of
/// cutting: the (x, row) of each entry.
pub(super) fn legend_layout(labels: &[&str]) -> Vec<(f64, usize)> {
    let mut out = Vec::new();
    let (mut x, mut row) = (MARGIN_L, 0);
    for l in labels {
        let w = 30.0 + CHAR_W * l.chars().count() as f64 + 20.0;
        if x + w > W - MARGIN_R && x > MARGIN_L {
            x = MARGIN_L;
            row += 1;
        }
        out.push((x, row));
        x += w;
    }
    out
}

/// Largest magnitude an axis reaches: past it a value (a sentinel such as -1.7e308) is
/// drawn at the frame's edge, as the span of an axis to it would overflow to infinity and
/// every coordinate with it.
pub(super) const AXIS_LIMIT: f64 = 1e100;

pub(super) fn range_of<'b>(values: impl Iterator<Item = &'b f64>) -> (f64, f64) {
    values
        .filter(|v| v.is_finite())
        .map(|v| v.clamp(-AXIS_LIMIT, AXIS_LIMIT))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        })
}

/// A canvas coordinate kept within a few canvases of the frame: a point far outside the
/// axes is clipped all the same, and its coordinate stays a short finite number.
pub(super) fn on_canvas(c: f64) -> f64 {
    c.clamp(-10.0 * W, 10.0 * W)
}
