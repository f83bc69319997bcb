//! The replay's start pose: the simulated path turned and shifted rigidly onto the
//! recording's, from the pose samples taken while the machine stands still.

use super::outputs::Channel;
use crate::record::channels as chan;
use crate::record::Recording;

/// Mean of the measured cells, if any.
pub(super) fn mean_of(cells: &[Option<f64>]) -> Option<f64> {
    let v: Vec<f64> = cells.iter().flatten().copied().collect();
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

/// Mean direction of the measured headings (through their sines and cosines, so that
/// samples either side of +-pi average correctly); a single sample is returned as it is.
pub(super) fn mean_heading(cells: &[Option<f64>]) -> Option<f64> {
    let v: Vec<f64> = cells.iter().flatten().copied().collect();
    match v.len() {
        0 => None,
        1 => Some(v[0]),
        _ => {
            let (s, c) = v
                .iter()
                .fold((0.0, 0.0), |(s, c), h| (s + h.sin(), c + h.cos()));
            Some(s.atan2(c))
        }
    }
}

/// Rows of rest at a segment's start from which its start pose is averaged well enough
/// (a tracker's noise over 20 samples is a fifth of one sample's); with fewer the start
/// pose is fitted over [`START_POSE_WINDOW_S`] instead ([`align_start_pose`]).
pub(super) const MIN_STILL_ROWS: usize = 20;

/// Span at a segment's start over which its start pose is fitted when the machine moves
/// from the first row, s: long enough to average the tracker's noise, short enough that
/// a model still being fitted stays close to the measurement.
const START_POSE_WINDOW_S: f64 = 0.25;

/// Fits the start pose of a segment that moves from its first row, where one noisy
/// sample would set it (a tracker's 5 mrad on the heading turns the whole replayed path,
/// and a fit bends the machine's keys to follow it). The floor is the same everywhere,
/// so a start pose off by a rotation and a shift moves the whole simulated path rigidly:
/// the heading is corrected by the mean measured-less-simulated heading over the window,
/// the path turned by it about its first point, then shifted by the mean position
/// difference. Outputs other than the pose are unchanged.
pub(super) fn align_start_pose(
    rec: &Recording,
    rows: std::ops::Range<usize>,
    chans: &[Channel],
    simulated: &mut [Vec<f64>],
) {
    let find = |name: &str| chans.iter().position(|c| c.name == name);
    let (Some(ix), Some(iy), Some(ih)) =
        (find(chan::X_M), find(chan::Y_M), find(chan::HEADING_RAD))
    else {
        return;
    };
    let (Some(mx), Some(my), Some(mh)) = (
        rec.column(chan::X_M),
        rec.column(chan::Y_M),
        rec.column(chan::HEADING_RAD),
    ) else {
        return;
    };
    let t0 = rec.t_s[rows.start];
    let window: Vec<usize> = (0..rows.len())
        .take_while(|&j| rec.t_s[rows.start + j] - t0 <= START_POSE_WINDOW_S)
        .filter(|&j| {
            let k = rows.start + j;
            mx[k].is_some() && my[k].is_some() && mh[k].is_some()
        })
        .collect();
    if window.len() < 2 {
        return;
    }
    let n = window.len() as f64;
    let (s, c) = window.iter().fold((0.0, 0.0), |(s, c), &j| {
        let d = mh[rows.start + j].unwrap() - simulated[ih][j];
        (s + d.sin(), c + d.cos())
    });
    let turn = s.atan2(c);
    let (x0, y0) = (simulated[ix][0], simulated[iy][0]);
    let (sin, cos) = turn.sin_cos();
    for j in 0..rows.len() {
        let (dx, dy) = (simulated[ix][j] - x0, simulated[iy][j] - y0);
        simulated[ix][j] = x0 + cos * dx - sin * dy;
        simulated[iy][j] = y0 + sin * dx + cos * dy;
        simulated[ih][j] += turn;
    }
    let shift = |m: &[Option<f64>], i: usize, sim: &[Vec<f64>]| {
        window
            .iter()
            .map(|&j| m[rows.start + j].unwrap() - sim[i][j])
            .sum::<f64>()
            / n
    };
    let (sx, sy) = (shift(mx, ix, simulated), shift(my, iy, simulated));
    for j in 0..rows.len() {
        simulated[ix][j] += sx;
        simulated[iy][j] += sy;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A path simulated from a start pose 0.02 rad and a few millimetres off (one noisy
    /// sample's) is turned and shifted back onto the measured one: after alignment it
    /// matches the measured path everywhere within a fraction of a millimetre, far
    /// beyond the window it was fitted on.
    #[test]
    fn a_start_pose_off_by_one_samples_noise_is_fitted_out_rigidly() {
        let n = 400;
        let t: Vec<f64> = (0..n).map(|k| k as f64 * 0.005).collect();
        let path = |t: f64| [t + 0.2 * t * t, 0.3 * t * t, 0.4 * t];
        let mut text = String::from("# agvsim-recording: 1\n# rig: vehicle\nt_s,left_voltage_V,right_voltage_V,x_m,y_m,heading_rad\n");
        for &t in &t {
            let p = path(t);
            text.push_str(&format!("{t},1,1,{},{},{}\n", p[0], p[1], p[2]));
        }
        let rec = Recording::parse(&text, std::path::Path::new("moving.csv")).unwrap();
        let chans: Vec<Channel> = ["x_m", "y_m", "heading_rad"]
            .iter()
            .map(|n| Channel {
                name: n.to_string(),
                read: |_| 0.0,
                rate_of: None,
            })
            .collect();
        // The simulated path: the measured one turned 0.02 rad and shifted by (3, -2) mm.
        let (turn, ox, oy) = (0.02_f64, 0.003, -0.002);
        let (s, c) = turn.sin_cos();
        let mut sim: Vec<Vec<f64>> = vec![vec![]; 3];
        for &t in &t {
            let p = path(t);
            sim[0].push(ox + c * p[0] - s * p[1]);
            sim[1].push(oy + s * p[0] + c * p[1]);
            sim[2].push(p[2] + turn);
        }
        align_start_pose(&rec, 0..n, &chans, &mut sim);
        for k in 0..n {
            let p = path(t[k]);
            for i in 0..3 {
                assert!(
                    (sim[i][k] - p[i]).abs() < 1e-9,
                    "row {k}, pose {i}: {} vs {}",
                    sim[i][k],
                    p[i]
                );
            }
        }
    }
}
