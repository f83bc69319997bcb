//! A tracked pose compared over windows: each pose sample as the motion since the sample a
//! window earlier, in the frame the vehicle had then (forward, left, turned), instead of
//! where the vehicle is on the floor. A simulation whose dynamics are a little off drifts
//! from a tracked path without bound, and the fit is then led by where the drift happens
//! to put the vehicle; the motion over a window (the "relative pose error" odometry is
//! judged by) carries the same physics, and a drift stays as short as the window. It is a
//! multiple shooting of the pose: the recording is cut into windows, each restarted from
//! the pose measured at its start, while the speeds, which the dynamics do not let drift,
//! run on.

use crate::ident::data::Dataset;
use crate::record::channels as chan;

/// Outputs of a tracked pose, in the order the windows transform them.
const POSE: [&str; 3] = [chan::X_M, chan::Y_M, chan::HEADING_RAD];

/// The shortest window, s, and the share of the recording a window spans where that is
/// longer: a window must hold enough motion to show the vehicle's geometry and dynamics
/// above the tracker's noise, and short enough for the drift of a slightly wrong model
/// to stay small.
pub const MIN_WINDOW_S: f64 = 2.0;
/// Share of a recording's span one window covers, where that is more than [`MIN_WINDOW_S`].
pub const WINDOW_SHARE: f64 = 1.0 / 20.0;

/// Where each row's window starts, for a dataset with a tracked pose.
#[derive(Debug, Clone)]
pub struct PoseWindows {
    /// Output indices of `x_m`, `y_m`, `heading_rad` in the dataset.
    columns: [usize; 3],
    /// For each row, the row its window starts at: the first row of the window (the test
    /// cut into windows from its start) with the whole pose measured; `None` for that row
    /// itself and the rows before it.
    anchors: Vec<Option<usize>>,
    /// For each window's start row, the rows its start pose is estimated from and their
    /// weights ([`anchor_weights`]); empty for every other row. The measured pose and the
    /// simulated one are smoothed alike, so that a model replaying the recording exactly
    /// compares as equal: a start taken from the simulation's own sample would differ from
    /// the measured start's estimate wherever the path curves within the smoother's span
    /// (at a command's step), an error no noise model has and the keys would bend to.
    starts: Vec<Vec<(usize, f64)>>,
    /// The window, s.
    pub window_s: f64,
}

impl PoseWindows {
    /// The windows of `data`, where it has all three pose outputs.
    pub fn of(data: &Dataset) -> Option<PoseWindows> {
        let columns = [
            data.output_index(POSE[0])?,
            data.output_index(POSE[1])?,
            data.output_index(POSE[2])?,
        ];
        let span = data.t_s.last()? - data.t_s.first()?;
        let window_s = (WINDOW_SHARE * span).max(MIN_WINDOW_S);
        let measured = |k: usize| {
            columns
                .iter()
                .all(|&j| data.outputs[j][k].is_some_and(f64::is_finite))
        };
        let mut anchors = vec![None; data.len()];
        for seg in data.segments() {
            let t0 = data.t_s[seg.start];
            let mut block = usize::MAX;
            let mut anchor = None;
            for k in seg.clone() {
                let b = ((data.t_s[k] - t0) / window_s).floor() as usize;
                if b != block {
                    block = b;
                    anchor = None;
                }
                if anchor.is_none() && measured(k) {
                    anchor = Some(k);
                }
                anchors[k] = anchor.filter(|&a| a < k);
            }
        }
        let mut starts = vec![vec![]; data.len()];
        for seg in data.segments() {
            for &j in anchors[seg.clone()].iter().flatten() {
                if starts[j].is_empty() {
                    starts[j] = anchor_weights(&data.t_s, seg.clone(), j, &measured);
                }
            }
        }
        Some(PoseWindows {
            columns,
            anchors,
            starts,
            window_s,
        })
    }

    /// The dataset's output indices of `x_m`, `y_m` and `heading_rad`, compared over the
    /// windows.
    pub fn outputs(&self) -> [usize; 3] {
        self.columns
    }

    /// The window a row's pose is compared over, by its start row; `None` for a row
    /// without one.
    pub fn window_of(&self, row: usize) -> Option<usize> {
        self.anchors.get(row).copied().flatten()
    }

    /// The same windows for another dataset of the same rows whose outputs include the pose
    /// (in any order).
    pub fn for_dataset(&self, data: &Dataset) -> Option<PoseWindows> {
        Some(PoseWindows {
            columns: [
                data.output_index(POSE[0])?,
                data.output_index(POSE[1])?,
                data.output_index(POSE[2])?,
            ],
            anchors: self.anchors.clone(),
            starts: self.starts.clone(),
            window_s: self.window_s,
        })
    }

    /// The first `rows` rows of `measured` (a dataset made by [`PoseWindows::measured`]:
    /// the part effects are raced on) and their windows. A window whose start is
    /// estimated from samples beyond the part has none there, and its rows' pose cells are
    /// left out of the part: their motions, measured over the whole recording, cannot be
    /// replayed on the part alone.
    pub fn part(&self, measured: &Dataset, rows: usize) -> (PoseWindows, Dataset) {
        let windows = self.prefix(rows);
        let mut data = measured.prefix(rows);
        windows.forget_unwindowed(&mut data);
        (windows, data)
    }

    /// The windows of the first `rows` rows, without those whose start reaches beyond.
    fn prefix(&self, rows: usize) -> PoseWindows {
        let mut starts: Vec<Vec<(usize, f64)>> = self.starts.iter().take(rows).cloned().collect();
        let reaches_beyond = |w: &Vec<(usize, f64)>| w.iter().any(|&(k, _)| k >= rows);
        let anchors = self
            .anchors
            .iter()
            .take(rows)
            .map(|a| a.filter(|&j| !reaches_beyond(&starts[j])))
            .collect();
        for w in starts.iter_mut().filter(|w| reaches_beyond(w)) {
            w.clear();
        }
        PoseWindows {
            columns: self.columns,
            anchors,
            starts,
            window_s: self.window_s,
        }
    }

    /// `data`'s pose cells emptied where the row has no window.
    fn forget_unwindowed(&self, data: &mut Dataset) {
        for (k, a) in self.anchors.iter().enumerate() {
            if a.is_none() {
                for &j in &self.columns {
                    data.outputs[j][k] = None;
                }
            }
        }
    }

    /// The motion over each row's window, from a pose at every row (`pose[i][row]`, x, y,
    /// heading): forward and left of the window's start in its frame, m, and the turn
    /// since, rad; `None` for a row without a window. Each start is the weighted samples of
    /// [`anchor_weights`] (NaN where one of them is).
    fn motions(&self, pose: [&[f64]; 3]) -> Vec<Option<[f64; 3]>> {
        let starts: Vec<Option<[f64; 3]>> = self
            .starts
            .iter()
            .map(|weights| {
                (!weights.is_empty()).then(|| {
                    let mut a = [0.0; 3];
                    for &(k, w) in weights {
                        for i in 0..3 {
                            a[i] += w * pose[i].get(k).copied().unwrap_or(f64::NAN);
                        }
                    }
                    a
                })
            })
            .collect();
        (0..self.anchors.len())
            .map(|k| {
                let a = starts[self.anchors[k]?]?;
                Some(motion_from(a, [pose[0][k], pose[1][k], pose[2][k]]))
            })
            .collect()
    }

    /// `data` with its pose outputs as motions over their windows (empty where the row or
    /// its window's start is not measured, or the row has no window).
    ///
    /// A window's start is the tracker's estimate there from the samples around it
    /// ([`anchor_weights`]), not its one sample: that sample's heading noise would turn every
    /// motion of the window by the same angle, an error the noise model does not have and
    /// the fit would bend the machine's keys to follow.
    pub fn measured(&self, data: &Dataset) -> Dataset {
        let mut out = data.clone();
        let cells: Vec<Vec<f64>> = self
            .columns
            .iter()
            .map(|&j| {
                data.outputs[j]
                    .iter()
                    .map(|c| c.unwrap_or(f64::NAN))
                    .collect()
            })
            .collect();
        let motions = self.motions([&cells[0][..], &cells[1][..], &cells[2][..]]);
        for (k, moved) in motions.into_iter().enumerate() {
            let moved = moved.filter(|m| m.iter().all(|v| v.is_finite()));
            for (i, &j) in self.columns.iter().enumerate() {
                out.outputs[j][k] = moved.map(|m| m[i]);
            }
        }
        out
    }

    /// Simulated outputs `y` (`[output][row]`, the dataset's order) with the pose as
    /// motions over the windows (0 where a row has none: its measured cell is empty).
    pub fn simulated(&self, y: &mut [Vec<f64>]) {
        let [x, yy, h] = self.columns;
        let motions = self.motions([&y[x], &y[yy], &y[h]]);
        for (k, moved) in motions.into_iter().enumerate() {
            let moved = moved.unwrap_or([0.0; 3]);
            for (i, &j) in self.columns.iter().enumerate() {
                y[j][k] = moved[i];
            }
        }
    }
}

/// The motion from pose `a` to pose `b` (x, y, heading): forward and left in `a`'s frame,
/// m, and the turn, rad.
fn motion_from(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let (s, c) = a[2].sin_cos();
    [c * dx + s * dy, -s * dx + c * dy, b[2] - a[2]]
}

/// Half the span of samples a window's start pose is estimated from, s. A start's error
/// stays in every motion of its window (a heading off by δ turns them all by δ), so it
/// must be averaged far below one sample's: over 0.1 s either side, the calibrate proof's
/// clean base (a tracker of 2 mm and 5 mrad at 100 Hz) came out at 40.32 ± 0.03 kg of 40,
/// over 0.5 s at 39.95 ± 0.04. The measured and the simulated starts are smoothed alike,
/// so a quadratic that does not follow the motion over the span is no error in itself (an
/// exact replay compares as equal); a wider span only makes the start less local.
const ANCHOR_HALF_SPAN_S: f64 = 0.5;

/// Fewest samples a start pose is estimated from; with fewer (a slow tracker) the
/// sample itself is the start.
const ANCHOR_MIN_SAMPLES: usize = 7;

/// The weights of the samples a window's start pose at row `j` is estimated from: the
/// least-squares quadratic in time through the measured rows within
/// [`ANCHOR_HALF_SPAN_S`] of it in its segment, evaluated at row `j` (the tracker's
/// estimate there, its noise averaged down), each of x, y and the unwrapped heading the
/// same weighted sum of its samples. With fewer than [`ANCHOR_MIN_SAMPLES`] rows (a slow
/// tracker), the row itself.
fn anchor_weights(
    t: &[f64],
    seg: std::ops::Range<usize>,
    j: usize,
    measured: &dyn Fn(usize) -> bool,
) -> Vec<(usize, f64)> {
    let near: Vec<usize> = seg
        .filter(|&k| (t[k] - t[j]).abs() <= ANCHOR_HALF_SPAN_S && measured(k))
        .collect();
    if near.len() < ANCHOR_MIN_SAMPLES || !measured(j) {
        return vec![(j, 1.0)];
    }
    // Normal equations of y = c0 + c1 s + c2 s^2, s = (t - t_j) / half span (scaled so the
    // matrix is well conditioned); the value at row j is c0 = e0' M^-1 sum_k r_k y_k.
    let rows: Vec<nalgebra::Vector3<f64>> = near
        .iter()
        .map(|&k| {
            let s = (t[k] - t[j]) / ANCHOR_HALF_SPAN_S;
            nalgebra::Vector3::new(1.0, s, s * s)
        })
        .collect();
    let m: nalgebra::Matrix3<f64> = rows.iter().map(|r| r * r.transpose()).sum();
    let Some(inv) = m.try_inverse() else {
        return vec![(j, 1.0)];
    };
    let first = inv.row(0);
    near.iter()
        .zip(&rows)
        .map(|(&k, r)| (k, (first * r)[0]))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dataset(t: &[f64], pose: &[[f64; 3]]) -> Dataset {
        Dataset {
            name: "d".into(),
            t_s: t.to_vec(),
            input_names: vec![],
            inputs: vec![],
            output_names: POSE.iter().map(|s| s.to_string()).collect(),
            outputs: (0..3)
                .map(|i| pose.iter().map(|p| Some(p[i])).collect())
                .collect(),
            segment_starts: vec![0],
        }
    }

    /// A vehicle driving a circle of radius 1 m at 1 rad/s, its tracked pose offset and
    /// rotated (a tracker's frame): within every window the motion is the circle's chord
    /// from the window's start in the vehicle's own frame, whatever the frame and wherever
    /// on the circle.
    #[test]
    fn a_window_sees_the_motion_in_the_vehicles_own_frame() {
        // Sampled every 0.25 s: too few samples around a start to smooth it, so each
        // window starts at its first sample and the chord is exact.
        let t: Vec<f64> = (0..=40).map(|k| k as f64 * 0.25).collect();
        let (x0, y0, a): (f64, f64, f64) = (5.0, -3.0, 0.7);
        let pose: Vec<[f64; 3]> = t
            .iter()
            .map(|&t| {
                let (x, y) = (t.sin(), 1.0 - t.cos());
                let (s, c) = a.sin_cos();
                [x0 + c * x - s * y, y0 + s * x + c * y, a + t]
            })
            .collect();
        let d = dataset(&t, &pose);
        let w = PoseWindows::of(&d).unwrap();
        assert_eq!(w.window_s, MIN_WINDOW_S);
        let m = w.measured(&d);
        for k in 0..t.len() {
            // Windows of 2 s: rows 0-7, 8-15, ...; each window's first row has none.
            if k % 8 == 0 {
                assert_eq!(m.outputs[0][k], None, "{k}");
                continue;
            }
            let dt = t[k] - t[k - k % 8];
            // The chord of an arc of dt rad on a unit circle, in the frame at its start.
            let (fwd, left) = (dt.sin(), 1.0 - dt.cos());
            assert!((m.outputs[0][k].unwrap() - fwd).abs() < 1e-9, "{k}");
            assert!((m.outputs[1][k].unwrap() - left).abs() < 1e-9, "{k}");
            assert!((m.outputs[2][k].unwrap() - dt).abs() < 1e-9, "{k}");
        }
        // A simulation of the same motion from another start compares as equal.
        let mut y: Vec<Vec<f64>> = (0..3)
            .map(|i| pose.iter().map(|p| p[i] + [1.0, 2.0, 0.0][i]).collect())
            .collect();
        w.simulated(&mut y);
        for k in (0..t.len()).filter(|k| k % 8 != 0) {
            for i in 0..3 {
                assert!((y[i][k] - m.outputs[i][k].unwrap()).abs() < 1e-9);
            }
        }
    }

    /// A window's start is the tracker's pose there, its noise averaged: on a path
    /// accelerating from rest and turning, sampled at 200 Hz with +-5 mm and +-5 mrad of
    /// alternating noise, a start mid-way comes out within a fifth of one sample's error
    /// of the true pose, one at the segment's first row (samples on one side only)
    /// within a third.
    #[test]
    fn a_window_start_averages_the_trackers_noise() {
        let t: Vec<f64> = (0..400).map(|k| k as f64 * 0.005).collect();
        let truth = |t: f64| [0.4 * t * t, 0.05 * t * t * t, 0.3 * t * t];
        let noise = |k: usize| if k.is_multiple_of(2) { 1.0 } else { -1.0 };
        let cells: Vec<Vec<f64>> = (0..3)
            .map(|i| {
                let e = [0.005, 0.005, 0.005][i];
                t.iter()
                    .enumerate()
                    .map(|(k, &t)| truth(t)[i] + e * noise(k))
                    .collect()
            })
            .collect();
        for (j, share) in [(0, 1.0 / 3.0), (200, 0.2)] {
            let weights = anchor_weights(&t, 0..t.len(), j, &|_| true);
            let a: Vec<f64> = (0..3)
                .map(|i| weights.iter().map(|&(k, w)| w * cells[i][k]).sum())
                .collect();
            for i in 0..3 {
                let err = (a[i] - truth(t[j])[i]).abs();
                assert!(err < share * 0.005, "row {j}, pose {i}: off by {err}");
            }
        }
    }

    /// A replay that reproduces the recording exactly compares as equal, wherever the
    /// path curves within the smoother's span: at 200 Hz, a base that starts to turn and
    /// accelerate at a window's start (a command's step at t = 2 s). Its smoothed start
    /// differs from the sample there (the quadratic cannot follow the kink: 0.8 mm to the
    /// left after one row here), so a start taken from the simulation's
    /// own sample would leave a residual at the true keys, the same sign in every window
    /// that starts on a step: on the calibrate proof's clean base, noise-free, the keys
    /// came back 0.2 % off (39.92 kg for 40) instead of exact.
    #[test]
    fn an_exact_replay_compares_as_equal_where_the_path_kinks() {
        let t: Vec<f64> = (0..800).map(|k| k as f64 * 0.005).collect();
        let pose: Vec<[f64; 3]> = t
            .iter()
            .map(|&t| {
                let late = (t - 2.0).max(0.0);
                let heading = 2.0 * late * late;
                [
                    0.3 * t + 1.0 * late * late,
                    0.2 * late * late * late,
                    heading,
                ]
            })
            .collect();
        let d = dataset(&t, &pose);
        let w = PoseWindows::of(&d).unwrap();
        let m = w.measured(&d);
        let mut y: Vec<Vec<f64>> = (0..3)
            .map(|i| pose.iter().map(|p| p[i]).collect())
            .collect();
        let raw_start = pose[400];
        let smoothed = w.motions([&y[0], &y[1], &y[2]])[401].unwrap();
        let from_sample = motion_from(raw_start, pose[401]);
        let gap = (0..3)
            .map(|i| (smoothed[i] - from_sample[i]).abs())
            .fold(0.0, f64::max);
        assert!(
            gap > 1e-4,
            "the smoother follows the kink: {smoothed:?} against {from_sample:?}"
        );
        w.simulated(&mut y);
        for k in 0..t.len() {
            for i in 0..3 {
                let (a, b) = (m.outputs[i][k].unwrap_or(0.0), y[i][k]);
                assert!((a - b).abs() < 1e-12, "row {k}, pose {i}: {a} against {b}");
            }
        }
    }

    /// The recording's first part (where effects are raced) compares as the whole does:
    /// a replay of the part alone, exact, equals the measured motions of the part's rows,
    /// and the window whose start is smoothed over samples beyond the part is left out.
    #[test]
    fn a_first_part_compares_alike_without_the_samples_beyond_it() {
        let t: Vec<f64> = (0..800).map(|k| k as f64 * 0.005).collect();
        let pose: Vec<[f64; 3]> = t
            .iter()
            .map(|&t| [0.3 * t + 0.1 * t * t, 0.05 * t * t, 0.2 * t * t])
            .collect();
        let d = dataset(&t, &pose);
        let w = PoseWindows::of(&d).unwrap();
        let (windows, part) = w.part(&w.measured(&d), 410);
        // The window starting at row 400 (t = 2 s) is smoothed over rows up to 500.
        assert!(part.outputs[0][405].is_none() && part.outputs[0][399].is_some());
        let mut y: Vec<Vec<f64>> = (0..3)
            .map(|i| pose[..410].iter().map(|p| p[i]).collect())
            .collect();
        windows.simulated(&mut y);
        for k in 0..410 {
            for i in 0..3 {
                if let Some(m) = part.outputs[i][k] {
                    assert!((m - y[i][k]).abs() < 1e-12, "row {k}, pose {i}");
                }
            }
        }
    }
}
