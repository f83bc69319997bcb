//! A scene's `[expect]` table: what a run of the scene as written shows, in the terms of
//! the run summary. `agvsim run` checks it after the run, and the test suite runs every
//! shipped scene against it, so a scene's description cannot drift from what it does.

use serde::{Deserialize, Serialize};

use super::Invalid;

/// Expected outcome of a run of the scene as written (no overrides). Every key is
/// optional; an empty table claims nothing. Bands are `[min, max]`, both included.
#[derive(Debug, Clone, Deserialize, Serialize, Default, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct ExpectSpec {
    /// The lateral error settles (stays within the 10 mm band for at least a fifth of the
    /// run, on the wire) or does not.
    pub settles: Option<bool>,
    /// Band for the RMS lateral error over the summary's stated window, mm.
    pub rms_error_mm: Option<[f64; 2]>,
    /// A sustained limit cycle at the end of the run (on the wire), or none.
    pub limit_cycle: Option<bool>,
    /// Band for the limit cycle's amplitude (half peak-to-peak), mm; implies a cycle.
    pub limit_cycle_mm: Option<[f64; 2]>,
    /// The sensors lose the wire at some point, or never.
    pub loses_wire: Option<bool>,
    /// The sensors are over the wire when the run ends.
    pub on_wire_at_end: Option<bool>,
    /// Band for how many times the sensors lose the wire.
    pub wire_losses: Option<[u32; 2]>,
    /// The axle passes the far end of an open wire, or never.
    pub reaches_wire_end: Option<bool>,
    /// The bumper stops the vehicle on an obstacle, or never.
    pub bumper_stop: Option<bool>,
    /// Band for the share of the slip window (second half of the time on the wire,
    /// see [`crate::sim::metrics::SlipWindow`]) in which a drive tyre slides, %.
    pub sliding_pct: Option<[f64; 2]>,
    /// Band for the distance the axle midpoint travels, m.
    pub distance_m: Option<[f64; 2]>,
}

impl ExpectSpec {
    /// What the `[expect]` table takes.
    pub fn takes() -> String {
        "`[expect]`: what a run of the scene shows (`settles`, `rms_error_mm`, `limit_cycle`, `limit_cycle_mm`, `loses_wire`, `on_wire_at_end`, `wire_losses`, `reaches_wire_end`, `bumper_stop`, `sliding_pct`, `distance_m`; ranges as `[lo, hi]`), checked by `run` and the tests".into()
    }

    /// True when the table claims nothing.
    pub fn is_empty(&self) -> bool {
        *self == ExpectSpec::default()
    }

    /// Each band must be finite with `min <= max`.
    pub fn validate(&self) -> Result<(), Invalid> {
        let bands = [
            ("expect.rms_error_mm", self.rms_error_mm),
            ("expect.limit_cycle_mm", self.limit_cycle_mm),
            ("expect.sliding_pct", self.sliding_pct),
            ("expect.distance_m", self.distance_m),
        ];
        for (key, band) in bands {
            if let Some([lo, hi]) = band {
                if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
                    return Err(Invalid {
                        key: key.into(),
                        value: format!("[{lo}, {hi}]"),
                        expected: "a band [min, max] of finite numbers with min <= max".into(),
                    });
                }
            }
        }
        if let Some([lo, hi]) = self.wire_losses {
            if lo > hi {
                return Err(Invalid {
                    key: "expect.wire_losses".into(),
                    value: format!("[{lo}, {hi}]"),
                    expected: "a band [min, max] with min <= max".into(),
                });
            }
        }
        if self.limit_cycle == Some(false) && self.limit_cycle_mm.is_some() {
            return Err(Invalid {
                key: "expect.limit_cycle_mm".into(),
                value: "given".into(),
                expected: "no amplitude band when `expect.limit_cycle = false`".into(),
            });
        }
        Ok(())
    }
}
