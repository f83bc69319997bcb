//! How often the proof's printed intervals hold the machine's value: per kind and key,
//! the realised share within 1 and 1.96 standard deviations (the nominal 68.3 % and 95 %
//! intervals) with its Monte Carlo error.

use std::fmt::Write as _;

use super::Outcome;

/// Share of the fitted keys whose 1-sigma interval holds the machine's value, and how many
/// keys were counted.
pub fn coverage(outcomes: &[Outcome]) -> (f64, usize) {
    let judged: Vec<bool> = outcomes
        .iter()
        .flat_map(|o| o.keys.iter())
        .filter(|k| !k.conditional)
        .filter_map(|k| k.std.map(|s| (k.calibrated - k.truth).abs() <= s))
        .collect();
    let n = judged.len();
    let covered = judged.iter().filter(|&&c| c).count();
    (covered as f64 / n.max(1) as f64, n)
}

/// Realised coverage of the printed intervals over round trips, for one key of one kind
/// (or `all keys` of it): how many fitted values had a standard deviation, and how many
/// of those held the machine's value within 1 and within 1.96 of it (the nominal 68.3 %
/// and 95 % intervals).
#[derive(Debug, Clone, PartialEq)]
pub struct CoverageRow {
    /// The kind's name.
    pub kind: &'static str,
    /// The scene key, or `all keys`.
    pub key: String,
    /// Fitted values with a standard deviation.
    pub n: usize,
    /// Of them, within one standard deviation of the truth.
    pub within_68: usize,
    /// Of them, within 1.96 standard deviations.
    pub within_95: usize,
}

impl CoverageRow {
    /// The realised share within `k` of `n`, and its Monte Carlo standard error
    /// `sqrt(p (1 - p) / n)` (a binomial share's).
    pub fn share(&self, k: usize) -> (f64, f64) {
        let n = self.n.max(1) as f64;
        let p = k as f64 / n;
        (p, (p * (1.0 - p) / n).sqrt())
    }
}

/// The coverage of every fitted key's interval in `outcomes`, by kind: one row per key,
/// then `all keys` of the kind.
pub fn coverage_table(outcomes: &[Outcome]) -> Vec<CoverageRow> {
    let mut rows: Vec<CoverageRow> = vec![];
    let mut add = |kind: &'static str, key: &str, z: f64| {
        let at = match rows.iter().position(|r| r.kind == kind && r.key == key) {
            Some(i) => i,
            None => {
                rows.push(CoverageRow {
                    kind,
                    key: key.to_string(),
                    n: 0,
                    within_68: 0,
                    within_95: 0,
                });
                rows.len() - 1
            }
        };
        let r = &mut rows[at];
        r.n += 1;
        r.within_68 += usize::from(z <= 1.0);
        r.within_95 += usize::from(z <= 1.96);
    };
    for o in outcomes {
        let kind = o.case.kind.name();
        for k in o.keys.iter().filter(|k| !k.conditional) {
            if let Some(z) = k.z().map(f64::abs) {
                add(kind, &k.key, z);
                add(kind, ALL_KEYS, z);
            }
        }
    }
    // Each kind's keys, then its total.
    rows.sort_by(|a, b| (a.kind, a.key == ALL_KEYS).cmp(&(b.kind, b.key == ALL_KEYS)));
    rows
}

const ALL_KEYS: &str = "all keys";

/// [`coverage_table`] as text: nominal and realised coverage with the Monte Carlo error.
pub fn render_coverage(rows: &[CoverageRow]) -> String {
    let mut s = format!(
        "{:<16} {:<34} {:>5}  {:>22}  {:>22}\n",
        "kind", "key", "n", "68.3 % nominal: real", "95 % nominal: real"
    );
    for r in rows {
        let cell = |k: usize| {
            let (p, e) = r.share(k);
            format!("{:.1} ± {:.1} %", 100.0 * p, 100.0 * e)
        };
        let _ = writeln!(
            s,
            "{:<16} {:<34} {:>5}  {:>22}  {:>22}",
            r.kind,
            r.key,
            r.n,
            cell(r.within_68),
            cell(r.within_95)
        );
    }
    s
}

/// Every fitted key of every round trip, a row each: the case, its seed, the key, the
/// machine's value, the calibrated value, its standard deviation (empty where the fit gave
/// none), `z`, the error in standard deviations, and whether the interval was said to hold
/// only given a held key (the coverage table's input, for a reader who wants to see which
/// keys miss and by how much).
pub fn coverage_csv(outcomes: &[Outcome]) -> String {
    let mut s = String::from("case,seed,key,truth,calibrated,std,z,conditional_on_held\n");
    for o in outcomes {
        for k in &o.keys {
            let z = k.z().map_or(String::new(), |z| format!("{z:.4}"));
            let _ = writeln!(
                s,
                "{},{},{},{:e},{:e},{},{z},{}",
                o.case.name,
                o.seed,
                k.key,
                k.truth,
                k.calibrated,
                k.std.map_or(String::new(), |s| format!("{s:e}")),
                k.conditional
            );
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibrate::prove::{Case, Excitation, FittedKey, Kind};

    fn outcome(kind: Kind, keys: &[(&str, f64, f64, Option<f64>)]) -> Outcome {
        let case = Case {
            name: "x".into(),
            kind,
            excitation: Excitation::CmdVelSteps,
            effect: None,
            truth: None,
            machine: vec![],
            common: vec![],
        };
        Outcome {
            case,
            seed: 1,
            accepted: vec![],
            key_error: None,
            keys: keys
                .iter()
                .map(|(k, t, v, s)| FittedKey {
                    key: k.to_string(),
                    truth: *t,
                    calibrated: *v,
                    std: *s,
                    conditional: k.starts_with('c'),
                })
                .collect(),
            fit_pct: (0.0, 0.0),
            passed: true,
        }
    }

    /// Each key's interval is judged at 1 and at 1.96 of its standard deviation, per kind,
    /// with the kind's total last; a key without a deviation, or whose interval was said to
    /// hold only given a held key (named `c` here), is not counted; the Monte Carlo error
    /// is the binomial share's.
    #[test]
    fn coverage_counts_each_interval_by_kind_and_key() {
        let outcomes = [
            // z = 0.5 and z = 1.5
            outcome(
                Kind::BaseRig,
                &[
                    ("m", 10.0, 10.5, Some(1.0)),
                    ("k", 1.0, 1.15, Some(0.1)),
                    // Said to hold only given a held key: not counted.
                    ("c", 1.0, 1.5, Some(0.1)),
                ],
            ),
            // z = 3, and a key the fit could not give a deviation
            outcome(
                Kind::BaseRig,
                &[("m", 10.0, 7.0, Some(1.0)), ("k", 1.0, 2.0, None)],
            ),
            outcome(Kind::AxisVoltage, &[("r", 1.0, 1.0, Some(0.1))]),
        ];
        let rows = coverage_table(&outcomes);
        let find = |kind: &str, key: &str| {
            rows.iter()
                .find(|r| r.kind == kind && r.key == key)
                .unwrap()
        };
        let m = find("base_rig", "m");
        assert_eq!((m.n, m.within_68, m.within_95), (2, 1, 1));
        let k = find("base_rig", "k");
        assert_eq!((k.n, k.within_68, k.within_95), (1, 0, 1));
        assert!(rows.iter().all(|r| r.key != "c"));
        assert_eq!(coverage(&outcomes), (2.0 / 4.0, 4));
        let all = find("base_rig", "all keys");
        assert_eq!((all.n, all.within_68, all.within_95), (3, 1, 2));
        assert_eq!(rows.last().unwrap().key, "all keys");
        let (p, e) = all.share(all.within_95);
        assert!((p - 2.0 / 3.0).abs() < 1e-12);
        assert!((e - (p * (1.0 - p) / 3.0).sqrt()).abs() < 1e-12);
        assert_eq!(find("axis_voltage", "all keys").within_68, 1);
    }
}
