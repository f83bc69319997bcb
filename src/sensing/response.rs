//! The measured coil response: one pick-up coil's reading against its distance from a
//! straight wire, as the thesis's calibration table (`AGVPOS.C`) records it.
//!
//! The table gives, for 21 positions `x` of the pair's centre off the wire, the reading of
//! the coil the wire passes under (`LuS2`, at distance `|x - a|`) and of the other
//! (`LuS1`, at `x + a`), `a` being half the coil spacing: 42 samples of one coil's
//! response. The curve is built from them without any free shape:
//!
//! 1. the 42 samples are sorted by distance;
//! 2. pooled where they do not fall with distance (least-squares isotonic regression: a
//!    coil cannot read more further from the wire; the two coils and the reading noise
//!    make a few neighbours disagree by a count or two), each pool becoming one knot at
//!    its mean distance and mean reading, so the knots fall strictly and the curve has
//!    no flat steps (a flat step would be a dead band in the sensor difference);
//! 3. a flat top at zero distance (the response is even in the distance, so its slope
//!    there is zero);
//! 4. joined by a monotone piecewise-cubic Hermite curve (Fritsch-Carlson slopes), so the
//!    reading and its slope are continuous and the curve never overshoots the data;
//! 5. zero beyond the farthest sample (164 mm: the far coil reads 0 from 133 mm).
//!
//! The table fixes `a` too: 36-37.5 mm reproduce it to about 1 count RMS, 35 or 39 mm to
//! 4-6 counts (a mismatch in where the two coils' samples interleave). We use 37 mm
//! ([`TABLE_HALF_SPACING_M`]).

use super::calibration_table::{LU_S1, LU_S2, LU_X};

/// Half the coil spacing the thesis's table implies, m.
pub const TABLE_HALF_SPACING_M: f64 = 0.037;

/// Most knots a curve holds (the table's 42 samples and the top).
const MAX_KNOTS: usize = 44;

/// One coil's reading against its distance from a straight wire (axis across the wire):
/// a monotone cubic through knots. Fixed capacity, so the sensing parameters stay `Copy`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ResponseCurve {
    n: usize,
    /// Knot distances, m, increasing from 0.
    distance_m: [f64; MAX_KNOTS],
    /// Readings at the knots, ADC counts, non-increasing.
    reading_adc: [f64; MAX_KNOTS],
    /// Slopes at the knots, counts per m.
    slope: [f64; MAX_KNOTS],
}

impl ResponseCurve {
    /// The thesis's coils, from the calibration table.
    pub fn thesis() -> ResponseCurve {
        ResponseCurve::from_pair_table(&LU_X, &LU_S2, &LU_S1, TABLE_HALF_SPACING_M)
    }

    /// Builds the curve from a pair's calibration table (positions in mm, readings of
    /// the near and the far coil) for coils `half_spacing_m` either side of the centre.
    /// Tables longer than 21 rows are not supported.
    pub fn from_pair_table(
        x_mm: &[f64],
        near_adc: &[f64],
        far_adc: &[f64],
        half_spacing_m: f64,
    ) -> ResponseCurve {
        let a_mm = half_spacing_m * 1e3;
        let mut samples: Vec<(f64, f64)> = x_mm
            .iter()
            .zip(near_adc)
            .map(|(x, s)| ((x - a_mm).abs() * 1e-3, *s))
            .chain(
                x_mm.iter()
                    .zip(far_adc)
                    .map(|(x, s)| ((x + a_mm) * 1e-3, *s)),
            )
            .collect();
        samples.sort_by(|p, q| p.0.total_cmp(&q.0));
        let mut knots = pooled_knots(&samples);
        if knots[0].0 > 0.0 {
            knots.insert(0, (0.0, knots[0].1));
        }
        knots.truncate(MAX_KNOTS);
        let mut c = ResponseCurve {
            n: knots.len(),
            distance_m: [0.0; MAX_KNOTS],
            reading_adc: [0.0; MAX_KNOTS],
            slope: [0.0; MAX_KNOTS],
        };
        for (k, (d, r)) in knots.iter().enumerate() {
            c.distance_m[k] = *d;
            c.reading_adc[k] = *r;
        }
        c.slope[..c.n].copy_from_slice(&monotone_slopes(&knots));
        // Even in the distance: flat at the top.
        c.slope[0] = 0.0;
        c
    }

    /// Reading at `distance_m` from the wire (either side), ADC counts.
    pub fn reading(&self, distance_m: f64) -> f64 {
        self.eval(distance_m.abs()).0
    }

    /// Slope of the reading with the signed lateral distance, counts per m.
    pub fn slope(&self, lateral_m: f64) -> f64 {
        lateral_m.signum() * self.eval(lateral_m.abs()).1
    }

    /// Reading directly over the wire, ADC counts.
    pub fn peak_adc(&self) -> f64 {
        self.reading_adc[0]
    }

    /// Farthest distance with a reading, m.
    pub fn range_m(&self) -> f64 {
        self.distance_m[self.n - 1]
    }

    /// (reading, slope) at a distance `d >= 0`.
    fn eval(&self, d: f64) -> (f64, f64) {
        let n = self.n;
        if d.is_nan() || d >= self.distance_m[n - 1] {
            return (self.reading_adc[n - 1], 0.0);
        }
        let k = self.distance_m[..n].partition_point(|x| *x <= d).max(1) - 1;
        let (d0, d1) = (self.distance_m[k], self.distance_m[k + 1]);
        let h = d1 - d0;
        let t = (d - d0) / h;
        let (y0, y1) = (self.reading_adc[k], self.reading_adc[k + 1]);
        let (m0, m1) = (self.slope[k] * h, self.slope[k + 1] * h);
        let (t2, t3) = (t * t, t * t * t);
        let y = (2.0 * t3 - 3.0 * t2 + 1.0) * y0
            + (t3 - 2.0 * t2 + t) * m0
            + (-2.0 * t3 + 3.0 * t2) * y1
            + (t3 - t2) * m1;
        let dy = ((6.0 * t2 - 6.0 * t) * y0
            + (3.0 * t2 - 4.0 * t + 1.0) * m0
            + (-6.0 * t2 + 6.0 * t) * y1
            + (3.0 * t2 - 2.0 * t) * m1)
            / h;
        (y, dy)
    }
}

/// Knots of the least-squares non-increasing fit of `(distance, reading)` samples sorted
/// by distance (pool adjacent violators): each pool of samples whose readings do not fall
/// (or that share a distance) becomes one knot at its mean distance and mean reading.
/// The knots' distances rise and their readings fall strictly.
pub fn pooled_knots(samples: &[(f64, f64)]) -> Vec<(f64, f64)> {
    // Pools of (sum of distances, sum of readings, count).
    let mut pools: Vec<(f64, f64, usize)> = Vec::new();
    for &(d, r) in samples {
        pools.push((d, r, 1));
        while pools.len() > 1 {
            let (d2, r2, c2) = pools[pools.len() - 1];
            let (d1, r1, c1) = pools[pools.len() - 2];
            let (mean_d1, mean_d2) = (d1 / c1 as f64, d2 / c2 as f64);
            if r1 / (c1 as f64) > r2 / (c2 as f64) && mean_d1 < mean_d2 {
                break;
            }
            pools.truncate(pools.len() - 2);
            pools.push((d1 + d2, r1 + r2, c1 + c2));
        }
    }
    pools
        .iter()
        .map(|&(d, r, c)| (d / c as f64, r / c as f64))
        .collect()
}

/// Fritsch-Carlson slopes of a monotone cubic Hermite interpolant through `(x, y)` knots:
/// the weighted harmonic mean of the neighbouring secants, zero where they differ in sign
/// or either is flat, one-sided at the ends.
fn monotone_slopes(knots: &[(f64, f64)]) -> Vec<f64> {
    let n = knots.len();
    if n < 2 {
        return vec![0.0; n];
    }
    let h: Vec<f64> = (0..n - 1).map(|k| knots[k + 1].0 - knots[k].0).collect();
    let sec: Vec<f64> = (0..n - 1)
        .map(|k| (knots[k + 1].1 - knots[k].1) / h[k])
        .collect();
    let mut m = vec![0.0; n];
    for k in 1..n - 1 {
        let (s0, s1) = (sec[k - 1], sec[k]);
        if s0 * s1 > 0.0 {
            let (w1, w2) = (2.0 * h[k] + h[k - 1], h[k] + 2.0 * h[k - 1]);
            m[k] = (w1 + w2) / (w1 / s0 + w2 / s1);
        }
    }
    m[0] = end_slope(
        h[0],
        h.get(1).copied().unwrap_or(h[0]),
        sec[0],
        sec.get(1).copied().unwrap_or(sec[0]),
    );
    m[n - 1] = end_slope(
        h[n - 2],
        if n > 2 { h[n - 3] } else { h[n - 2] },
        sec[n - 2],
        if n > 2 { sec[n - 3] } else { sec[n - 2] },
    );
    m
}

/// One-sided three-point end slope, limited so the end interval stays monotone.
fn end_slope(h0: f64, h1: f64, s0: f64, s1: f64) -> f64 {
    let d = ((2.0 * h0 + h1) * s0 - h0 * s1) / (h0 + h1);
    if d * s0 <= 0.0 {
        0.0
    } else if s0 * s1 <= 0.0 && d.abs() > 3.0 * s0.abs() {
        3.0 * s0
    } else {
        d
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pooling_merges_a_rise_into_one_knot_at_the_means() {
        let k = pooled_knots(&[(0.0, 5.0), (1.0, 3.0), (2.0, 4.0), (3.0, 1.0), (3.0, 0.5)]);
        assert_eq!(k, vec![(0.0, 5.0), (1.5, 3.5), (3.0, 0.75)]);
    }

    #[test]
    fn thesis_curve_is_even_monotone_and_zero_far_away() {
        let c = ResponseCurve::thesis();
        let mut last = c.reading(0.0);
        for k in 1..400 {
            let d = k as f64 * 0.5e-3;
            let r = c.reading(d);
            assert!(r <= last + 1e-9, "rises at {d}: {r} > {last}");
            assert_eq!(r, c.reading(-d));
            last = r;
        }
        assert_eq!(c.reading(0.2), 0.0);
        assert!(c.slope(0.0).abs() < 1e-12);
        assert!(c.slope(0.02) < 0.0 && c.slope(-0.02) > 0.0);
        // No dead band where the pair works: the slope is strictly negative from the
        // peak's shoulder to the far tail.
        for k in 2..120 {
            let d = k as f64 * 1e-3;
            assert!(c.slope(d) < 0.0, "flat at {d} m");
        }
    }
}
