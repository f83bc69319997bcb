//! Limit cycles of the lateral error at the end of a run: a sustained swing, or what the
//! window shows instead (too small, dying away, or too short to call).

/// Smallest oscillation counted as a limit cycle: half peak-to-peak lateral error, m.
/// About the resolution of the thesis's pen traces (pen play 2 mm, wire straight to
/// +/-3 mm): anything smaller could not have been seen on its floor.
pub const LIMIT_CYCLE_MIN_AMPLITUDE_M: f64 = 0.002;

/// Share of the run, at its end, in which a limit cycle is looked for: the loop has had
/// the rest to settle from its start offset.
pub const LIMIT_CYCLE_TAIL_FRACTION: f64 = 0.4;

/// What the cycle window of a run shows when it holds no limit cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoCycle {
    /// Half the peak-to-peak lateral error over the window, m.
    pub swing_m: f64,
    /// The window's length, s.
    pub window_s: f64,
    /// Why the swing is not called a limit cycle.
    pub reason: NoCycleReason,
}

/// Why a window's swing is not a limit cycle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NoCycleReason {
    /// Smaller than [`LIMIT_CYCLE_MIN_AMPLITUDE_M`].
    Small,
    /// Dying away: the window's later half swings less than half as far as its earlier.
    Decaying,
    /// Large and not decaying, but fewer than two full periods fit in the window: too
    /// short to tell a limit cycle from a slow transient.
    TooShort,
    /// Too few samples in the window (a run that left the wire almost at once).
    NoWindow,
}

/// A sustained oscillation of the lateral error at the end of a run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LimitCycle {
    /// Half the peak-to-peak lateral error, m.
    pub amplitude_m: f64,
    /// Mean period between like zero crossings, s.
    pub period_s: f64,
}

/// A sustained oscillation in `(t_s, e_m)` samples: at least two full periods about the
/// mean (crossings counted with a hysteresis of a quarter of the amplitude, so noise does
/// not count), an amplitude of at least [`LIMIT_CYCLE_MIN_AMPLITUDE_M`], and no decay
/// (the later half of the window swings at least half as far as the earlier half: a loop
/// still ringing down from its start is not cycling).
pub fn limit_cycle(samples: &[(f64, f64)]) -> Option<LimitCycle> {
    classify_cycle(samples).ok()
}

/// The limit cycle in `(t_s, e_m)` samples ([`limit_cycle`]), or what the window shows
/// instead: its swing, its length and why the swing is not a limit cycle.
pub fn classify_cycle(samples: &[(f64, f64)]) -> Result<LimitCycle, NoCycle> {
    let window_s = match (samples.first(), samples.last()) {
        (Some(a), Some(b)) => b.0 - a.0,
        _ => 0.0,
    };
    let no = |swing_m: f64, reason| NoCycle {
        swing_m,
        window_s,
        reason,
    };
    if samples.len() < 8 {
        return Err(no(0.0, NoCycleReason::NoWindow));
    }
    let mean = samples.iter().map(|s| s.1).sum::<f64>() / samples.len() as f64;
    let p2p = |w: &[(f64, f64)]| {
        let (lo, hi) = w
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), s| {
                (lo.min(s.1), hi.max(s.1))
            });
        hi - lo
    };
    let amplitude = 0.5 * p2p(samples);
    if !(amplitude >= LIMIT_CYCLE_MIN_AMPLITUDE_M) {
        return Err(no(amplitude, NoCycleReason::Small));
    }
    let mid = samples.len() / 2;
    if p2p(&samples[mid..]) < 0.5 * p2p(&samples[..mid]) {
        return Err(no(amplitude, NoCycleReason::Decaying));
    }
    // Upward crossings of the mean, with hysteresis.
    let band = 0.25 * amplitude;
    let mut below = samples[0].1 - mean < -band;
    let mut ups = Vec::new();
    for &(t, e) in samples {
        let d = e - mean;
        if below && d > band {
            ups.push(t);
            below = false;
        } else if !below && d < -band {
            below = true;
        }
    }
    if ups.len() < 3 {
        return Err(no(amplitude, NoCycleReason::TooShort));
    }
    let period_s = (ups[ups.len() - 1] - ups[0]) / (ups.len() - 1) as f64;
    Ok(LimitCycle {
        amplitude_m: amplitude,
        period_s,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sine(amp: f64, period: f64, decay_per_s: f64) -> Vec<(f64, f64)> {
        (0..800)
            .map(|k| {
                let t = k as f64 * 0.01;
                (
                    t,
                    0.003
                        + amp
                            * (-decay_per_s * t).exp()
                            * (std::f64::consts::TAU * t / period).sin(),
                )
            })
            .collect()
    }

    #[test]
    fn a_steady_oscillation_is_a_limit_cycle_with_its_amplitude_and_period() {
        let c = limit_cycle(&sine(0.01, 1.3, 0.0)).expect("cycle");
        assert!((c.amplitude_m - 0.01).abs() < 1e-4, "{c:?}");
        // Crossings are found to the sample (10 ms) over 5 periods: a few ms of error.
        assert!((c.period_s - 1.3).abs() < 0.01, "{c:?}");
    }

    #[test]
    fn a_window_without_a_cycle_says_what_it_shows() {
        let why = |v: &[(f64, f64)]| classify_cycle(v).unwrap_err();
        // Ringing down: the swing is reported with the decay as the reason.
        let d = why(&sine(0.02, 1.0, 0.5));
        assert_eq!(d.reason, NoCycleReason::Decaying);
        assert!(d.swing_m > 0.01, "{d:?}");
        // 1 mm: under the 2 mm a cycle needs.
        let s = why(&sine(0.001, 1.0, 0.0));
        assert_eq!(s.reason, NoCycleReason::Small);
        assert!((s.swing_m - 0.001).abs() < 1e-4, "{s:?}");
        // A steady 60 mm swing with a 5 s period in an 8 s window: fewer than two periods,
        // too short to call, its swing given.
        let t = why(&sine(0.06, 5.0, 0.0));
        assert_eq!(t.reason, NoCycleReason::TooShort);
        assert!(
            (t.swing_m - 0.06).abs() < 1e-3 && (t.window_s - 7.99).abs() < 1e-9,
            "{t:?}"
        );
    }

    #[test]
    fn ringing_down_small_or_slow_swings_are_not_limit_cycles() {
        // Decays by e over 2 s: the later half swings far less than the earlier half.
        assert!(limit_cycle(&sine(0.02, 1.0, 0.5)).is_none());
        assert!(limit_cycle(&sine(0.001, 1.0, 0.0)).is_none());
        // One drift, not two full periods in 8 s.
        assert!(limit_cycle(&sine(0.02, 10.0, 0.0)).is_none());
    }
}
