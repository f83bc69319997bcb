//! Streams of different rates on one time base: a decoded stream, and the two ways a row
//! takes a stream's value (the nearest sample within a tolerance, or the latest one held).

/// A decoded stream: times (ns since the epoch) and, per sample, its components.
#[derive(Debug, Clone, Default)]
pub(super) struct Series {
    /// Sample times, ns since the epoch.
    pub t_ns: Vec<i64>,
    /// Each sample's components.
    pub values: Vec<Vec<f64>>,
}

impl Series {
    /// Appends a sample.
    pub fn push(&mut self, t: i64, v: Vec<f64>) {
        self.t_ns.push(t);
        self.values.push(v);
    }

    /// Sorted by time (header stamps need not arrive in order).
    pub fn sorted(mut self) -> Series {
        let mut idx: Vec<usize> = (0..self.t_ns.len()).collect();
        idx.sort_by_key(|&i| self.t_ns[i]);
        self.t_ns = idx.iter().map(|&i| self.t_ns[i]).collect();
        self.values = idx
            .iter()
            .map(|&i| std::mem::take(&mut self.values[i]))
            .collect();
        self
    }

    /// Component `j`, an angle in rad, made continuous: no jump of 2 pi between
    /// neighbouring samples (a heading read from quaternions wraps at +-pi). A sample that
    /// is not a number (a NaN quaternion) stays one and is left out of the unwrapping: it
    /// must not poison every later heading.
    pub fn with_continuous(mut self, j: usize) -> Series {
        let tau = std::f64::consts::TAU;
        let mut prev: Option<f64> = None;
        for v in self.values.iter_mut() {
            let Some(cur) = v.get_mut(j) else {
                continue;
            };
            if !cur.is_finite() {
                continue;
            }
            if let Some(p) = prev {
                *cur -= ((*cur - p) / tau).round() * tau;
            }
            prev = Some(*cur);
        }
        self
    }
}

#[cfg(test)]
mod continuity_tests {
    use super::*;

    #[test]
    fn a_nan_heading_does_not_spoil_the_later_ones() {
        let s = Series {
            t_ns: vec![0, 1, 2, 3],
            values: vec![vec![3.0], vec![f64::NAN], vec![-3.0], vec![-2.9]],
        }
        .with_continuous(0);
        assert!(s.values[1][0].is_nan());
        // -3 after 3 is a small turn past pi, unwrapped to 2 pi - 3.
        assert!((s.values[2][0] - (std::f64::consts::TAU - 3.0)).abs() < 1e-12);
        assert!((s.values[3][0] - (std::f64::consts::TAU - 2.9)).abs() < 1e-12);
    }
}

/// Median interval between distinct times, ns.
pub(super) fn median_interval_ns(t: &[i64]) -> Option<i64> {
    let mut d: Vec<i64> = t
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|d| *d > 0)
        .collect();
    d.sort_unstable();
    d.get(d.len() / 2).copied()
}

/// Each row's nearest sample of `s` (component `j`) within `half` ns, else empty.
pub(super) fn nearest(rows: &[i64], s: &Series, j: usize, half: i64) -> Vec<Option<f64>> {
    let mut out = vec![None; rows.len()];
    let mut k = 0;
    for (r, t) in rows.iter().enumerate() {
        while k + 1 < s.t_ns.len() && (s.t_ns[k + 1] - t).abs() <= (s.t_ns[k] - t).abs() {
            k += 1;
        }
        if let Some(&ts) = s.t_ns.get(k) {
            if (ts - t).abs() <= half {
                out[r] = s.values[k].get(j).copied().filter(|v| v.is_finite());
            }
        }
    }
    out
}

/// Each row's latest sample of `s` at or before it (component `j`), else empty.
pub(super) fn held(rows: &[i64], s: &Series, j: usize) -> Vec<Option<f64>> {
    let mut out = vec![None; rows.len()];
    let mut k: Option<usize> = None;
    for (r, t) in rows.iter().enumerate() {
        while s.t_ns.get(k.map_or(0, |k| k + 1)).is_some_and(|ts| ts <= t) {
            k = Some(k.map_or(0, |k| k + 1));
        }
        out[r] = k.and_then(|k| s.values[k].get(j).copied());
    }
    out
}

/// Nanoseconds as seconds in decimal, exactly (`20000000` -> `0.02`).
pub(super) fn seconds_of_ns(ns: i64) -> String {
    let sign = if ns < 0 { "-" } else { "" };
    let (s, frac) = (ns.abs() / 1_000_000_000, ns.abs() % 1_000_000_000);
    if frac == 0 {
        return format!("{sign}{s}");
    }
    let f = format!("{frac:09}");
    format!("{sign}{s}.{}", f.trim_end_matches('0'))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_take_the_nearest_within_tolerance_or_the_latest_held() {
        let s = Series {
            t_ns: vec![0, 100, 200],
            values: vec![vec![1.0], vec![2.0], vec![3.0]],
        };
        let rows = [0, 40, 60, 150, 400];
        assert_eq!(
            nearest(&rows, &s, 0, 45),
            vec![Some(1.0), Some(1.0), Some(2.0), None, None]
        );
        assert_eq!(
            held(&[-5, 0, 150, 400], &s, 0),
            vec![None, Some(1.0), Some(2.0), Some(3.0)]
        );
        assert_eq!(seconds_of_ns(20_000_000), "0.02");
        assert_eq!(seconds_of_ns(3_000_000_000), "3");
    }

    #[test]
    fn a_heading_across_pi_stays_continuous() {
        let s = Series {
            t_ns: vec![0, 1, 2],
            values: vec![vec![3.1], vec![-3.1], vec![-3.0]],
        }
        .with_continuous(0);
        let tau = std::f64::consts::TAU;
        assert!((s.values[1][0] - (-3.1 + tau)).abs() < 1e-12);
        assert!((s.values[2][0] - (-3.0 + tau)).abs() < 1e-12);
    }
}
