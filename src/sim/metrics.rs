//! Run metrics for summaries and sweeps, accumulated from snapshots as a run goes.

use super::Snapshot;

pub use super::cycle::{
    classify_cycle, limit_cycle, LimitCycle, NoCycle, NoCycleReason, LIMIT_CYCLE_MIN_AMPLITUDE_M,
    LIMIT_CYCLE_TAIL_FRACTION,
};
pub use super::summary::{
    ErrorWindow, Motion, RunEvent, RunSummary, SlidingByMotion, SlipWindow, WheelMotion,
    NEAR_REST_M_S,
};
use crate::model::chassis::wrap_angle;

/// Tracking settles when the lateral error stays within this band, m.
pub const SETTLED_BAND_M: f64 = 0.010;

/// A run has settled if its error then stays in the band for at least this share of the
/// run.
pub const SETTLED_MIN_SHARE: f64 = 0.2;

#[derive(Debug, Clone, Copy)]
struct Sample {
    t_s: f64,
    distance_m: f64,
    lateral_error_m: f64,
}

/// Accumulates a [`RunSummary`] from snapshots taken at regular intervals.
#[derive(Debug, Clone, Default)]
pub struct MetricsObserver {
    /// No wire to follow (a velocity-commanded base): the coils' losing it means nothing.
    wireless: bool,
    motion: Motion,
    samples: Vec<Sample>,
    last_xy: Option<[f64; 2]>,
    distance_m: f64,
    /// The drive tyres' slip at each sample.
    slip: Vec<SlipSample>,
    energy_j: f64,
    last_t: f64,
    /// (time, mean squared swivel rate over the castors) per interval.
    swivel_rate_sq: Vec<(f64, f64)>,
    last_swivel: Vec<f64>,
    faults: Vec<String>,
    lost_wire: bool,
    wire_lost: Option<RunEvent>,
    wire_losses: u32,
    off_wire_now: bool,
    wire_end: Option<RunEvent>,
    wheels_lifted: bool,
    bumper: bool,
    bumper_at: Option<RunEvent>,
}

/// The drive tyres' slip at one sample.
#[derive(Debug, Clone, Copy)]
struct SlipSample {
    /// Time, s.
    t_s: f64,
    /// The larger |slip ratio| of the two sides.
    peak: f64,
    /// The mean |slip ratio| of the two sides.
    mean: f64,
    /// Either tyre on its friction limit.
    sliding: bool,
    /// What the wheels were doing.
    motion: WheelMotion,
}

/// The sliding samples of a window split by what the wheels were doing, as shares of it.
fn sliding_by_motion(late: &[&SlipSample]) -> SlidingByMotion {
    let n = late.len().max(1) as f64;
    let mut out = SlidingByMotion::default();
    for x in late.iter().filter(|x| x.sliding) {
        let share = match x.motion {
            WheelMotion::Driving => &mut out.moving,
            WheelMotion::TurningOnTheSpot => &mut out.turning_on_spot,
            WheelMotion::NearRest => &mut out.near_rest,
        };
        *share += 1.0 / n;
    }
    out
}

impl MetricsObserver {
    /// The measures of a run with no wire to follow: a wire lost or ended is no event.
    pub fn wireless() -> MetricsObserver {
        MetricsObserver {
            wireless: true,
            ..MetricsObserver::default()
        }
    }

    /// Takes one snapshot into the measures.
    pub fn observe(&mut self, s: &Snapshot) {
        self.motion.observe(s, s.t_s - self.last_t);
        let xy = [s.pose.x_m, s.pose.y_m];
        if let Some(l) = self.last_xy {
            self.distance_m += (xy[0] - l[0]).hypot(xy[1] - l[1]);
        }
        self.last_xy = Some(xy);
        let dt = s.t_s - self.last_t;
        self.last_t = s.t_s;
        self.samples.push(Sample {
            t_s: s.t_s,
            distance_m: self.distance_m,
            lateral_error_m: s.lateral_error_m,
        });
        let [l, r] = [s.sides[0].slip_ratio.abs(), s.sides[1].slip_ratio.abs()];
        self.slip.push(SlipSample {
            t_s: s.t_s,
            peak: l.max(r),
            mean: 0.5 * (l + r),
            sliding: s.sides.iter().any(|x| x.sliding),
            motion: WheelMotion::of([s.sides[0].wheel_rim_m_s, s.sides[1].wheel_rim_m_s]),
        });
        self.energy_j += s.battery_v * s.battery_current_a * dt;
        if !s.castors.is_empty() {
            if self.last_swivel.len() == s.castors.len() && dt > 0.0 {
                let mean_sq = s
                    .castors
                    .iter()
                    .zip(&self.last_swivel)
                    .map(|(c, last)| {
                        let rate = wrap_angle(c.swivel_rad - last) / dt;
                        rate * rate
                    })
                    .sum::<f64>()
                    / s.castors.len() as f64;
                self.swivel_rate_sq.push((s.t_s, mean_sq));
            }
            self.last_swivel = s.castors.iter().map(|c| c.swivel_rad).collect();
        }
        if let Some(f) = s.dcmc_fault {
            if !self.faults.iter().any(|x| x == f) {
                self.faults.push(f.to_string());
            }
        }
        let event = RunEvent {
            t_s: s.t_s,
            distance_m: self.distance_m,
            at_m: xy,
        };
        let (lost_wire, past_wire_end) = if self.wireless {
            (false, false)
        } else {
            (s.lost_wire, s.past_wire_end)
        };
        if lost_wire && self.wire_lost.is_none() {
            self.wire_lost = Some(event);
        }
        if past_wire_end && self.wire_end.is_none() {
            self.wire_end = Some(event);
        }
        if s.bumper && self.bumper_at.is_none() {
            self.bumper_at = Some(event);
        }
        if lost_wire && !self.off_wire_now {
            self.wire_losses += 1;
        }
        self.off_wire_now = lost_wire;
        self.wheels_lifted = s.wheels_lifted;
        self.lost_wire |= lost_wire;
        self.bumper |= s.bumper;
    }

    /// Where the run settled (the first sample of its last stay in the band), if it did:
    /// never once the wire was lost or ended, and only if it then stays in the band for a
    /// real stretch (a cycle that leaves the band once a period would otherwise "settle"
    /// after its last swing).
    fn settled_at(&self, event_t: f64) -> Option<usize> {
        let settle_idx = self
            .samples
            .iter()
            .rposition(|s| s.lateral_error_m.abs() > SETTLED_BAND_M)
            .map(|i| i + 1)
            .unwrap_or(0);
        let settled = event_t.is_infinite()
            && settle_idx < self.samples.len()
            && self.samples.len() - settle_idx >= 2
            && self.last_t - self.samples[settle_idx].t_s >= SETTLED_MIN_SHARE * self.last_t;
        settled.then_some(settle_idx)
    }

    /// RMS swivel rate of the castors over the run's second half, rad/s.
    fn castor_shimmy_rad_s(&self) -> f64 {
        let half = 0.5 * self.last_t;
        let shimmy: Vec<f64> = self
            .swivel_rate_sq
            .iter()
            .filter(|(t, _)| *t >= half)
            .map(|(_, v)| *v)
            .collect();
        if shimmy.is_empty() {
            0.0
        } else {
            (shimmy.iter().sum::<f64>() / shimmy.len() as f64).sqrt()
        }
    }

    /// The measures so far.
    pub fn summary(&self) -> RunSummary {
        let motion = self.motion;
        // Tracking is judged only while there is a wire under the sensors: after the wire
        // is lost or ends, the "lateral error" measures distance from it, not tracking.
        let event_t = [self.wire_lost, self.wire_end]
            .iter()
            .flatten()
            .map(|e| e.t_s)
            .fold(f64::INFINITY, f64::min);
        // What ended the time on the wire, if anything: the wire lost (first) or its end.
        let lost_first = event_t
            .is_finite()
            .then(|| self.wire_lost.is_some_and(|e| e.t_s <= event_t));
        let on_wire_n = self.samples.partition_point(|s| s.t_s < event_t);
        let on_wire = &self.samples[..on_wire_n];
        let settled_at = self.settled_at(event_t);
        let (window, error_window) = if let Some(i) = settled_at {
            (&self.samples[i..], ErrorWindow::AfterSettling)
        } else if let Some(lost_first) = lost_first {
            let w = if lost_first {
                ErrorWindow::UntilWireLost
            } else {
                ErrorWindow::UntilWireEnd
            };
            (on_wire, w)
        } else {
            (&self.samples[..], ErrorWindow::WholeRun)
        };
        let n = window.len().max(1) as f64;
        let rms = (window
            .iter()
            .map(|s| s.lateral_error_m.powi(2))
            .sum::<f64>()
            / n)
            .sqrt();
        let peak = window
            .iter()
            .map(|s| s.lateral_error_m.abs())
            .fold(0.0, f64::max);
        let slip_window = match lost_first {
            None => SlipWindow::SecondHalf,
            Some(true) => SlipWindow::SecondHalfUntilWireLost,
            Some(false) => SlipWindow::SecondHalfUntilWireEnd,
        };
        // The second half of the time on the wire (of the whole run when it stayed on).
        let slip_from_t = 0.5 * event_t.min(self.last_t);
        let late_slip: Vec<&SlipSample> = self
            .slip
            .iter()
            .filter(|x| x.t_s >= slip_from_t && x.t_s < event_t)
            .collect();
        let late_n = late_slip.len().max(1) as f64;
        let cycle_end_t = on_wire.last().map_or(0.0, |s| s.t_s);
        let tail_start = (1.0 - LIMIT_CYCLE_TAIL_FRACTION) * cycle_end_t;
        let cycle_tail: Vec<(f64, f64)> = on_wire
            .iter()
            .filter(|s| s.t_s >= tail_start)
            .map(|s| (s.t_s, s.lateral_error_m))
            .collect();
        let cycle = (!self.wheels_lifted).then(|| classify_cycle(&cycle_tail));
        RunSummary {
            motion,
            duration_s: self.last_t,
            distance_m: self.distance_m,
            settling_distance_m: settled_at
                .map(|i| self.samples.get(i).map(|s| s.distance_m).unwrap_or(0.0)),
            rms_lateral_error_m: rms,
            peak_lateral_error_m: peak,
            error_window,
            limit_cycle: cycle.and_then(Result::ok),
            no_cycle: cycle.and_then(Result::err),
            peak_abs_slip_ratio: late_slip.iter().map(|x| x.peak).fold(0.0, f64::max),
            mean_abs_slip_ratio: late_slip.iter().map(|x| x.mean).sum::<f64>() / late_n,
            sliding_fraction: late_slip.iter().filter(|x| x.sliding).count() as f64 / late_n,
            sliding_by_motion: sliding_by_motion(&late_slip),
            peak_slip_motion: late_slip
                .iter()
                .max_by(|a, b| a.peak.total_cmp(&b.peak))
                .map_or(WheelMotion::NearRest, |x| x.motion),
            slip_window,
            battery_energy_j: self.energy_j,
            castor_shimmy_rad_s: self.castor_shimmy_rad_s(),
            final_lateral_error_m: self
                .samples
                .last()
                .map(|s| s.lateral_error_m)
                .unwrap_or(0.0),
            lost_wire: self.lost_wire,
            wire_lost: self.wire_lost,
            wire_losses: self.wire_losses,
            off_wire_at_end: self.off_wire_now,
            wire_end: self.wire_end,
            wheels_lifted: self.wheels_lifted,
            faults: self.faults.clone(),
            bumper_stop: self.bumper,
            bumper_at: self.bumper_at,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sliding is split by what the wheels do: opposite ways is turning on the spot, both
    /// slow is starting or stopping, else driving; the shares add up to the fraction.
    #[test]
    fn sliding_is_split_by_what_the_wheels_were_doing() {
        assert_eq!(WheelMotion::of([-0.1, 0.1]), WheelMotion::TurningOnTheSpot);
        assert_eq!(WheelMotion::of([0.01, -0.015]), WheelMotion::NearRest);
        assert_eq!(WheelMotion::of([0.3, 0.25]), WheelMotion::Driving);
        assert_eq!(WheelMotion::of([-0.1, 0.01]), WheelMotion::Driving);
        let mut m = MetricsObserver::wireless();
        for k in 0..=400 {
            let t_s = k as f64 * 0.01;
            let mut s = Snapshot {
                t_s,
                ..Snapshot::default()
            };
            // Second half: 1 s turning on the spot and sliding, then 1 s driving, gripping.
            let turning = t_s < 3.0;
            s.sides[0].wheel_rim_m_s = if turning { -0.1 } else { 0.3 };
            s.sides[1].wheel_rim_m_s = if turning { 0.1 } else { 0.3 };
            for side in &mut s.sides {
                side.sliding = turning;
                side.slip_ratio = if turning { 1.5 } else { 0.01 };
            }
            m.observe(&s);
        }
        let r = m.summary();
        let b = r.sliding_by_motion;
        assert!((b.turning_on_spot - 0.5).abs() < 0.02, "{b:?}");
        assert_eq!(b.moving + b.near_rest, 0.0);
        assert!((r.sliding_fraction - b.turning_on_spot).abs() < 1e-12);
        assert_eq!(r.peak_slip_motion, WheelMotion::TurningOnTheSpot);
    }

    /// A run of 10 s whose tyres grip (slip 0.02) while on the wire, then spin freely
    /// (slip 0.9, sliding) once the wire is lost at `lost_at_s`.
    fn run_losing_wire_at(lost_at_s: f64) -> RunSummary {
        let mut m = MetricsObserver::default();
        for k in 0..=1000 {
            let t_s = k as f64 * 0.01;
            let lost = t_s >= lost_at_s;
            let mut s = Snapshot {
                t_s,
                lost_wire: lost,
                ..Snapshot::default()
            };
            for side in &mut s.sides {
                side.slip_ratio = if lost { 0.9 } else { 0.02 };
                side.sliding = lost;
            }
            m.observe(&s);
        }
        m.summary()
    }

    #[test]
    fn slip_figures_cover_the_second_half_of_the_time_on_the_wire() {
        // Lost at 6 s: the window is 3 s to 6 s, where the tyres gripped.
        let s = run_losing_wire_at(6.0);
        assert_eq!(s.slip_window, SlipWindow::SecondHalfUntilWireLost);
        assert!((s.peak_abs_slip_ratio - 0.02).abs() < 1e-12, "{s:?}");
        assert_eq!(s.sliding_fraction, 0.0);
        // Never lost: the second half of the run, gripping throughout.
        let s = run_losing_wire_at(f64::INFINITY);
        assert_eq!(s.slip_window, SlipWindow::SecondHalf);
        assert!((s.mean_abs_slip_ratio - 0.02).abs() < 1e-12);
    }
}
