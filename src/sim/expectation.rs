//! Checks a run's summary against its scene's `[expect]` table: one line per claim, with
//! what the run showed.

use super::metrics::RunSummary;
use crate::scene::ExpectSpec;

/// One claim of an `[expect]` table against the run.
#[derive(Debug, Clone, PartialEq)]
pub struct ExpectCheck {
    /// The claim, in words ("settles", "limit cycle 20-60 mm").
    pub claim: String,
    /// What the run showed, in the same terms.
    pub observed: String,
    /// Whether the run shows it.
    pub met: bool,
}

fn in_band(v: f64, [lo, hi]: [f64; 2]) -> bool {
    v >= lo && v <= hi
}

fn yes_no(b: bool) -> &'static str {
    if b {
        "yes"
    } else {
        "no"
    }
}

/// Every claim the table makes, checked against `s`, in the table's key order.
pub fn check(e: &ExpectSpec, s: &RunSummary) -> Vec<ExpectCheck> {
    let mut out = Vec::new();
    let mut flag = |what: &str, want: Option<bool>, got: bool| {
        if let Some(w) = want {
            out.push(ExpectCheck {
                claim: format!("{what}: {}", yes_no(w)),
                observed: yes_no(got).into(),
                met: w == got,
            });
        }
    };
    flag("settles", e.settles, s.settling_distance_m.is_some());
    flag(
        "limit cycle",
        e.limit_cycle.or(e.limit_cycle_mm.map(|_| true)),
        s.limit_cycle.is_some(),
    );
    flag("loses the wire", e.loses_wire, s.lost_wire);
    flag(
        "on the wire at the end",
        e.on_wire_at_end,
        !s.off_wire_at_end,
    );
    flag(
        "reaches the wire's end",
        e.reaches_wire_end,
        s.wire_end.is_some(),
    );
    flag("bumper stop", e.bumper_stop, s.bumper_stop);
    let mut band = |what: &str, unit: &str, want: Option<[f64; 2]>, got: Option<f64>| {
        if let Some(b) = want {
            // As many decimals as the band's width needs, at least one.
            let decimals =
                (-(b[1] - b[0]).max(1e-9).log10().floor() + 1.0).clamp(1.0, 6.0) as usize;
            out.push(ExpectCheck {
                claim: format!("{what} {}-{} {unit}", b[0], b[1]),
                observed: got.map_or("none".into(), |v| format!("{v:.decimals$} {unit}")),
                met: got.is_some_and(|v| in_band(v, b)),
            });
        }
    };
    band(
        &format!("RMS error ({})", s.error_window.describe()),
        "mm",
        e.rms_error_mm,
        Some(1000.0 * s.rms_lateral_error_m),
    );
    band(
        "limit-cycle amplitude",
        "mm",
        e.limit_cycle_mm,
        s.limit_cycle.map(|c| 1000.0 * c.amplitude_m),
    );
    band(
        "sliding",
        "% of the slip window",
        e.sliding_pct,
        Some(100.0 * s.sliding_fraction),
    );
    band("distance", "m", e.distance_m, Some(s.distance_m));
    if let Some([lo, hi]) = e.wire_losses {
        out.push(ExpectCheck {
            claim: if lo == hi {
                format!("wire lost {lo} times")
            } else {
                format!("wire lost {lo}-{hi} times")
            },
            observed: format!("{} times", s.wire_losses),
            met: (lo..=hi).contains(&s.wire_losses),
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::metrics::LimitCycle;

    #[test]
    fn each_claim_is_met_or_not_by_the_summary() {
        let s = RunSummary {
            rms_lateral_error_m: 0.020,
            limit_cycle: Some(LimitCycle {
                amplitude_m: 0.030,
                period_s: 1.1,
            }),
            ..RunSummary::default()
        };
        let e = ExpectSpec {
            settles: Some(false),
            limit_cycle_mm: Some([20.0, 40.0]),
            rms_error_mm: Some([0.0, 10.0]),
            loses_wire: Some(false),
            ..ExpectSpec::default()
        };
        let c = check(&e, &s);
        let met: Vec<bool> = c.iter().map(|c| c.met).collect();
        // settles no, cycle yes, not lost, cycle 30 mm in band; RMS 20 mm is out of band.
        assert_eq!(met, [true, true, true, false, true], "{c:#?}");
        assert!(check(&ExpectSpec::default(), &s).is_empty());
    }
}
