//! Run metrics for summaries and sweeps, accumulated from snapshots as a run goes.

use super::Snapshot;

/// Tracking settles when the lateral error stays within this band, m.
pub const SETTLED_BAND_M: f64 = 0.010;

/// The summary of a run.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RunSummary {
    pub duration_s: f64,
    /// Distance travelled by the axle midpoint, m.
    pub distance_m: f64,
    /// Distance travelled until the lateral error last left the settled band; `None` if it
    /// never settled.
    pub settling_distance_m: Option<f64>,
    /// RMS lateral error after settling (whole run if it never settled), m.
    pub rms_lateral_error_m: f64,
    /// Peak |lateral error| after settling, m.
    pub peak_lateral_error_after_settling_m: f64,
    pub peak_abs_slip_ratio: f64,
    /// Share of the time either drive tyre was sliding (friction limit active).
    pub sliding_fraction: f64,
    /// Energy drawn from the battery, J.
    pub battery_energy_j: f64,
    pub final_lateral_error_m: f64,
    pub faults: Vec<String>,
    pub bumper_stop: bool,
}

/// Accumulates a [`RunSummary`] from snapshots taken every `dt`.
#[derive(Debug, Clone, Default)]
pub struct MetricsObserver {
    samples: Vec<(f64, f64)>,
    last_xy: Option<[f64; 2]>,
    distance_m: f64,
    peak_slip: f64,
    sliding_samples: usize,
    samples_n: usize,
    energy_j: f64,
    last_t: f64,
    faults: Vec<String>,
    bumper: bool,
}

impl MetricsObserver {
    pub fn observe(&mut self, s: &Snapshot) {
        let xy = [s.pose.x_m, s.pose.y_m];
        if let Some(l) = self.last_xy {
            self.distance_m += (xy[0] - l[0]).hypot(xy[1] - l[1]);
        }
        self.last_xy = Some(xy);
        let dt = s.t_s - self.last_t;
        self.last_t = s.t_s;
        self.samples.push((self.distance_m, s.lateral_error_m));
        self.samples_n += 1;
        for side in &s.sides {
            self.peak_slip = self.peak_slip.max(side.slip_ratio.abs());
        }
        if s.sides.iter().any(|x| x.sliding) {
            self.sliding_samples += 1;
        }
        self.energy_j += s.battery_v * s.battery_current_a * dt;
        if let Some(f) = s.dcmc_fault {
            if !self.faults.iter().any(|x| x == f) {
                self.faults.push(f.to_string());
            }
        }
        self.bumper |= s.bumper;
    }

    pub fn summary(&self) -> RunSummary {
        let settle_idx = self
            .samples
            .iter()
            .rposition(|(_, e)| e.abs() > SETTLED_BAND_M)
            .map(|i| i + 1)
            .unwrap_or(0);
        let settled = settle_idx < self.samples.len() && self.samples.len() - settle_idx >= 2;
        let tail = if settled {
            &self.samples[settle_idx..]
        } else {
            &self.samples[..]
        };
        let n = tail.len().max(1) as f64;
        let rms = (tail.iter().map(|(_, e)| e * e).sum::<f64>() / n).sqrt();
        let peak = tail.iter().map(|(_, e)| e.abs()).fold(0.0, f64::max);
        RunSummary {
            duration_s: self.last_t,
            distance_m: self.distance_m,
            settling_distance_m: settled
                .then(|| self.samples.get(settle_idx).map(|s| s.0).unwrap_or(0.0)),
            rms_lateral_error_m: rms,
            peak_lateral_error_after_settling_m: peak,
            peak_abs_slip_ratio: self.peak_slip,
            sliding_fraction: self.sliding_samples as f64 / self.samples_n.max(1) as f64,
            battery_energy_j: self.energy_j,
            final_lateral_error_m: self.samples.last().map(|s| s.1).unwrap_or(0.0),
            faults: self.faults.clone(),
            bumper_stop: self.bumper,
        }
    }
}
